"""Diagnose on a plant nobody here shaped the effects of: eq. (1) with its effects in the modelling tools' forms.

    python benchmarks/independent.py --seed 7301      # 30 benches, 2 processes; writes "Independent plants"
    python benchmarks/independent.py --seed 7301 --n 6 --no-write      # the first 6, printed only
    python benchmarks/independent.py --seed 7301 --only 3 17           # these benches again (printed only)

The logs come from tests/plants/textbook.py, written from the model and the blocks' documentation, not from sim/
or trms_ident/: a dead zone as Simulink's Dead Zone block draws it (0 inside [-w, w], u - w sign(u) outside), a
saturation as its Saturation block, a motor of second order with both time constants free (its own T11 or T21
off the table and a second lag T2 in front), driven by a digital PID on the logged angles and logged through a
12-bit encoder or Gaussian noise.  Kinds of bench (30 in all, in this order, bench i of a kind drawn from
[seed, i]): clean (4); a dead zone on one motor, 0.1-0.3 V (6); on both motors (4); a second-order motor with
both time constants off the table, its own 10-25 % (6); a known value 15-40 % off beside a dead zone (4); a
saturation on one motor at a level its voltages reach (3); a dead zone beside a second-order motor (3).  Each
log 60 s, from rest or cut 20-40 s into a run, 100-500 Hz (a sixth at 1 kHz).  A bench whose closed loop runs
away (the pitch beyond 1 rad or the main motor at its limit on more than a fifth of the samples; a lab would
retune its PID) is drawn again.
diagnose is given the log alone (Table 1's values).

Judged per bench as benchmarks/compound.py judges: each difference *named* (a finding, or a flagged look-alike of
one; a second-order motor whose first time constant is off: its second lag and its T11/T21, the latter as the
known value or as motor_lag), its value within 30 %, *nothing invented* (every finding is a difference of the bench
or flags one as its look-alike), and the verdict.  A dead zone named in the cut-off form (``dead_zone``) is
counted apart: the right motor, the wrong form.  Issue #74's targets: every difference named on >= 85 %, nothing
invented on >= 90 %, clean logs 0 findings.
"""
from __future__ import annotations

import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from compound import SAME  # noqa: E402  (library keys that are a known value under another name)

KINDS = (("clean", 4), ("dead zone", 6), ("dead zone, both motors", 4), ("second-order motor", 6),
         ("known value + dead zone", 4), ("saturation", 3), ("dead zone + second-order motor", 3))
TOLERANCE = 0.3
KNOWN = ("Mg", "kc", "k1", "k2", "b1", "a2")
TIME_CONSTANT = {"pitch": "T11", "yaw": "T21"}


def _draw(kind: str, rng) -> tuple[dict, dict]:
    """(the plant's keywords for textbook.simulate_log, the truth: key -> value)."""
    kw: dict = {"values": {}}
    truth: dict = {}
    axis = ("pitch", "yaw")[int(rng.integers(2))]

    def dead_zone(ax):
        w = round(float(rng.uniform(0.1, 0.3)), 3)
        zone = kw.setdefault("dead_zone_v", [0.0, 0.0])
        zone[0 if ax == "pitch" else 1] = w
        truth[f"shifted_dead_zone:{ax}"] = w

    def second_order(ax):
        j = 0 if ax == "pitch" else 1
        table = {"pitch": 1.1, "yaw": 1.0}[ax]
        # the main motor's loop tolerates less lag under the PID (a faster first lag, a shorter second)
        t2 = round(float(rng.uniform(0.05, 0.12) if ax == "pitch" else rng.uniform(0.1, 0.3)), 3)
        # its own time constant at least 10 % off the table's (a draw within 1 % is the table's value: seed
        # 69985 drew T21 0.996 s and 0.993 s, judged as misses of a known value no log can tell from the table's)
        f = float(rng.uniform(0.75, 0.9) if ax == "pitch" else rng.uniform(0.75, 1.05))
        t1 = round(table * (f if f < 0.9 else f + 0.2), 3)  # the yaw's: 0.75-0.9 or 1.1-1.25 of the table's
        lags = list(kw.get("second_lag_s", (0.0, 0.0)))
        lags[j] = t2
        kw["second_lag_s"] = tuple(lags)
        kw["values"][TIME_CONSTANT[ax]] = t1
        truth[f"motor_second_lag:{ax}"] = t2
        truth[f"known_value:{TIME_CONSTANT[ax]}"] = t1

    if kind == "dead zone":
        dead_zone(axis)
    elif kind == "dead zone, both motors":
        dead_zone("pitch")
        dead_zone("yaw")
    elif kind == "second-order motor":
        second_order(axis)
    elif kind == "known value + dead zone":
        name = KNOWN[int(rng.integers(len(KNOWN)))]
        from trms_ident.params import defaults

        v = defaults()[name] * (1 + float(rng.choice([-1, 1])) * float(rng.uniform(0.15, 0.4)))
        kw["values"][name] = round(v, 5)
        truth[f"known_value:{name}"] = kw["values"][name]
        dead_zone(axis)
    elif kind == "saturation":
        truth[f"input_saturation:{axis}"] = None  # its level: where the voltages reach (run)
    elif kind == "dead zone + second-order motor":
        dead_zone(axis)
        second_order(("yaw", "pitch")[int(rng.integers(2))] if axis == "yaw" else "yaw")
    if "dead_zone_v" in kw:
        kw["dead_zone_v"] = tuple(kw["dead_zone_v"])
    rate = float(rng.choice([100.0, 200.0, 500.0, 1000.0], p=[0.3, 0.3, 0.25, 0.15]))
    kw.update(duration_s=60.0, rate_hz=rate, seed=int(rng.integers(2 ** 31)),
              ref=("multisine", "steps")[int(rng.integers(2))],
              start_s=0.0 if rng.random() < 0.5 else round(float(rng.uniform(20.0, 40.0)), 1))
    if rng.random() < 0.5:
        kw.update(encoder_bits=12, noise_rad=0.0)
    else:
        kw.update(encoder_bits=None, noise_rad=round(float(rng.uniform(3e-4, 1e-3)), 5))
    return kw, truth


