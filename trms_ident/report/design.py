"""design's page: the references, the angles and voltages the closed loop would produce with the limits drawn,
and the predicted 95 % intervals beside the paper's square reference."""
from __future__ import annotations

import html

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..params import ESTIMATED, UNITS  # noqa: E402
from .figures import stride, png_data_uri  # noqa: E402
from .html import CSS  # noqa: E402


def design_doc(d, p: dict, settings: dict) -> dict:
    """design's JSON: the predicted precision of the design and of the square reference, their envelopes, the
    references' multisines and every setting."""
    import dataclasses

    from .summary import versions

    def run_doc(r) -> dict:
        return {"predicted": {k: {"half_width": v["half_width"], "relative": v["relative"], "se": v["se"]}
                              for k, v in r.precision.items()},
                "envelope": r.envelope, "violations": list(r.violations),
                **({"effect": r.effect} if r.effect is not None else {}),
                **({"discrimination": r.discrimination} if r.discrimination is not None else {})}

    breaks = ", but it breaks the limits: " + "; ".join(d.square.violations) if d.square.violations else ""
    if d.run.discrimination is not None:
        sentence = discrimination_sentence(d, settings["duration_s"])
    elif d.run.effect is not None:
        e, q = d.run.effect, d.square.effect
        sentence = (f"Within the limits the design predicts {e['key']} of {e['size']:g} at t = {e['t']:.3g} "
                    f"(diagnose's output-error test finds it with a chance of {100 * e['power']:.3g} %); the paper's "
                    "square reference, same length, "
                    + (f"t = {q['t']:.3g} ({100 * q['power']:.3g} %){breaks}." if q else f"no prediction{breaks}."))
    else:
        worst = max(ESTIMATED, key=lambda k: d.run.precision[k]["relative"])
        sentence = (f"Within the limits the design predicts {worst} to "
                    f"+-{100 * d.run.precision[worst]['relative']:.3g} % (its widest interval); the paper's square "
                    "reference, same length, ")
        if d.square.precision:
            sq_worst = max(ESTIMATED, key=lambda k: d.square.precision[k]["relative"])
            sentence += f"{sq_worst} to +-{100 * d.square.precision[sq_worst]['relative']:.3g} %{breaks}."
        else:  # its closed loop diverged
            sentence += f"no prediction{breaks}."
    sentence += _off_bench_clause(d.run.envelope.get("off_bench"), settings.get("limits"))
    model = settings.get("model") or {}
    if model.get("effects"):
        sentence += (f" Planned for the bench as diagnosed, {model['equation']}: every candidate simulated with its "
                     "effects, its intervals those estimate --params would give under them.")
    shapes = {"pitch": dataclasses.asdict(d.pitch), "yaw": dataclasses.asdict(d.yaw)}
    return {"kind": "trms-ident design", "sentence": sentence, "design": {**run_doc(d.run), **shapes},
            "square": run_doc(d.square), "candidates": d.candidates, "feasible": d.feasible,
            "parameters": {k: float(v) for k, v in p.items() if isinstance(v, (int, float))},
            "settings": settings, "versions": versions()}


def _off_bench_clause(off: dict | None, limits: dict | None) -> str:
    """What the design's run does on a bench whose J/B are off the given ones: whether it keeps the limits."""
    if not off or not limits:
        return ""
    from ..design import Limits, off_bench_breaks

    broken = off_bench_breaks(off, Limits(**limits))
    if not broken:
        return f" On a bench whose J/B are {100 * off['relative']:g} % off these, it keeps the limits too."
    return (f" On a bench whose J/B are {100 * off['relative']:g} % off these, " + "; ".join(broken)
            + ": plan from a previous estimate of this bench (--from result.json) or with --robust, and run it in "
            "simulation first.")


