"""Self-contained HTML report (figures embedded), built from the summary dict and the Result."""
from __future__ import annotations

from typing import TYPE_CHECKING

import html

from ..log import Log
from ..params import ESTIMATED, UNITS, marked

if TYPE_CHECKING:
    from ..identify import Result

CSS = """body{font-family:system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:4px 10px;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}code{background:#f5f5f5;padding:1px 4px}
.note{color:#555;font-size:0.92em}img{max-width:100%}"""


def _row(cells, tag="td") -> str:
    return "<tr>" + "".join(f"<{tag}>{html.escape(str(c))}</{tag}>" for c in cells) + "</tr>"


def _g(x: float) -> str:
    return f"{x:.6g}"


def _timing(inp: dict) -> str:
    from .summary import voltage_timing_text

    s = inp.get("sampling", {})
    lines = [] if s.get("uniform", True) else [
        f"Jittered stamps: steps {s['min_step_over_median']:.3g}-{s['max_step_over_median']:.3g} x the median "
        f"({s['median_step_s']:.6g} s), jitter RMS {s['jitter_rms_percent']:.3g} %, {s['dropped_samples']} dropped "
        "sample(s); voltages held over each actual interval."]
    timing = voltage_timing_text(inp)
    if timing:
        lines.append(timing.capitalize() + ".")
    return "".join(f'<br><span class="note">{html.escape(x)}</span>' for x in lines)


def _white(w: dict) -> str:
    if not w.get("applies", True):
        return "does not apply (no measurable noise)"
    return f"Q = {w['ljung_box_q']:.3g} (<= {w['threshold']:.3g})" + ("" if w["white"] else ": not white")


def _cross(c: dict) -> str:
    if not c.get("applies", True):
        return "does not apply (no measurable noise)"
    return (", ".join(f"{k} {x:.3g}" for k, x in c["statistic"].items()) + f" (<= {c['threshold']:.3g})"
            + ("" if c["uncorrelated"] else ": correlated"))


def _verdict(doc: dict) -> str:
    c = doc["model_check"]
    colour, title = {True: ("#e8f5e9", "The model fits this log"), False: ("#fdecea", "The model does NOT fit this log"),
                     None: ("#fff8e1", "Not decided whether the model fits this log")}[c["adequate"]]
    rows = "".join(_row([axis, f"{v['fit_percent']:.2f} %", f"{v['noise_floor_fit_percent']:.2f} %" +
                         ("" if v.get("noise_floor_measured", True) else " (floor not measurable)"),
                         f"{v['rms_over_noise']:.3g} (<= {v['rms_over_noise_threshold']:g})",
                         _white(v["whiteness"]), _cross(v["input_correlation"])])
                   for axis, v in c["axes"].items())
    head = _row(["axis", "simulation fit", "noise floor allows", "error RMS / noise", "whiteness",
                 "input correlation"], "th")
    table = f"<table>{head}{rows}</table>" if rows else ""
    return (f'<div style="background:{colour};padding:0.6em 1em;border-radius:6px"><h2 style="margin-top:0.2em">'
            f'{title}</h2><p>{html.escape(c["sentence"])}</p>{table}<p class="note">Simulation: '
            f'{html.escape(c["simulation"])}. The verdict is the error RMS against the noise floor; the residual '
            f'tests show where a misfit lies.</p></div>')


def _fit_figures(result: Result, log: Log) -> str:
    from .figures import compare_figure

    if result.simulated is None:
        return ""
    return (f'<h2>Model against measurement</h2><img alt="measured and simulated angles" '
            f'src="{compare_figure(log, result.simulated, result.model_check)}">'
            + _residual_section(result, log))


def _residual_section(result: Result, log: Log) -> str:
    """The residual tests' figure for the axes where they apply; where none does, why not, and no figure."""
    from .figures import residual_figure

    axes = result.model_check["axes"]
    off = {axis: v["whiteness"]["why_not"] for axis, v in axes.items() if not v["whiteness"].get("applies", True)}
    said = "".join(f'<p class="note">{html.escape(axis)}: the residual tests do not apply: {html.escape(why)}.</p>'
                   for axis, why in off.items())
    if len(off) == len(axes):
        return f"<h2>Residual tests</h2>{said}"
    return (f'<h2>Residual tests</h2>{said}<img alt="residual correlations" '
            f'src="{residual_figure(log, result.simulated, result.sample_time_s, skip=tuple(off))}">')


def _refined_cell(refined: dict | None, k: str) -> str:
    """The refinement's value, marked when it is not the estimate (its fit missed the noise floor or did not
    converge: the number is then a fit's end point, e.g. 3.6e13 kg m^2 on a real log the model does not fit)."""
    if not refined:
        return "-"
    v = _g(refined["estimates"][k])
    return v if refined["used"] else f"{v} (not used)"


