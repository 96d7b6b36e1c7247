"""The rule that weighs a known value off its table against the effect library: the simplest explanation that
reaches the noise floor wins, and two that reach it with as few parameters are look-alikes, never one picked
silently.

The hypotheses come from two searches over the same log:

- the known values (trms_ident/known_values.py): each value of eq. (1)'s table set free alone and refitted by
  output error.  identify's adequacy check runs that search (estimate's sentence names its result); diagnose
  reads the same result from its seed check, so the two commands name the same value on every log;
- the effect library (search.py): effects added one at a time, judged by held-out tests, output-error fits and
  the noise floor.

The rule, in order (each explanation counted by the parameters it adds to eq. (1); J/B and start states are
refitted with every one):

1. a known value that, set free alone, brings both simulated angles to RMS_OVER_NOISE of their noise floors
   explains the log with one parameter.  It is the finding; the known values that reach the floor as well are
   its look-alikes (the log cannot tell them apart);
2. the effect search's findings then stand only as look-alikes, and only when a single effect explains the log
   too (verdict "explained" with one finding; the search refuses in its round a finding whose output-error fit
   alone leaves the angles far above their floors, search._may_explain_alone): one parameter each, both at the
   noise floor, the one that leaves the angles nearer their floors first (an effect that is the known value under
   another name, SAME, first: the motor_lag candidate's time constant is T11 or T21 itself).  Otherwise they need
   more parameters, or leave more than the noise, for what the one value explains: they are refused, each with
   that reason;
3. with no known value reaching the floor, the effect search's verdict stands, and its sentence says which
   known values were tried alone and how far each left the angles from their floors; but where it explains the
   log with two or more findings, one of them an effect, the known values refitted together (the joint search of
   5) that reach the floor with as many parameters win: a known value off its table is no new physics, and the
   effect search's findings are their look-alikes (_values_beside_effects); unless the findings leave the angles
   nearer their floors, as between one effect and one value: then they stay, the values their look-alikes
   (_effects_beside_values);
4. when neither a single known value nor the effect search reaches the floor, each of the search's findings is
   put into the model and the log estimated under it, its known-value search run with the effect in
   (compound.py): an effect that fits alone (one parameter), else an effect with a known value (two) that
   reaches the floor explains the log, the search's other findings refused as not needed.  Also when every known
   value refitted alone wandered off to an implausible number (known_values.far_from_table), which the other
   difference's misfit can cause; steps 5 and 6 start from those refits and are not taken then (7 is);
5. when that reaches no floor either, several known values are refitted
   together (known_values.joint, a forward search, each value a further parameter that must earn its place).
   A set that reaches the floor explains the log: one finding per value, the effect search's findings refused
   (they do not reach it).  A set that does not is reported in the sentence with the values the log
   determines;
6. when that does not either, the known values that came nearest the floor alone lead (compound.value_first),
   after the joint search's set of values (compound.joint_lead, freed together beside each effect):
   the effect search runs again with one of them at its refit, and its findings are estimated under with the
   value freed beside them; a pair that reaches the floor explains the log, the first search's findings
   refused.  Refits that wander off to implausible numbers are never reported (known_values.far_from_table
   says the bench is far from the values given);
7. when none of that reaches the floor, the effects the equation error ranked best in its first round that were
   not tried yet, passed or not (compound.ranked: a known value off its table leaves its misfit in every effect's
   test, so the other difference need not pass alone), and a shifted dead zone and a saturation on each motor
   whatever the equation error made of them (compound.freed_modifications: their value freed beside every known
   value's refit), are estimated under as in 4, each with the known values freed in turn; an effect with a known
   value that reaches the floor explains the log, the search's findings refused.  Last, so that every log an
   earlier step explains is explained as before.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .. import known_values
from ..log import Log
from ..numerics.adequacy import RMS_OVER_NOISE
from ..numerics.stats import block_length
from . import search
from .compound import SAME, later_tries_sentence, ranked_together, together, tried_sentence, value_first
from .fits import prediction_fits
from .model import AXIS_ANGLE, regression, settings_of
from .oe import motor_states
from .result import known_value_finding
from .select import block_ids, score
from .verdict import value_alone_sentence

#: the verdict sentence of a known value that explains the log
EXPLAINED_BY_VALUE = ("the model fits the log to its noise level once one known value takes the bench's own value "
                      "instead of the one it was given: a known value, not new physics")


def weigh(d, log: Log, p: dict, law: str, overrides: dict | None = None, exclude: tuple = ()):
    """The diagnosis after the rule (module docstring); ``d`` the effect search's (result.Diagnosis), ``p`` the
    values it was given (``overrides``: the ones that differ from Table 1, as diagnose was called).  Unchanged
    when the seed check ran no known-value search (the model fits, or the fit was not decided).  ``exclude``: the
    library keys the effect search left out (refused by the held-out gate, run.py), left out of its searches
    under a known value too."""
    kv = d.seed_check.get("known_values")
    if not kv:
        return d
    named = kv.get("named")
    if named is None and _new_physics(d) and known_values.far_from_table(kv["fits"], kv.get("precision")) is None:
        # the effect search explains the log with an effect among two or more findings: known values refitted
        # together with as few parameters are the simpler answer (no new physics), its findings their look-alikes
        j = _joint(log, law, overrides, p, kv, d.seed_check)
        if j is not None and j.explains and len(j.names) <= len(d.findings):
            if _closer(d.settings.get("output_error_check"), j.over_noise):
                return _effects_beside_values(d, j)  # the effects leave the angles nearer their floors: first
            return _values_beside_effects(d, log, p, law, j)
        return d
    if named is None:
        if d.verdict in ("partly_explained", "unexplained"):
            # an "unexplained" verdict already carries the seed check's sentence, which says what the single
            # refits found (known_values.sentence): said once
            said = any(words in d.verdict_sentence for words in known_values.SEARCH_SAID)
            far = known_values.far_from_table(kv["fits"], kv.get("precision"))

            def refit(pp, est, start, found):
                return _refitted(d, log, pp, law, est, start, found)

            # each finding estimated under, its known-value search run with it in: also when every value refitted
            # alone wandered off, which the other difference's misfit can cause (a yaw dead zone beside Mg 21 %
            # high: each refit alone ran off, Mg under the dead zone reaches the floor)
            both, tried = together(d, log, p, law, overrides, refit)
            if both is not None:
                return both
            d.settings = {**d.settings, "together": tried}
            tried_first = []
            if far is not None:  # every refit wandered off: nothing to refit jointly from or lead with (5, 6)
                d.verdict_sentence += ("" if said else far) + tried_sentence(tried)
            else:
                listed = ", ".join(f"{f['name']} {max(f['over_noise'].values()):.3g}x" for f in kv["fits"])
                if not said:
                    d.verdict_sentence += (" No known value explains the log alone (each refitted by output error, "
                                           "the most likely leave the angles above their noise floors: "
                                           f"{listed or 'none could be fitted'}).")
                d.verdict_sentence += tried_sentence(tried)
                j = _joint(log, law, overrides, p, kv, d.seed_check)
                if j is not None:
                    d.known_values_joint = j.to_json()
                    if j.explains:
                        return _explained_by_values(d, log, p, law, j)
                    base = max(kv.get("shooting_over_noise", {}).values(), default=None)
                    d.verdict_sentence += known_values.joint_sentence(j, base)
                first, tried_first = value_first(
                    d, log, p, law, overrides, kv, refit,
                    lambda under: search.effect_search(log, under, law, d.settings["a_rad_s"],
                                                       lambda stage, done: None, exclude), joint=j)
                if first is not None:
                    return first
            last, tried_last = ranked_together(d, log, p, law, overrides, refit, {t["effect"] for t in tried})
            record = tried + tried_first + tried_last
            if last is not None:
                last.settings["together"] = record
                return last
            if tried_first or tried_last:
                d.settings["together"] = record
                d.verdict_sentence += later_tries_sentence(tried_first + tried_last)
        return d
    fit = next(f for f in kv["fits"] if f["name"] == named)
    name, value, table = fit["name"], fit["value"], fit["table"]
    pp = {**p, name: value}
    est = dict(fit["estimates"])
    start = motor_states(fit["start_states"]) or None
    fits_after, overlay, residual = _refitted(d, log, pp, law, est, start)
    axis = known_values.AXIS[name]
    effect_alike = (d.verdict == "explained" and len(d.findings) == 1)
    alternatives = list(kv.get("look_alikes", []))
    if effect_alike:
        alternatives.append(f"{d.findings[0].effect}:{d.findings[0].axis}")
    lo, hi = fit["ci95"]
    ratio = fit["over_noise"]
    base = d.seed_check.get("axes", {})
    before = _seed_ratios(base)
    evidence = (f"set free alone and refitted by output error with J1, B1, J2, B2 and the start states "
                f"(multiple shooting in {known_values.SHOOTING_WINDOW_S:g} s windows, then the standard windows), "
                f"it brings the angles to {ratio['alpha']:.3g}x and {ratio['beta']:.3g}x their noise floors "
                f"(seed model: {before}); 95 % interval {lo:.6g} to {hi:.6g} {fit['unit']}; score-test share "
                f"{fit['score']:.2g} of the misfit")
    if alternatives:
        evidence += "; cannot be told apart with this log from " + ", ".join(alternatives)
    finding = known_value_finding(name, value, table, fit["unit"], (lo, hi), d.fit_before,
                                  fits_after.get(axis, math.nan), evidence, _drop(base, ratio), alternatives,
                                  {k: 100.0 * (d.nominal[k] / est[k] - 1.0) for k in est})
    refused = list(d.refused)
    if not effect_alike:
        why = value_alone_sentence(name, value, table) + "; this effect is not needed"
        refused += [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter["value"], "reason": why}
                    for f in d.findings]
    step = _step(log, name, axis, d, overlay, residual, fits_after)
    sentence = EXPLAINED_BY_VALUE + f": the bench's {name} is {value:.4g}, not {table:.4g}"
    if alternatives:
        sentence += (f"; {', '.join(alternatives)} would explain it as well with one parameter: this log cannot "
                     "tell them apart")
    sentence += (f" (both angles within {RMS_OVER_NOISE:g}x their noise floors). Check {name} on the bench, or "
                 f"estimate it with `trms-ident estimate --free {name}`.")
    same = effect_alike and SAME.get(f"{d.findings[0].effect}:{d.findings[0].axis}") == name
    effect_first = effect_alike and (same or _closer(d.settings.get("output_error_check"), ratio))
    if effect_alike:  # the single effect and the value flag each other, whichever is named first (measured,
        # any_bench seed 33274 bench 22: a1 0.74x and a pitch thrust asymmetry both at the floor; with the value
        # first the asymmetry had been listed as a finding of its own, read as a second difference)
        effect = d.findings[0]
        effect.alternatives = list(dict.fromkeys(effect.alternatives + [f"known_value:{name}"]))
        effect.evidence += (f"; the same physics as the known value {name} = {value:.4g} instead of {table:.4g} (its "
                            "refit alone reaches the noise floor too)" if same else
                            f"; cannot be told apart with this log from {name} = {value:.4g} instead of {table:.4g} "
                            + ("(a known value, refitted alone, also reaches the noise floor)" if effect_first else
                               "(a known value, refitted alone, reaches the noise floor too and leaves the angles "
                               "nearer it: named first)"))
    if effect_first:
        # the single effect leaves the angles nearer their floors, or is the library's name for this very known
        # value: it stays first, the known value its look-alike
        d.verdict_sentence += (f" That is the known value {name}: refitted alone it comes out {value:.4g} instead of "
                               f"{table:.4g}." if same else
                               f" A known value would explain the log as well: with {name} = {value:.4g} instead of "
                               f"{table:.4g} the model fits to the noise level too; this log cannot tell them apart.")
        d.findings.append(finding)
        d.steps.append(step)
        return d
    findings = [finding] + ([d.findings[0]] if effect_alike else [])
    return replace(d, mismatch=True, findings=findings, augmented=est, fit_after=fits_after, overlay=overlay,
                   residual=residual, verdict="explained", verdict_sentence=sentence, refused=refused,
                   corrections=[], steps=[step] + (d.steps[:1] if effect_alike else []),
                   settings=_value_settings(d, ratio, start))


def _refitted(d, log: Log, pp: dict, law: str, est: dict, start: dict | None, findings=()):
    """The seed model with known values ``pp``, J/B ``est`` and ``findings``' effects: its 2 s prediction fits, and
    ``d``'s overlay and residual with its predictions and equation error as the "after" ones."""
    from .held_out import final_model

    model, values, _ = final_model([f for f in findings if f.effect != "known_value"], pp)
    with np.errstate(all="ignore"):
        fits_after, preds = prediction_fits(log, pp, law, model, values, est, start=start)
        a = d.settings["a_rad_s"]
        block = block_length(len(log), log.sample_time_s, 1.0 / a)
        reg = regression(log, pp, law, a, model, {("start_states",): start})
        sc = score(reg, block_ids(len(log), block), ("pitch", "yaw"))
    overlay = {ax: (ov[0], ov[1], ov[2], preds[ax]) for ax, ov in d.overlay.items()}
    residual = {ax: (r[0], r[1], reg.g[ax] - reg.x[ax] @ sc.theta[ax]) for ax, r in d.residual.items()}
    return fits_after, overlay, residual


