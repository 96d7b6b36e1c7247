"""Detection power of diagnose (issue #12, point 3): detection rate against effect size, and false alarms.

    python benchmarks/power.py        # ~200 logs on 2 processes, about 16 minutes; writes the "Diagnose power"
                                      # section of RESULTS.md and benchmarks/power_curve.png

For each effect the issue names, four sizes (0.5, 1, 2 and 4 times the size the issue asks to detect) and
four logs per size, each with its own excitation, rate, noise, start (from rest or 30 s into the run) and a
seed no test uses (from 5000 up).  A log counts as detected when diagnose names the injected effect and
axis first (or as the flagged indistinguishable alternative) with its parameter within 30 %.  Voltage
saturation's size is how far the limit sits below the peak |u1| of the same run without it (0.1 = at 90 %
of the peak: the issue names no size; a limit above every command would not act); the two-effect row (yaw Coulomb
friction beside a cable, both at the size) counts when both are named within 30 %.  Every other log's
bench is off Table 1: J1, B1, J2, B2 drawn in 0.6-1.6x the table's and Mg, a1, b2, kc in 0.8-1.25x (from the
log's seed); diagnose is given those known values (as a user passes --params), never J/B.  A log whose yaw
winds past 8 pi is refused by the unit check ("... degrees, or a yaw that drifted; ... --angle-unit rad if they
are radians"); the benchmark then says rad, as that message asks a user to, and counts such logs.
`--rerun-errors` runs again only the saved results' logs that ended in an error and rewrites the section.
`--factors 1` runs only those sizes' logs and the nulls and prints the table (RESULTS.md, the saved results and the
figure left as they are): a shorter check of the size asked.  Nulls: clean
logs at 250 Hz with 1 mrad noise and 12-bit encoders, from rest and mid-run; any finding on them is a false
alarm.  diagnose sees the log only.
"""
from __future__ import annotations

import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

#: (effect, axis, the size the issue asks to find, unit)
EFFECTS = [
    ("coulomb_friction", "pitch", 0.002, "N m"),
    ("coulomb_friction", "yaw", 0.002, "N m"),
    ("quadratic_drag", "yaw", 0.02, "N m s^2/rad^2"),
    ("cable_stiffness", "yaw", 0.005, "N m/rad"),
    ("com_offset", "pitch", 0.04, "rad"),
    ("input_delay", "both", 0.02, "s"),
    ("thrust_asymmetry", "yaw", 0.1, "1"),
    ("yaw_inertia_pitch", "yaw", 0.004, "kg m^2"),
    ("dead_zone", "yaw", 0.1, "V"),
    ("input_saturation", "pitch", 0.1, "x the peak |u1|, below it"),
    ("coulomb_friction+cable_stiffness", "yaw", 1.0, "x (0.002 N m, 0.005 N m/rad)"),
]
#: the two-effect row: its effects at the sizes the issue asks, times the row's factor
PAIR = (("coulomb_friction", "yaw", 0.002), ("cable_stiffness", "yaw", 0.005))
#: known values drawn off Table 1 for the off-table benches, and the J/B range
KNOWN_OFF = ("Mg", "a1", "b2", "kc")
FACTORS = (0.5, 1.0, 2.0, 4.0)
#: (reference, rate [Hz], noise [rad], quantization [rad], start [s])
CONDITIONS = (("multisine", 200.0, 0.0, 2 * math.pi / 4096, 0.0), ("steps", 250.0, 1e-3, 0.0, 30.0),
              ("square", 1000.0, 0.0, 2 * math.pi / 4096, 30.0), ("chirp", 100.0, 5e-4, 0.0, 0.0))
NULLS = [(ref, 250.0, noise, q, start) for ref in ("multisine", "steps", "square", "chirp")
         for noise, q in ((1e-3, 0.0), (0.0, 2 * math.pi / 4096)) for start in (0.0, 30.0)]
DURATION_S = 90.0


def cases() -> list[dict]:
    out = []
    for effect, axis, size, unit in EFFECTS:
        for f in FACTORS:
            for cond in CONDITIONS:
                out.append(dict(effect=effect, axis=axis, value=size * f, factor=f, cond=cond))
    for cond in NULLS:
        out.append(dict(effect=None, cond=cond))
    for i, c in enumerate(out):
        c["seed"] = 5000 + i
    return out


