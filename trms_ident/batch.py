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

from .errors import JoinedRunsError, SettingsError, TrmsError
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
                    parts = doc.get("joint")  # a log estimated as its parts (gaps, runs joined)
                    row.update(status="ok", skipped=True, estimates=(parts or doc)["estimates"],
                               adequate=parts["adequate"] if parts else doc.get("model_check", {}).get("adequate"),
                               not_credible=doc.get("not_credible", {}),
                               report=str(out / "report.html") if (out / "report.html").exists() else None)
                    if (out / "diagnosis.json").exists():
                        row["diagnosis"] = diagnosis_row(json.loads((out / "diagnosis.json").read_text()), out)
                    return row
            except (ValueError, KeyError):
                pass
        try:
            res = estimate_file(path_p, settings, out, html=options.get("html", True),
                                angle_unit=options.get("angle_unit", "auto"),
                                time_unit=options.get("time_unit", "auto"),
                                signals=options.get("signals"), time_source=options.get("time_source", "auto"),
                                voltage_time=options.get("voltage_time", "stamp"), rate_hz=options.get("rate_hz"))
        except JoinedRunsError as exc:  # gaps in its stamps, or runs joined: its parts estimated jointly
            if options.get("strict_gaps") and exc.gaps:
                raise
            row.update(_parts_jointly(path_p, out, settings, options))
            write_text(stamp, json.dumps(key, indent=1))
            return row
        row.update(status="ok", estimates=res.summary["estimates"], adequate=res.summary["model_check"]["adequate"],
                   not_credible=res.summary["not_credible"],
                   report=str(out / "report.html") if options.get("html", True) else None)
        if options.get("diagnose") and row["adequate"] is False:  # the model does not fit: what does it leave out?
            row["diagnosis"] = _diagnosed(res.log, out, settings, options, res.result)
        write_text(stamp, json.dumps(key, indent=1))
        if res.log.meta.get("warnings"):
            row["error"] = "warning: " + res.log.meta["warnings"]
    except TrmsError as exc:
        row["error"] = str(exc)
    except Exception as exc:  # noqa: BLE001 - one broken log must not stop the batch
        row["error"] = f"internal error: {type(exc).__name__}: {exc}"
    return row


def _diagnosed(log, out: Path, settings: Settings, options: dict, estimated=None) -> dict:
    """diagnose of a log the model does not fit (batch --diagnose), written as diagnosis.json (and its report)
    beside the estimate; the summary's verdict and findings.  ``estimated``: the log's estimate (identify's
    Result), diagnose's seed-model check when it was made with the settings that check uses."""
    from dataclasses import replace

    from .api import diagnose
    from .report.diagnosis import render, to_doc
    from .report.summary import to_json

    from .diagnosis.model import settings_of
    from .model.bench import with_given
    from .model.structure import with_structure

    # the bench: its known values, its structure and its input modifications, taken as given
    bench = with_given(with_structure(dict(settings.overrides), settings.structure), settings.effects)
    seedlike = replace(settings, inputs_unit=None) == settings_of(bench, settings.thrust_law)
    try:
        d = diagnose(log, params=bench, thrust_law=settings.thrust_law, seed=estimated if seedlike else None)
    except TrmsError as exc:  # a log too short to diagnose, ...: said in its row, the estimate stands
        return {"verdict": "not diagnosed", "findings": [], "file": None, "error": str(exc)}
    doc = to_doc(d, log)
    write_text(out / "diagnosis.json", to_json(doc))
    if options.get("html", True):
        write_text(out / "diagnosis.html", render(doc, d, log))
    return diagnosis_row(doc, out)


def diagnosis_row(doc: dict, out: Path) -> dict:
    """A diagnosis.json's verdict and findings for the batch summary: each finding's key ("effect:axis", or a
    known value's name) and its plain words (report.terminal.finding_words, as diagnose's first line names it)."""
    from .report.terminal import finding_words

    found = [{"key": f["parameter"]["name"] if f["effect"] == "known_value" else f"{f['effect']}:{f['axis']}",
              "text": finding_words(f)} for f in doc["findings"]]
    return {"verdict": doc["verdict"], "findings": found, "file": str(out / "diagnosis.json")}


