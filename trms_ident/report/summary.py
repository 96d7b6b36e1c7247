"""The result as a plain dict: the JSON contract, and the source of the HTML tables."""
from __future__ import annotations

import json
import math
import platform
from dataclasses import asdict
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

from .. import __version__
from ..settings import AXES
from ..log import Log
from ..params import BY_NAME, ESTIMATED, THRUST_LAWS, UNITS, defaults, not_credible
from ..model.bench import model_doc

if TYPE_CHECKING:
    from ..identify import Result


def versions() -> dict[str, str]:
    out = {"trms-ident": __version__, "python": platform.python_version()}
    for pkg in ("numpy", "scipy", "numba", "pyarrow"):
        try:
            out[pkg] = metadata.version(pkg)
        except metadata.PackageNotFoundError:
            out[pkg] = "not installed"
    return out


def load_truth(path: Path) -> dict | None:
    """Ground truth from a simulator sidecar file, or None when absent or unreadable."""
    try:
        truth = json.loads(path.read_text(encoding="utf-8"))
        est = truth["estimated"]
        return {k: float(est[k]) for k in ESTIMATED}
    except (OSError, ValueError, KeyError, TypeError):
        return None


HEADLINE_MEANING = {
    "refined": "prediction-error (output-error) refinement of the angles, started from DREM's offline optimum: "
               "Gauss-Newton over windows with fitted starts (maximum likelihood for white angle noise)",
    "offline": "offline optimum sum(eps*phi)/sum(phi^2) of each DREM scalar regression (eq. 7) over the whole log",
    "drem": "final value of the causal DREM gradient trace (eq. 8)",
}


def summarize(result: Result, log: Log, truth: dict | None = None, truth_source: str | None = None) -> dict:
    from ..numerics.adequacy import below_integrator

    s = result.settings
    table = defaults()
    check = result.model_check
    doc = {
        "tool": "trms-ident",
        "model_check": check,
        "estimates": {k: result.estimates[k] for k in ESTIMATED},
        "ci95": {k: _pair(result.intervals[k]) for k in ESTIMATED},
        "ci95_meaning": {True: ("95 % intervals from what the fit leaves, below the integrator's precision: the log "
                                "carries no measurable noise, and they are a lower bound"
                                if below_integrator(check.get("axes") or {}) else
                                "95 % intervals from the noise in this log; the model fits it to the noise level"),
                         False: "95 % intervals CONDITIONAL on a model that does not fit this log (model_check): "
                                "they measure the noise, not the model's error, and the true values may lie far "
                                "outside",
                         None: "95 % intervals with no adequacy verdict: "
                               f"{check.get('undecided_because') or 'not decided'}, so whether the model fits this "
                               "log is not decided (model_check); they measure the noise alone and assume the model "
                               "is right"}[check["adequate"]],
        "identifiable": {k: result.intervals[k].identifiable for k in ESTIMATED},
        "identifiability": {k: result.intervals[k].reason for k in ESTIMATED},
        "not_credible": not_credible(result.estimates),
        "units": {k: UNITS[k] for k in ESTIMATED},
        "headline": result.headline,
        "headline_meaning": HEADLINE_MEANING[result.headline],
        "model": model_doc(s.effects, s.effect_sources, result.refined.freed if result.refined else {}, s.structure),
        "refinement": result.refine_note,
        "drem_final": result.drem_final,
        "traces_every_nth_sample": result.trace_step,
        "offline_optimum": result.offline,
        "offline_ci95": {k: _pair(result.offline_intervals[k]) for k in ESTIMATED},
        "refined": None if result.refined is None else {
            "estimates": result.refined.estimate, "ci95": {k: list(v) for k, v in result.refined.ci95.items()},
            "used": result.headline == "refined", "converged": result.refined.converged,
            "iterations": result.refined.iterations, "window_s": result.refined.window_s,
            "windows": result.refined.windows, "start_states": result.refined.start_states,
            "start_states_se": result.refined.start_states_se,
            "known_values_estimated": result.refined.freed,
            "rk4_substeps_per_sample": result.refined.substeps,
            "angle_error_rms_rad": result.refined.rms_rad,
            "integration_error": result.refined.integration_error},
        "excitation": {axis: {"phi_energy": result.axes[axis].phi_energy,
                              "verdict": _verdict([result.offline_intervals[k] for k in AXES[axis]])}
                       for axis in AXES},
        "input": {
            "path": log.source,
            "sha256": log.sha256,
            "samples": len(log),
            "sample_time_s": log.sample_time_s,
            "duration_s": log.duration_s,
            **{k: v for k, v in log.meta.items() if isinstance(v, (str, int, float, dict))},
        },
        "settings": {
            **asdict(s),
            "filter_F": f"{'a^2' if s.gain_convention == 'unit' else 'a'}/(s+a)^2, a = {s.filter_a_rad_s:g} rad/s",
            "filter_H": f"{'b^2' if s.gain_convention == 'unit' else 'b'}/(s+b)^2, b = {s.filter_b_rad_s:g} rad/s",
            "gain": ("fixed gamma " + json.dumps(s.gamma)) if s.gamma else
                    f"normalized, 1 % settling in about {s.settle_time_s} s",
            "thrust_law_meaning": THRUST_LAWS[s.thrust_law],
            "filter_design": result.design.reason if result.design else "bandwidths given by the user",
            "noise_estimate_rad": result.design.noise_rad if result.design else None,
            "discretization": "ZOH for motor lags and M_R (held voltages); bilinear for F and H; "
                              "central difference for beta' (one sample latency)",
        },
        "parameters": {
            name: {"value": value, "unit": UNITS[name], "meaning": BY_NAME[name].meaning,
                   "source": "override" if name in s.overrides else "table"}
            for name, value in result.parameters.items() if BY_NAME[name].role == "known"
        },
        "table_defaults_changed": sorted(k for k in s.overrides if s.overrides[k] != table[k]),
        "versions": versions(),
    }
    if truth:
        doc["truth"] = {"source": truth_source, "values": truth,
                        "error_percent": {k: (100.0 * (result.estimates[k] / truth[k] - 1.0) if result.estimates[k] is not None
                                  else None) for k in ESTIMATED},
        "inside_ci95": {k: (bool(result.intervals[k].low <= truth[k] <= result.intervals[k].high)
                            if math.isfinite(result.intervals[k].low) else None) for k in ESTIMATED}}
    return doc


