"""The joint estimate's outputs: result.json (``joint``) and report.html with a forest plot."""
from __future__ import annotations

import html
import math
from typing import TYPE_CHECKING

import numpy as np

from ..params import ESTIMATED, UNITS, defaults
from ..model.bench import model_doc
from .summary import interval_text, strict, versions

if TYPE_CHECKING:
    from ..joint import JointResult
    from ..log import Log

VERDICT = {True: "fits", False: "does NOT fit", None: "fit not decided"}


def joint_doc(result: JointResult, logs: list[Log]) -> dict:
    """The result.json contract of a joint estimate (documented in docs/joint.md)."""
    table = defaults()
    fit = result.fit
    per_log = []
    for v, log in zip(result.logs, logs):
        alone = v.result.model_check
        per_log.append({
            "path": log.source, "name": v.name, "sha256": log.sha256, "samples": len(log),
            "duration_s": log.duration_s, "sample_time_s": log.sample_time_s, "in_pool": v.in_pool,
            "estimates": v.estimates, "ci95": {k: [_num(a) for a in v.ci95[k]] for k in ESTIMATED},
            "headline": v.result.headline,
            "against_others": {"z": v.z, "relative": v.rel, "chi2": v.q, "df": v.df, "p": v.p},
            "model_check": v.model_check,
            "model_check_alone": {"adequate": alone["adequate"], "sentence": alone["sentence"]},
        })
    doc = {
        "tool": "trms-ident",
        "joint": {
            "estimates": result.estimates,
            "ci95": {k: list(result.ci95[k]) for k in ESTIMATED},
            "identifiability": result.identifiability,
            "units": {k: UNITS[k] for k in ESTIMATED},
            "consistent": result.consistent,
            "outliers": result.outliers,
            "sentence": result.sentence,
            "test": result.test,
            "adequate": result.adequate,
            "model": model_doc(result.settings.effects, result.settings.effect_sources, {}, result.settings.structure),
            "logs": per_log,
            "fit": {"method": "output error over all pooled logs at once (numerics/joint.py): J/B shared, each log's "
                              "start states, windows and noise weights its own; then one efficient step of the "
                              "logs' score equations weighted by their own covariances (the estimate and its "
                              "intervals)",
                    "converged": fit.converged, "iterations": fit.iterations, "cost": fit.cost,
                    "blocks": fit.blocks, "output_error_estimate": fit.output_error,
                    "weights": [r["weight"] for r in fit.runs]},
        },
        "parameters": {k: {"value": v, "unit": UNITS.get(k, ""), "source": "table" if v == table[k] else "file"}
                       for k, v in result.params.items() if k not in ESTIMATED},
        "settings": {"thrust_law": result.settings.thrust_law, "refine": result.settings.refine,
                     "headline": result.settings.headline},
        "versions": versions(),
    }
    return strict(doc)


def _g(x, missing: str, fmt: str = ".6g") -> str:
    return missing if x is None else format(x, fmt)


def _num(x):
    return None if x is None or not math.isfinite(x) else float(x)