def _recurring_html(found: dict) -> str:
    if not found:
        return ""
    items = "".join(f"<li>{html.escape(k)}: in {v['logs']} of the {v['diagnosed']} logs diagnosed"
                    + (" (one log only: suspect until another run of the bench shows it)" if v["logs"] == 1 and
                       v["diagnosed"] > 1 else "") + "</li>" for k, v in found.items())
    return f"<h2>Findings across the logs</h2><ul>{items}</ul>"


def recurring_findings(rows: list[dict]) -> dict:
    """Each finding's key -> (in how many of the diagnosed logs, how many were diagnosed), most frequent first: a
    structure of the bench recurs, one only a log shows is suspect."""
    diagnosed = [r["diagnosis"] for r in rows if r.get("diagnosis") and r["diagnosis"].get("file")]
    counts: dict = {}
    for dg in diagnosed:
        for key in dict.fromkeys(f["key"] for f in dg["findings"]):
            counts[key] = counts.get(key, 0) + 1
    return {k: (n, len(diagnosed)) for k, n in sorted(counts.items(), key=lambda kv: -kv[1])}


def _parts_jointly(path: Path, out: Path, settings: Settings, options: dict) -> dict:
    """A log that broke into parts estimated as runs of one bench (api.estimate_joint_with, as `estimate` does),
    written to ``out``; the summary row's fields, with what was found and left out as its note."""
    from .api import estimate_joint_with
    from .io.manifest import Entry

    est = estimate_joint_with([Entry(path, options.get("signals"), options.get("rate_hz"),
                                     options.get("angle_unit", "auto"), options.get("time_unit", "auto"))], settings)
    est.save(out, html=options.get("html", True))
    j = est.doc["joint"]
    said = "; ".join(f"{x['found']}: estimated jointly as its parts"
                     + "".join(f"; {lo['part']} left out ({lo['why']})" for lo in x["left_out"])
                     for x in j.get("split", []))
    return {"status": "ok", "estimates": j["estimates"], "adequate": j["adequate"], "error": f"note: {said}",
            "report": str(out / "report.html") if options.get("html", True) else None}


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
    doc = {"files": [{**{k: r[k] for k in ("path", "status", "adequate", "error", "estimates", "not_credible", "skipped",
                                           "output")}, "diagnosis": r.get("diagnosis")}
                     for r in rows],
           "ok": sum(r["status"] == "ok" for r in rows), "failed": sum(r["status"] != "ok" for r in rows),
           "inadequate": sum(r["adequate"] is False for r in rows),
           "findings_across_logs": {k: {"logs": n, "diagnosed": m} for k, (n, m) in recurring_findings(rows).items()}}
    write_text(out_dir / "summary.json", to_json(doc))
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["path", "status", "adequate", *names, "error", "diagnosis", "findings"])
    for r in rows:
        est = r["estimates"] or {}
        dg = r.get("diagnosis") or {}
        writer.writerow([r["path"], r["status"], "" if r["adequate"] is None else str(r["adequate"]).lower(),
                         *("" if est.get(k) is None else repr(est[k]) for k in names), r["error"] or "",
                         dg.get("verdict", ""), "; ".join(f["text"] for f in dg.get("findings", []))])
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
        dg = r.get("diagnosis")
        dcell = "" if not dg else (html.escape(f"not diagnosed: {dg.get('error')}") if not dg.get("file") else
                                   f'<a href="{html.escape(os.path.relpath(dg["file"], out_dir))}">'
                                   f'{html.escape(dg["verdict"].replace("_", " "))}</a>: '
                                   + html.escape("; ".join(f["text"] for f in dg["findings"]) or "no finding"))
        items.append(f'<tr><td>{link}</td><td class="{r["status"]}">{r["status"]}</td>'
                     f'{fits[r["adequate"]] or "<td></td>"}{cells}'
                     f'<td>{html.escape(r["error"] or "")}</td><td>{dcell}</td></tr>')
    page = f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>trms-ident batch</title>
