"""Physics outside diagnose's library (issues #12, #32, #76): Rotondo's plant never explained; a known value off
named; a torque outside the effect library named as a term.

    python benchmarks/outside.py        # 16 logs on 2 processes, a few minutes; writes the "Outside the library"
                                        # section of RESULTS.md
    python benchmarks/outside.py --terms --seed 7601    # 20 logs with a term (issue #76); writes "Outside the
                                        # library: terms" (--no-write: printed only)

Terms (issue #76): the simulator's bench with one torque no library effect has, c x a product of the model's
signals (sim/ integrates it from its true states; trms_ident/model/terms.py's grammar), five kinds, c drawn from
[seed, i]: the main rotor's thrust growing with the pitch angle (pitch M1 sin(alpha)), the tail rotor's thrust
growing with the yaw rate (yaw M2 beta'), a pitch torque in the yaw rate squared (pitch beta'^2), a yaw friction
whose level follows the pitch angle (yaw sign(beta') cos(alpha)), and one the search does not try (the main
rotor's thrust changing with the pitch rate, pitch M1 alpha'); four logs each (multisine 200 Hz 12-bit from rest,
steps 250 Hz 1 mrad from 30 s, square 500 Hz 12-bit from 20 s, chirp 100 Hz 0.5 mrad from rest), 60 s.  Judged:
the term *named* (a finding, or a flagged look-alike of one, c within 30 %), the *held-out* simulation of its axis
within 2x the angle's noise floor (diagnose's held-out fit, the findings' model, over the log's measured floor),
*nothing invented* (no other finding, but one that flags the term as its look-alike), and no finding outside its
plausible range.  A draw whose pitch leaves +-pi/2 is not a bench (the beam rests on its stops long before; seed
7601's bench 9, c = -0.0277 beta'^2, turned the beam over 390 times): c is drawn again from [seed, i, k], k = 1,
2, ..., and the table says so.

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


#: (axis, product, drawn |c| range, sign of c or 0 for either, what it is, searched by diagnose)
TERM_KINDS = (("pitch", "M1*sin(alpha)", (0.15, 0.4), 0, "thrust growing with the pitch angle", True),
              ("yaw", "M2*beta'", (0.1, 0.3), 0, "tail thrust growing with the yaw rate", True),
              ("pitch", "beta'*beta'", (0.01, 0.03), 0, "pitch torque in the yaw rate squared", True),
              ("yaw", "sign(beta')*cos(alpha)", (0.002, 0.005), -1, "yaw friction following the pitch angle", True),
              ("pitch", "M1*alpha'", (0.05, 0.2), 0, "thrust changing with the pitch rate (not searched)", False))
TERM_CONDITIONS = (("multisine", 200.0, 0.0, 2 * math.pi / 4096, 0.0), ("steps", 250.0, 1e-3, 0.0, 30.0),
                   ("square", 500.0, 0.0, 2 * math.pi / 4096, 20.0), ("chirp", 100.0, 5e-4, 0.0, 0.0))
TERM_DURATION_S = 60.0


def term_cases(seed: int) -> list[dict]:
    import numpy as np

    out = []
    for k, (axis, product, (lo, hi), sign, what, searched) in enumerate(TERM_KINDS):
        for j, cond in enumerate(TERM_CONDITIONS):
            i = len(out)
            rng = np.random.default_rng([seed, i])
            c = float(rng.uniform(lo, hi)) * (sign or (1 if rng.uniform() < 0.5 else -1))
            out.append(dict(plant="term", i=i, axis=axis, product=product, c=c, what=what, searched=searched,
                            cond=cond, seed=seed * 100 + i, base=seed))
    return out


#: a term bench's pitch stays within this [rad] (a TRMS beam rests on its stops well before), else c is drawn again
PITCH_RANGE_RAD = math.pi / 2
#: draws of c tried for a bench before it is given up
TERM_DRAWS = 5


def term_run(c: dict):
    """The simulator's run of a term bench, and c with the draw it took (0: term_cases'; k: drawn again from
    [seed, i, k] because the pitch of draw k - 1 left PITCH_RANGE_RAD)."""
    import numpy as np

    from sim import SimSettings, simulate

    ref, rate, noise, q, start = c["cond"]
    (lo, hi), sign = next((r, s) for axis, product, r, s, *_ in TERM_KINDS
                          if (axis, product) == (c["axis"], c["product"]))
    value = c["c"]
    for k in range(TERM_DRAWS):
        if k:
            rng = np.random.default_rng([c["base"], c["i"], k])
            value = float(rng.uniform(lo, hi)) * (sign or (1 if rng.uniform() < 0.5 else -1))
        r = simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=TERM_DURATION_S, noise_std_rad=noise,
                                 quantization_rad=q, seed=c["seed"], start_s=start,
                                 effects=[dict(effect="term", axis=c["axis"], product=c["product"], value=value)]))
        if np.max(np.abs(r.alpha_rad)) <= PITCH_RANGE_RAD:
            return r, {**c, "c": value, "draw": k}
    raise RuntimeError(f"term bench {c['i']}: the pitch left +-{PITCH_RANGE_RAD:.2f} rad on {TERM_DRAWS} draws of c")


def run_term(c: dict) -> dict:
    from trms_ident.diagnosis.run import diagnose
    from trms_ident.log import validated
    from trms_ident.model import effects
    from trms_ident.model.terms import term_key
    from trms_ident.numerics.design import angle_noise_rad

    r, c = term_run(c)
    log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad")
    t0 = time.perf_counter()
    d = diagnose(log)
    seconds = time.perf_counter() - t0
    key = term_key(c["product"], c["axis"])
    keys = [f"{f.effect}:{f.axis}" for f in d.findings]
    named = any(k == key and abs(f.parameter["value"] - c["c"]) <= 0.3 * abs(c["c"]) for k, f in zip(keys, d.findings))
    flagged = any(key in f.alternatives for f in d.findings)
    angle = "alpha" if c["axis"] == "pitch" else "beta"
    h = d.held_out or {}
    rms = (h.get("rms_rad") or {}).get("after") or (h.get("rms_rad") or {}).get("before") or {}
    n = (h.get("samples") or len(log))
    floor = angle_noise_rad(getattr(log, f"{angle}_rad")[:n])
    implausible = [k for k, f in zip(keys, d.findings) if f.effect != "known_value" and effects.by_key(k) is not None
                   and not effects.by_key(k).plausible(float(f.parameter["value"]))]
    # a finding that flags the term as its look-alike is the same torque on this log (a Coulomb friction for c
    # sign(beta') cos(alpha) when the pitch stays near 0), not an invention
    return dict(case=c, verdict=d.verdict, named=named or flagged, flagged=flagged and not named,
                invented=[k for k, f in zip(keys, d.findings) if k != key and key not in f.alternatives],
                implausible=implausible,
                held_over=(rms.get(angle, math.nan) / floor if floor > 0 else math.nan),
                findings=[f"{k}={f.parameter['value']:.4g}" for k, f in zip(keys, d.findings)],
                corrections=[x.axis for x in d.corrections], seconds=seconds)


def main_terms(seed: int, write: bool, only: list[int] | None = None) -> None:
    t0 = time.perf_counter()
    chosen = [c for c in term_cases(seed) if not only or c["i"] in only]
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(run_term, chosen))
    elapsed = time.perf_counter() - t0
    rows = []
    for r in results:
        c = r["case"]
        ref, rate, noise, q, start = c["cond"]
        cond = (f"{ref} {rate:g} Hz " + ("12-bit" if q else f"{noise * 1e3:g} mrad")
                + (f", from {start:g} s" if start else ", from rest"))
        again = f" (drawn again {c['draw']}x: the pitch left its range)" if c.get("draw") else ""
        rows.append(f"| {c['i']} | {c['axis']}: {c['product']} = {c['c']:.4g}{again} | {cond} | {r['verdict']} | "
                    f"{'; '.join(r['findings']) or '-'} | {'yes' + (' (look-alike)' if r['flagged'] else '') if r['named'] else 'no'} | "
                    f"{r['held_over']:.2f}x | {'no' if r['invented'] else 'yes'} | {r['seconds']:.0f} |")
    searched = [r for r in results if r["case"]["searched"]]
    held = sum(r["held_over"] <= 2.0 for r in results)
    text = (f"## Outside the library: terms (benchmarks/outside.py --terms, seed {seed})\n\n"
            "The simulator's bench with one torque outside the effect library, c x a product of the model's signals "
            "(the module docstring lists the kinds; the last is a product diagnose does not try). 'named': the term "
            "found (or a flagged look-alike), c within 30 %; 'held-out': the error RMS of the term's axis in "
            "diagnose's held-out simulation (the findings' model) over the angle's measured noise floor; 'nothing "
            "invented': no other finding (one that flags the term as its look-alike is the same torque on the log)."
            "\n\n"
            "| # | term | log | verdict | findings | named | held-out | nothing invented | s |\n"
            "|---|---|---|---|---|---|---|---|---|\n" + "\n".join(rows)
            + f"\n\nNamed: {sum(r['named'] for r in searched)}/{len(searched)} of the terms the search tries, "
            f"{sum(r['named'] for r in results)}/{len(results)} in all; held-out within 2x the floor: "
            f"{held}/{len(results)}; nothing invented: {sum(not r['invented'] for r in results)}/{len(results)}; a "
            f"finding outside its plausible range: {sum(bool(r['implausible']) for r in results)}. Median "
            f"{sorted(r['seconds'] for r in results)[len(results) // 2]:.0f} s a log, {elapsed:.0f} s in all on "
            "2 processes.\n")
    if write and not only:
        from results import update_section

        update_section(Path(__file__).with_name("RESULTS.md"), "Outside the library: terms", text)
    print(text)


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--terms", action="store_true", help="the term benches (issue #76) instead of the library's")
    ap.add_argument("--seed", type=int, default=7601, help="the term benches' seed (say which in RESULTS.md)")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    ap.add_argument("--only", type=int, nargs="*", help="--terms: these benches (printed only)")
    args = ap.parse_args()
    if args.terms:
        main_terms(args.seed, not args.no_write, args.only)
        return
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