def forest_figure(doc: dict) -> str:
    """Each log's own estimate with its 95 % interval beside the pooled one, per parameter."""
    import matplotlib.pyplot as plt

    from .figures import png_data_uri

    j = doc["joint"]
    logs = j["logs"]
    fig, axes = plt.subplots(1, 4, figsize=(12, 0.5 * len(logs) + 1.8), sharey=True)
    ys = np.arange(len(logs))[::-1] + 1
    for ax, k in zip(axes, ESTIMATED):
        lo, hi = j["ci95"][k]
        est = j["estimates"][k]
        ref = est if est is not None else next((lg["estimates"][k] for lg in logs if lg["estimates"][k]), None)
        if ref is None:
            ax.set_title(f"{k}: no log determines it", fontsize=9)
            continue
        if est is not None:  # the pooled estimate and its interval, as the zero line and a band
            ax.axvspan(100 * (lo / ref - 1), 100 * (hi / ref - 1), color="tab:blue", alpha=0.15)
            ax.axvline(0.0, color="tab:blue", lw=1)
        for y, lg in zip(ys, logs):
            e = lg["estimates"][k]
            if e is None:
                continue
            a, b = lg["ci95"][k]
            x = 100 * (e / ref - 1)
            err = [[x - 100 * (a / ref - 1)], [100 * (b / ref - 1) - x]] if a is not None and b is not None else None
            ax.errorbar([x], [y], xerr=err, fmt="o", color="black" if lg["in_pool"] else "tab:red", capsize=3, ms=4)
        ax.set_title(f"{k} = {ref:.4g} {UNITS[k]}" + ("" if est is not None else " (not pooled)"), fontsize=9)
        ax.set_xlabel("% from the pooled value", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
    axes[0].set_yticks(list(ys), [lg["name"] for lg in logs], fontsize=8)
    fig.suptitle("Each log alone (black; red: left out of the pool) against the pooled estimate (blue band)",
                 fontsize=9)
    fig.tight_layout()
    return png_data_uri(fig)


def render(doc: dict, result: JointResult, logs: list[Log]) -> str:
    from .figures import compare_figure
    from .html import CSS

    j = doc["joint"]
    colour = ("#fdecea" if j["consistent"] is False else "#e8f5e9" if j["consistent"] and not j["outliers"] else
              "#fff8e1")
    rows = "".join(
        f"<tr><td>{k}</td><td>{UNITS[k]}</td><td>{_g(j['estimates'][k], '')}</td>"
        f"<td>{interval_text(*j['ci95'][k], j['estimates'][k]) if j['estimates'][k] is not None else 'n.i.'}</td>"
        f"<td>{html.escape(j['identifiability'][k])}</td></tr>" for k in ESTIMATED)
    log_rows = "".join(
        f"<tr><td>{html.escape(lg['name'])}</td><td>{'yes' if lg['in_pool'] else 'LEFT OUT'}</td>"
        + "".join(f"<td>{_g(lg['estimates'][k], 'n.i.')}</td>" for k in ESTIMATED)
        + f"<td>{_g(lg['against_others']['p'], '-', '.3g')}</td>"
        f"<td>{VERDICT[lg['model_check']['adequate']] if lg['model_check'] else '-'}</td></tr>"
        for lg in j["logs"])
    split = "".join(  # a file that broke into parts: gaps or runs joined, and the parts left out
        f"<p class='note'>{html.escape(x['found'])}: its parts are the logs below"
        + "".join(f"; {html.escape(lo['part'])} (t = {lo['from_s']:.6g} to {lo['to_s']:.6g} s) left out: "
                  f"{html.escape(lo['why'])}" for lo in x["left_out"]) + ".</p>" for x in j.get("split", []))
    figures = "".join(
        f"<h3>{html.escape(v.name)}</h3><img alt='measured and simulated angles, pooled model' "
        f"src='{compare_figure(log, result.fit.runs[k]['prediction'], v.model_check)}'>"
        for k, (v, log) in enumerate((v, log) for v, log in zip(result.logs, logs) if v.in_pool))
    return f"""<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>trms-ident joint estimate</title>
<style>{CSS}</style></head><body>
<h1>TRMS parameter identification: one bench, {len(logs)} logs</h1>
<div style="background:{colour};padding:0.6em 1em;border-radius:6px"><h2 style="margin-top:0.2em">
Do the logs agree?</h2><p>{html.escape(j['sentence'])}</p>
<p>Pooled model on each pooled log: {', '.join(f"{html.escape(lg['name'])} {VERDICT[lg['model_check']['adequate']]}"
                                              for lg in j['logs'] if lg['model_check'])}.</p>{split}</div>
<h2>Pooled estimate</h2><table><tr><th>parameter</th><th>unit</th><th>estimate</th><th>95 % interval</th>
<th>identifiability</th></tr>{rows}</table>
<p class="note">{html.escape(j['fit']['method'])}; {j['fit']['iterations']} Gauss-Newton iteration(s), converged:
{j['fit']['converged']}, {j['fit']['blocks']} blocks.</p>
<h2>Each log alone</h2><img alt="forest plot" src="{forest_figure(doc)}">
<table><tr><th>log</th><th>pooled</th>{''.join(f'<th>{k}</th>' for k in ESTIMATED)}<th>p against the others</th>
<th>pooled model fits</th></tr>{log_rows}</table>
<p class="note">Consistency test: {html.escape(j['test']['method'])}; level {j['test']['level']:g} over the logs.</p>
<h2>Measured against the pooled model</h2>{figures}
<h2>Inputs and versions</h2><ul>{''.join(f"<li><code>{html.escape(lg['path'])}</code> sha256 {lg['sha256']}</li>"
                                         for lg in j['logs'])}</ul>
<p class="note">{html.escape(', '.join(f'{k} {v}' for k, v in doc['versions'].items()))}</p>
</body></html>"""
