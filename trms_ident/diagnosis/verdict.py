"""A diagnosis' verdict (result.VERDICTS): the model with its findings simulated by output error and judged
against each angle's floor as estimate judges the seed model (or, where that fit cannot carry the findings, its
2 s predictions against the noise level); J/B refitted far from the bench turn "explained" into leads to check."""
from __future__ import annotations

import math

import numpy as np

from ..log import Log
from ..model import effects
from ..numerics.adequacy import AXIS_OF, RMS_OVER_NOISE
from ..params import PLAUSIBLE_FACTOR, not_credible
from .model import AXIS_ANGLE
from .result import VERDICTS

#: the findings' prediction errors within this factor of the noise level count as explained
EXPLAINED_RMS_OVER_NOISE = 1.5
#: and, when the output-error fit can carry the findings, the angles it simulates within this factor (estimate's
#: adequacy threshold): the 2 s predictions restart from the measured angles, so a yaw that drifts between
#: restarts can pass them (measured: a 0.4 V yaw dead zone fitted at 0.237 V, predictions within 1.5x, the
#: output-error simulation left the yaw 5.7x its noise level)
EXPLAINED_OE_OVER_NOISE = RMS_OVER_NOISE


def over_noise(log: Log, seed: dict, fits: dict) -> dict:
    """Per axis: the prediction error's RMS over the seed check's noise floor (inf when the axis has no
    prediction: its J or B not physical, the fit not a number)."""
    out = {}
    for axis in ("pitch", "yaw"):
        y = getattr(log, AXIS_ANGLE[axis])
        floor = seed.get("axes", {}).get(axis, {}).get("noise_floor_rad", 0.0)
        rms = (100.0 - fits.get(axis, -math.inf)) / 100.0 * float(np.std(y))
        out[axis] = rms / floor if floor > 0 and math.isfinite(rms) else math.inf
    return out


def _floor_words(used: dict, angle: str) -> str:
    """What an angle's floor is, in words (adequacy.judging_floors' kinds)."""
    if used.get(angle) == "black_box":
        return "the error a flexible black-box model leaves on held-out data (its angles carry no measurable noise)"
    return "its noise level"


def verdict_of(log: Log, seed: dict, findings: list, fit_after: dict, seg: dict, oe_check: dict | None,
               used: dict | None = None) -> tuple[str, str]:
    """The verdict and its sentence; ``oe_check``: angle -> the findings' model's output-error simulation error
    over its floor (oe.Fitter.check), None when that fit cannot carry the findings; ``used``: angle -> which
    floor (adequacy.judging_floors)."""
    if seed.get("adequate") and not findings:
        return "consistent", VERDICTS["consistent"] + "."
    if not findings and _as_well_as_black_box(seed):  # estimate: not decided; no finding changes that
        return "consistent", (
            "the seed model simulates this log as well as a flexible black-box model does on held-out data, and "
            "its angles carry no measurable noise: no misfit this log can show, and no finding. " + seed.get(
                "sentence", ""))
    if findings and oe_check is not None:
        # the findings' model simulated by output error, judged as estimate judges the seed model: the one test
        # both commands share (the 2 s predictions restart from measured angles and use the equation error's
        # J/B: they passed a yaw that drifts between restarts, and failed a 0.29 s second-order yaw motor at 10x
        # on a 500 Hz log its output-error simulation fits at 0.99x)
        ratio = {a: (v if math.isfinite(v) else math.inf) for a, v in oe_check.items()}  # NaN never passes
        worst = max(ratio, key=ratio.get)
        used = used or {}
        if used.get(worst) == "none":  # neither a noise floor nor a black box measures this angle's floor
            return "partly_explained", (
                VERDICTS["partly_explained"] + f" as far as this log can tell: the {AXIS_OF[worst]} angle carries "
                "no measurable noise and a flexible black-box model does not simulate it either, so no floor says "
                "how well it can be fitted.")
        if not ratio[worst] <= EXPLAINED_OE_OVER_NOISE:
            return "partly_explained", (
                VERDICTS["partly_explained"] + f" (simulated by output error with the findings in, the "
                f"{AXIS_OF[worst]} angle's error is still {oe_check[worst]:.3g}x {_floor_words(used, worst)}; "
                f"{EXPLAINED_OE_OVER_NOISE:g}x is allowed).")
        boxed = [AXIS_OF[a] for a in ratio if used.get(a) == "black_box"]
        if not boxed:
            floors_told = "noise levels)."
        else:
            many = len(boxed) > 1
            floors_told = (f"floors; the {' and '.join(boxed)} {'angles carry' if many else 'angle carries'} no "
                           f"measurable noise, so {'their' if many else 'its'} floor is the error a flexible "
                           "black-box model leaves on held-out data: the finest misfit this log can show).")
        return "explained", (VERDICTS["explained"] + " (simulated by output error with the findings in, both angles "
                             f"within {EXPLAINED_OE_OVER_NOISE:g}x their " + floors_told)
    if findings:
        ratios = over_noise(log, seed, fit_after)
        if any(r > EXPLAINED_RMS_OVER_NOISE for r in ratios.values()):
            worst = max(ratios, key=ratios.get)
            still = (f"is still {ratios[worst]:.3g}x its noise level" if math.isfinite(ratios[worst]) else
                     "cannot be told: the findings' model has no prediction of it")
            return "partly_explained", VERDICTS["partly_explained"] + f" (the {worst} prediction error {still})."
        return "explained", (VERDICTS["explained"] + " in its 2 s predictions (the output-error simulation "
                             "cannot carry these findings, so it did not check them).")
    where = []
    for axis, s in seg.items():
        for g in s[:2] if isinstance(s, list) else []:
            if isinstance(g, dict) and "start_s" in g:
                where.append(f"{axis} {g['start_s']:.4g}-{g.get('end_s', g['start_s']):.4g} s"
                             + (f" ({', '.join(g['context'])})" if g.get("context") else ""))
    return "unexplained", (VERDICTS["unexplained"] + ". " + seed.get("sentence", "") +
                           (" The residual is largest at " + "; ".join(where) + "." if where else ""))