def bench(seed: int) -> tuple[dict, dict]:
    """(the simulated bench's overrides, the known values diagnose is told): every other seed off Table 1."""
    import numpy as np

    from trms_ident.params import defaults

    if seed % 2:
        return {}, {}
    rng = np.random.default_rng(seed)
    p = defaults()
    jb = {k: p[k] * float(rng.uniform(0.6, 1.6)) for k in ("J1", "B1", "J2", "B2")}
    known = {k: p[k] * float(rng.uniform(0.8, 1.25)) for k in KNOWN_OFF}
    return {**jb, **known}, known


def injected(c: dict, peak_u1_v: float = 0.0) -> list[dict]:
    """The effects a case injects, with the simulator's parameter values (saturation: below ``peak_u1_v``, the
    peak |u1| of the same run without it)."""
    if c["effect"] is None:
        return []
    if "+" in c["effect"]:
        return [dict(effect=e, axis=a, value=v * c["factor"]) for e, a, v in PAIR]
    value = (1.0 - c["value"]) * peak_u1_v if c["effect"] == "input_saturation" else c["value"]
    return [dict(effect=c["effect"], axis=c["axis"], value=value)]


def run_case(c: dict) -> dict:
    import numpy as np

    from sim import SimSettings, simulate
    from trms_ident.diagnosis.run import diagnose
    from trms_ident.errors import IdentificationError, LogFormatError
    from trms_ident.log import validated

    ref, rate, noise, q, start = c["cond"]
    plant, known = bench(c["seed"])
    run = dict(ref=ref, sample_rate_hz=rate, duration_s=DURATION_S, noise_std_rad=noise, quantization_rad=q,
               seed=c["seed"], start_s=start, overrides=plant)
    peak = float(np.max(np.abs(simulate(SimSettings(**run)).u1_v))) if c["effect"] == "input_saturation" else 0.0
    c["injected"] = injected(c, peak)
    r = simulate(SimSettings(**run, effects=c["injected"]))
    try:
        try:
            log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
        except LogFormatError as exc:  # yaw wound past 8 pi: as the message asks, the user states the unit
            if "--angle-unit rad if they are radians" not in str(exc):
                raise
            c["unit_stated"] = True
            log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad")
        d = diagnose(log, known)
    except (LogFormatError, IdentificationError) as exc:  # e.g. a run the effect drove off its range
        return dict(case=c, error=str(exc), findings=[], off_table=bool(plant))
    return dict(case=c, verdict=d.verdict, off_table=bool(plant),
                findings=[dict(effect=f.effect, axis=f.axis, value=f.parameter["value"],
                               alternatives=f.alternatives) for f in d.findings])


