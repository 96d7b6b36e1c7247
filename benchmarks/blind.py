"""Blind set (issues #11, #14): logs whose shape no test chose, drawn from a seed no test uses.

    python benchmarks/blind.py             # 32 good-model logs + 8 wrong-model logs, 2 processes (~3 min)

Good-model logs (seed-model physics, sim/): true J1, B1, J2, B2 and every known value drawn off Table 1
(known values +-10 %, handed to the tool as its parameter file, as a lab would), reference, sample rate
(100 Hz-1 kHz), noise (12-bit, 0.5 mrad, 1 mrad), start (rest, or 20-60 s into a run), stamp jitter (0 or
+-20 %) and voltage offset (0, or 0.1-0.9 of a step, carried in the CSV column t_u), 60-120 s long.
Criteria: J within 1 %, B within 3 %, the 95 % intervals cover (counted), the model judged adequate.
Wrong-model logs: the published Rotondo et al. (2013) plant (tests/plants), and seed logs with an effect
the model lacks or with a known value given 15 % off: the model must be judged NOT adequate.
Writes the "Blind set" section of benchmarks/RESULTS.md.
"""
from __future__ import annotations

import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

SEED = 20261123  # no test uses it
REFS = ("square", "sine", "multisine", "steps", "chirp")
KNOWN_JITTER = ("a1", "b1", "a2", "b2", "Mg", "Kg", "k1", "k2", "kc")
NAMES = ("J1", "B1", "J2", "B2")
VERDICT = {True: "yes", False: "NO", None: "not decided"}
VERDICT_WRONG = {True: "YES (miss)", False: "no", None: "not decided"}


def good(i: int) -> dict:
    from results import percent_errors

    from sim import SimSettings, simulate
    from trms_ident.identify import Settings, identify
    from trms_ident.log import validated
    from trms_ident.params import defaults

    rng = np.random.default_rng([SEED, i])
    table = defaults()
    true = {"J1": rng.uniform(0.05, 0.09), "B1": rng.uniform(0.004, 0.009), "J2": rng.uniform(0.015, 0.03),
            "B2": rng.uniform(0.07, 0.14)}
    known = {k: table[k] * rng.uniform(0.9, 1.1) for k in KNOWN_JITTER}
    noise = rng.choice(["12-bit", "0.5 mrad", "1 mrad"])
    case = dict(ref=str(rng.choice(REFS)), sample_rate_hz=float(rng.choice([100.0, 250.0, 500.0, 1000.0])),
                duration_s=float(rng.choice([60.0, 90.0, 120.0])), seed=int(rng.integers(1 << 30)),
                noise_std_rad={"12-bit": 0.0, "0.5 mrad": 5e-4, "1 mrad": 1e-3}[noise],
                quantization_rad=2 * math.pi / 4096 if noise == "12-bit" else 0.0,
                start_s=float(rng.choice([0.0, rng.uniform(20, 60)])), jitter=float(rng.choice([0.0, 0.2])),
                voltage_offset=float(rng.choice([0.0, rng.uniform(0.1, 0.9)])),
                initial_yaw_rad=float(rng.uniform(-0.3, 0.3)), overrides={**true, **known})
    r = simulate(SimSettings(**case))
    sw = None if not case["voltage_offset"] else np.repeat(r.u_time_s[:, None], 2, axis=1)
    # the angles are radians and said so: the seed model's yaw can drift past 8 pi (its weak reverse thrust),
    # which --angle-unit auto would refuse as "looks like degrees"
    log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, u_switch_s=sw, angle_unit="rad")
    res = identify(log, Settings(overrides=known))
    err = percent_errors(res.estimates, true)
    cover = {k: bool(res.intervals[k].low <= true[k] <= res.intervals[k].high) for k in NAMES}
    ok = all(err[k] <= (1.0 if k.startswith("J") else 3.0) for k in NAMES)
    desc = (f"{case['ref']} {case['sample_rate_hz']:g} Hz {noise} {'mid-run' if case['start_s'] else 'rest'}"
            f"{' jitter' if case['jitter'] else ''}{' v-offset' if case['voltage_offset'] else ''}")
    return {"kind": "good", "i": i, "desc": desc, "err": err, "cover": cover, "ok": ok,
            "adequate": res.model_check["adequate"]}


