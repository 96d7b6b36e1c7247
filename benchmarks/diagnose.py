"""Diagnose benchmark (issue #5): blind detection of concealed effects.

    python benchmarks/diagnose.py            # ~70 logs, 2 processes, writes the diagnose section of RESULTS.md
    python benchmarks/diagnose.py --no-write # prints it only (RESULTS.md and diagnose_results.json left as they are)

Every log is simulated with an effect injected (recorded only in the truth), across every
effect, three magnitudes from barely detectable to large, four excitations, three sample
rates and three noise kinds; plus clean logs and logs with two effects.  `diagnose` sees the
log alone.  A finding is correct when its effect and axis match the injected one.
"""
from __future__ import annotations

import itertools
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

EFFECTS = [  # (effect, axis, magnitudes small -> large)
    ("coulomb_friction", "pitch", (5e-4, 1e-3, 3e-3)),
    ("coulomb_friction", "yaw", (2e-3, 5e-3, 1e-2)),
    ("quadratic_drag", "pitch", (0.003, 0.01, 0.03)),
    ("quadratic_drag", "yaw", (0.002, 0.005, 0.02)),
    ("cable_stiffness", "yaw", (0.002, 0.005, 0.01)),
    ("com_offset", "pitch", (0.005, 0.01, 0.03)),
    ("sensor_offset", "pitch", (0.005, 0.01, 0.03)),
    ("dead_zone", "pitch", (0.05, 0.1, 0.2)),
    ("dead_zone", "yaw", (0.05, 0.1, 0.2)),
    ("input_saturation", "pitch", (2.3, 2.1, 1.8)),
    ("input_saturation", "yaw", (2.3, 2.1, 1.8)),
    ("input_delay", "both", (0.005, 0.01, 0.03)),
    ("motor_lag", "pitch", (1.21, 1.32, 1.54)),  # table 1.1 s: +10 %, +20 %, +40 %
    ("motor_lag", "yaw", (1.1, 1.2, 1.4)),  # table 1.0 s
    ("thrust_asymmetry", "pitch", (0.1, 0.2, 0.4)),
    ("thrust_asymmetry", "yaw", (0.1, 0.2, 0.4)),
    ("yaw_inertia_pitch", "yaw", (0.002, 0.004, 0.006)),  # J2 = 0.02 kg m^2
]
REFS = ("multisine", "steps", "square", "sine")
RATES = (200.0, 1000.0, 100.0)
NOISES = (("12-bit", 0.0, 2 * math.pi / 4096), ("1 mrad", 1e-3, 0.0), ("none", 0.0, 0.0))
DURATION_S = 90.0
#: an injected dead zone or saturation that can act on fewer samples than this cannot be observed
NOT_EXERCISED = 0.005


def cases():
    out = []
    # the reference varies fastest, so each effect's three magnitudes meet three excitations
    combos = itertools.cycle((ref, rate, noise) for noise, rate, ref in itertools.product(NOISES, RATES, REFS))
    for (effect, axis, mags) in EFFECTS:
        for level, mag in zip(("small", "medium", "large"), mags):
            ref, rate, noise = next(combos)
            out.append(dict(kind="effect", effects=[dict(effect=effect, axis=axis, value=mag)], level=level,
                            ref=ref, rate=rate, noise=noise))
    clean = itertools.product(REFS, RATES[:2], NOISES)
    for i, (ref, rate, noise) in enumerate(clean):
        out.append(dict(kind="clean", effects=[], level="-", ref=ref, rate=rate, noise=noise))
    for pair in ((0, 4), (1, 7), (11, 5), (3, 12), (2, 9), (8, 6)):
        (e1, a1, m1), (e2, a2, m2) = EFFECTS[pair[0]], EFFECTS[pair[1]]
        ref, rate, noise = next(combos)
        out.append(dict(kind="two", effects=[dict(effect=e1, axis=a1, value=m1[1]), dict(effect=e2, axis=a2,
                                                                                         value=m2[1])],
                        level="medium", ref=ref, rate=rate, noise=noise))
    for i, c in enumerate(out):
        c["seed"] = 100 + i
    return out


