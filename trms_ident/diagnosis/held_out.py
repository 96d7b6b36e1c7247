"""Held-out simulation fits: does the model with diagnose's findings predict samples it was not fitted on
better than the model without them?

The prediction fits the findings are chosen on restart from the measured angles every 2 s, and the
output-error check that gives the verdict fits every parameter on the samples it scores.  A finding that only
fits this recording's noise raises both.  Here each model (the seed model, and the model with the findings:
effects at their values, or the known values diagnose named at theirs) is fitted by output error on one half
of the fitted samples (J/B, its torque effects' parameters and the start states free; oe.Fitter.held_out) and
simulated on the other half with those values held, only the start states fitted there (the motors' and each
40 s window's angles and rates), then the other way round.  The fit is NRMSE over both held-out halves:
100 (1 - error RMS / the angle's standard deviation) [%].

On a log the seed model already fits, before and after are one model.  A model holding a torque effect the
output-error fit cannot carry has no held-out fit (None), and the report says so.
"""
from __future__ import annotations

import numpy as np

from ..log import Log
from ..model import effects
from . import oe
from .model import Model, given_model
from .trials import axes_of, jb_start

#: the held-out fits use at most this many seconds of the output-error fit's samples (two halves): on an hour
#: at 1 kHz the seed model's fit of a half that misses physics runs to its iteration limit, and 2 x 60 s of a
#: multisine are as telling as 2 x 125 s
MAX_SPAN_S = 120.0


def final_model(findings, p: dict | None = None) -> tuple[Model, dict, dict]:
    """(the model, its effects' values, known values changed) the findings make on top of the bench ``p``'s given
    input modifications (model.given_model): effects by key, known values (effect "known_value") as parameter
    changes."""
    model, changes = given_model(p), {}
    values = dict(model.mods)
    for f in findings:
        v = float(f.parameter["value"])
        if f.effect == "known_value":
            changes[f.parameter["name"]] = v
            continue
        key = f"{f.effect}:{f.axis}"
        model = model.with_mod(key, v) if effects.by_key(key).kind == "grid" else model.with_linear(key)
        values[key] = v
    return model, values, changes


def held_out_fits(d, log: Log, p: dict, law: str) -> dict | None:
    """{"before": {axis: fit %}, "after": {axis: fit %} (None when no finding changed the model), "span_s",
    "samples", "prediction": {"t_s", "before", "after"} (held-out simulated angles, (n, 2) each), "folds",
    "method"}; None when the seed model's fit fails.  The findings' model's is None when its fit fails."""
    model, values, changes = final_model(d.findings, p)
    most = int(MAX_SPAN_S / log.sample_time_s)
    fitter = oe.Fitter(log, p, law, most, d.seed_check)
    n = fitter.n
    before = fitter.held_out(given_model(p), {}, jb_start(d.nominal, p))
    if before is None:
        return None
    after = None
    if d.findings:
        f_after = fitter if not changes else oe.Fitter(log, {**p, **changes}, law, most, d.seed_check)
        after = f_after.held_out(model, values, jb_start(d.augmented, p))
    t = log.t_s[:n]
    return {"before": before["fit_percent"], "after": after["fit_percent"] if after else None,
            "rms_rad": {"before": before["rms_rad"], "after": after["rms_rad"] if after else None},
            "span_s": float(t[-1] - t[0]), "samples": n,
            "folds": {"before": before["folds"], "after": after["folds"] if after else None},
            "converged": {"before": before["converged"], "after": after["converged"] if after else None},
            "prediction": {"t_s": t, "before": before["prediction"],
                           "after": after["prediction"] if after else None},
            "method": "output error fitted on one half of the samples, simulated on the other with J/B and the "
                      "findings' values held (start states fitted), both ways round; NRMSE over both halves"}


def correction_fits(d, log: Log, p: dict, law: str, h: dict | None) -> list:
    """The sparse corrections (d.corrections) put into the findings' model together as the bench file carries them
    (their terms, model/terms.py, as torque effects with their c free) and fitted by output error: per correction
    None (a term cannot be carried, or the fit fails) or {"values": key -> {"estimate", "ci95"} (the whole fitted
    span, J/B and the start states free beside them), "held_out": {"before", "after"} [%] (its axis' held-out
    simulation fit, as held_out_fits measures it, without and with the corrections), "over_noise": angle -> error
    RMS over its floor, "estimates": J/B}.  The equation error chose the terms; this is the fit that shows what they
    do to a simulation of samples they were not fitted on (issue #76)."""
    if not d.corrections or h is None:
        return [None] * len(d.corrections)
    model, values, changes = final_model(d.findings, p)
    fitter = oe.Fitter(log, {**p, **changes}, law, int(MAX_SPAN_S / log.sample_time_s), d.seed_check)
    start = jb_start(d.augmented, p)
    before = h["after"] if h.get("after") else h["before"]
    # every correction's terms in one model: a correction on one axis fitted while the other axis' misfit stays in
    # the simulation takes it up (measured: the pitch's gyroscopic term -0.099 for -0.05 beside a yaw reaction half
    # the table's, tests/test_sparse_correction.py)
    keys = [t.get("key") for c in d.corrections for t in c.terms]
    if (not all(keys) or not all(oe.carries(k) for k in keys) or set(keys) & set(model.keys)
            or len(set(keys)) < len(keys)):
        return [None] * len(d.corrections)
    m, v = model, dict(values)
    for c in d.corrections:
        for t in c.terms:
            m, v[t["key"]] = m.with_linear(t["key"]), float(t["coefficient"])
    ho = fitter.held_out(m, v, start)
    r = fitter.base(m, v, start)
    if ho is None or r is None or not all(k in r.freed for k in keys):
        return [None] * len(d.corrections)
    return [{"values": {t["key"]: {"estimate": float(r.freed[t["key"]]["estimate"]),
                                   "ci95": [float(x) for x in r.freed[t["key"]]["ci95"]]} for t in c.terms},
             "held_out": {"before": float(before[c.axis]), "after": float(ho["fit_percent"][c.axis])},
             "over_noise": {a: float(r.rms_rad[a] / fitter.noise_floor[a]) for a in fitter.noise},
             "estimates": {k: float(x) for k, x in r.estimate.items()}} for c in d.corrections]


