"""Freed effects' 95 % intervals against the truth, blind: does `estimate --free KEY` cover as often as it says?

    python benchmarks/freed_coverage.py            # 10 benches per effect, 2 processes
    python benchmarks/freed_coverage.py --n 20

Per effect (a pitch Coulomb friction, a pitch centre-of-mass offset, a yaw cable, a yaw Coulomb friction) and seed
(from a seed no test uses): a bench with J1, B1, J2, B2 at 0.7-1.4x Table 1 and that one effect at a random value;
one log with a random reference, rate (100-500 Hz), start (from rest or 10-40 s into a run) and noise (12-bit or
Gaussian 0.3-1 mrad), 40-60 s, as diagnosed_model.py draws them.  The effect is given 20 % off its value and
freed (`estimate --params` with it in [effects], `--free KEY`).  Reported: the error in half-widths of the 95 %
interval (|z| <= 1: covered), the share covered, and J/B's intervals' coverage beside it.  It separates an
interval's calibration from diagnose's findings: diagnosed_model.py's freed line mixes both.  Writes the "Freed
intervals" section of benchmarks/RESULTS.md.
"""
from __future__ import annotations

import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

SEED = 20261202  # no test uses it
KEYS = {"coulomb_friction:pitch": (0.002, 0.005), "com_offset:pitch": (0.01, 0.03),
        "cable_stiffness:yaw": (0.002, 0.006), "coulomb_friction:yaw": (0.002, 0.005)}
NAMES = ("J1", "B1", "J2", "B2")


def run(job: tuple) -> dict:
    import trms_ident as ti
    from diagnosed_model import log_draw
    from trms_ident.errors import SettingsError
    from trms_ident.io.csv_log import write_csv_log
    from trms_ident.params import defaults

    key, i = job
    rng = np.random.default_rng([SEED, i, list(KEYS).index(key)])
    table = defaults()
    lo, hi = KEYS[key]
    effect, axis = key.split(":")
    for _ in range(10):  # a bench whose closed loop leaves the pitch range: drawn again
        true = {k: table[k] * rng.uniform(0.7, 1.4) for k in NAMES}
        v = float(rng.uniform(lo, hi))
        noise = str(rng.choice(["12-bit", "gauss"]))
        s = dict(log_draw(rng, noise), overrides=true, effects=[{"effect": effect, "axis": axis, "value": v}])
        try:
            sim = ti.simulate(**s)
            break
        except SettingsError:
            continue
    out = {"key": key, "i": i, "log": f"{s['ref']} {s['sample_rate_hz']:g} Hz "
           f"{'from rest' if not s['start_s'] else 'mid-run'} {noise}"}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.csv"
        write_csv_log(path, sim.t_s, sim.u1_v, sim.u2_v, sim.alpha_rad, sim.beta_rad)
        try:
            doc = ti.estimate(path, angle_unit="rad", effects={key: 1.2 * v}, free=(key,)).doc
        except Exception as exc:  # noqa: BLE001 - a benchmark says what happened, it does not stop
            return {**out, "failed": str(exc)}
    f = doc["refined"]["known_values_estimated"][key]
    half = (f["ci95"][1] - f["ci95"][0]) / 2.0
    out["z"] = (f["estimate"] - v) / half  # the error in half-widths: |z| <= 1 is covered
    out["error_percent"] = 100.0 * (f["estimate"] / v - 1.0)
    out["jb_covered"] = sum(doc["ci95"][k][0] is not None and doc["ci95"][k][0] <= t <= doc["ci95"][k][1]
                            for k, t in true.items())
    out["fits"] = doc["model_check"]["adequate"]
    return out


def main() -> None:
    from results import publish, seed_args

    args = seed_args(__doc__, n=10)
    t0 = time.perf_counter()
    jobs = [(k, i) for k in KEYS for i in range(args.n)]
    with ProcessPoolExecutor(max_workers=2) as pool:
        rows = list(pool.map(run, jobs))
    ok = [r for r in rows if "z" in r]
    lines = ["| effect | seed | log | error [%] | error / half-width | covered | J/B covered | fits |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "z" not in r:
            lines.append(f"| {r['key']} | {r['i']} | {r['log']} | failed: {r['failed']} | | | | |")
            continue
        lines.append(f"| {r['key']} | {r['i']} | {r['log']} | {r['error_percent']:+.3g} | {r['z']:+.2f} | "
                     f"{'yes' if abs(r['z']) <= 1 else 'NO'} | {r['jb_covered']}/4 | {r['fits']} |")
    per_key = "; ".join(f"{k} {sum(abs(r['z']) <= 1 for r in ok if r['key'] == k)}/"
                        f"{sum(r['key'] == k for r in ok)}" for k in KEYS)
    summary = (f"{len(rows)} benches: the freed value's 95 % interval covers the truth on "
               f"{sum(abs(r['z']) <= 1 for r in ok)}/{len(ok)} ({per_key}); J/B's intervals cover "
               f"{sum(r['jb_covered'] for r in ok)}/{4 * len(ok)}; \"fits\" on {sum(r['fits'] is True for r in ok)}/"
               f"{len(ok)}; failed {len(rows) - len(ok)}.  {time.perf_counter() - t0:.0f} s on 2 processes.")
    text = ("## Freed intervals (benchmarks/freed_coverage.py, blind, seed 20261202)\n\n"
            "One effect per bench, given 20 % off its value and freed with J/B (`estimate --params` with it in "
            "[effects], `--free KEY`): the interval's calibration alone, without diagnose.\n\n"
            + summary + "\n\n" + "\n".join(lines) + "\n")
    publish("Freed intervals", text, write=not args.no_write)


if __name__ == "__main__":
    main()
