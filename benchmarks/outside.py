"""Physics outside diagnose's library (issues #12, #32): Rotondo's plant never explained; a known value off named.

    python benchmarks/outside.py        # 16 logs on 2 processes, a few minutes; writes the "Outside the library"
                                        # section of RESULTS.md

Logs whose physics no named effect describes, from seeds no test uses (from 7000 up):
- the published plant of Rotondo, Nejjari and Puig (2013) (tests/plants/rotondo.py, a port nobody here shaped:
  rotor-speed states, asymmetric thrust, pitch-dependent yaw inertia, cable torque), four open-loop logs;
- the seed model with one known value off the value diagnose is given (Table 1's): the gyroscopic coupling Kg
  twice, the reaction moment kc half, the gravity moment Mg 0.75x, the tail rotor's thrust b2 1.3x, the main
  rotor's thrust a1 0.8x, the reaction's lead T0 0.5x; each on two logs (multisine 200 Hz 12-bit from rest,
  steps 250 Hz 1 mrad 30 s into the run).
Rotondo's plant: the verdict must be partly_explained or unexplained (consistent only where the seed-model check
says the model fits: nothing to explain); a named finding there is a lead, never a reason to call it explained.
One known value off (issue #32): that value must be named, first or as a flagged look-alike of the first finding,
refitted within 30 % of the deviation (|value - true| <= 0.3 |true - table|), verdict explained; no cable, offset
or asymmetry invented in its place.
"""
from __future__ import annotations

import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

#: (known value, factor the plant's value is off by)
OFF = (("Kg", 2.0), ("kc", 0.5), ("Mg", 0.75), ("b2", 1.3), ("a1", 0.8), ("T0", 0.5))
#: (reference, rate [Hz], noise [rad], quantization [rad], start [s])
CONDITIONS = (("multisine", 200.0, 0.0, 2 * math.pi / 4096, 0.0), ("steps", 250.0, 1e-3, 0.0, 30.0))
ROTONDO = ((100.0, 5e-4), (200.0, 1e-3), (100.0, 1e-3), (250.0, 5e-4))  # (rate [Hz], noise [rad])
DURATION_S = 90.0


def cases() -> list[dict]:
    out = [dict(plant="rotondo", rate=rate, noise=noise) for rate, noise in ROTONDO]
    out += [dict(plant="seed", known=k, factor=f, cond=c) for k, f in OFF for c in CONDITIONS]
    for i, c in enumerate(out):
        c["seed"] = 7000 + i
    return out


def _log(c: dict):
    from sim import SimSettings, simulate
    from trms_ident.log import validated

    if c["plant"] == "rotondo":
        from tests.plants.rotondo import simulate_log

        t, u1, u2, a, b = simulate_log(DURATION_S, c["rate"], c["seed"], c["noise"])
        return validated(t, u1, u2, a, b, angle_unit="rad")
    from trms_ident.params import defaults

    ref, rate, noise, q, start = c["cond"]
    r = simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=DURATION_S, noise_std_rad=noise,
                             quantization_rad=q, seed=c["seed"], start_s=start,
                             overrides={c["known"]: defaults()[c["known"]] * c["factor"]}))
    return validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad")


def run_case(c: dict) -> dict:
    from trms_ident.diagnosis.run import diagnose
    from trms_ident.errors import IdentificationError, LogFormatError

    t0 = time.perf_counter()
    try:
        d = diagnose(_log(c))
    except (LogFormatError, IdentificationError) as exc:
        return dict(case=c, error=str(exc))
    first = d.findings[0] if d.findings else None
    names = []
    if first is not None:
        names = [first.parameter["name"] if first.effect == "known_value" else f"{first.effect}:{first.axis}"]
        names += [a.split(":", 1)[1] if a.startswith("known_value:") else a for a in first.alternatives]
    value = next((f.parameter["value"] for f in d.findings if f.effect == "known_value" and
                  f.parameter["name"] == c.get("known")), None)
    return dict(case=c, verdict=d.verdict, seed_fits=bool(d.seed_check.get("adequate")),
                findings=[(f"{f.parameter['name']}={f.parameter['value']:.4g} (known value)" if f.effect == "known_value"
                           else f"{f.effect}:{f.axis}={f.parameter['value']:.3g}") for f in d.findings],
                names=names, value=value, estimate_named=(d.seed_check.get("suspect") or {}).get("name"),
                corrections=[c_.axis for c_ in d.corrections], seconds=time.perf_counter() - t0)


