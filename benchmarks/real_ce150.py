"""Real Humusoft CE150 recordings, estimated with Table 1's known values and with the bench's own published ones.

    python benchmarks/real_ce150.py FOLDER [FOLDER...]       # every .mat holding u1, u2, psi, phi
    python benchmarks/real_ce150.py FOLDER --diagnose        # and diagnose each with the CE150's values
    python benchmarks/real_ce150.py FOLDER --joint           # only the joint estimate over the recordings
    python benchmarks/real_ce150.py FOLDER --diagnosed-model # J/B with intervals under the seed model and under
                                                             # each recording's diagnosed model; the recordings
                                                             # pooled under the recurring findings' bench file

The recordings: the public repository JurCag/NN_for_FF_Compensation, folder MeasuredDatasets, files
Data100_*.mat (100 Hz, no time vector, angles in degrees, inputs in machine units; three of them record no u1
and are reported as such).  Two of them sit in ../shared/real_logs/ce150/ and are in the tests; the others are a
blind set nothing here was tuned on.  The published identification of the same bench (that repository's
parameter file) is the yardstick: I = 0.00437 kg m^2, B_psi = 0.00184 N m s/rad (elevation), I_phi = 0.00414,
B_phi = 0.00869 (azimuth); `--params humusoft_ce150_eq1` is it, mapped onto eq. (1) itself (the CE150 with its own
structure, `--params humusoft_ce150`, is benchmarks/ce150_structure.py's; diagnose searches under eq. (1)'s).

Per recording: the simulation fit of each axis (model_check) with Table 1's values and with the CE150's, the
estimates with the CE150's (None: not identifiable from the log, with the reason), which are not credible, and
with --diagnose the verdict and findings.  Writes the "Real CE150 recordings" section of RESULTS.md.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import scipy.io

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import trms_ident as ti  # noqa: E402
from trms_ident.params import load_parameter_file  # noqa: E402

PUBLISHED = load_parameter_file("humusoft_ce150", allow_estimated=True)
#: the CE150's values mapped onto eq. (1), the bench file diagnose takes
BENCH = "humusoft_ce150_eq1"
IN_TESTS = {"Data100_ea_a0", "Data100_ea_e675_aN130toP130"}
READ = {"rate_hz": 100.0, "angle_unit": "deg"}


VERDICT = {True: "fits", False: "does not fit", None: "not decided"}


def _floor(axis: dict) -> str:
    """Which floor judged an axis, and how far the error sits from it."""
    if axis["floor_used"] == "black_box":
        return (f"black box, {axis['black_box_ratio']:.3g}x ({axis['error_rms_rad']:.2g} against "
                f"{axis['black_box']['rms_rad']:.2g} rad)")
    if axis["floor_used"] == "none":
        return f"none (black-box held-out fit {axis['black_box']['fit_percent']:.3g} %)"
    return (f"noise, {axis['rms_over_noise']:.3g}x" + ("" if axis["noise_floor_measured"] else " (not measurable)"))


def _table_words(d) -> str:
    """diagnose with Table 1's values, in a cell: the verdict, the known values it names, and whether it says the
    bench is far from the values it was given."""
    named = [f"{f.parameter['name']} {f.parameter['value']:.3g} (table {f.parameter['table']:.3g})"
             for f in d.findings if f.effect == "known_value"]
    effects = [f"{f.effect} on {f.axis}" for f in d.findings if f.effect != "known_value"]
    far = "far from the values" in d.verdict_sentence
    return (d.verdict + (": known values " + ", ".join(named) if named else "")
            + ("; " + ", ".join(effects) if effects else "")
            + ("; says the bench is far from the values given (give --params)" if far else ""))


def _fmt(v) -> str:
    return "n.i." if v is None else f"{v:.3g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--diagnose", action="store_true", help="also diagnose each recording with the CE150's values")
    ap.add_argument("--joint", action="store_true", help="only the joint estimate over all recordings with u1 "
                                                         "(section 'Real CE150 recordings, jointly')")
    ap.add_argument("--diagnosed-model", action="store_true", help="only the estimates under the diagnosed model "
                    "(section 'Real CE150 recordings, under the diagnosed model')")
    args = ap.parse_args()
    files = sorted({p.resolve() for f in args.folders for p in f.glob("*.mat")}, key=lambda p: p.name)
    if args.joint:
        return joint(files)
    if args.diagnosed_model:
        return diagnosed_model(files)
    rows, skipped = [], []
    t0 = time.perf_counter()
    for path in files:
        names = {w[0] for w in scipy.io.whosmat(path)}
        if not {"u1", "u2", "psi", "phi"} <= names:
            skipped.append(f"{path.name} (holds {', '.join(sorted(names))}: no u1)")
            continue
        table = ti.estimate(path, **READ)
        ce = ti.estimate(path, params=BENCH, **READ)
        row = {"name": path.stem, "blind": path.stem not in IN_TESTS,
               "fit_table": {a: table.model_check["axes"][a]["fit_percent"] for a in ("pitch", "yaw")},
               "fit_ce150": {a: ce.model_check["axes"][a]["fit_percent"] for a in ("pitch", "yaw")},
               "estimates": ce.estimates, "not_credible": ce.doc["not_credible"], "adequate": ce.adequate,
               "floors": {a: _floor(v) for a, v in ce.model_check["axes"].items()}}
        if args.diagnose:
            d = ti.diagnose(path, params=BENCH, **READ)
            row["verdict"] = d.verdict
            row["findings"] = [f"{f.effect} on {f.axis} ({f.parameter['value']:.3g})" for f in d.findings]
            row["corrections"] = [f"{c.axis}: {c.sentence}" for c in d.corrections]
            row["prediction_fit"] = {a: (d.fit_before[a], d.fit_after[a]) for a in ("pitch", "yaw")}
            h = d.held_out
            row["held_out"] = ({a: (h["before"][a], (h["after"] or h["before"])[a]) for a in ("pitch", "yaw")}
                               if h else None)
            row["diag_floors"] = {a: v["used"] for a, v in d.settings["floors"].items()}
            dt = ti.diagnose(path, **READ)  # Table 1's values: does diagnose say the bench is not the table?
            row["table_diagnose"] = _table_words(dt)
        rows.append(row)
        print(row, flush=True)
    lines = ["## Real CE150 recordings", "",
             f"`python benchmarks/real_ce150.py FOLDER{' --diagnose' if args.diagnose else ''}` on the Data100_*.mat "
             "recordings of a Humusoft CE150 (public repository JurCag/NN_for_FF_Compensation, MeasuredDatasets; "
             "blind: not in the tests). Simulation fit of each axis (model_check) with Table 1's known values and "
             "with `--params humusoft_ce150_eq1`; the estimates with the latter (n.i.: not identifiable from the log). "
             f"Published: J1 {PUBLISHED['J1']}, B1 {PUBLISHED['B1']}, J2 {PUBLISHED['J2']}, B2 {PUBLISHED['B2']}.",
             "",
             "| recording | blind | pitch fit Table 1 -> CE150 [%] | yaw fit Table 1 -> CE150 [%] | J1 | B1 | J2 | B2 "
             "| not credible | verdict (CE150's values): floor used per axis |"
             + (" diagnose (CE150's values): floors, verdict, findings | held-out simulation fit before -> after [%] "
                "| 2 s prediction fit before -> after [%] | diagnose (Table 1's values) |" if args.diagnose else ""),
             "|---|---|---|---|---|---|---|---|---|---|" + ("---|---|---|---|" if args.diagnose else "")]
    for r in rows:
        e = r["estimates"]
        cells = [r["name"], "yes" if r["blind"] else "no",
                 f"{r['fit_table']['pitch']:.1f} -> {r['fit_ce150']['pitch']:.1f}",
                 f"{r['fit_table']['yaw']:.1f} -> {r['fit_ce150']['yaw']:.1f}",
                 *(_fmt(e[k]) for k in ("J1", "B1", "J2", "B2")), ", ".join(r["not_credible"]) or "-",
                 VERDICT[r["adequate"]] + ": " + "; ".join(f"{a} {f}" for a, f in r["floors"].items())]
        if args.diagnose:
            cells.append("floors " + ", ".join(f"{a} {u}" for a, u in r["diag_floors"].items()) + "; "
                         + r["verdict"] + (": " + "; ".join(r["findings"]) if r["findings"] else "")
                         + ("; outside the library " + "; ".join(r["corrections"]) if r["corrections"] else ""))
            cells.append("n/a" if r["held_out"] is None else
                         ", ".join(f"{a} {b:.1f} -> {c:.1f}" for a, (b, c) in r["held_out"].items()))
            cells.append(", ".join(f"{a} {b:.1f} -> {c:.1f}" for a, (b, c) in r["prediction_fit"].items()))
            cells.append(r["table_diagnose"])
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", f"Not estimated: {'; '.join(skipped) or 'none'}. {len(rows)} recordings in "
                  f"{time.perf_counter() - t0:.0f} s. The recordings smoothed the angles (third differences below "
                  "1.5e-6 rad), so no noise floor can be measured; where eq. (1) misses an axis, the floor is a "
                  "flexible black-box model's held-out simulation error (numerics/blackbox.py): above 1.2x it the "
                  "axis does not fit (measured), within it the verdict is not decided. diagnose judges such an "
                  "axis against the same floor (settings.floors); its held-out simulation fit fits each model on "
                  "one half of the recording's first 120 s and simulates it on the other, both ways round."]
    text = "\n".join(lines) + "\n"
    print(text)
    from results import update_section

    update_section(Path(__file__).with_name("RESULTS.md"), "Real CE150 recordings", text)


def joint(files: list[Path]) -> None:
    """One bench from every recording that holds u1: the pooled estimate beside the published values, each
    recording's own, and whether they agree."""
    t0 = time.perf_counter()
    usable = [p for p in files if {"u1", "u2", "psi", "phi"} <= {w[0] for w in scipy.io.whosmat(p)}]
    j = ti.estimate_joint(usable, params=BENCH, **READ)
    doc = j.doc["joint"]
    lines = ["## Real CE150 recordings, jointly", "",
             f"`python benchmarks/real_ce150.py FOLDER --joint`: the {len(usable)} Data100_*.mat recordings that hold "
             "u1 (the same public repository), estimated as runs of one bench with `estimate --joint --params "
             "humusoft_ce150_eq1` (n.i.: not identifiable). Published (the bench's own identification, another model): "
             f"J1 {PUBLISHED['J1']}, B1 {PUBLISHED['B1']}, J2 {PUBLISHED['J2']}, B2 {PUBLISHED['B2']}.", "",
             "| recording | in the pool | J1 | B1 | J2 | B2 | pooled model on it |", "|---|---|---|---|---|---|---|"]
    verdict = {True: "fits", False: "does not fit", None: "not decided"}
    for lg in doc["logs"]:
        lines.append(f"| {lg['name']} | {'yes' if lg['in_pool'] else 'no'} | "
                     + " | ".join(_fmt(lg["estimates"][k]) for k in ("J1", "B1", "J2", "B2"))
                     + f" | {verdict[lg['model_check']['adequate']] if lg['model_check'] else '-'} |")
    pooled = ", ".join(f"{k} {_fmt(doc['estimates'][k])}" + (f" [{doc['ci95'][k][0]:.3g}, {doc['ci95'][k][1]:.3g}]"
                                                              if doc["estimates"][k] is not None else
                                                              f" ({doc['identifiability'][k]})")
                       for k in ("J1", "B1", "J2", "B2"))
    lines += ["", f"Pooled: {pooled}. Consistency: {doc['sentence']} Pooled model fits every pooled recording: "
                  f"{verdict[doc['adequate']]}. {time.perf_counter() - t0:.0f} s."]
    text = "\n".join(lines) + "\n"
    print(text)
    from results import update_section

    update_section(Path(__file__).with_name("RESULTS.md"), "Real CE150 recordings, jointly", text)