def _seed_ratios(base: dict) -> str:
    """The seed check's angle errors over their floors, as text ("alpha 7.48x, beta 457x")."""
    return ", ".join(f"{ang} {v['rms_over_noise']:.3g}x" for ang, v in base.items() if "rms_over_noise" in v)


def _value_settings(d, ratio: dict, start: dict | None) -> dict:
    """``d``'s settings when known values explain the log: their refit's check, start states and J/B."""
    return {**d.settings, "output_error_check": {"rms_over_noise": dict(ratio), "threshold": RMS_OVER_NOISE},
            "start_states_after": start, "estimates_augmented_from": "known_value",
            "rule": "simplest explanation reaching the noise floor (diagnosis/weigh.py)"}


def _joint(log: Log, law: str, overrides: dict | None, p: dict, kv: dict, check: dict | None = None):
    """known_values.joint on the fit estimate's search used (identify.known_value_fit); None when it finds no
    set of two or more values that earns its place, or cannot be fitted."""
    from ..identify import known_value_fit

    fit, noise, _ = known_value_fit(log, settings_of(overrides, law), check)
    try:
        return known_values.joint(fit, p, noise, kv.get("fits", []))
    except (np.linalg.LinAlgError, FloatingPointError, ValueError, ZeroDivisionError):
        return None