def _pair(ci) -> list[float | None]:
    return [None if math.isnan(ci.low) else ci.low, None if math.isnan(ci.high) else ci.high]


def _verdict(intervals) -> str:
    if not all(ci.identifiable for ci in intervals):
        return "insufficient: " + "; ".join(ci.reason for ci in intervals if not ci.identifiable)
    worst = max((ci.rel_half_width for ci in intervals if math.isfinite(ci.low)), default=math.nan)
    if math.isnan(worst):
        return "unknown (log too short for intervals)"
    return ("good" if worst < 0.01 else "adequate") + f": widest 95 % interval ±{100 * worst:.2g} %"


def interval_text(low: float, high: float, estimate: float | None = None) -> str:
    """"[low, high]" with as many significant digits (6 to 12) as it takes for the ends to differ from each other
    and from ``estimate``: an interval of +/- 2e-7 about 0.1 printed as "[0.1, 0.1]" claims no width at all."""
    values = [low, high] + ([] if estimate is None else [estimate])
    for d in range(6, 13):
        text = [f"{v:.{d}g}" for v in values]
        if len(set(text)) == len(text):
            break
    return f"[{text[0]}, {text[1]}]"


def units_text(inp: dict) -> str | None:
    """One line on the units the log was read in (Log.meta["units"]), or None when the input does not say."""
    u = inp.get("units")
    return f"Units: angles {u['angles']}; inputs {u['inputs']}." if u else None


def voltage_timing_text(inp: dict) -> str | None:
    """One line on how an MCAP log's voltages were placed in time, or None for logs without a voltage topic."""
    vt = inp.get("voltage_timing")
    if not vt:
        return None
    parts = [f"{topic} {o['median_ms']:.3g} ms ({o['median_samples']:.2f} samples) after the angle stamp, "
             f"5-95 % {o['p05_ms']:.3g}-{o['p95_ms']:.3g} ms" for topic, o in vt["offset_after_angle"].items()]
    rule = ("each voltage acts from its own message time" if vt["convention"] == "stamp" else
            "each voltage acts from the next angle sample on (--voltage-time next-sample)")
    clocks = ", ".join(f"{k}: {v}" for k, v in vt["clocks"].items())
    return f"voltages: {'; '.join(parts) or 'at the angle stamps'}; {rule}; clocks {clocks}"


def strict(value):
    """``value`` with every NaN or infinite float replaced by None: JSON has no such numbers (Python writes
    ``NaN``, which jq, JavaScript's JSON.parse and most other readers refuse).  null means "not a number here",
    e.g. a prediction fit when the model had no physical J or B to predict with."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict(v) for v in value]
    return value


def to_json(doc: dict) -> str:
    """The document as strict JSON (RFC 8259): NaN and infinities are written as null."""
    return json.dumps(strict(doc), indent=2, sort_keys=False, allow_nan=False) + "\n"
