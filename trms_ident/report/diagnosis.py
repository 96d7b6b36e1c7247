"""Diagnosis as the JSON contract and as a self-contained HTML report with figures."""
from __future__ import annotations

import html

from ..model.effects import with_unit
from ..diagnosis.held_out import sentence as held_out_sentence
from ..diagnosis.predict import fit_change, fit_text
from ..diagnosis.result import Diagnosis
from ..log import Log
from ..params import PLAUSIBLE_FACTOR, marked, not_credible
from .summary import units_text, versions
from .terminal import bench_lines, headline


def to_doc(d: Diagnosis, log: Log) -> dict:
    return {
        "verdict": d.verdict,
        "verdict_sentence": d.verdict_sentence,
        "mismatch": d.mismatch,
        "refused": d.refused,
        "seed_model_check": d.seed_check,
        "known_values_joint": d.known_values_joint,
        "findings": [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter, "fit_before": f.fit_before,
                      "fit_after": f.fit_after, "evidence": f.evidence, "explanation": f.explanation,
                      "alternatives": f.alternatives, "estimate_shift_percent": f.shift} for f in d.findings],
        "corrections": [{"axis": c.axis, "terms": c.terms, "sentence": c.sentence, "held_out_gain": c.held_out_gain,
                         "t": c.t, "p": c.p, "fit_before": c.fit_before, "fit_after": c.fit_after,
                         "estimates": c.estimates, "output_error": c.output_error} for c in d.corrections],
        "estimates": {"nominal": d.nominal, "augmented": d.augmented, "with_findings": d.with_findings,
                      "not_credible": {"nominal": not_credible(d.nominal), "augmented": not_credible(d.augmented)}},
        "fit": {"measure": f"NRMSE fit [%] of {d.settings['horizon_s']:g} s multi-step predictions, each window "
                           "started from the angle and velocity fitted to it (a free run drifts on yaw, which has "
                           "no restoring force)",
                "before": d.fit_before, "after": d.fit_after},
        "held_out_fit": (None if d.held_out is None else
                         {k: d.held_out.get(k) for k in ("before", "after", "rms_rad", "span_s", "samples", "folds",
                                                         "converged", "method")}),
        "located": {"segments": d.segments, "regimes": d.regimes, "lag": d.lag},
        "tested": d.tested,
        "output_error_tested": d.oe_tested,
        "settings": {k: v for k, v in d.settings.items()},
        "input": {"path": log.source, "sha256": log.sha256, "samples": len(log), "sample_time_s": log.sample_time_s,
                  "units": log.meta.get("units")},
        "versions": versions(),
        "meaning": {
            "estimates.nominal": "J, B by least squares on the filtered regression (3) of the seed model",
            "estimates.not_credible": "per J or B of nominal and augmented that is not finite and positive (not "
                                      f"physical) or is more than {PLAUSIBLE_FACTOR:g}x from Table 1 (implausible; "
                                      "a B may be arbitrarily small): why; such a value is a least-squares number of "
                                      "a model far from the bench, not a measurement",
            "estimates.with_findings": "J, B estimated as `trms-ident estimate --params` does under the bench file "
                                       "`trms-ident export` writes from this diagnosis (the findings in the model, "
                                       "known-value findings among the known values): 95 % intervals (ci95; null: no "
                                       "interval), identifiable, the adequacy verdict of that model (adequate, "
                                       "sentence); null without findings",
            "estimates.augmented": "the same with the findings' terms added and refitted together; where those are "
                                   "not physical, the J, B of the output-error fit that decided the last finding; "
                                   "the output-error check's J, B when that fit of the findings' model reaches the "
                                   "noise level and predicts no worse (output_error_check); "
                                   "for a known-value finding, those of its output-error refit "
                                   "(settings.estimates_augmented_from)",
            "findings (effect known_value)": "a known value of eq. (1) that, set free alone and refitted by output "
                                             "error with J, B and the start states, brings both angles to their "
                                             "noise floors: parameter.name as in --params, value refitted, table the "
                                             "value diagnose was given, ci95 its 95 % interval; it wins over effects "
                                             "that need more parameters (diagnosis/weigh.py), and one-parameter "
                                             "explanations that also reach the floor are its alternatives",
            "findings (input modification)": "a dead zone, saturation, delay or second-order motor whose value "
                                              "the output-error profile set: parameter.ci95 its 95 % interval "
                                              "(the profile's batch-means standard error, normal quantile; absent "
                                              "when another step moved the value); `export` writes it, and "
                                              "`estimate --params` widens J/B's intervals by it",
            "seed_model_check.known_values": "the known-value search estimate's adequacy check ran on this log "
                                             "(trms_ident/known_values.py): score-test ranking, the refits and "
                                             "the value named",
            "known_values_joint": "diagnose's forward search over several known values refitted together "
                                  "(known_values.joint), run when no single value and no effect explains the log: "
                                  "names in the order freed, values, ci95, over_noise after, explains, determined "
                                  "(95 % half-width within 10 % of the value), off_table (interval excludes the "
                                  "value given), steps (names freed, worst angle over its floor); null when not run "
                                  "or no second value earned its place",
            "output_error_tested": "every candidate the equation-error test passed and the output-error fit can "
                                   "carry (that test decides; torque_floor false: judged without the torque-share "
                                   "floor), and, when the equation-error test passes no candidate, its best "
                                   "output-error candidates, fitted by output error (the effect's parameter free "
                                   "with J, B, the findings' parameters and the motors' start states; an input "
                                   "modification by a profile over its value): value, standard error (batch means; a "
                                   "modification's from the profile's per-block costs), t, p (passes below 0.05 / "
                                   "candidates; a modification's t is its held-out drop in angle error), the "
                                   "relative drop of the noise-weighted squared angle error (passes from 1 %), the "
                                   "share of the misfit above the noise floor it removes (information), and its "
                                   "torque over its axis' thrust torque (passes from 0.5 %; a modification's "
                                   "change of thrust torque from 0.1 %)",
            "estimate_shift_percent": "how far leaving the effect out (the findings before it in) had moved each "
                                      "estimate",
            "findings.fit_before, fit_after": "this finding's own step: the prediction fit [%] of its axes with the "
                                              "findings before it, then with it added (worst axis); a finding "
                                              "the output-error fit decided gives that fit's simulation fits, "
                                              "which decided, in its evidence",
            "refused": "findings taken back: the last one when refitting J/B with it is not physical or it does "
                       "not raise the prediction fit of its axes (unless the output-error fit confirms it); an "
                       "earlier one when, given the later findings, the same test fails, and any torque term "
                       "whose value given the others is below practical size ('given the other findings')",
            "settings.output_error_check": "the findings' model simulated by output error: each angle's error "
                                           "RMS over its noise floor and the threshold 'explained' needs (null: "
                                           "that fit cannot carry the findings)",
            "settings.start_states_before, start_states_after": "the motors' states at the first sample the seed "
                                                                "model and the findings' model predict from (each "
                                                                "chosen by its fit over the first 60 s among the "
                                                                "seed model's choice, steady state, rest and the "
                                                                "estimates; null: steady state)",
            "settings.known_values": "the known values diagnose was given: value and source (table or override, "
                                     "--params); `trms-ident export` writes them, with the findings, as the bench file",
            "settings.structure, given_effects": "the bench file's [structure] every fit was made under, and its "
                                                 "input modifications ([effects]) the search started from and held "
                                                 "at their values (taken as given, never searched): key -> value; "
                                                 "empty under eq. (1) alone",
            "settings.floors": "per axis the floor [rad] the output-error fits are weighted by and the verdict is "
                               "judged against, and which: noise (the measured noise floor), black_box (the angles "
                               "carry no measurable noise; the held-out error of the flexible black-box model the "
                               "seed model's check fitted, seed_model_check.axes.*.black_box), none (neither: the "
                               "noise floor is kept as a lower bound and no verdict rests on it)",
            "held_out_fit": "held-out simulation fit [%] per axis of the seed model (before) and of the model with "
                            "the findings (after; null without findings): fitted by output error on one half of "
                            "the first span_s seconds, simulated on the other half with J, B and the findings' "
                            "values held and only the start states fitted, both ways round; NRMSE over both "
                            "halves (diagnosis/held_out.py); null when the seed model's fit failed",
            "corrections": "physics outside the library: a sparse data-driven correction of an axis' residual torque "
                           "(terms from a small library, pysindy STLSQ, kept only when it lowers the held-out "
                           "residual beyond chance and raises the prediction fit); a description, not a named effect. "
                           "output_error: its terms put into the findings' model as the bench file's [terms] carry "
                           "them and fitted by output error (values with 95 % intervals; the axis' held-out "
                           "simulation fit without -> with them; null when that fit fails)",
        },
    }