def _as_well_as_black_box(seed: dict) -> bool:
    """Does the seed model's check leave every axis fitting or, where the log measures no noise floor, within
    the black-box floor (adequate None for that reason alone: estimate's "not decided")?"""
    axes = (seed.get("axes") or {}).values()
    return bool(axes) and seed.get("adequate") is None and all(
        ax.get("adequate") is True or (ax.get("adequate") is None and ax.get("floor_used") == "black_box")
        for ax in axes)


def credible(verdict: str, sentence: str, augmented: dict) -> tuple[str, str]:
    """The verdict and sentence, told when J/B refitted with the findings are not credible (params.implausible):
    the findings' model then sits far from the bench, so "explained" becomes "partly_explained" and the sentence
    says the findings' values are leads to check, not measurements."""
    bad = not_credible(augmented)
    if not bad:
        return verdict, sentence
    told = ", ".join(f"{k} = {augmented[k]:.3g}" for k in bad)
    return ("partly_explained" if verdict == "explained" else verdict,
            sentence + f" The J/B refitted with the findings are not credible ({told}: not positive, or more than "
                       f"{PLAUSIBLE_FACTOR:g}x from Table 1): the findings' model is far from this bench, so read the "
                       "findings and their values as leads to check, not measurements.")


#: a refusal's reason begins so when the value lies outside its parameter's plausible range (stand_in)
STAND_IN = "stands in for something the model lacks"


def stand_in(effect: str, axis: str, value: float) -> dict | None:
    """A refusal ({"key", "effect", "axis", "parameter", "reason"}) when ``value`` of the library's ``effect`` on
    ``axis`` lies outside its plausible range (model.effects: a 49 deg encoder offset describes no bench, it
    absorbs a misfit the model cannot otherwise fit); None when it is plausible or not the library's."""
    c = effects.by_key(f"{effect}:{axis}")
    if c is None or c.plausible(value):
        return None
    lo, hi = c.bounds
    shown = f"{value:.4g} {c.unit}" + (f" ({math.degrees(value):.3g} deg)" if c.unit == "rad" else "")
    if not math.isfinite(lo):
        span = f"below {hi:.4g} {c.unit}"
    elif not math.isfinite(hi):
        span = f"above {lo:.4g} {c.unit}"
    else:
        span = f"{lo:.4g} to {hi:.4g} {c.unit}"
    return {"key": c.key, "effect": effect, "axis": axis, "parameter": float(value),
            "reason": (f"{STAND_IN}: {c.parameter} = {shown} is outside a bench's plausible range ({span}), so "
                       f"the value describes no bench; the {'motors' if axis == 'both' else axis} model lacks "
                       "something it stands in for")}


def stand_ins(findings) -> list[dict]:
    """The effect findings whose values lie outside their plausible ranges, each as stand_in's refusal."""
    out = []
    for f in findings:
        if f.effect != "known_value":
            r = stand_in(f.effect, f.axis, float(f.parameter["value"]))
            if r is not None:
                out.append(r)
    return out


def stand_in_sentence(refused: list[dict]) -> str:
    """The verdict's words for the refusals that stood in for missing physics (STAND_IN); empty when none."""
    told = [r for r in refused if str(r.get("reason", "")).startswith(STAND_IN)]
    if not told:
        return ""
    names = "; ".join(f"{r['effect'].replace('_', ' ')} on {r['axis']} ({r['parameter']:.4g})" for r in told)
    return (f" Not findings: {names}: each would need a value outside a bench's plausible range, so it stands in "
            "for physics the model lacks; that part of the misfit is unexplained.")


def value_alone_sentence(name: str, value: float, table: float) -> str:
    """Why an effect is refused beside a known value that explains the log alone (weigh.py, rule 2; the effect
    search's single round, search._may_explain_alone): its first words, the reason's rest said by the caller."""
    return (f"a known value explains the log alone with one parameter ({name} = {value:.4g} instead of {table:.4g} "
            "brings both angles to their noise floors)")
