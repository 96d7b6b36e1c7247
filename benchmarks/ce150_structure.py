"""The Humusoft CE150 under its own structure: `estimate --params humusoft_ce150` on logs of its published model.

    python benchmarks/ce150_structure.py --seed 31 [--folder DIR ...] [--n 2] [--no-write]

The bundled CE150 bench states the published model's structure (trms_ident/benches/humusoft_ce150.toml:
second-order motors, the gyroscope and the reaction driven by the input u1, end stops; docs/parameters.md).  Two
kinds of logs, both with the published values as their truth (I = 0.00437, B_psi = 0.00184, I_phi = 0.00414,
B_phi = 0.00869):

- recordings: the .mat files of the folders given (default ../shared/real_logs/ce150; the public repository
  JurCag/NN_for_FF_Compensation holds ten Data100_*.mat, simulations of that model by its authors, seven with
  u1), each estimated alone, then the two shared ones pooled (`--joint`);
- new logs made by the model ported from its Simulink diagram (tests/plants/ce150.py, which no part of the tool
  shares): three excitations (multisine, steps, ramp) x a 12-bit encoder or Gaussian noise of 0.2 mrad x
  ``--n`` seeds drawn from ``--seed``, 100 or 200 Hz, 40-60 s, from rest on the 45 degree stop.

Per log: J/B and their error against the published values, whether each 95 % interval covers it, the verdict,
the time.  Writes the "CE150 under its own structure" section of RESULTS.md.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from results import publish  # noqa: E402

from tests.plants import ce150  # noqa: E402
from trms_ident.identify import identify  # noqa: E402
from trms_ident.io.readers import read_log  # noqa: E402
from trms_ident.log import validated  # noqa: E402
from trms_ident.params import bench_settings  # noqa: E402
from trms_ident.settings import Settings  # noqa: E402

TRUTH = {"J1": 0.00437, "B1": 0.00184, "J2": 0.00414, "B2": 0.00869}
SHARED = Path(__file__).resolve().parents[2] / "shared" / "real_logs" / "ce150"
VERDICT = {True: "fits", False: "does not fit", None: "not decided"}


def _row(name: str, log, seconds_extra: float = 0.0) -> tuple[str, dict]:
    t0 = time.perf_counter()
    r = identify(log, Settings(**bench_settings("humusoft_ce150")))
    dt = time.perf_counter() - t0 + seconds_extra
    cells, stats = [], {"within2": 0, "covered": 0, "ni": 0, "given": 0}
    for k, v in TRUTH.items():
        est, iv = r.estimates[k], r.intervals[k]
        if est is None:
            cells.append("n.i.")
            stats["ni"] += 1
            continue
        err = 100 * (est / v - 1)
        cover = iv.low <= v <= iv.high
        stats["given"] += 1
        stats["within2"] += abs(err) <= 2.0
        stats["covered"] += cover
        cells.append(f"{est:.5g} ({err:+.2f} %{'' if cover else ', not covered'})")
    verdict = VERDICT[r.model_check["adequate"]]
    stats["fits"] = r.model_check["adequate"] is True
    return f"| {name} | {' | '.join(cells)} | {verdict} ({r.headline}) | {dt:.1f} |", stats


def recordings(folders: list[Path]) -> tuple[list[str], list[dict], list[Path]]:
    rows, stats, fitting = [], [], []
    for folder in folders:
        for path in sorted(folder.glob("Data100_*.mat")):
            try:
                log = read_log(path, rate_hz=100.0, angle_unit="deg")
            except Exception as exc:  # a file without u1: said, not estimated
                rows.append(f"| {path.name} | {str(exc).splitlines()[0][:90]} | | | | | |")
                continue
            row, st = _row(path.name, log)
            rows.append(row)
            stats.append(st)
            if st["fits"]:
                fitting.append(path)
            print(row, flush=True)
    return rows, stats, fitting


def new_logs(seed: int, n: int) -> tuple[list[str], list[dict]]:
    rng = np.random.default_rng(seed)
    rows, stats = [], []
    for ref in ("multisine", "steps", "ramp"):
        for quant in ("12-bit", "Gaussian 0.2 mrad"):
            for _ in range(n):
                s = int(rng.integers(1 << 30))
                rate = float(rng.choice([100.0, 200.0]))
                duration = float(round(rng.uniform(40.0, 60.0)))  # whole seconds: the row names the log
                t, u1, u2, a, b = ce150.simulate_log(duration, rate, seed=s, ref=ref,
                                                     encoder_bits=12 if quant == "12-bit" else None,
                                                     noise_rad=0.0 if quant == "12-bit" else 2e-4)
                log = validated(t, u1, u2, a, b, source=f"ce150 {ref}", angle_unit="rad")
                row, st = _row(f"{ref}, {quant}, {rate:g} Hz, {duration:.0f} s (seed {s})", log)
                rows.append(row)
                stats.append(st)
                print(row, flush=True)
    return rows, stats


def _summary(stats: list[dict]) -> str:
    given = sum(s["given"] for s in stats)
    return (f"{sum(s['within2'] for s in stats)}/{given} values within 2 % of the published ones, "
            f"{sum(s['covered'] for s in stats)}/{given} covered by their 95 % interval, "
            f"{sum(s['ni'] for s in stats)} not identifiable; {sum(s['fits'] for s in stats)}/{len(stats)} logs "
            "fit")


def joint(paths: list[Path]) -> str:
    """The recordings pooled as runs of one bench (estimate --joint)."""
    import subprocess

    exe = Path(sys.executable).with_name("trms-ident")
    out = Path("/tmp") / "ce150_structure_joint.json"
    cmd = [str(exe), "estimate", *map(str, paths), "--joint", "--rate", "100", "--angle-unit", "deg", "--params",
           "humusoft_ce150", "--json", str(out), "-o", str(out.with_suffix(""))]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode not in (0, 3) or not out.exists():
        return f"`--joint` failed (exit {res.returncode}): {res.stderr.strip().splitlines()[-1:]}"
    import json

    doc = json.loads(out.read_text())["joint"]
    est, ci = doc.get("estimates", {}), doc.get("ci95", {})
    cells = []
    for k, v in TRUTH.items():
        e = est.get(k)
        if e is None:
            cells.append(f"{k} n.i.")
            continue
        lo, hi = ci.get(k) or (math.nan, math.nan)
        cells.append(f"{k} {e:.5g} ({100 * (e / v - 1):+.2f} %, 95 % [{lo:.5g}, {hi:.5g}])")
    words = doc.get("sentence", "")
    return "; ".join(cells) + (f". The tool says: {words}" if words else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, required=True, help="draws the new logs' seeds, rates and lengths")
    ap.add_argument("--n", type=int, default=1, help="new logs per excitation and noise kind")
    ap.add_argument("--folder", type=Path, action="append", help="folders of CE150 .mat recordings")
    ap.add_argument("--no-write", action="store_true", help="print the section; leave RESULTS.md alone")
    args = ap.parse_args()
    folders = args.folder or [SHARED]
    head = "| log | J1 | B1 | J2 | B2 | verdict (headline) | time [s] |\n|---|---|---|---|---|---|---|"
    rec_rows, rec_stats, fitting = recordings(folders)
    new_rows, new_stats = new_logs(args.seed, args.n)
    pooled = joint(sorted(SHARED.glob("Data100_*.mat"))) if SHARED.exists() else "shared files not found"
    pooled_fitting = joint(fitting) if len(fitting) > 1 else "fewer than two recordings fit"
    text = "\n".join([
        "## CE150 under its own structure",
        "",
        f"`python benchmarks/ce150_structure.py --seed {args.seed} --n {args.n}"
        + "".join(f" --folder {f}" for f in (args.folder or [])) + "`: `estimate --params humusoft_ce150` "
        "(second-order motors, the gyroscope and the reaction driven by u1, end stops: docs/parameters.md) against "
        "the published values I 0.00437, B_psi 0.00184, I_phi 0.00414, B_phi 0.00869 (the error in brackets; "
        "\"not covered\": the 95 % interval misses it; n.i.: not identifiable).",
        "",
        f"Recordings (simulations of the published model by its authors): {_summary(rec_stats)}.",
        "",
        head, *rec_rows, "",
        f"The two shared recordings pooled (`--joint`): {pooled}",
        "",
        f"The recordings the model fits ({', '.join(p.name for p in fitting)}) pooled: {pooled_fitting}",
        "",
        f"New logs of the model ported from its Simulink diagram (tests/plants/ce150.py), seed {args.seed}: "
        f"{_summary(new_stats)}.",
        "",
        head, *new_rows,
    ])
    publish("CE150 under its own structure", text, write=not args.no_write)


if __name__ == "__main__":
    main()