def _runs_away(u1, alpha, beta) -> bool:
    """The closed loop lost the bench: the beam past 1 rad, the main motor at its limit on a fifth of the samples, or
    the yaw beyond the four turns a cabled bench allows (trms_ident.log.YAW_LIMIT_RAD: such a log is refused as in
    no angle unit; seed 4471 drew one, and the run stopped there)."""
    from trms_ident.log import YAW_LIMIT_RAD

    return bool(np.max(np.abs(alpha)) > 1.0 or np.mean(np.abs(u1) >= 2.5 - 1e-9) > 0.2
                or np.max(np.abs(beta)) > YAW_LIMIT_RAD)


def _judge(d, truth: dict) -> dict:
    """Named, within tolerance, invented; a dead zone named in the cut-off form."""
    found = {}
    for f in d.findings:
        key = f"known_value:{f.parameter['name']}" if f.effect == "known_value" else f"{f.effect}:{f.axis}"
        key = SAME.get(key, key)
        found[key] = (float(f.parameter["value"]), [SAME.get(a, a) if ":" in a else "known_value:" + a
                                                    for a in f.alternatives])
    named, within, form = {}, {}, []
    for key, v in truth.items():
        flagged = any(key in alts or any(a.startswith(key + " ") for a in alts) for _, alts in found.values())
        named[key] = key in found or flagged
        within[key] = flagged if key not in found else abs(found[key][0] - v) <= TOLERANCE * abs(v)
        cut = key.replace("shifted_dead_zone", "dead_zone")
        if key.startswith("shifted_dead_zone") and not named[key] and cut in found:
            form.append(key)
    invented = [k for k, (_, alts) in found.items() if k not in truth and k.replace("dead_zone", "shifted_dead_zone")
                not in form and not any(t in alts or any(a.startswith(t + " ") for a in alts) for t in truth)]
    return {"named": named, "within": within, "invented": invented, "wrong_form": form,
            "found": [f"{k} {v:.4g}" for k, (v, _) in found.items()]}


def draw_log(case: dict) -> tuple[dict, dict, tuple]:
    """(the plant's keywords, the truth, the log's columns t, u1, u2, alpha, beta) of bench ``case``."""
    from tests.plants.textbook import simulate_log

    rng = np.random.default_rng([case["seed"], case["i"]])
    for _ in range(20):
        kw, truth = _draw(case["kind"], rng)
        if case["kind"] == "saturation":  # a level the motor reaches: 70-95 % of its samples below it
            j = next(0 if k.endswith("pitch") else 1 for k in truth)
            bare = simulate_log(**kw)
            u = np.abs(bare[1 + j])
            level = round(min(max(float(np.quantile(u, rng.uniform(0.7, 0.95))), 0.8), 2.4), 3)
            kw["saturation_v"] = tuple(level if m == j else math.inf for m in range(2))
            truth = {next(iter(truth)): level}
        t, u1, u2, alpha, beta = simulate_log(**kw)
        if not _runs_away(u1, alpha, beta):
            break
    return kw, truth, (t, u1, u2, alpha, beta)