def _explained_by_values(d, log: Log, p: dict, law: str, j):
    """The diagnosis when the joint search's known values, refitted together, bring both angles to their noise
    floors and no single refit did, nor the effect search: each value a finding, the effect search's findings
    refused.  One value alone where the backward step dropped the others (known_values._backward)."""
    pp = {**p, **j.values}
    est = dict(j.estimates)
    start = motor_states(j.start_states) or None
    fits_after, overlay, residual = _refitted(d, log, pp, law, est, start)
    base = d.seed_check.get("axes", {})
    before = _seed_ratios(base)
    listed = ", ".join(f"{k} = {j.values[k]:.4g} instead of {j.table[k]:.4g}" for k in j.names)
    one = len(j.names) == 1  # the backward step left one value: said in the singular
    count, verb_s, noun_s, them = (("one known value", "s", "", "it") if one else
                                   (f"{len(j.names)} known values", "", "s", "them"))
    findings = []
    for name in j.names:
        axis = known_values.AXIS[name]
        lo, hi = j.ci95[name]
        others = [k for k in j.names if k != name]
        freed = (f"freed together with {', '.join(others)}" if others else
                 "freed alone (the joint search's backward step held the other values it had freed at their given "
                 "values: not needed)")
        evidence = (f"{freed} and refitted by output error with J1, B1, J2, B2 and "
                    f"the start states (multiple shooting in {known_values.SHOOTING_WINDOW_S:g} s windows, then the "
                    f"standard windows), {count} bring{verb_s} the angles to {j.over_noise['alpha']:.3g}x "
                    f"and {j.over_noise['beta']:.3g}x their noise floors (seed model: {before})"
                    f"{'; no single known value does' if others else ''}; 95 % interval {lo:.6g} to {hi:.6g} "
                    f"{j.units[name]}" +
                    ("" if name in j.determined else
                     f" (wider than {100 * known_values.DETERMINED_REL:g} % of the value: this log does not "
                     "determine it well)"))
        alike = j.look_alikes.get(name, [])
        if alike:
            evidence += (f"; {', '.join(alike)}, freed in its place, explain{'s' if len(alike) == 1 else ''} the "
                         "log too: this log cannot tell them apart")
        findings.append(known_value_finding(name, j.values[name], j.table[name], j.units[name], (lo, hi),
                                            d.fit_before, fits_after.get(axis, math.nan), evidence,
                                            _drop(base, j.over_noise), alike,
                                            {k: 100.0 * (d.nominal[k] / est[k] - 1.0) for k in est}))
    why = (f"{count} refitted {'' if one else 'together '}explain{verb_s} the log ({listed}); the effect search's "
           "findings do not bring the angles to their noise floors")
    refused = list(d.refused) + [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter["value"],
                                  "reason": why} for f in d.findings]
    step = _step(log, ", ".join(j.names), "both", d, overlay, residual, fits_after)
    how = (f"refitted with J/B, both angles within {RMS_OVER_NOISE:g}x their noise floors; found by the joint "
           "search over several known values, whose backward step held the others it had freed at their given "
           "values: not needed)" if one else
           f"refitted together, both angles within {RMS_OVER_NOISE:g}x their noise floors; no single value and no "
           "effect of the library does)")
    sentence = (f"the model fits the log to its noise level once {count} take{verb_s} the bench's own value{noun_s} "
                f"instead of the one{noun_s} it was given: {listed} ({how}. Check {them} on the bench, or estimate "
                f"{them} with `trms-ident estimate " + " ".join(f"--free {k}" for k in j.names) + "`.")
    told = "; ".join(f"{k} from {' or '.join(v)}" for k, v in j.look_alikes.items() if k in j.names and v)
    if told:
        sentence += f" This log cannot tell {told}: each, freed in its place, brings the angles to their floors too."
    return replace(d, mismatch=True, findings=findings, augmented=est, fit_after=fits_after, overlay=overlay,
                   residual=residual, verdict="explained", verdict_sentence=sentence, refused=refused,
                   corrections=[], steps=[step], settings=_value_settings(d, j.over_noise, start))


