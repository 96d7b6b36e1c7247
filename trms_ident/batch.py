"""Batch over folders of recordings: every log gets a folder of outputs and a line in the summary.

Runs locally in worker processes (``jobs``) or on a Dask distributed cluster (``scheduler``);
either way each log is one call of :func:`process_one`, so the results are the same.
"""
from __future__ import annotations

import csv
import glob
import hashlib
import html
import io
import json
import os
from dataclasses import asdict
from pathlib import Path
from typing import Callable, Iterable

from .errors import SettingsError, TrmsError
from .io.atomic import write_text
from .io.readers import LOG_SUFFIXES
from .settings import Settings

BATCH_KEY = "batch_key.json"


def discover(inputs: Iterable[str], out_dir: Path) -> list[Path]:
    """Every CSV and MCAP log under folders, matching globs, or named; sorted, no duplicates."""
    found: list[Path] = []
    out_dir = out_dir.resolve()
    for arg in inputs:
        p = Path(arg)
        if p.is_dir():
            cands = [q for q in sorted(p.rglob("*")) if q.is_file() and q.suffix.lower() in LOG_SUFFIXES]
        elif p.exists():
            cands = [p]
        else:
            cands = [Path(q) for q in sorted(glob.glob(arg, recursive=True))]
            if not cands:
                raise SettingsError(f"{arg}: no such file, folder or matching pattern")
            cands = [q for q in cands if q.is_file()]
        for q in cands:
            if out_dir in q.resolve().parents or is_our_output(q):
                continue  # never re-read our own outputs, of this batch or an earlier one
            if q.resolve() not in {f.resolve() for f in found}:
                found.append(q)
    return found


def is_our_output(path: Path) -> bool:
    """A file trms-ident wrote: traces.csv beside result.json, a batch's summary.csv, anything in a folder a
    batch stamped (batch_key.json)."""
    folder = path.parent
    return ((folder / BATCH_KEY).exists() or (path.name == "traces.csv" and (folder / "result.json").exists())
            or (path.name == "summary.csv" and (folder / "summary.json").exists()))


def output_name(path: Path, taken: set[str]) -> str:
    """A folder name for this log's outputs: its stem, made unique with a short hash of its path."""
    name = path.name.split(".")[0] or "log"
    if name in taken:
        name = f"{name}-{hashlib.sha1(str(path.resolve()).encode()).hexdigest()[:8]}"
    taken.add(name)
    return name


