"""Accuracy over noise seeds (issue #11, item 9): is the tool as accurate as the output-error baseline?

    python benchmarks/accuracy_seeds.py            # 16 cells x 5 seeds, 2 processes (~15 min on 2 cores)
    python benchmarks/accuracy_seeds.py --seeds 2  # quicker look

Cells: noise (12-bit encoder, 0.5 mrad Gaussian) x sample rate (1 kHz, 100 Hz) x reference (square,
multisine) x start (from rest with the controller driving; cut 21-39 s into a running experiment), 60 s each,
seed-model logs from sim/; each seed is another run (noise, multisine phases, the yaw angle the beam rests
at, the cut time).  Per cell and parameter, over the seeds: the tool's mean |error|, the output-error
baseline's mean |error| (benchmarks/baselines.output_error with initial_state="estimate": scipy least squares on the angles, decimated to
50 Hz, the initial state estimated too, started from 0.5x the truth), and the tool's mean 95 % half-width.
Criterion: tool mean |error| <= baseline mean |error| + tool mean half-width, in every cell and parameter;
the tool's 95 % intervals cover the truth in >= 90 % of (run, parameter) pairs.  Writes the section
"Accuracy over noise seeds" of benchmarks/RESULTS.md and prints the table (docs/benchmarks.md describes it).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

NOISES = {"12-bit": (0.0, 2 * math.pi / 4096), "0.5 mrad": (5e-4, 0.0)}
RATES = (1000.0, 100.0)
REFS = ("square", "multisine")
STARTS = {"rest": 0.0, "mid-run": 30.0}
NAMES = ("J1", "B1", "J2", "B2")


def run(args) -> dict:
    from baselines import output_error

    from sim import SimSettings, simulate
    from trms_ident.identify import identify
    from trms_ident.log import validated

    noise, rate, ref, start, seed = args
    sigma, q = NOISES[noise]
    # every seed is a different run, also where the reference and the encoder have no random element (square,
    # 12-bit): the beam rests at a random yaw angle, and a mid-run log is cut at a random time
    rng = np.random.default_rng(1000 + seed)
    yaw0, cut = rng.uniform(-0.2, 0.2), STARTS[start] * rng.uniform(0.7, 1.3)
    r = simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=60.0, noise_std_rad=sigma, quantization_rad=q,
                             seed=100 + seed, start_s=cut, initial_yaw_rad=yaw0))
    truth = r.truth["estimated"]
    log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    t0 = time.perf_counter()
    res = identify(log)
    t_tool = time.perf_counter() - t0
    t0 = time.perf_counter()
    oe = output_error(log, truth, initial_state="estimate")
    t_oe = time.perf_counter() - t0
    row = {"cell": (noise, rate, ref, start), "seed": seed, "adequate": res.model_check["adequate"],
           "headline": res.headline, "t_tool": t_tool, "t_oe": t_oe}
    for k in NAMES:
        est, ci = res.estimates[k], res.intervals[k]
        row[f"tool_{k}"] = math.nan if est is None else 100 * abs(est / truth[k] - 1)
        row[f"half_{k}"] = 100 * (ci.high - ci.low) / 2 / truth[k] if math.isfinite(ci.low) else math.nan
        row[f"cover_{k}"] = bool(ci.low <= truth[k] <= ci.high) if math.isfinite(ci.low) else False
        row[f"oe_{k}"] = 100 * abs(oe[k] / truth[k] - 1)
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    grid = [(n, r, f, s, seed) for n in NOISES for r in RATES for f in REFS for s in STARTS
            for seed in range(args.seeds)]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(run, grid))
    wall = time.perf_counter() - t0
    cells = {}
    for row in rows:
        cells.setdefault(row["cell"], []).append(row)
    lines = ["| noise | rate | ref | start | " + " | ".join(f"{k} tool / OE / half [%]" for k in NAMES) +
             " | adequate | ok |", "|" + "---|" * (6 + len(NAMES))]
    all_ok, covered, pairs = True, 0, 0
    for (noise, rate, ref, start), rs in cells.items():
        cols, ok = [], True
        for k in NAMES:
            tool = float(np.nanmean([r[f"tool_{k}"] for r in rs]))
            oe = float(np.mean([r[f"oe_{k}"] for r in rs]))
            half = float(np.nanmean([r[f"half_{k}"] for r in rs]))
            ok &= bool(tool <= oe + half)
            cols.append(f"{tool:.3g} / {oe:.3g} / {half:.3g}")
            covered += sum(r[f"cover_{k}"] for r in rs)
            pairs += len(rs)
        all_ok &= ok
        adequate = sum(r["adequate"] for r in rs)
        lines.append(f"| {noise} | {rate:g} Hz | {ref} | {start} | " + " | ".join(cols) +
                     f" | {adequate}/{len(rs)} | {'yes' if ok else 'NO'} |")
    t_tool = float(np.median([r["t_tool"] for r in rows]))
    t_oe = float(np.median([r["t_oe"] for r in rows]))
    summary = (f"{len(cells)} cells x {args.seeds} seeds: criterion (tool mean |error| <= output-error mean |error| "
               f"+ tool mean 95 % half-width) met in {'every' if all_ok else 'NOT every'} cell and parameter; "
               f"95 % intervals cover the truth in {covered}/{pairs} = {100 * covered / pairs:.1f} % of (run, "
               f"parameter) pairs; model adequate in {sum(r['adequate'] for r in rows)}/{len(rows)} runs. "
               f"Median time per log: tool {t_tool:.2f} s, output-error baseline {t_oe:.2f} s "
               f"({args.jobs} processes, {wall:.0f} s in all).")
    text = ("## Accuracy over noise seeds\n\n`python benchmarks/accuracy_seeds.py` (60 s logs; seeds 100..; errors "
            "and half-widths in % of the truth, means over the seeds).\n\n" + "\n".join(lines) + "\n\n" + summary
            + "\n")
    print(text)
    from results import update_section

    update_section(Path(__file__).with_name("RESULTS.md"), "Accuracy over noise seeds", text)


if __name__ == "__main__":
    main()