def run(case: dict) -> dict:
    import trms_ident as ti
    from trms_ident.log import validated

    kw, truth, columns = draw_log(case)
    t0 = time.perf_counter()
    try:
        d = ti.diagnose(validated(*columns))
        verdict, judged = d.verdict, _judge(d, truth)
    except Exception as exc:  # noqa: BLE001 - a benchmark says what happened, it does not stop
        verdict, judged = f"failed ({exc})", {"named": {}, "within": {}, "invented": [], "wrong_form": [],
                                              "found": []}
    told = (f"{kw['ref']} {kw['rate_hz']:g} Hz {'from rest' if not kw['start_s'] else 'mid-run'} "
            f"{'12-bit' if kw['encoder_bits'] else 'gauss'}")
    return {"i": case["i"], "kind": case["kind"], "log": told, "verdict": verdict,
            "hidden": [f"{k} {v:.4g}" for k, v in truth.items()], **judged, "seconds": time.perf_counter() - t0}


def cases(seed: int, n: int) -> list[dict]:
    out = []
    for kind, count in KINDS:
        out += [{"kind": kind, "seed": seed} for _ in range(count)]
    for i, c in enumerate(out):
        c["i"] = i
    return out[:n]


def _row(r: dict) -> str:
    named = all(r["named"].values()) if r["named"] else True
    return (f"| {r['i']} | {r['kind']} | {r['log']} | {', '.join(r['hidden']) or '-'} | "
            f"{', '.join(r['found']) or '-'} | {r['verdict']} | {'yes' if named else 'no'} | "
            f"{', '.join(r['invented']) or '-'} | {r['seconds']:.0f} |")


def table(results: list[dict], seed: int, commit: str) -> str:
    res = sorted(results, key=lambda r: r["i"])
    diff = [r for r in res if r["kind"] != "clean"]
    clean = [r for r in res if r["kind"] == "clean"]
    all_named = sum(all(r["named"].values()) for r in diff)
    keys = sum(len(r["named"]) for r in diff)
    named_keys = sum(sum(r["named"].values()) for r in diff)
    within = sum(all(r["within"].values()) for r in diff)
    clean_ok = sum(not r["found"] for r in clean)
    nothing_invented = sum(not r["invented"] for r in res)
    explained = sum(r["verdict"] == "explained" for r in diff)
    form = sum(len(r["wrong_form"]) for r in res)
    secs = sorted(r["seconds"] for r in res)
    lines = [f"## Independent plants (seed {seed}, at {commit})", "",
             "`python benchmarks/independent.py --seed " + str(seed) + "`: tests/plants/textbook.py's effects in the "
             "modelling tools' forms (module docstring). "
             f"Every difference named on **{all_named}/{len(diff)}** benches ({named_keys}/{keys} differences), "
             f"values within 30 % on {within}/{len(diff)}, explained {explained}/{len(diff)}; nothing invented on "
             f"**{nothing_invented}/{len(res)}**; clean logs with no finding **{clean_ok}/{len(clean)}**; dead zones "
             f"named in the cut-off form instead: {form}. diagnose's time a log: median "
             f"{secs[len(secs) // 2]:.0f} s, slowest {secs[-1]:.0f} s (2 processes on 2 cores). "
             "Issue #74's targets: named >= 85 %, nothing invented >= 90 %, clean 0 findings.", "",
             "| # | kind | log | the bench's differences | findings | verdict | all named | invented | s |",
             "|---|---|---|---|---|---|---|---|---|"]
    return "\n".join(lines + [_row(r) for r in res])


def main() -> None:
    import argparse
    import subprocess

    from results import publish

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, required=True, help="the benches' seed (say which in RESULTS.md)")
    ap.add_argument("--n", type=int, default=30, help="how many benches (default 30, the kinds in order)")
    ap.add_argument("--only", type=int, nargs="+", help="run only these benches (printed only)")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    todo = cases(a.seed, 30 if a.only else a.n)
    if a.only:
        todo = [c for c in todo if c["i"] in a.only]
    results = []
    with ProcessPoolExecutor(a.workers) as pool:
        for fut in as_completed([pool.submit(run, c) for c in todo]):
            r = fut.result()
            results.append(r)
            print(_row(r), file=sys.stderr, flush=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=Path(__file__).parent).stdout.strip()
    publish("Independent plants", table(results, a.seed, commit), write=not (a.no_write or a.only or a.n < 30))


if __name__ == "__main__":
    main()
