"""`trms-ident design --effect` (issue #35, item 4): does diagnose find the effect on the designed run?

    python benchmarks/design_effect.py      # a 0.001 N m pitch Coulomb friction, 10 seeds; prints and writes
                                            # the "Design for an effect" section of RESULTS.md

Table 1's bench with a pitch Coulomb friction of 0.001 N m, 30 s at 100 Hz, 1 mrad Gaussian noise.  The design
is made for that effect and size; then the designed references and the paper's square are each run through the
simulator with 10 noise seeds from 12000 and diagnosed (diagnose sees the log only).  Found: coulomb_friction on
pitch named first (or as the first finding's flagged look-alike) with its value within 30 %.
"""
from __future__ import annotations

import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

KEY, SIZE, SIGMA, RATE, DURATION = "coulomb_friction:pitch", 0.001, 1e-3, 100.0, 30.0
SEEDS = tuple(range(12000, 12010))


def _one(args) -> dict:
    from sim import SimSettings, simulate
    from trms_ident.diagnosis.run import diagnose
    from trms_ident.log import validated

    ref, table, seed = args
    kw = dict(ref="file", ref_table=table) if ref == "design" else dict(ref=ref)
    r = simulate(SimSettings(**kw, duration_s=DURATION, sample_rate_hz=RATE, seed=seed, noise_std_rad=SIGMA,
                             effects=[{"effect": "coulomb_friction", "axis": "pitch", "value": SIZE}]))
    d = diagnose(validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad"), {})
    first = d.findings[0] if d.findings else None
    found = bool(first) and ((f"{first.effect}:{first.axis}" == KEY and abs(first.parameter["value"] / SIZE - 1) <= 0.3)
                             or KEY in first.alternatives)
    return {"ref": ref, "seed": seed, "found": found, "verdict": d.verdict,
            "first": None if first is None else f"{first.effect}:{first.axis}={first.parameter['value']:.3g}"}


def main() -> None:
    from results import plain_args

    args = plain_args(__doc__)
    from sim.simulate import DEFAULT_PID
    from trms_ident.design import Limits, describe, design
    from trms_ident.params import defaults

    t0 = time.perf_counter()
    noise = {"alpha": SIGMA, "beta": SIGMA}
    d = design(DURATION, RATE, defaults(), "quadratic", noise, DEFAULT_PID, 2.5, Limits(), effect=(KEY, SIZE))
    table = (d.run.t_s, d.run.alpha_ref_rad, d.run.beta_ref_rad)
    with ProcessPoolExecutor(max_workers=2) as pool:
        rows = list(pool.map(_one, [(ref, table, s) for ref in ("design", "square") for s in SEEDS]))
    lines = []
    for ref, run in (("design", d.run), ("square", d.square)):
        rs = [r for r in rows if r["ref"] == ref]
        lines.append(f"| {ref} | {run.effect['t']:.3g} | {100 * run.effect['power']:.3g} % | "
                     f"{sum(r['found'] for r in rs)}/{len(rs)} | {100 * run.envelope['saturated_share']:.1f} % | "
                     f"{'; '.join(run.violations) or 'none'} | "
                     f"{', '.join(sorted(set(r['first'] or '-' for r in rs if not r['found']))) or '-'} |")
    text = ("## Design for an effect (benchmarks/design_effect.py, blind, seeds from 12000)\n\n"
            f"`design --effect {KEY} --size {SIZE:g}` on Table 1's bench with that friction, {DURATION:g} s at "
            f"{RATE:g} Hz, {1e3 * SIGMA:g} mrad noise; the designed run (pitch {describe(d.pitch)}; yaw "
            f"{describe(d.yaw)}) and the paper's square, "
            f"each diagnosed on {len(SEEDS)} noise seeds.\n\n"
            "| reference | predicted t | predicted power | diagnose found it | at the voltage limit | limits broken | "
            "first finding when missed |\n|---|---|---|---|---|---|---|\n" + "\n".join(lines)
            + f"\n\n{time.perf_counter() - t0:.0f} s on 2 processes.\n")
    from results import publish

    publish("Design for an effect", text, write=not args.no_write)


if __name__ == "__main__":
    main()