def _value_name(f) -> str | None:
    """The known value a finding is: its own name, or the one an effect is under another name (SAME); None for an
    effect that is new physics."""
    return f.parameter.get("name") if f.effect == "known_value" else SAME.get(f"{f.effect}:{f.axis}")


def _new_physics(d) -> bool:
    """Does the effect search explain the log with two or more findings, one of them an effect (not a known value,
    nor the library's name for one, SAME)?  Then known values refitted together may explain it with as few
    parameters (the module docstring's step 3)."""
    return d.verdict == "explained" and len(d.findings) >= 2 and any(_value_name(f) is None for f in d.findings)


def _values_beside_effects(d, log: Log, p: dict, law: str, j):
    """The diagnosis when the effect search explained the log with an effect among its findings and known values
    refitted together (``j``) explain it with no more parameters: a known value off its table is no new physics,
    so the values are the findings and the effect search's findings that are not one of them (SAME) their
    look-alikes, flagged on the values of the same axis (this log cannot tell them apart).  Measured (any_bench.py
    seed 57579 bench 26): T21 16 % high beside Kg 15 % low explained by T21 and a pitch thrust asymmetry of -3.8 %
    (or a pitch torque in beta'^2), which the bench does not have."""
    out = _explained_by_values(d, log, p, law, j)
    out.known_values_joint = j.to_json()
    # (the look-alike as the findings' alternatives name it, its axis, the finding)
    alike = [(f.parameter.get("name") if f.effect == "known_value" else f"{f.effect}:{f.axis}", f.axis, f)
             for f in d.findings if _value_name(f) not in j.names]
    # each look-alike flagged on the values of its axis (a transport delay's on all); one on an axis no value is on,
    # on every value
    on_axis = [[k for k, ax, _ in alike if ax in (g.axis, "both")] for g in out.findings]
    unplaced = [k for k, _, _ in alike if not any(k in mine for mine in on_axis)]
    for g, mine in zip(out.findings, on_axis):
        mine = mine + unplaced
        if mine:
            g.alternatives = list(dict.fromkeys(list(g.alternatives) + mine))
            g.evidence += ("; the effect search explained the log as well with " + ", ".join(mine) + " in its "
                           "place: this log cannot tell them apart, and a known value is no new physics")
    why = ("a look-alike of the known values that explain the log: with as many parameters it reaches the noise "
           "floor too, but it is new physics where a known value off its table is not")
    out.refused = list(d.refused) + [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter["value"],
                                      "reason": why} for _, _, f in alike]
    out.verdict_sentence += (" The effect search explained the log as well with " + ", ".join(k for k, _, _ in alike)
                             + " in their place, with as many parameters: this log cannot tell them apart; a known "
                             "value off its table is the simpler answer.")
    return out