def _with_interval(v, ci) -> str:
    if v is None or ci is None or ci[0] is None:
        return "n.i."
    return f"{v:.3g} [{ci[0]:.3g}, {ci[1]:.3g}]"


def _held(h: dict | None) -> str:
    if not h:
        return "n/a"
    after = h["after"] or h["before"]
    return ", ".join(f"{a} {h['before'][a]:.1f} -> {after[a]:.1f}" for a in ("pitch", "yaw"))


def diagnosed_model(files: list[Path]) -> None:
    """Issue #48's real-recordings line: per recording with u1, J/B with 95 % intervals under the seed model
    (eq. (1), the CE150's values) and under the model its diagnose found (diagnose's "under the findings' model",
    the estimate `export` then `estimate --params` gives), each with its adequacy verdict and held-out fit; then
    the recordings pooled under the bench file of the finding that recurs most across them."""
    import tempfile
    from collections import Counter

    from trms_ident.commands import bench_from_diagnosis
    from trms_ident.io.readers import read_log
    from trms_ident.params import to_toml
    from trms_ident.report.diagnosis import to_doc
    from trms_ident.report.summary import to_json

    t0 = time.perf_counter()
    usable = [p for p in files if {"u1", "u2", "psi", "phi"} <= {w[0] for w in scipy.io.whosmat(p)}]
    rows, docs = [], {}
    tmp = Path(tempfile.mkdtemp())
    for path in usable:
        seed = ti.estimate(path, params=BENCH, **READ)
        d = ti.diagnose(path, params=BENCH, **READ)
        w = d.with_findings or {}
        doc = to_doc(d, read_log(path, **READ))
        (tmp / f"{path.stem}.json").write_text(to_json(doc))
        docs[path.stem] = doc
        rows.append({"name": path.stem, "blind": path.stem not in IN_TESTS,
                     "seed": {k: _with_interval(seed.estimates[k], seed.ci95[k]) for k in ("J1", "B1", "J2", "B2")},
                     "seed_fits": VERDICT[seed.adequate], "verdict": d.verdict,
                     "findings": [f"{f.effect}:{f.axis} {f.parameter['value']:.3g}" if f.effect != "known_value"
                                  else f"{f.parameter['name']} {f.parameter['value']:.3g}" for f in d.findings],
                     "model": {k: _with_interval((w.get("estimates") or {}).get(k), (w.get("ci95") or {}).get(k))
                               for k in ("J1", "B1", "J2", "B2")} if w.get("estimates") else None,
                     "model_fits": VERDICT[w.get("adequate")] if w.get("estimates") else "-",
                     "held_out": _held(d.held_out)})
        print(rows[-1], flush=True)
    counts = Counter(k for r in rows for k in dict.fromkeys(f.split(" ")[0] for f in r["findings"]))
    pool_line = "No finding recurs across the recordings: nothing to pool under."
    if counts:
        key, n = counts.most_common(1)[0]
        source = next((r["name"] for r in rows if [f.split(" ")[0] for f in r["findings"]] == [key]), None)
        if n >= 2 and source is not None:
            b = bench_from_diagnosis(tmp / f"{source}.json")
            bench = tmp / "bench.toml"
            bench.write_text(to_toml(b["known"], b["identified"], b["header"], b["effects"], b["sources"],
                                     b["intervals"]))
            j = ti.estimate_joint(usable, params=bench, **READ).doc["joint"]
            alone = {k: [r["model"][k] != "n.i." for r in rows if r["model"]] for k in ("J1", "B1", "J2", "B2")}
            only_pool = [k for k in ("J1", "B1", "J2", "B2") if j["estimates"][k] is not None and not any(alone[k])]
            pool_line = (f"Pooled under {key} (found in {n} of {len(rows)} recordings; the bench file exported from "
                         f"{source}'s diagnosis, the CE150's known values): "
                         + ", ".join(f"{k} {_with_interval(j['estimates'][k], j['ci95'][k])}"
                                     if j["estimates"][k] is not None else f"{k} n.i. ({j['identifiability'][k]})"
                                     for k in ("J1", "B1", "J2", "B2"))
                         + f"; consistency: {j['sentence']} The pooled model fits every pooled recording: "
                         f"{VERDICT[j['adequate']]}. Determined by the pool and by no single recording: "
                         f"{', '.join(only_pool) or 'none'}. Left out: {', '.join(j['outliers']) or 'none'}.")
    lines = ["## Real CE150 recordings, under the diagnosed model", "",
             "`python benchmarks/real_ce150.py FOLDER --diagnosed-model`: the Data100_*.mat recordings holding u1 "
             "(public repository JurCag/NN_for_FF_Compensation), each estimated with `--params humusoft_ce150_eq1` "
             "under "
             "eq. (1) (the seed model) and under the model its `diagnose` found (the estimate `export` then "
             "`estimate --params` gives: diagnose's \"under the findings' model\"), J/B with 95 % intervals (n.i.: "
             "not identifiable), each model's adequacy verdict, and the held-out simulation fit before -> after the "
             f"findings. Published: J1 {PUBLISHED['J1']}, B1 {PUBLISHED['B1']}, J2 {PUBLISHED['J2']}, "
             f"B2 {PUBLISHED['B2']}.", "",
             "| recording | blind | seed model J1 | B1 | J2 | B2 | seed verdict | diagnose | findings | diagnosed "
             "model J1 | B1 | J2 | B2 | its verdict | held-out fit [%] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        m = r["model"] or {k: "-" for k in ("J1", "B1", "J2", "B2")}
        lines.append(f"| {r['name']} | {'yes' if r['blind'] else 'no'} | "
                     + " | ".join(r["seed"][k] for k in ("J1", "B1", "J2", "B2"))
                     + f" | {r['seed_fits']} | {r['verdict']} | {', '.join(r['findings']) or '-'} | "
                     + " | ".join(m[k] for k in ("J1", "B1", "J2", "B2"))
                     + f" | {r['model_fits']} | {r['held_out']} |")
    lines += ["", pool_line, "", f"{len(rows)} recordings in {time.perf_counter() - t0:.0f} s."]
    text = "\n".join(lines) + "\n"
    print(text)
    from results import update_section

    update_section(Path(__file__).with_name("RESULTS.md"), "Real CE150 recordings, under the diagnosed model", text)


if __name__ == "__main__":
    main()
