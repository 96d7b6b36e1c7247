"""diagnose on logs of the Humusoft CE150's published model, under its own structure and under eq. (1)'s.

    python benchmarks/ce150_diagnose.py --seed 5150 [--n 1] [--no-write]

The logs come from the model ported from its Simulink diagram (tests/plants/ce150.py, which no part of the tool
shares): second-order motors (T 0.3 s main, 0.25 s tail, each twice), the gyroscope and the reaction driven by u1,
end stops.  Each log is diagnosed twice, blind (diagnose sees the log and the bench file only):

- `--params humusoft_ce150`: the published model, values, [structure] and [effects] (the second-order motors,
  which diagnose takes as given): the right answer is "consistent", nothing found;
- humusoft_ce150 without its [effects] (the values and the [structure]; the API's bench dict): the right answer
  is both motors second order (motor_second_lag on pitch ~0.3 s and on yaw ~0.25 s), nothing else;
- `--params humusoft_ce150_eq1`: the same values mapped onto eq. (1) (first-order motors of 0.6 and 0.5 s, the
  gyroscope and the reaction driven by the motor): what a user with eq. (1) and the CE150's values has.  diagnose
  does not search structures, so the voltage drives cannot be named here and the stop only said (the angle lies
  on a value the model passes); what it names instead is the point.

Per log: the findings with their values, the verdict, the end stops the verdict says the log shows, J/B under the
findings against the published values, the time.  Writes the "CE150 diagnosed" section of RESULTS.md.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from results import publish  # noqa: E402

from tests.plants import ce150  # noqa: E402
from trms_ident.api import diagnose  # noqa: E402
from trms_ident.log import validated  # noqa: E402

TRUTH = {"J1": 0.00437, "B1": 0.00184, "J2": 0.00414, "B2": 0.00869}
BENCHES = ("humusoft_ce150", "humusoft_ce150 without [effects]", "humusoft_ce150_eq1")


def _bench(name: str):
    """The params diagnose is given for bench ``name``: the bench file, or humusoft_ce150's values and structure
    without its effects."""
    if name != "humusoft_ce150 without [effects]":
        return name
    from trms_ident.model.structure import with_structure
    from trms_ident.params import load_parameter_file, parameter_file_structure

    return with_structure(load_parameter_file("humusoft_ce150"), parameter_file_structure("humusoft_ce150"))


def _finding(f) -> str:
    p = f.parameter
    name = p["name"] if f.effect == "known_value" else f"{f.effect}:{f.axis}"
    return f"{name} {p['value']:.4g}"


def _jb(d) -> str:
    est = (d.with_findings or {}).get("estimates") or d.augmented or {}
    cells = []
    for k, v in TRUTH.items():
        e = est.get(k)
        cells.append(f"{k} n.i." if e is None else f"{k} {100 * (e / v - 1):+.1f} %")
    return ", ".join(cells)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, required=True, help="draws the logs' seeds, rates and lengths")
    ap.add_argument("--n", type=int, default=1, help="logs per excitation")
    ap.add_argument("--no-write", action="store_true", help="print the section; leave RESULTS.md alone")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    rows, times = [], {b: [] for b in BENCHES}
    for ref in ("multisine", "steps", "ramp"):
        for _ in range(args.n):
            s = int(rng.integers(1 << 30))
            rate = float(rng.choice([100.0, 200.0]))
            duration = float(round(rng.uniform(40.0, 60.0)))
            bits = 12 if rng.random() < 0.5 else None
            t, u1, u2, a, b = ce150.simulate_log(duration, rate, seed=s, ref=ref, encoder_bits=bits,
                                                 noise_rad=0.0 if bits else 2e-4)
            log = validated(t, u1, u2, a, b, source=f"ce150 {ref}", angle_unit="rad")
            name = f"{ref}, {'12-bit' if bits else 'Gaussian 0.2 mrad'}, {rate:g} Hz, {duration:.0f} s (seed {s})"
            for bench in BENCHES:
                t0 = time.perf_counter()
                d = diagnose(log, params=_bench(bench))
                dt = time.perf_counter() - t0
                times[bench].append(dt)
                seen = ", ".join(f"{s['axis']} {s['deg']:.4g} deg ({s['rest_s']:.2g} s)"
                                 for s in d.settings.get("stops_seen") or []) or "-"
                row = (f"| {name} | {bench} | {', '.join(map(_finding, d.findings)) or '-'} | "
                       f"{d.verdict.replace('_', ' ')} | {seen} | {_jb(d)} | {dt:.0f} |")
                rows.append(row)
                print(row, flush=True)
    text = "\n".join([
        "## CE150 diagnosed (benchmarks/ce150_diagnose.py)",
        "",
        f"`python benchmarks/ce150_diagnose.py --seed {args.seed} --n {args.n}`: logs of the CE150's published model "
        "(tests/plants/ce150.py) diagnosed blind under `humusoft_ce150` (its [structure] and its [effects]' "
        "second-order motors, taken as given: the right answer is consistent, nothing found), under humusoft_ce150 "
        "without its [effects] (the right answer is motor_second_lag on pitch ~0.3 s and on yaw ~0.25 s) and under "
        "`humusoft_ce150_eq1` (eq. (1)'s structure). J/B: under the findings' model, against "
        "the published values. Stop said: an end stop the bench file does not state, which the verdict says may hold "
        "the angle (the model has one under humusoft_ce150, which states it). Median time a log: "
        + ", ".join(f"{b} {np.median(v):.0f} s" for b, v in times.items()) + ".",
        "",
        "| log | bench | findings | verdict | stop said | J/B | time [s] |",
        "|---|---|---|---|---|---|---|",
        *rows,
    ])
    publish("CE150 diagnosed (benchmarks/ce150_diagnose.py)", text, write=not args.no_write)


if __name__ == "__main__":
    main()