def _effects_beside_values(d, j):
    """``d`` (the effect search explains the log) with the known values ``j`` that explain it too with as many
    parameters flagged as look-alikes of its findings on their axes (all of them where none shares an axis): the
    effects leave the angles nearer their floors (_closer), so they stay first, as a single effect does beside a
    single value (weigh's step 2)."""
    d.known_values_joint = j.to_json()
    values = [n for n in j.names if not any(_value_name(f) == n for f in d.findings)]
    if not values:
        return d
    for f in d.findings:
        if _value_name(f) is not None:
            continue
        mine = [n for n in values if known_values.AXIS[n] in (f.axis, "both") or f.axis == "both"] or values
        f.alternatives = list(dict.fromkeys(list(f.alternatives) + mine))
        f.evidence += ("; cannot be told apart with this log from " + ", ".join(mine) + " off the table (known values "
                       "refitted together reach the noise floor too, with as many parameters)")
    listed = ", ".join(f"{n} = {j.values[n]:.4g} instead of {j.table[n]:.4g}" for n in values)
    d.verdict_sentence += (f" Known values would explain the log as well with as many parameters ({listed}): this log "
                           "cannot tell them apart; the findings leave the angles nearer their floors.")
    return d


def _closer(effect_check: dict | None, ratio: dict) -> bool:
    """Does the effect's output-error check leave the angles nearer their floors (sum of squared ratios) than
    the known value's refit?"""
    if not effect_check:
        return False
    e = effect_check["rms_over_noise"]
    return sum(v * v for v in e.values()) < sum(v * v for v in ratio.values())