def finding_figure(step: dict):
    """One finding's figure set: per axis it acts on, measured against the model's prediction before and after
    the finding (as ``compare``), then the prediction error, the equation error over time (located segments
    shaded) and against the effect's regime variable, before and after; last the fitted term's shape against
    what the seed model assumes."""
    import matplotlib.pyplot as plt

    axes = step["axes"]
    sh = step["shape"]  # None for a known value: it changes a coefficient of eq. (1), not a term's form
    rows = 2 * len(axes) + (sh is not None)
    fig = plt.figure(figsize=(12, 2.7 * rows))
    grid = fig.add_gridspec(rows, 3)
    t = step["t"]
    for row, (axis, a) in enumerate(axes.items()):
        ov = fig.add_subplot(grid[2 * row, :])
        ov.plot(t, a["measured"], color="0.35", lw=1.0, label="measured")
        ov.plot(t, a["before"], color="tab:blue", lw=0.8, label=f"model before: fit {fit_text(a['fit_before'])}")
        ov.plot(t, a["after"], color="tab:orange", lw=0.8, ls="--", label=f"with it: fit {fit_text(a['fit_after'])}")
        ov.set_ylabel(f"{axis} angle [rad]")
        ov.set_xlabel("t [s]")
        ov.legend(fontsize=8, loc="upper right")
        pe, rt, rr = (fig.add_subplot(grid[2 * row + 1, j]) for j in range(3))
        pe.plot(t, a["measured"] - a["before"], color="tab:blue", lw=0.6, label="before")
        pe.plot(t, a["measured"] - a["after"], color="tab:orange", lw=0.6, label="with it")
        pe.set_ylabel(f"{axis} prediction error [rad]")
        pe.set_xlabel("t [s]")
        rt.plot(t, a["residual_before"], color="tab:blue", lw=0.6, label="before")
        rt.plot(t, a["residual_after"], color="tab:orange", lw=0.6, label="with it")
        for seg in a["segments"]:
            rt.axvspan(seg["start_s"], seg["end_s"], color="tab:red", alpha=0.12)
        rt.set_ylabel(f"{axis} equation error [N m]")
        rt.set_xlabel("t [s] (shaded: located)")
        rr.plot(a["regime"], a["residual_before"], ".", color="tab:blue", ms=1.2, alpha=0.5, label="before")
        rr.plot(a["regime"], a["residual_after"], ".", color="tab:orange", ms=1.2, alpha=0.5, label="with it")
        rr.set_xlabel(a["regime_label"])
        rr.set_ylabel("equation error [N m]")
        for p in (ov, pe, rt, rr):
            p.grid(alpha=0.3)
        for p in (pe, rt):
            p.legend(fontsize=7, loc="upper right")
        rr.legend(fontsize=7, markerscale=6, loc="upper right")
    if sh is not None:
        ax = fig.add_subplot(grid[2 * len(axes), :])
        ax.plot(sh.x, sh.seed, color="0.45", lw=1.0, ls=":", label="seed model (the values given)")
        ax.plot(sh.x, sh.fitted, color="tab:red", lw=1.4, label="with the fitted term")
        ax.set_xlabel(sh.x_label)
        ax.set_ylabel(sh.y_label)
        ax.set_title(sh.title, fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle(f"{step['key'].replace(':', ' on ')}: prediction, prediction and equation error in time and "
                 "regime (before and with this finding)" + (", and the term's shape" if sh is not None else ""))
    fig.tight_layout()
    return fig


def _oe_note(c: dict) -> str:
    """A correction's output-error fit in the report (held_out.correction_sentence's figures), escaped."""
    fit = c.get("output_error")
    if not fit:
        return ""
    from ..model.bench import shown

    ho = fit["held_out"]
    values = ", ".join(f"{shown(k)}: c = {v['estimate']:.4g} [{v['ci95'][0]:.4g}, {v['ci95'][1]:.4g}]"
                       for k, v in fit["values"].items())
    return html.escape(f"; by output error with the findings: {values}; held-out simulation fit of {c['axis']} "
                       f"{ho['before']:.1f} % -> {ho['after']:.1f} %")


def render(doc: dict, d: Diagnosis, log: Log) -> str:
    from .figures import png_data_uri

    import matplotlib.pyplot as plt

    figs = []
    stride = max(1, len(log) // 4000)
    # 1. residual over time, located segments shaded
    fig, ax = plt.subplots(2, 1, figsize=(10, 5), sharex=True)
    for a, axis in zip(ax, ("pitch", "yaw")):
        t, r0, r1 = d.residual[axis]
        a.plot(t[::stride], r0[::stride], lw=0.7, label="seed model")
        a.plot(t[::stride], r1[::stride], lw=0.7, label="with findings")
        for s in d.segments[axis]:
            a.axvspan(s["start_s"], s["end_s"], color="tab:red", alpha=0.15)
        a.set_ylabel(f"{axis} equation error [N m]")
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    ax[1].set_xlabel("t [s]")
    fig.suptitle("Equation error (filtered, eq. 3) over time; shaded: located segments")
    figs.append(("Residual over time", png_data_uri(fig)))
    # 2. residual against the regime variable of each finding's axis, before and after
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for a, axis in zip(ax, ("pitch", "yaw")):
        t, r0, r1 = d.residual[axis]
        v = d.velocity[axis]
        a.plot(v[::stride], r0[::stride], ".", ms=1.5, alpha=0.5, label="seed model")
        a.plot(v[::stride], r1[::stride], ".", ms=1.5, alpha=0.5, label="with findings")
        a.set_xlabel(f"{axis} velocity [rad/s]")
        a.set_ylabel("equation error [N m]")
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8, markerscale=6)
    fig.suptitle("Equation error against velocity (Coulomb friction shows as a step at zero, drag as a curve)")
    fig.tight_layout()
    figs.append(("Residual against the regime", png_data_uri(fig)))
    # 3. fit overlay
    fig, ax = plt.subplots(2, 1, figsize=(10, 5), sharex=True)
    corr = {c.axis: c for c in d.corrections}
    for a, axis in zip(ax, ("pitch", "yaw")):
        t, y, p0, p1 = d.overlay[axis][:4]
        a.plot(t[::stride], y[::stride], "k", lw=0.8, label="measured")
        a.plot(t[::stride], p0[::stride], lw=0.8, label=f"seed model ({fit_text(d.fit_before[axis])})")
        a.plot(t[::stride], p1[::stride], lw=0.8, ls="--", label=f"with findings ({fit_text(d.fit_after[axis])})")
        if axis in corr:
            a.plot(t[::stride], d.overlay[axis][4][::stride], lw=0.8, ls=":",
                   label=f"with the data-driven correction ({fit_text(corr[axis].fit_after)})")
        a.set_ylabel(f"{axis} [rad]")
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    ax[1].set_xlabel("t [s]")
    fig.suptitle(f"{d.settings['horizon_s']:g} s multi-step predictions against the measurement")
    figs.append(("Fit overlay", png_data_uri(fig)))
    # 3b. held-out simulation: each model fitted on one half, simulated on the other
    if d.held_out is not None:
        h = d.held_out
        t = h["prediction"]["t_s"]
        st = max(1, t.size // 4000)
        fig, ax = plt.subplots(2, 1, figsize=(10, 5), sharex=True)
        for j, (a, axis, angle) in enumerate(zip(ax, ("pitch", "yaw"), ("alpha_rad", "beta_rad"))):
            a.plot(t[::st], getattr(log, angle)[:t.size][::st], "k", lw=0.8, label="measured")
            a.plot(t[::st], h["prediction"]["before"][::st, j], lw=0.8,
                   label=f"seed model ({fit_text(h['before'][axis])})")
            if h["after"] is not None:
                a.plot(t[::st], h["prediction"]["after"][::st, j], lw=0.8, ls="--",
                       label=f"with findings ({fit_text(h['after'][axis])})")
            a.axvline(t[t.size // 2], color="0.6", lw=0.8)
            a.set_ylabel(f"{axis} [rad]")
            a.legend(fontsize=8)
            a.grid(alpha=0.3)
        ax[1].set_xlabel("t [s] (each half simulated with the values fitted on the other)")
        fig.suptitle("Held-out simulation against the measurement")
        figs.append(("Held-out simulation", png_data_uri(fig)))
    # 4. per finding: what it changed on its axes, where, and the shape of its term
    for i, step in enumerate(d.steps, 1):
        figs.append((f"Finding {i}: {step['key'].replace(':', ' on ')}", png_data_uri(finding_figure(step))))
    # 5. the shape of each data-driven correction: its torque against the axis' velocity and against time
    for c in d.corrections:
        fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
        v = d.velocity[c.axis]
        ax[0].plot(v[::stride], c.torque_nm[::stride], ".", ms=1.5, alpha=0.5)
        ax[0].set_xlabel(f"{c.axis} velocity [rad/s]")
        ax[0].set_ylabel("correction torque [N m]")
        ax[1].plot(log.t_s[::stride], c.torque_nm[::stride], lw=0.7)
        ax[1].set_xlabel("t [s]")
        for a in ax:
            a.grid(alpha=0.3)
        fig.suptitle(f"{c.axis}: the fitted correction (outside the library)")
        fig.tight_layout()
        figs.append((f"Correction of the {c.axis} torque", png_data_uri(fig)))
    items = "".join(
        f"<li><b>{html.escape(f['effect'])}</b> on {f['axis']}: {html.escape(f['parameter']['name'])} = "
        f"{html.escape(with_unit(f['parameter']['value'], f['parameter']['unit']))}. "
        f"{html.escape(f['explanation'])}.<br>"
        f"Fit {fit_change(f['fit_before'], f['fit_after'], '&rarr;')}. <span class='note'>{html.escape(f['evidence'])}"
        "</span></li>" for f in doc["findings"])
    corrections = "".join(
        f"<li><b>outside the library</b>, {c['axis']}: {html.escape(c['sentence'])}. Prediction fit "
        f"{fit_change(c['fit_before'], c['fit_after'], '&rarr;')}. <span class='note'>held-out equation-error RSS "
        f"{-100 * c['held_out_gain']:+.1f} % (t = {c['t']:.1f}, p = {c['p']:.1e}); terms: "
        + html.escape(", ".join(f"{t['term']} = {with_unit(t['coefficient'], t['unit'])}" for t in c["terms"]))
        + _oe_note(c) + "</span></li>" for c in doc["corrections"])
    corrected = {k: v for c in doc["corrections"] for k, v in c["estimates"].items()}
    est = "".join(f"<tr><td>{k}</td><td>{marked(k, doc['estimates']['nominal'][k])}</td>"
                  f"<td>{marked(k, doc['estimates']['augmented'][k])}</td>"
                  + (f"<td>{marked(k, corrected[k])}</td>" if k in corrected else ("<td></td>" if corrected else ""))
                  + "</tr>" for k in ("J1", "B1", "J2", "B2"))
    est_head = "<th>with the correction</th>" if corrected else ""
    w = doc["estimates"].get("with_findings")
    under = ""
    if w and w.get("estimates") is not None:
        fits = {True: "fits", False: "does NOT fit", None: "fit not decided"}[w["adequate"]]
        under = (f"<p><b>Under the findings' model</b> ({html.escape(w['model'])}; it {fits} this log), estimated as "
                 f"<code>trms-ident estimate --params</code> does under the bench file <code>trms-ident export</code> "
                 f"writes from this diagnosis, 95 %: {html.escape(w['text'])}.</p>")
    elif w:
        under = f"<p><b>Under the findings' model</b>: no estimate ({html.escape(w['error'])}).</p>"
    aug_from = {"output_error": " (output-error fit: the equation error's were not physical)",
                "output_error_check": " (output-error check of the findings' model)",
                "known_value": (" (output-error refit with the known values free)"
                                if sum(f["effect"] == "known_value" for f in doc["findings"]) > 1 else
                                " (output-error refit with the known value free)")}.get(
        doc["settings"].get("estimates_augmented_from"), "")
    imgs = "".join(f"<h2>{html.escape(title)}</h2><img alt='{html.escape(title)}' src='{uri}'>" for title, uri in figs)
    colour = {"consistent": "#e8f5e9", "explained": "#e8f5e9", "partly_explained": "#fff4e0"}.get(doc["verdict"],
                                                                                                   "#fdecea")
    # as the terminal says it (report/terminal.py): the verdict and the findings in plain words, then why
    leads = bool(doc["estimates"]["not_credible"]["augmented"])
    verdict = (f'<span style="background:{colour};padding:2px 6px;border-radius:4px">'
               f'{html.escape(doc["verdict"].replace("_", " ").upper())}</span> '
               f'{html.escape(headline(doc["verdict"], doc["findings"], leads))}')
    why = f'Why: {html.escape(doc["verdict_sentence"])} {len(doc["findings"])} finding(s).'
    check = doc["settings"].get("output_error_check")
    oe_line = html.escape("" if check is None else " Output-error check of the findings' model: error RMS over its "
                          "floor (settings.floors) " + ", ".join(f"{ang} {r:.2f}x" if r >= 0.01 else f"{ang} {r:.2g}x"
                                                                 for ang, r in check["rms_over_noise"].items())
                          + f" ({check['threshold']:g}x allowed for 'explained').")
    if d.held_out is not None:  # in the words the terminal shows
        oe_line += " " + html.escape(held_out_sentence(d.held_out, bool(d.findings)))
    units = units_text(doc["input"])
    units = html.escape(units) + "<br>" if units else ""
    bench = _bench_line(doc["settings"])
    return f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>trms-ident diagnose</title>
<style>body{{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto}}img{{max-width:100%}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px}}.note{{color:#555;font-size:.9em}}</style>
</head><body><h1>Diagnosis of {html.escape(log.source)}</h1><p><b>{verdict}</b>.</p><p>{why}
Fit measure: {html.escape(doc['fit']['measure'])}.{oe_line}</p>{bench}<ol>{items}{corrections}</ol>
<table><tr><th>parameter</th><th>seed model</th><th>with findings{aug_from}</th>{est_head}</tr>{est}</table>{under}{imgs}
<p class="note">{units}sha256 {log.sha256}; versions {html.escape(str(doc['versions']))}</p></body></html>
"""


def _bench_line(settings: dict) -> str:
    """The bench the search stood on (terminal.bench_lines, each line a sentence); "" under eq. (1) alone."""
    parts = [line[:1].upper() + line[1:] for line in bench_lines(settings)]
    return f"<p>{html.escape('. '.join(parts))}.</p>" if parts else ""