<style>body{{font-family:system-ui,sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px}}.failed{{color:#b00}}.ok{{color:#070}}
.cond{{color:#888;font-style:italic}}</style></head><body>
<h1>trms-ident batch: {doc['ok']} ok, {doc['failed']} failed; the model does not fit {doc['inadequate']}</h1>
<table><tr><th>log</th><th>status</th><th>model fits</th><th>J1 [kg m^2]</th><th>B1 [N m s/rad]</th><th>J2 [kg m^2]</th>
<th>B2 [N m s/rad]</th><th>reason</th><th>diagnosis (--diagnose)</th></tr>{''.join(items)}</table>
<p><i>Grey, italic numbers come from a model that does not fit that log: conditional on it, not to be trusted as
they stand (open its report).</i></p>{_recurring_html(doc["findings_across_logs"])}</body></html>
"""
    write_text(out_dir / "index.html", page)
    return [out_dir / "summary.json", out_dir / "summary.csv", out_dir / "index.html"]


def run_joint(entries: list, by: str, out_dir: Path, settings: Settings, html_report: bool = True,
              progress: Callable[[int, int], None] | None = None, diagnose: bool = False) -> list[dict]:
    """``batch --joint-by FIELD``: one joint estimate per value of the manifest's column ``by`` (a bench), each
    written to its own folder; a group whose logs cannot be read or estimated is a failed row, the others go on.
    ``diagnose``: each log the model does not fit alone is diagnosed (its diagnosis.json in the group's folder,
    under the log's name), and the group's row says which findings recur across its logs and which only one
    log shows (findings_across_logs)."""
    from .api import estimate_joint_with

    if by not in ("bench", "date", "name"):
        raise SettingsError(f"--joint-by {by!r}: expected a manifest column, bench (or date, name)")
    groups: dict[str, list] = {}
    for e in entries:
        groups.setdefault(getattr(e, by) or "(none)", []).append(e)
    rows, taken = [], set()
    for n, (key, members) in enumerate(groups.items()):
        folder = out_dir / output_name(Path(key.replace("/", "_")), taken)
        row = {"group": key, "logs": [str(e.path) for e in members], "names": [e.label for e in members],
               "dates": [e.date for e in members], "status": "failed", "error": None, "output": str(folder)}
        try:
            est = estimate_joint_with(members, settings)
            est.save(folder, html=html_report)
            j = est.doc["joint"]
            row.update(status="ok", estimates=j["estimates"], ci95=j["ci95"], consistent=j["consistent"],
                       outliers=j["outliers"], sentence=j["sentence"], adequate=j["adequate"],
                       per_log=[{"name": lg["name"], "estimates": lg["estimates"], "ci95": lg["ci95"],
                                 "in_pool": lg["in_pool"]} for lg in j["logs"]])
            if diagnose:
                _diagnose_group(row, est, folder, settings, html_report)
        except TrmsError as exc:
            row["error"] = str(exc)
        rows.append(row)
        if progress:
            progress(n + 1, len(groups))
    return rows


def _diagnose_group(row: dict, est, folder: Path, settings: Settings, html_report: bool) -> None:
    """batch --joint-by --diagnose: each log of the group the model does not fit alone, diagnosed; the findings
    across them (recurring_findings: a structure of the bench recurs, one only a log shows is suspect)."""
    taken: set = set()
    for lg, v, log in zip(row["per_log"], est.result.logs, est.logs):
        if v.result.model_check.get("adequate") is False:
            out = folder / output_name(Path(lg["name"].replace("/", "_")), taken)
            lg["diagnosis"] = _diagnosed(log, out, settings, {"html": html_report}, v.result)
    row["findings_across_logs"] = {k: {"logs": n, "diagnosed": m}
                                   for k, (n, m) in recurring_findings(row["per_log"]).items()}


def write_joint_summary(out_dir: Path, rows: list[dict], html_report: bool = True) -> list[Path]:
    """joint_summary.json and joint_index.html: per group the pooled J/B, whether its logs agree, which differ;
    with dates, each log's own J/B over time with its interval (wear, drift) and the ones that differ marked."""
    from .report.summary import to_json

    doc = {"groups": rows, "ok": sum(r["status"] == "ok" for r in rows),
           "failed": sum(r["status"] != "ok" for r in rows),
           "disagree": sum(r["status"] == "ok" and bool(r.get("outliers") or r.get("consistent") is False)
                           for r in rows)}
    write_text(out_dir / "joint_summary.json", to_json(doc))
    written = [out_dir / "joint_summary.json"]
    if html_report:
        write_text(out_dir / "joint_index.html", _joint_page(out_dir, rows))
        written.append(out_dir / "joint_index.html")
    return written


def _joint_page(out_dir: Path, rows: list[dict]) -> str:
    names = ("J1", "B1", "J2", "B2")
    items = []
    for r in rows:
        link = os.path.relpath(Path(r["output"]) / "report.html", out_dir)
        if r["status"] != "ok":
            items.append(f"<h2>{html.escape(r['group'])}</h2><p class='failed'>failed: {html.escape(r['error'])}</p>")
            continue
        cells = "".join(f"<td>{'n.i.' if r['estimates'][k] is None else format(r['estimates'][k], '.6g')}</td>"
                        for k in names)
        figure = _over_time(r) if any(r["dates"]) else ""
        diagnosed = "".join(
            f"<li>{html.escape(lg['name'])}: {html.escape(lg['diagnosis']['verdict'])}"
            + (": " + html.escape(", ".join(f["text"] for f in lg["diagnosis"]["findings"]))
               if lg["diagnosis"]["findings"] else "") + "</li>" for lg in r["per_log"] if lg.get("diagnosis"))
        items.append(f"<h2><a href='{html.escape(link)}'>{html.escape(r['group'])}</a>: {len(r['logs'])} logs</h2>"
                     f"<p>{html.escape(r['sentence'])}</p><table><tr><th></th>"
                     + "".join(f"<th>{k}</th>" for k in names) + f"</tr><tr><td>pooled</td>{cells}</tr></table>"
                     + figure + (f"<h3>Diagnosed (the model does not fit them alone)</h3><ul>{diagnosed}</ul>"
                                 if diagnosed else "") + _recurring_html(r.get("findings_across_logs") or {}))
    return ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>trms-ident benches</title><style>"
            "body{font-family:system-ui,sans-serif;margin:2em;max-width:1100px}table{border-collapse:collapse}"
            "td,th{border:1px solid #ccc;padding:3px 8px}.failed{color:#b00}</style></head><body>"
            "<h1>Benches: one joint estimate each</h1>" + "".join(items) + "</body></html>")


def _over_time(r: dict) -> str:
    """Each log's own J/B against its date, with 95 % intervals; logs left out of the pool in red."""
    import matplotlib.pyplot as plt
    import numpy as np

    from .report.figures import png_data_uri

    order = sorted(range(len(r["dates"])), key=lambda i: r["dates"][i])
    fig, axes = plt.subplots(1, 4, figsize=(12, 2.8))
    left_out = set(r["outliers"])
    for ax, k in zip(axes, ("J1", "B1", "J2", "B2")):
        for x, i in enumerate(order):
            lg = r["per_log"][i]
            e = lg["estimates"][k]
            if e is None:
                continue
            lo, hi = lg["ci95"][k]
            err = [[e - lo], [hi - e]] if lo is not None and hi is not None else None
            ax.errorbar([x], [e], yerr=err, fmt="o", capsize=3, ms=4,
                        color="tab:red" if lg["name"] in left_out else "black")
        if r["estimates"][k] is not None:
            lo, hi = r["ci95"][k]
            ax.axhspan(lo, hi, color="tab:blue", alpha=0.15)
        ax.set_xticks(np.arange(len(order)), [r["dates"][i] or "?" for i in order], rotation=45, fontsize=7)
        ax.set_title(k, fontsize=9)
        ax.grid(alpha=0.3)
    fig.suptitle("Each log's own estimate by date (red: differs from the others, left out of the pool)", fontsize=9)
    fig.tight_layout()
    return f"<img alt='estimates over time' src='{png_data_uri(fig)}'>"