def _drop(base: dict, ratio: dict) -> float:
    """The share of the worst angle's squared error (over its noise floor) the refit removes."""
    before = max((base.get(ang, {}).get("rms_over_noise", math.nan) for ang in ("alpha", "beta")), default=math.nan)
    return 1.0 - max(ratio.values()) ** 2 / before ** 2 if before > 0 else math.nan


def _step(log: Log, name: str, axis: str, d, overlay: dict, residual: dict, fits_after: dict) -> dict:
    """The known value's figures (report/diagnosis.finding_figure): on both angles the measured angle, the
    predictions before and after, the equation error before and after over time and against the angle; no
    term shape (a known value changes a coefficient of eq. (1), not a term's form)."""
    from .shapes import thin

    th = thin(len(log))
    axes = {}
    for ax in ("pitch", "yaw"):
        x = getattr(log, AXIS_ANGLE[ax])
        axes[ax] = {"measured": x[th], "before": overlay[ax][2][th], "after": overlay[ax][3][th],
                    "fit_before": d.fit_before[ax], "fit_after": fits_after[ax],
                    "residual_before": residual[ax][1][th], "residual_after": residual[ax][2][th],
                    "regime_label": f"{AXIS_ANGLE[ax].split('_')[0]} [rad]", "regime": x[th],
                    "segments": d.segments[ax]}
    return {"key": f"{name} (known value, {axis})", "t": log.t_s[th], "axes": axes, "shape": None}