def correction_sentence(c, fit: dict | None) -> str:
    """The output-error fit of a correction in words (correction_fits); "" without one."""
    if fit is None:
        return ""
    ho = fit["held_out"]
    rose = ho["after"] > ho["before"]
    return (f"fitted by output error with the findings (J/B and the start states free): held-out {c.axis} fit "
            f"{ho['before']:.1f} % -> {ho['after']:.1f} %" + ("" if rose else " (no better on samples it was not "
                                                                          "fitted on: a description, not a model)"))


def sentence(h: dict | None, findings: bool) -> str:
    """The held-out fits in words."""
    if h is None:
        return ""
    if not findings or h["after"] is None:
        return ("Held-out simulation fit (fitted on one half, simulated on the other): "
                + ", ".join(f"{a} {v:.1f} %" for a, v in h["before"].items())
                + ("" if not findings else " for the seed model; the findings' model could not be fitted by output "
                   "error on the halves") + ".")
    loose = h.get("converged", {}).get("after") is False  # the seed model's often does not: it misses physics
    return ("Held-out simulation fit (fitted on one half, simulated on the other), before -> after the findings: "
            + ", ".join(f"{a} {h['before'][a]:.1f} % -> {h['after'][a]:.1f} %" for a in h["before"])
            + (" (the findings' model's fit on a half did not converge: the after figure is no measure of it, and "
               "the findings are not judged by it)" if loose else "") + ".")


#: a held-out fit lower than the seed model's by more than this [percentage points] is said (caution)
LOWERED_BY_PERCENT = 0.1


def lowered(h: dict | None, axes=("pitch", "yaw"), margin_percent: float = LOWERED_BY_PERCENT,
            converged_only: bool = False) -> list[str]:
    """The axes whose held-out fit the findings lower (by more than ``margin_percent``); with ``converged_only``
    none when the findings' model's fit on a half did not converge (the gate: its held-out simulation is then no
    measure of the model to refuse it by; measured, a true 0.1 s acquisition lag whose fit on the second half of a
    mid-run steps log ran off to J1 2.6x).  The caution says it either way."""
    if not h or h["after"] is None or (converged_only and h.get("converged", {}).get("after") is False):
        return []
    return [a for a in axes if np.isfinite(h["before"][a]) and not h["after"][a] >= h["before"][a] - margin_percent]


def lowering(findings, h: dict | None) -> list[dict]:
    """The effect findings that act on an axis whose held-out fit the findings lower (lowered): each as a refusal
    {"key", "effect", "axis", "parameter", "reason"}.  Known values are left to the caution: they are eq. (1)'s
    own terms, weighed by their own rule (weigh.py)."""
    worse = set(lowered(h, converged_only=True))
    if not worse:
        return []
    told = ", ".join(f"{a} {h['before'][a]:.1f} % -> {h['after'][a]:.1f} %" for a in sorted(worse))
    out = []
    for f in findings:
        if f.effect == "known_value" or not set(axes_of(effects.by_key(f"{f.effect}:{f.axis}"))) & worse:
            continue
        out.append({"key": f"{f.effect}:{f.axis}", "effect": f.effect, "axis": f.axis,
                    "parameter": float(f.parameter["value"]),
                    "reason": ("held-out simulation: fitted on one half of the log and simulated on the other, the "
                               f"model with the findings did worse than the seed model ({told}); searched again "
                               "without it")})
    return out


def gate_sentence(refused: list[dict]) -> str:
    """The verdict's words for the findings the held-out gate refused; empty when none."""
    if not refused:
        return ""
    names = ", ".join(f"{g['effect'].replace('_', ' ')} on {g['axis']} ({g['parameter']:.3g})" for g in refused)
    return (f" Refused: {names}, which fitted this recording but simulated it worse on the half they were not "
            "fitted on (the findings may describe the recording rather than the bench).")


def caution(h: dict | None) -> str:
    """The verdict's closing words when the findings simulate an axis worse on the samples they were not fitted
    on than the seed model does; empty otherwise."""
    worse = lowered(h)
    if not worse:
        return ""
    told = ", ".join(f"{a} {h['before'][a]:.1f} % -> {h['after'][a]:.1f} %" for a in worse)
    return (f" Caution: fitted on one half of the log and simulated on the other, the model with the findings does "
            f"worse than the seed model ({told}): the findings may describe this recording rather than the bench.")