def wrong(i: int) -> dict:
    from sim import SimSettings, simulate
    from trms_ident.identify import Settings, identify
    from trms_ident.log import validated

    rng = np.random.default_rng([SEED, 1000 + i])
    if i < 2:
        from tests.plants.rotondo import simulate_log

        t, u1, u2, a, b = simulate_log(duration_s=90.0, rate_hz=float(rng.choice([100.0, 200.0])),
                                       seed=int(rng.integers(1 << 30)))
        log, settings, desc = validated(t, u1, u2, a, b), Settings(), "Rotondo et al. (2013) plant"
    else:
        effects = [("cable_stiffness", "yaw", 0.006), ("coulomb_friction", "pitch", 0.004),
                   ("quadratic_drag", "yaw", 0.03), ("input_delay", "both", 0.03)]
        common = dict(ref=str(rng.choice(REFS[2:])), sample_rate_hz=200.0, duration_s=90.0,
                      noise_std_rad=5e-4, seed=int(rng.integers(1 << 30)))
        if i < 6:
            e = effects[i - 2]
            r = simulate(SimSettings(**common, effects=[{"effect": e[0], "axis": e[1], "value": e[2]}]))
            settings, desc = Settings(), f"{e[0]}:{e[1]}={e[2]} ({common['ref']})"
        else:
            name = ("Mg", "k2")[i - 6]
            r = simulate(SimSettings(**common))
            settings, desc = Settings(overrides={name: 1.15 * {"Mg": 0.32, "k2": 0.8}[name]}), f"{name} given 15 % off"
        log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad")
    res = identify(log, settings)
    return {"kind": "wrong", "i": i, "desc": desc, "adequate": res.model_check["adequate"],
            "suspect": (res.model_check.get("suspect") or {}).get("name")}


def run(job):
    kind, i = job
    return good(i) if kind == "good" else wrong(i)


def main() -> None:
    from results import plain_args

    args = plain_args(__doc__)
    t0 = time.perf_counter()
    jobs = [("good", i) for i in range(32)] + [("wrong", i) for i in range(8)]
    with ProcessPoolExecutor(max_workers=2) as pool:
        rows = list(pool.map(run, jobs))
    goods = [r for r in rows if r["kind"] == "good"]
    wrongs = [r for r in rows if r["kind"] == "wrong"]
    lines = ["| # | log | J1 | B1 | J2 | B2 [% error] | covered | adequate | within J 1 % / B 3 % |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in goods:
        lines.append(f"| {r['i']} | {r['desc']} | " + " | ".join(f"{r['err'][k]:.3g}" for k in NAMES) +
                     f" | {sum(r['cover'].values())}/4 | {VERDICT[r['adequate']]} | "
                     f"{'yes' if r['ok'] else 'NO'} |")
    lines += ["", "| # | wrong-model log | judged adequate | known value blamed |", "|---|---|---|---|"]
    for r in wrongs:
        lines.append(f"| {r['i']} | {r['desc']} | {VERDICT_WRONG[r['adequate']]} | {r['suspect'] or '-'} |")
    covered = sum(sum(r["cover"].values()) for r in goods)
    summary = (f"Good-model logs: within J 1 % / B 3 % in {sum(r['ok'] for r in goods)}/{len(goods)}, judged adequate "
               f"in {sum(r['adequate'] is True for r in goods)}/{len(goods)}, 95 % intervals cover {covered}/{4 * len(goods)} "
               f"({100 * covered / (4 * len(goods)):.1f} %). Wrong-model logs judged not adequate: "
               f"{sum(r['adequate'] is False for r in wrongs)}/{len(wrongs)} (not decided: "
               f"{sum(r['adequate'] is None for r in rows)}). {time.perf_counter() - t0:.0f} s on 2 "
               "processes.")
    text = ("## Blind set\n\n`python benchmarks/blind.py` (seed 20261123, used by no test; see its docstring for "
            "what is drawn).\n\n" + "\n".join(lines) + "\n\n" + summary + "\n")
    print(text)
    from results import update_section

    if not args.no_write:
        update_section(Path(__file__).with_name("RESULTS.md"), "Blind set", text)


if __name__ == "__main__":
    main()