def right(r: dict) -> bool:
    """Rotondo's plant: never explained (consistent only where the seed model fits).  One known value off: that
    value named first or as a flagged look-alike of the first finding, within 30 % of the deviation, explained."""
    c = r["case"]
    if c["plant"] == "rotondo":
        return r["verdict"] in ("partly_explained", "unexplained") or (r["seed_fits"] and r["verdict"] == "consistent")
    from trms_ident.params import defaults

    table = defaults()[c["known"]]
    true = table * c["factor"]
    return (r["verdict"] == "explained" and c["known"] in r["names"] and r["value"] is not None
            and abs(r["value"] - true) <= 0.3 * abs(true - table))


def _name(c: dict) -> str:
    if c["plant"] == "rotondo":
        return f"Rotondo et al. (2013), {c['rate']:g} Hz, {c['noise'] * 1e3:g} mrad"
    ref, rate, noise, q, start = c["cond"]
    return (f"{c['known']} x{c['factor']:g}, {ref} {rate:g} Hz " + ("12-bit" if q else f"{noise * 1e3:g} mrad")
            + (f", from {start:g} s" if start else ", from rest"))


def main() -> None:
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(run_case, cases()))
    elapsed = time.perf_counter() - t0
    rows, wrong = [], []
    for r in results:
        if "error" in r:
            rows.append(f"| {_name(r['case'])} | - | refused: {r['error'][:120]} | - | - | - | - |")
            wrong.append(_name(r["case"]))
            continue
        ok = right(r)
        if not ok:
            wrong.append(_name(r["case"]))
        rows.append(f"| {_name(r['case'])} | {'fits' if r['seed_fits'] else 'does not fit'} | {r['verdict']} | "
                    f"{'; '.join(r['findings']) or '-'} | {r['estimate_named'] or '-'} | "
                    f"{', '.join(r['corrections']) or '-'} | {'yes' if ok else 'NO'} |")
    rot = [r for r in results if r["case"]["plant"] == "rotondo"]
    known = [r for r in results if r["case"]["plant"] == "seed"]
    text = ("## Outside the library (benchmarks/outside.py, blind, seeds from 7000)\n\n"
            "The published Rotondo et al. (2013) plant (right: `partly_explained` or `unexplained`, `consistent` "
            "only where the seed model already fits), and the seed model with one known value off the one diagnose "
            "is given (right: that value named first or as a flagged look-alike, refitted within 30 % of the "
            "deviation, `explained`). 'estimate names' is the known value estimate's adequacy check blames on the "
            "same log.\n\n"
            "| log | seed model | verdict | findings | estimate names | corrections (axes) | right |\n"
            "|---|---|---|---|---|---|---|\n"
            + "\n".join(rows)
            + f"\n\nRotondo's plant right: {sum(right(r) for r in rot if 'error' not in r)}/{len(rot)}. Known value "
            f"named right: {sum(right(r) for r in known if 'error' not in r)}/{len(known)}"
            f"{' (wrong: ' + '; '.join(wrong) + ')' if wrong else ''}. Total {elapsed:.0f} s on 2 processes.\n")
    from results import update_section

    update_section(Path(__file__).with_name("RESULTS.md"), "Outside the library", text)
    print(text)


if __name__ == "__main__":
    main()