def detected(res: dict) -> bool:
    """Every injected effect named (first for a single one, or flagged as its indistinguishable alternative)
    with its parameter within 30 %."""
    c = res["case"]
    f = res["findings"]
    want = c.get("injected", [])
    if not f or not want:
        return False
    if len(want) == 1:
        w, first = want[0], f[0]
        if (first["effect"], first["axis"]) == (w["effect"], w["axis"]):
            return abs(first["value"] / w["value"] - 1) <= 0.3
        return f"{w['effect']}:{w['axis']}" in first["alternatives"]
    named = {(x["effect"], x["axis"]): x["value"] for x in f}
    return all((w["effect"], w["axis"]) in named and abs(named[(w["effect"], w["axis"])] / w["value"] - 1) <= 0.3
               for w in want)


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--replot", action="store_true", help="the table and figure again from the saved results")
    ap.add_argument("--rerun-errors", action="store_true", help="run again the saved results' logs that erred")
    ap.add_argument("--factors", type=float, nargs="+", help="only these sizes (multiples of the size asked) and "
                    "the nulls: printed only")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md, the saved results and "
                    "the figure as they are")
    args = ap.parse_args()
    saved = Path(__file__).with_name("power_results.json")
    timed, factors = "Total", (tuple(args.factors) if args.factors else None)
    if args.replot:  # the table and figure again from the saved results (no new runs)
        results, elapsed = json.loads(saved.read_text()), math.nan
    elif args.rerun_errors:  # the saved results' errors run again (a harness that refused them)
        results = json.loads(saved.read_text())
        again = [i for i, r in enumerate(results) if "error" in r]
        t0 = time.perf_counter()
        with ProcessPoolExecutor(max_workers=2) as pool:
            for i, r in zip(again, pool.map(run_case, [results[i]["case"] for i in again])):
                results[i] = r
        elapsed = time.perf_counter() - t0
        if not args.no_write:
            saved.write_text(json.dumps(results, indent=1, default=str))
        timed = f"The {len(again)} logs that had ended in an error run again:"
    else:
        cs = [c for c in cases() if factors is None or c["effect"] is None or c["factor"] in factors]
        t0 = time.perf_counter()
        with ProcessPoolExecutor(max_workers=2) as pool:
            results = list(pool.map(run_case, cs))
        elapsed = time.perf_counter() - t0
        if factors is None and not args.no_write:
            saved.write_text(json.dumps(results, indent=1, default=str))
    rows, curves = [], {}
    for effect, axis, size, unit in EFFECTS:
        rates = []
        for f in FACTORS:
            rs = [r for r in results if r["case"]["effect"] == effect and r["case"]["axis"] == axis
                  and r["case"]["factor"] == f]
            rates.append((sum(detected(r) for r in rs), len(rs)))
        curves[f"{effect}:{axis}"] = (size, unit, rates)
        rows.append(f"| {effect} | {axis} | {size:g} {unit} | " + " | ".join(f"{d}/{n}" for d, n in rates) + " |")
    nulls = [r for r in results if r["case"]["effect"] is None]
    false = [r for r in nulls if r["findings"]]
    errors = [r for r in results if "error" in r]
    at_size = [r for r in results if r["case"]["effect"] is not None and r["case"]["factor"] >= 1.0]
    by_bench = {off: (sum(detected(r) for r in at_size if r["off_table"] == off),
                      sum(1 for r in at_size if r["off_table"] == off)) for off in (False, True)}
    head = "| effect | axis | size asked (x1) | " + " | ".join(f"x{f:g}" for f in FACTORS) + " |"
    text = ("## Diagnose power (benchmarks/power.py, blind, seeds from 5000)\n\n"
            "Detection rate (right effect and axis first, or flagged as the indistinguishable alternative; "
            "parameter within 30 %) against size, in multiples of the size the issue asks to detect; 4 logs "
            "per cell (multisine 200 Hz 12-bit from rest, steps 250 Hz 1 mrad mid-run, square 1 kHz 12-bit "
            "mid-run, chirp 100 Hz 0.5 mrad from rest), 90 s each.\n\n" + head + "\n|" + "---|" * (3 + len(FACTORS))
            + "\n" + "\n".join(rows) + f"\n\nFalse alarms on {len(nulls)} clean logs (250 Hz, 1 mrad or 12-bit, "
            f"from rest and mid-run): {len(false)}"
            + (" (" + "; ".join(f"{r['case']['cond'][0]}: " + ", ".join(f"{x['effect']}:{x['axis']}"
                                                                            for x in r["findings"]) for r in false)
               + ")" if false else "")
            + f".\nAt the size asked and above (x1-x4): Table 1 benches {by_bench[False][0]}/{by_bench[False][1]}, "
            f"benches off Table 1 (J/B 0.6-1.6x, Mg, a1, b2, kc 0.8-1.25x, known values given) "
            f"{by_bench[True][0]}/{by_bench[True][1]}; false alarms on off-table nulls "
            f"{sum(1 for r in false if r['off_table'])}/{sum(1 for r in nulls if r['off_table'])}."
            + f"\nLogs the simulator or validation refused: {len(errors)}; logs given --angle-unit rad after the unit "
            f"check asked for it (yaw past 8 pi): {sum(1 for r in results if r['case'].get('unit_stated'))}. "
            f"{timed} {elapsed:.0f} s on 2 processes.\n"
            "Figure: benchmarks/power_curve.png.\n")
    if factors is not None or args.no_write:  # a part of the sizes, or asked: printed only
        print(text)
        return
    _figure(curves, Path(__file__).with_name("power_curve.png"))
    if not args.replot:  # the saved run's section stays as it was written
        from results import update_section
        update_section(Path(__file__).with_name("RESULTS.md"), "Diagnose power", text)
    print(text)


def _figure(curves: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(11.5, 4.8))
    styles = ("-", "--", ":", "-.")
    for i, (key, (size, unit, rates)) in enumerate(curves.items()):
        shift = 0.012 * (i - len(curves) / 2)  # curves offset slightly so that equal ones stay visible
        ax.plot(FACTORS, [d / n + shift if n else math.nan for d, n in rates], marker="os^Dv"[i % 5],
                ls=styles[i // 10 % 4], label=f"{key} (x1 = {size:g} {unit})")
    ax.set_xscale("log", base=2)
    ax.set_xticks(FACTORS, [f"x{f:g}" for f in FACTORS])
    ax.set_ylim(-0.05, 1.05)
    ax.axvline(1.0, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("effect size, in multiples of the size the issue asks to detect")
    ax.set_ylabel("detection rate")
    ax.set_title("diagnose: detection power (4 logs per point, blind; curves offset by up to 0.07 to stay visible)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