def _model_line(doc: dict) -> str:
    """The model the estimate was made under, when the bench file adds effects to eq. (1) or states a structure."""
    m = doc.get("model") or {}
    tables = [t for t, k in (("[effects]", "effects"), ("[structure]", "structure")) if m.get(k)]
    if not tables:
        return ""
    return f'<p><b>Model:</b> {html.escape(m["equation"])} (the bench file\'s {" and ".join(tables)}).</p>'


def _effect_table(doc: dict) -> str:
    from .summary import interval_text

    m = doc.get("model") or {}
    if not m.get("effects"):
        return ""
    rows = "".join(_row([k, v["parameter"], _g(v["value"]), v["unit"],
                         interval_text(*v["ci95"], v["value"]) if v["ci95"] else "-", v["how"], v["from"] or "-"])
                   for k, v in m["effects"].items())
    return (f"<h2>Effects beyond eq. (1)</h2><table>"
            f"{_row(['effect', 'parameter', 'value', 'unit', '95 %', 'how', 'from'], 'th')}{rows}</table>")


def render(doc: dict, result: Result, log: Log) -> str:
    from .figures import signals_figure, traces_figure  # matplotlib only when a report is asked for
    from .summary import interval_text, units_text

    settings = doc["settings"]
    truth = doc.get("truth", {}).get("values")
    head = ["parameter", "unit", f"estimate ({doc['headline']})", "95 % interval", "DREM final", "offline optimum",
            "refined"]
    if truth:
        head += ["ground truth", "error [%]"]
    rows = []
    for k in ESTIMATED:
        est = doc["estimates"][k]
        lo, hi = doc["ci95"][k]
        r = [k, UNITS[k], (marked(k, est) if est is not None else "not identifiable"),
             interval_text(lo, hi, est) if lo is not None else "-", _g(doc["drem_final"][k]), _g(doc["offline_optimum"][k]),
             _refined_cell(doc["refined"], k)]
        if truth:
            err = doc["truth"]["error_percent"][k]
            r += [_g(truth[k]), f"{err:+.3f}" if err is not None else "-"]
        rows.append(_row(r))
    set_rows = "".join(_row([k, v]) for k, v in settings.items() if k != "overrides")
    par_rows = "".join(_row([k, _g(v["value"]), v["unit"], v["source"], v["meaning"]])
                       for k, v in doc["parameters"].items())
    inp = doc["input"]
    units = units_text(inp)
    ver = ", ".join(f"{k} {v}" for k, v in doc["versions"].items())
    excitation = "; ".join(f"{a}: {v['verdict']}" for a, v in doc["excitation"].items())
    notes = "".join(f"<li>{html.escape(k)}: {html.escape(v)}</li>" for k, v in doc["identifiability"].items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>trms-ident report: {html.escape(inp['path'])}</title>
<style>{CSS}</style></head><body>
<h1>TRMS parameter identification</h1>
{_verdict(doc)}
<p>Log <code>{html.escape(inp['path'])}</code>: {inp['samples']} samples, {inp['duration_s']:.6g} s,
sample time {inp['sample_time_s']:.6g} s.<br><span class="note">sha256 {inp['sha256']}</span>
{f'<br><span class="note">{html.escape(units)}</span>' if units else ''}{_timing(inp)}</p>
<h2>Estimates</h2>
{_model_line(doc)}
<table>{_row(head, 'th')}{''.join(rows)}</table>
<p class="note"><b>Intervals:</b> {html.escape(doc['ci95_meaning'])}.</p>
<p class="note">Headline: {html.escape(doc['headline_meaning'])}. Intervals: batch means over blocks
(valid for correlated residuals), on angles that sit on an encoder's grid the wider of that and the spread the
rounding causes; for DREM widened by the predicted errors-in-variables bias.</p>
<p class="note">{html.escape(doc['refinement'])}.</p>
<p>Excitation: {html.escape(excitation)}.</p><ul class="note">{notes}</ul>
<p class="note">Filters: {html.escape(settings['filter_F'])}; {html.escape(settings['filter_H'])}.
{html.escape(settings['filter_design'])}.</p>
{_fit_figures(result, log)}
<h2>Estimate traces</h2><img alt="estimate traces" src="{traces_figure(result, truth)}">
<h2>Signals used</h2><img alt="signals" src="{signals_figure(log)}">
<h2>Settings</h2><table>{_row(['setting', 'value'], 'th')}{set_rows}</table>
<h2>Known parameters used</h2>
<table>{_row(['name', 'value', 'unit', 'source', 'meaning'], 'th')}{par_rows}</table>
{_effect_table(doc)}
<p class="note">Versions: {html.escape(ver)}.</p>
</body></html>
"""