def discrimination_sentence(d, duration_s: float) -> str:
    """What the design predicts for telling diagnose's first finding from its look-alikes, beside the square."""
    from ..design import MIN_COST_GAP, gap_needed
    from ..numerics.adequacy import RMS_OVER_NOISE

    t, q = d.run.discrimination, d.square.discrimination

    def told(key: str, v: dict) -> str:
        if v["rule"] == "cost_gap":
            return (f"{key}, refitted, leaves a noise-weighted squared angle error {v['gap']:.3g} above the truth's "
                    f"(diagnose needs {MIN_COST_GAP:g})")
        worst = max(v["rms_over_noise"], key=v["rms_over_noise"].get)
        return (f"{key}, refitted, leaves the {'pitch' if worst == 'alpha' else 'yaw'} angle at "
                f"{v['rms_over_noise'][worst]:.3g}x its noise floor "
                f"(above {RMS_OVER_NOISE:g}x it is no look-alike)")

    c = t["rivals"][t["closest"]]
    text = (f"Within the limits, on the bench with {t['truth']} = {t['truth_value']:.4g}, the design predicts that "
            f"{told(t['closest'], c)}: diagnose tells them apart with a chance of {100 * c['power']:.3g} %")
    others = [k for k in t["rivals"] if k != t["closest"]]
    if others:
        text += " (the other rivals: " + ", ".join(f"{k} {100 * t['rivals'][k]['power']:.3g} %" for k in others) + ")"
    if q:
        text += (f"; under the paper's square reference, same length, {100 * q['rivals'][t['closest']]['power']:.3g} %"
                 + (", but it breaks the limits" if d.square.violations else ""))
    text += "."
    if c["power"] < 0.9 and c["rule"] == "cost_gap" and c["gap"] > 0:
        need = gap_needed(0.9)
        text += (f" That is not enough to decide: a 90 % chance needs a gap of {need:.3g}. The gap grows with the "
                 f"samples: about {duration_s * need / c['gap']:.3g} s of this design at this rate, a faster rate, "
                 "a quieter encoder or wider limits would reach it.")
    elif c["power"] < 0.9:
        text += (" That is not enough to decide, and a longer run does not help much here (the error over the floor "
                 "is a mean square, not a sum): a quieter encoder or wider limits would.")
    return text


def run_figure(run, square, limits, u_limit_v: float) -> str:
    """Pitch and yaw (reference and predicted angle, with the range allowed) and both voltages (with the
    controller's limit), the design's run beside the square reference's."""
    s = stride(run.t_s.size)
    t = run.t_s[s]
    fig, ax = plt.subplots(3, 1, figsize=(10, 7.5), sharex=True)
    for a, ref, y, sq, lim, name in ((ax[0], run.alpha_ref_rad, run.alpha_rad, square.alpha_rad, limits.pitch_rad,
                                      "pitch alpha [rad]"),
                                     (ax[1], run.beta_ref_rad, run.beta_rad, square.beta_rad, limits.yaw_rad,
                                      "yaw beta [rad]")):
        a.plot(t, sq[s], color="0.75", lw=0.8, label="paper's square: predicted angle")
        a.plot(t, ref[s], color="C1", lw=0.8, ls="--", label="design: reference")
        a.plot(t, y[s], color="C0", lw=1.0, label="design: predicted angle")
        for v in (-lim, lim):
            a.axhline(v, color="C3", lw=0.8, ls=":")
        a.set_ylabel(name)
        a.grid(alpha=0.3)
    ax[0].legend(loc="upper right", fontsize=8)
    ax[2].plot(t, run.u1_v[s], lw=0.8, label="u1 (pitch motor)")
    ax[2].plot(t, run.u2_v[s], lw=0.8, label="u2 (yaw motor)")
    for v in (-u_limit_v, u_limit_v):
        ax[2].axhline(v, color="C3", lw=0.8, ls=":")
    ax[2].set_ylabel("design: voltage [V]")
    ax[2].set_xlabel("t [s]")
    ax[2].legend(loc="upper right", fontsize=8)
    ax[2].grid(alpha=0.3)
    fig.suptitle("The design in the closed loop (noise-free prediction); dotted: the limits")
    return png_data_uri(fig)


def _percent(p: dict | None) -> str:
    """A predicted relative half-width in %, or why there is none (the run diverged)."""
    return f"{100 * p['relative']:.3g} %" if p else "n/a (its run diverges)"