def job_key(path: Path, settings: Settings, options: dict) -> dict:
    st = path.stat()
    return {"input": str(path.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns,
            "settings": asdict(settings), "options": options}


def process_one(path: str, out_dir: str, settings: Settings, options: dict) -> dict:
    """Estimate one log into out_dir; never raises for a bad log: the row says what went wrong."""
    from .commands import estimate_file

    path_p, out = Path(path), Path(out_dir)
    row = {"path": path, "output": out_dir, "status": "failed", "error": None, "skipped": False,
           "estimates": None, "adequate": None, "report": None, "not_credible": {}}
    try:
        key = json.loads(json.dumps(job_key(path_p, settings, options)))  # as stored: tuples become lists
        stamp = out / BATCH_KEY
        if stamp.exists() and (out / "result.json").exists():
            try:
                if json.loads(stamp.read_text()) == key:
                    doc = json.loads((out / "result.json").read_text())
                    row.update(status="ok", skipped=True, estimates=doc["estimates"],
                               adequate=doc.get("model_check", {}).get("adequate"),
                               not_credible=doc.get("not_credible", {}),
                               report=str(out / "report.html") if (out / "report.html").exists() else None)
                    return row
            except (ValueError, KeyError):
                pass
        res = estimate_file(path_p, settings, out, html=options.get("html", True), angle_unit=options.get("angle_unit", "auto"),
                            time_unit=options.get("time_unit", "auto"),
                            signals=options.get("signals"), time_source=options.get("time_source", "auto"),
                            voltage_time=options.get("voltage_time", "stamp"), rate_hz=options.get("rate_hz"))
        write_text(stamp, json.dumps(key, indent=1))
        row.update(status="ok", estimates=res.summary["estimates"], adequate=res.summary["model_check"]["adequate"],
                   not_credible=res.summary["not_credible"],
                   report=str(out / "report.html") if options.get("html", True) else None)
        if res.log.meta.get("warnings"):
            row["error"] = "warning: " + res.log.meta["warnings"]
    except TrmsError as exc:
        row["error"] = str(exc)
    except Exception as exc:  # noqa: BLE001 - one broken log must not stop the batch
        row["error"] = f"internal error: {type(exc).__name__}: {exc}"
    return row


def run(paths: list[Path], out_dir: Path, settings: Settings, options: dict, jobs: int = 1,
        scheduler: str | None = None, on_done: Callable[[dict], None] | None = None) -> list[dict]:
    """Process every log; rows come back in the order of ``paths``."""
    taken: set[str] = set()
    # absolute paths: workers (other processes, Dask workers) may run in other working directories
    work = [(str(p.resolve()), str((out_dir / output_name(p, taken)).resolve())) for p in paths]
    done = on_done or (lambda row: None)
    rows: list[dict] = [None] * len(work)  # type: ignore[list-item]
    if scheduler:
        try:
            from distributed import Client, as_completed
        except ImportError:
            raise SettingsError("--scheduler needs Dask: pip install 'trms-ident[dask]'") from None
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise SettingsError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
        with client:
            futures = {client.submit(process_one, p, o, settings, options, pure=False): i
                       for i, (p, o) in enumerate(work)}
            for fut in as_completed(futures):
                rows[futures[fut]] = fut.result()
                done(rows[futures[fut]])
    elif jobs > 1:
        from concurrent.futures import ProcessPoolExecutor, as_completed as done_first

        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = {pool.submit(process_one, p, o, settings, options): i for i, (p, o) in enumerate(work)}
            for fut in done_first(futures):
                rows[futures[fut]] = fut.result()
                done(rows[futures[fut]])
    else:
        for i, (p, o) in enumerate(work):
            rows[i] = process_one(p, o, settings, options)
            done(rows[i])
    return rows


def write_summary(out_dir: Path, rows: list[dict]) -> list[Path]:
    from .report.summary import to_json

    names = ("J1", "B1", "J2", "B2")
    doc = {"files": [{k: r[k] for k in ("path", "status", "adequate", "error", "estimates", "not_credible", "skipped",
                                        "output")}
                     for r in rows],
           "ok": sum(r["status"] == "ok" for r in rows), "failed": sum(r["status"] != "ok" for r in rows),
           "inadequate": sum(r["adequate"] is False for r in rows)}
    write_text(out_dir / "summary.json", to_json(doc))
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["path", "status", "adequate", *names, "error"])
    for r in rows:
        est = r["estimates"] or {}
        writer.writerow([r["path"], r["status"], "" if r["adequate"] is None else str(r["adequate"]).lower(), *("" if est.get(k) is None else repr(est[k]) for k in names),
                         r["error"] or ""])
    write_text(out_dir / "summary.csv", buf.getvalue())
    items = []
    for r in rows:
        rel = os.path.relpath(r["report"], out_dir) if r.get("report") else None
        link = f'<a href="{html.escape(rel)}">{html.escape(r["path"])}</a>' if rel else html.escape(r["path"])
        est = r["estimates"] or {}
        cond = ' class="cond" title="conditional on a model that does not fit this log"' if r["adequate"] is False else ""
        why = r.get("not_credible") or {}
        cells = "".join(f"<td{cond}>{'' if est.get(k) is None else f'{est[k]:.6g}'}"
                        + (f" ({html.escape(why[k])})" if k in why else "") + "</td>" for k in names)
        fits = {None: "<td>not decided</td>" if r["status"] == "ok" else "", True: '<td class="ok">yes</td>',
                False: '<td class="failed">NO: model does not fit</td>'}
        items.append(f'<tr><td>{link}</td><td class="{r["status"]}">{r["status"]}</td>'
                     f'{fits[r["adequate"]] or "<td></td>"}{cells}'
                     f'<td>{html.escape(r["error"] or "")}</td></tr>')
    page = f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>trms-ident batch</title>
<style>body{{font-family:system-ui,sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px}}.failed{{color:#b00}}.ok{{color:#070}}
.cond{{color:#888;font-style:italic}}</style></head><body>
<h1>trms-ident batch: {doc['ok']} ok, {doc['failed']} failed; the model does not fit {doc['inadequate']}</h1>
<table><tr><th>log</th><th>status</th><th>model fits</th><th>J1 [kg m^2]</th><th>B1 [N m s/rad]</th><th>J2 [kg m^2]</th>
<th>B2 [N m s/rad]</th><th>reason</th></tr>{''.join(items)}</table>
<p><i>Grey, italic numbers come from a model that does not fit that log: conditional on it, not to be trusted as
they stand (open its report).</i></p></body></html>
"""
    write_text(out_dir / "index.html", page)
    return [out_dir / "summary.json", out_dir / "summary.csv", out_dir / "index.html"]