def run_case(c):
    from sim import SimSettings, simulate
    from trms_ident.diagnosis.run import diagnose
    from trms_ident.log import validated

    name, sigma, q = c["noise"]
    r = simulate(SimSettings(ref=c["ref"], sample_rate_hz=c["rate"], duration_s=DURATION_S, noise_std_rad=sigma,
                             quantization_rad=q, seed=c["seed"], effects=c["effects"]))
    log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    t0 = time.perf_counter()
    d = diagnose(log)
    el = time.perf_counter() - t0
    truth = r.truth["estimated"]
    exercised = 1.0  # fraction of samples where the injected effect can act at all
    for e in c["effects"]:
        u = r.u1_v if e["axis"] == "pitch" else r.u2_v
        if e["effect"] == "dead_zone":
            exercised = min(exercised, float(np.mean(np.abs(u) < e["value"])))
        elif e["effect"] == "input_saturation":
            exercised = min(exercised, float(np.mean(np.abs(u) > e["value"])))
    nominal_err = max(abs(d.nominal[k] / truth[k] - 1) for k in truth)
    return dict(case=c, seconds=el, mismatch=d.mismatch, exercised=exercised, nominal_max_err=nominal_err,
                fit_before=d.fit_before, findings=[dict(**named_as(f), value=f.parameter["value"],
                                                        fit_before=f.fit_before, fit_after=f.fit_after,
                                                        alternatives=f.alternatives) for f in d.findings])


def named_as(f) -> dict:
    """A finding's effect and axis; a known value that is a library effect under another name (a motor's time
    constant T11 or T21 is motor_lag on its axis: diagnosis.compound.SAME, as compound.py reads it) as that effect."""
    from trms_ident.diagnosis.compound import SAME

    as_effect = {name: key.split(":") for key, name in SAME.items()}
    effect, axis = as_effect.get(f.parameter.get("name"), (f.effect, f.axis)) if f.effect == "known_value" \
        else (f.effect, f.axis)
    return dict(effect=effect, axis=axis)


def judge(res):
    c = res["case"]
    truth = c["effects"]
    f = res["findings"]
    out = {"first_right": False, "param_err": None, "fit_gain": None, "alias_right": False}
    if not truth:
        return out
    first = f[0] if f else None
    if first:
        match = [e for e in truth if e["effect"] == first["effect"] and e["axis"] == first["axis"]]
        if match:
            out["first_right"] = True
            out["param_err"] = abs(first["value"] / match[0]["value"] - 1)
            out["fit_gain"] = first["fit_after"] - first["fit_before"]
        elif any(f"{e['effect']}:{e['axis']}" in first["alternatives"] for e in truth):
            out["alias_right"] = True
    if len(truth) == 2:
        named = {(x["effect"], x["axis"]) for x in f}
        out["both_named"] = all((e["effect"], e["axis"]) in named for e in truth)
    return out