def precision_figure(doc: dict) -> str:
    """Predicted relative 95 % half-widths [%] of J1, B1, J2, B2: the design beside the square reference."""
    x = np.arange(len(ESTIMATED))
    d = [100 * doc["design"]["predicted"][k]["relative"] for k in ESTIMATED]
    q = [100 * doc["square"]["predicted"].get(k, {}).get("relative", np.nan) for k in ESTIMATED]  # NaN: diverged
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.bar(x - 0.2, d, 0.4, label="design (within the limits)")
    ax.bar(x + 0.2, q, 0.4, color="0.6", label="paper's square" + (" (breaks the limits)" if doc["square"]["violations"]
                                                                  else ""))
    ax.set_xticks(x, ESTIMATED)
    ax.set_yscale("log")
    ax.set_ylabel("predicted 95 % half-width [% of value]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return png_data_uri(fig)


#: settings the page shows in their own words, not in the settings line
SHOWN_APART = ("pid", "limits", "noise_std_rad", "not_weighed")


def render(doc: dict, d, limits, u_limit_v: float) -> str:
    """The page (self-contained HTML)."""
    def env_row(name: str, r: dict) -> str:
        e = r["envelope"]
        return (f"<tr><td>{name}</td><td>{e['alpha_rad']:.3g}</td><td>{e['beta_rad']:.3g}</td><td>{e['u1_v']:.3g}</td>"
                f"<td>{e['u2_v']:.3g}</td><td>{100 * e['saturated_share']:.3g} %</td><td>"
                f"{html.escape('; '.join(r['violations']) or 'none')}</td></tr>")

    rows = "".join(f"<tr><td>{k}</td><td>{html.escape(UNITS[k])}</td>"
                   f"<td>{doc['design']['predicted'][k]['half_width']:.3g}</td>"
                   f"<td>{100 * doc['design']['predicted'][k]['relative']:.3g} %</td>"
                   f"<td>{_percent(doc['square']['predicted'].get(k))}</td></tr>" for k in ESTIMATED)
    told = ""
    if "discrimination" in doc["design"]:
        t, q = doc["design"]["discrimination"], doc["square"].get("discrimination")
        told = ("<h2>Telling the look-alikes apart</h2><table><tr><th>rival</th><th>diagnose's rule</th>"
                "<th>design: cost gap</th><th>design: error RMS / floor (pitch, yaw)</th>"
                "<th>design: chance told apart</th><th>rival's refitted value</th>"
                "<th>paper's square: chance</th></tr>" + "".join(
                    f"<tr><td>{html.escape(k)}</td><td>{v['rule'].replace('_', ' ')}</td><td>{v['gap']:.3g}</td>"
                    f"<td>{v['rms_over_noise']['alpha']:.3g}, {v['rms_over_noise']['beta']:.3g}</td>"
                    f"<td>{100 * v['power']:.3g} %</td><td>{v['value']:.4g}</td>"
                    f"<td>{format(100 * q['rivals'][k]['power'], '.3g') + ' %' if q else '-'}</td></tr>"
                    for k, v in t["rivals"].items()) + "</table>"
                f"<p class=\"note\">The bench simulated with {html.escape(t['truth'])} = {t['truth_value']:.4g} "
                "(diagnose's first finding); each rival fitted to its noise-free angles by output error with J/B and "
                "its own value free. The cost gap is the noise-weighted squared angle error it leaves beyond the "
                "truth's: the expected difference of the two fits' costs on the recorded run, twice the log "
                "likelihood ratio; diagnose tells the two pitch offsets apart by it (10 needed), any other "
                "look-alike by whether its refit leaves an angle above 1.2x its noise floor.</p>")
    st = doc["settings"]
    rounding = ("; with encoders of " + str(st["encoder_bits"]) + " bits, instead, what estimate would report on "
                "the rounded run (numerics/quantization.py)" if st.get("encoder_bits") else "")
    noise = ", ".join(f"{a} {v:.3g} rad" for a, v in st["noise_std_rad"].items())
    return f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>trms-ident design</title>
<style>{CSS}</style></head><body>
<h1>The next experiment: {st['duration_s']:g} s at {st['rate_hz']:g} Hz</h1>
<p>{html.escape(doc['sentence'])}</p>{told}
<h2>Predicted precision</h2>
<table><tr><th>parameter</th><th>unit</th><th>design: 95 % half-width</th><th>design: relative</th>
<th>paper's square: relative</th></tr>{rows}</table>
<img alt="predicted half-widths" src="{precision_figure(doc)}">
<p class="note">Cramer-Rao bound of the output-error estimate for the run (numerics/fisher.py), white noise of
the logged angles: {noise}{rounding}; the estimate's own intervals on a recorded run are measured, not
these.</p>
<h2>What the bench would do</h2>
<table><tr><th>run</th><th>largest |pitch| [rad]</th><th>largest |yaw| [rad]</th><th>largest |u1| [V]</th>
<th>largest |u2| [V]</th><th>at the voltage limit</th><th>limits broken</th></tr>
{env_row('design', doc['design'])}{env_row("paper's square", doc['square'])}</table>
<p class="note">Limits: |pitch| &le; {limits.pitch_rad:g} rad, |yaw| &le; {limits.yaw_rad:g} rad, a voltage at its
{u_limit_v:g} V limit at most {100 * limits.saturated_share:g} % of the time, reference rate
{'unlimited' if limits.ref_rate_rad_s is None else f'&le; {limits.ref_rate_rad_s:g} rad/s'}.</p>
<img alt="references, predicted angles and voltages" src="{run_figure(d.run, d.square, limits, u_limit_v)}">
<h2>Settings and versions</h2>
<p class="note">{html.escape(', '.join(f'{k} {v}' for k, v in st.items() if k not in SHOWN_APART))}; noise {noise};
PID {html.escape(', '.join(f'{k} {v:g}' for k, v in st['pid'].items()))}.</p>
<p class="note">{html.escape(', '.join(f'{k} {v}' for k, v in doc['versions'].items()))}</p>
</body></html>"""