def main():
    from results import plain_args

    args = plain_args(__doc__)
    cs = cases()
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(run_case, cs))
    rows = []
    for r in results:
        j = judge(r)
        c = r["case"]
        eff = " + ".join(f"{e['effect']}:{e['axis']}={e['value']:g}" for e in c["effects"]) or "clean"
        found = "; ".join(f"{f['effect']}:{f['axis']}={f['value']:.3g}" + (f" (~{','.join(f['alternatives'])})"
                                                                            if f["alternatives"] else "")
                          for f in r["findings"]) or "no mismatch"
        rows.append((c, r, j, eff, found))
    idle = [x for x in rows if x[0]["kind"] == "effect" and x[1]["exercised"] < NOT_EXERCISED]
    eff_all = [x for x in rows if x[0]["kind"] == "effect"]
    eff_rows = [x for x in eff_all if x[1]["exercised"] >= NOT_EXERCISED]
    clean_rows = [x for x in rows if x[0]["kind"] == "clean"]
    two_rows = [x for x in rows if x[0]["kind"] == "two"]
    right = [x for x in eff_rows if x[2]["first_right"]]
    alias = [x for x in eff_rows if x[2]["alias_right"]]
    fp = [x for x in clean_rows if x[1]["mismatch"]]
    perr = [x[2]["param_err"] for x in right]
    gains = [x[2]["fit_gain"] for x in right]
    lines = ["| log | injected | ref | rate [Hz] | noise | nominal fit pitch/yaw [%] | nominal worst J/B error [%] "
             "| diagnose says | right first | param. error [%] | fit before -> after [%] |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for i, (c, r, j, eff, found) in enumerate(rows):
        first = r["findings"][0] if r["findings"] else None
        fits = f"{first['fit_before']:.3f} -> {first['fit_after']:.3f}" if first else "-"
        perr_text = "" if j["param_err"] is None else f"{100 * j['param_err']:.1f}"
        ok = "yes" if j["first_right"] else ("alias" if j["alias_right"] else ("-" if not c["effects"] else "no"))
        if c["effects"] and r["exercised"] < NOT_EXERCISED:
            ok += f" (not exercised: {100 * r['exercised']:.1f} % of samples)"
        if c["kind"] == "two":
            ok = "both" if j.get("both_named") else ok
        lines.append(f"| {i} | {eff} | {c['ref']} | {c['rate']:g} | {c['noise'][0]} | "
                     f"{r['fit_before']['pitch']:.3f} / {r['fit_before']['yaw']:.3f} | {100 * r['nominal_max_err']:.1f} | "
                     f"{found} | {ok} | {perr_text} | {fits} |")
    per_level = {lv: [x for x in eff_rows if x[0]["level"] == lv] for lv in ("small", "medium", "large")}
    right_all = [x for x in eff_all if x[2]["first_right"]]
    summary = [
        f"- logs with one effect: {len(eff_all)}, of which {len(idle)} never exercise it (the excitation keeps the "
        f"input out of the dead zone / below the saturation level on more than {100 * (1 - NOT_EXERCISED):g} % of "
        f"samples: {', '.join(x[3] + ' (' + x[0]['ref'] + ')' for x in idle) or 'none'}); "
        f"diagnose said 'no mismatch' on {sum(not x[1]['mismatch'] for x in idle)} of those",
        f"- exercised logs with one effect: {len(eff_rows)}; right effect and axis named first: {len(right)} "
        f"({100 * len(right) / max(len(eff_rows), 1):.0f} %); named first or as an indistinguishable alternative: "
        f"{len(right) + len(alias)} ({100 * (len(right) + len(alias)) / max(len(eff_rows), 1):.0f} %); over all "
        f"{len(eff_all)} one-effect logs: {len(right_all)} ({100 * len(right_all) / len(eff_all):.0f} %) named first",
        "- by magnitude: " + ", ".join(f"{lv} {sum(x[2]['first_right'] for x in v)}/{len(v)}"
                                      for lv, v in per_level.items()),
        f"- clean logs: {len(clean_rows)}; false findings: {len(fp)} ({100 * len(fp) / max(len(clean_rows), 1):.0f} %)",
        f"- logs with two effects: {len(two_rows)}; both named: {sum(x[2].get('both_named', False) for x in two_rows)}",
        f"- parameter error of right findings: median {100 * np.median(perr):.1f} %, worst {100 * max(perr):.1f} %, "
        f"within 30 %: {sum(e <= 0.3 for e in perr)}/{len(perr)}",
        f"- fit improved on {sum(g > 0 for g in gains)}/{len(gains)} right findings (median gain "
        f"{np.nanmedian(gains) if gains else float('nan'):.3f} NRMSE points; {int(np.sum(np.isnan(gains)))} without a "
        "seed-model prediction: its least-squares J or B not physical)",
        f"- median diagnose time per log: {np.median([x[1]['seconds'] for x in rows]):.1f} s "
        f"(total benchmark {time.perf_counter() - t0:.0f} s on 2 processes)",
    ]
    text = "## Diagnose (benchmarks/diagnose.py, blind: diagnose sees the log only)\n\n" + "\n".join(summary) + \
        "\n\n" + "\n".join(lines) + "\n"
    print(text)
    if args.no_write:
        return
    from results import update_section
    update_section(Path(__file__).with_name("RESULTS.md"), "Diagnose", text)
    (Path(__file__).with_name("diagnose_results.json")).write_text(json.dumps([r for _, r, *_ in rows], indent=1,
                                                                              default=str))


if __name__ == "__main__":
    main()
