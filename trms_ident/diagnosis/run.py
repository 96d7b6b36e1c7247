"""diagnose(log) -> Diagnosis, top to bottom: the effect search (search.py) finds what the seed model leaves
out, the rule (weigh.py) sets it beside the known values off their table, and findings whose model simulates an
axis worse on held-out samples (held_out.py) are refused and the search run again without them.  Where the log
stays unexplained beside a dead zone found, the search runs once more without that dead zone's form
(_other_forms): kept when it explains the log."""
from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from ..log import Log
from ..model.bench import given_of, is_term
from ..model.terms import searched_keys
from ..model.structure import of_bench
from ..params import KNOWN, merge
from . import held_out, search
from .result import VERDICTS, Diagnosis
from .verdict import STAND_IN, stand_in_sentence, stand_ins
from .weigh import weigh


def diagnose(log: Log, overrides: dict | None = None, law: str = "quadratic", a_rad_s: float | None = None,
             progress: Callable[[str, float], None] | None = None, seed=None) -> Diagnosis:
    """Find what the seed model leaves out of this log, fit it, and give the verdict (VERDICTS).

    ``overrides``: the bench's known values that differ from Table 1, its structure under
    model.structure.BENCH_KEY when it is not eq. (1)'s (every fit below reads it from there), and the input
    modifications its bench file states under model.bench.GIVEN_KEY (taken as given: the search starts from them,
    holds them at their values and adds to them).
    ``progress(stage, fraction done)``: called as the work advances (the CLI draws a bar with it).  ``seed``:
    identify's Result of this log with Settings(thrust_law=law, overrides=overrides) when the caller has it
    (batch --diagnose: the estimate it just made), else made here; either way made once, not per search rerun."""
    progress = progress or (lambda stage, done: None)
    p = merge(overrides or {}, source="parameter overrides")
    progress("fitting the seed model", 0.0)
    seed = seed if seed is not None else search.seed_result(log, overrides, law)
    with np.errstate(all="ignore"):
        stops_seen = _stops_seen(log, p, law, seed)
    answers: dict = {}  # the output-error fits' answers, shared by every search of this log (effect_search)
    d, gated, h = _searched(log, overrides, p, law, a_rad_s, progress, seed, [], answers)
    other = _other_forms(d)
    if other:
        # the search chose a dead zone's form on a model still missing something, and the log stays unexplained:
        # the same search with that form left out, kept only when it explains the log (OTHER_FORM)
        d2, gated2, h2 = _searched(log, overrides, p, law, a_rad_s,
                                   lambda stage, done: progress(f"the dead zone in its other form: {stage}", done),
                                   seed, other, answers)
        if d2.verdict == "explained":
            d, gated, h = d2, gated2, h2
    with np.errstate(all="ignore"):
        if d.corrections:
            progress("the corrections by output error", 0.98)
            d = replace(d, corrections=[replace(c, output_error=f) for c, f in
                                        zip(d.corrections, held_out.correction_fits(d, log, p, law, h))])
        refused = [{k: v for k, v in g.items() if k != "key"} for g in gated]
        held = [g for g in refused if not g["reason"].startswith((STAND_IN, TERM_SHORT, OTHER_FORM))]
        given = {k: {"value": p[k], "source": "override" if k in (overrides or {}) else "table"} for k in KNOWN}
        refused = d.refused + refused
        return replace(d, held_out=h, refused=refused, settings={**d.settings, "known_values": given,
                                                                  "structure": of_bench(p),
                                                                  "given_effects": given_of(p),
                                                                  "stops_seen": stops_seen},
                       verdict_sentence=d.verdict_sentence + held_out.gate_sentence(held) + held_out.caution(h)
                       + (stops_sentence(stops_seen) + stand_in_sentence(refused) + short_terms_sentence(refused)
                          if d.verdict not in ("explained", "consistent") else ""))


def _searched(log: Log, overrides: dict | None, p: dict, law: str, a_rad_s: float | None, progress, seed,
              gated: list, answers: dict | None = None) -> tuple[Diagnosis, list, dict | None]:
    """The effect search, the rule and the held-out gate (module docstring), the searches run again without what a
    rerun refuses: (the diagnosis, every refusal that excluded a key, as {"key", "effect", "axis", "parameter",
    "reason"}, ``gated``'s first, the held-out fits).  ``gated``: keys left out from the start; ``answers``: as
    search.effect_search's, kept by the caller for every search of this log."""
    gated = list(gated)
    with np.errstate(all="ignore"):  # a model far off the log overflows its predictions: they score as misfits
        no_terms = ()  # the searched terms, once one of them was found where the log stays unexplained
        for attempt in range(HELD_OUT_RERUNS + 1):
            exclude = tuple(g["key"] for g in gated) + no_terms
            found = search.effect_search(log, overrides, law, a_rad_s, progress, exclude, seed, answers)
            d = weigh(found, log, p, law, overrides, exclude)
            # no finding leaves diagnose with a value outside its plausible range, whichever step placed it: it
            # stands in for physics the model lacks, and the search runs again without it; nor does a term that
            # leaves the log unexplained (short_terms), and the search runs again without any term
            shorts = short_terms(d)
            outside = stand_ins(d.findings) + shorts
            if outside and attempt < HELD_OUT_RERUNS:
                gated += outside
                no_terms = no_terms or (searched_keys() if shorts else ())
                continue
            d = _without_unneeded(_without_inert(_without_stand_ins(d, outside), log, p, law), log, p, law)
            progress("held-out simulation fits", 0.97)
            h = held_out.held_out_fits(d, log, p, law)
            refuse = held_out.lowering(d.findings, h)
            if not refuse or attempt == HELD_OUT_RERUNS:
                break
            gated += refuse  # the search again without them: a rival they hid may hold on held-out samples
    return d, gated, h


#: why a dead zone's form found first is refused when the search without it explains the log (_other_forms)
OTHER_FORM = "in this form it left the log unexplained"


def _other_forms(d: Diagnosis) -> list[dict]:
    """The dead zones (model.effects.FORMS: cut off below the width, or the characteristic shifted by it) the
    diagnosis ``d`` found whose other form passed its output-error test too (d.oe_tested), as refusals {"key",
    "effect", "axis", "parameter", "reason"}, when the log stays unexplained ("partly explained" or
    "unexplained"); [] otherwise.  The search picks a motor's form by the output-error fit on the model it has
    then, before a second difference is in: with the other motor's dead zone or a known value still missing, the
    wrong form at a wrong width can lower the cost more (measured, independent.py seed 6161 bench 11: Simulink's
    dead zone on both motors, 0.167 V and 0.187 V; the cut-off form at 0.4365 V dropped the cost 99.0 %, the
    shifted one 95.0 %, both passed; the other motor's dead zone in the cut-off form then failed its test and the
    log was left partly explained).  Searched again without them, the search can reach the other form (and the
    other motor's in it); that diagnosis is kept only when it explains the log.  A form whose rival never passed is
    not searched again: the rerun cannot name it first (measured, diagnose_speed.py seed 8383 bench 27: the right
    0.24 V main-motor dead zone beside a yaw motor time constant 1.4 % off, the rerun 1.5x the time for the same
    diagnosis)."""
    from ..model.effects import FORMS

    if d.verdict not in ("partly_explained", "unexplained"):
        return []
    passed = {f"{t['effect']}:{t['axis']}" for t in d.oe_tested if t.get("passed")}
    return [{"key": f"{f.effect}:{f.axis}", "effect": f.effect, "axis": f.axis,
             "parameter": float(f.parameter["value"]),
             "reason": f"{OTHER_FORM}; searched again without it, the model explains the log"}
            for f in d.findings if f.effect in FORMS and f"{FORMS[f.effect]}:{f.axis}" in passed]


#: an angle lying on its extreme is said to be held there by an end stop the model lacks when the model without a
#: stop simulates it this many of the stop's tolerances past it on those samples (measured on the CE150's published
#: model under eq. (1)'s structure, from rest on its 45 degree stop: 12x on a multisine, 2.7x on a steps log whose
#: misfit lies elsewhere; on seed 5150, not tuned on, 8.3x on a multisine, said on the ramp).  Said only when the
#: findings do not explain the log (a model that fits does not pass the value)
STOP_BEYOND_TOLERANCES = 10.0


def _stops_seen(log: Log, p: dict, law: str, seed) -> list[dict]:
    """The end stops the log shows and the bench does not state: an angle lying on its extreme
    (identify.resting_extremes) that the seed model, fitted by output error (J/B and the start states free),
    simulates well past it there.  Said, not modelled: where the stop is is measured, but whether adding it is the
    simplest explanation is the search's question, and diagnose does not search structures (the bench file's
    [structure] states stops; docs/parameters.md).  [] when there is none."""
    from ..identify import resting_extremes
    from ..model.structure import stops
    from .model import given_model
    from .oe import Fitter
    from .trials import jb_start

    have = of_bench(p)
    candidates = [c for c in resting_extremes(log) if stops(have, c["axis"]) is None]
    if not candidates:
        return []
    fitter = Fitter(log, p, law, check=seed.model_check)
    r0 = fitter.base(given_model(p), {}, jb_start({k: v for k, v in seed.estimates.items() if v is not None}, p))
    if r0 is None:
        return []
    n, seen = fitter.n, []
    for c in candidates:
        at = c["at"][:n]
        if not at.any():
            continue
        sim = r0.prediction[:n, 0 if c["axis"] == "pitch" else 1][at]
        beyond = float(np.max(c["rad"] - sim if c["side"] == "low" else sim - c["rad"]))
        if beyond >= STOP_BEYOND_TOLERANCES * c["tol_rad"]:
            seen.append({"axis": c["axis"], "side": c["side"], "rad": c["rad"], "deg": float(np.degrees(c["rad"])),
                         "rest_s": float(np.count_nonzero(c["at"]) * log.sample_time_s), "beyond_rad": beyond})
    return seen


def stops_sentence(seen: list[dict]) -> str:
    """What the end stops seen say (the end of diagnose's verdict sentence); "" without any."""
    if not seen:
        return ""
    parts = [f"the {f['axis']} angle lies on its {'lowest' if f['side'] == 'low' else 'highest'} value, "
             f"{f['rad']:.4g} rad ({f['deg']:.4g} deg), for {f['rest_s']:.3g} s, where the model simulates it up to "
             f"{f['beyond_rad']:.3g} rad further" for f in seen]
    entries = " and ".join(dict.fromkeys(f"{f['axis']}_stops_deg" for f in seen))  # each axis once, in order
    return (f" An end stop the model lacks may hold it there: {'; '.join(parts)}. If the bench has one, state it in "
            f"the bench file ([structure] {entries}, docs/parameters.md) and diagnose again: the search does "
            "not add stops itself.")


def _without_stand_ins(d: Diagnosis, outside: list[dict]) -> Diagnosis:
    """The diagnosis without the findings ``outside`` names (the reruns did not get rid of them): never reported
    as findings; the verdict can then be at most partly explained (with findings left) or unexplained."""
    if not outside:
        return d
    keys = {g["key"] for g in outside}
    kept = [f for f in d.findings if f"{f.effect}:{f.axis}" not in keys]
    verdict = d.verdict if d.verdict == "consistent" else "partly_explained" if kept else "unexplained"
    return replace(d, findings=kept, verdict=verdict, verdict_sentence=VERDICTS[verdict] + ".",
                   refused=d.refused + [{k: v for k, v in g.items() if k != "key"} for g in outside])


def _without_inert(d: Diagnosis, log: Log, p: dict, law: str) -> Diagnosis:
    """The diagnosis without the input-modification findings that change their motor's thrust torque by less than
    oe.MIN_MODIFICATION_SHARE of its RMS (oe.modification_torque_share), whichever step placed them, when the model
    without them fits the log as well (fit_without): a value that acts on no sample that matters describes no
    bench (measured: a 6.3e-7 V main-motor dead zone named beside a right 0.878 V saturation, "explained").  The fit
    without them is measured, not assumed: a small share of a large thrust can be most of what moves an axis that
    thrust and reaction hold nearly balanced (measured: a 0.42 s second lag of the CE150's tail motor on its
    elevation ramp, 0.00099 of the thrust's RMS, brings the yaw from 25 000x its floor to it; refusing it had made
    the verdict "consistent", the seed model's yaw fit 10 %).  The verdict stands while findings are left; with none
    left it is the model's without them: consistent when that reaches the floors, else unexplained."""
    from ..numerics.adequacy import RMS_OVER_NOISE
    from .oe import MIN_MODIFICATION_SHARE, modification_torque_share, profiled

    inert = []
    for f in d.findings:
        key = f"{f.effect}:{f.axis}"
        if f.effect == "known_value" or not profiled(key):
            continue
        share = modification_torque_share(key, float(f.parameter["value"]), log, p, law)
        if share < MIN_MODIFICATION_SHARE:
            inert.append((f, share))
    if not inert:
        return d
    gone = {id(f) for f, _ in inert}
    kept = [f for f in d.findings if id(f) not in gone]
    after = fit_without(d, kept, log, p, law)
    if after is None:
        return d
    refused = [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter["value"],
                "reason": f"changes its motor's thrust torque by {share:.2g} of its RMS, below the practical size of "
                          f"{MIN_MODIFICATION_SHARE:g}, and the model without it fits the log as well: it acts on no "
                          "sample that matters"} for f, share in inert]
    keys = {f"{f.effect}:{f.axis}" for f, _ in inert}
    steps = [s for s in d.steps if s.get("key") not in keys]  # (the report draws a figure per finding's step)
    if kept or d.verdict in ("consistent", "unexplained"):
        return replace(d, findings=kept, steps=steps, refused=d.refused + refused)
    # no finding left: the verdict is the model's without them, as measured (a verdict of "partly explained" with
    # no finding had reached the user: a wrong-width dead zone that fitted worse than none)
    verdict = "consistent" if all(r <= RMS_OVER_NOISE for r in after.values()) else "unexplained"
    # unexplained: the verdict's words swapped, what the search and the rule said after them kept (the known values
    # tried); consistent: nothing of the findings' model's words applies
    said = d.verdict_sentence
    sentence = VERDICTS[verdict] + (said[len(VERDICTS[d.verdict]):] if verdict == "unexplained" and
                                    said.startswith(VERDICTS[d.verdict]) else ".")
    return replace(d, findings=kept, steps=steps, verdict=verdict, verdict_sentence=sentence,
                   refused=d.refused + refused)


#: why a library effect found beside a term is dropped (_without_unneeded)
UNNEEDED = "a term found beside it makes it unnecessary"


def _without_unneeded(d: Diagnosis, log: Log, p: dict, law: str) -> Diagnosis:
    """Beside a term found (model/terms.py), each library effect found is dropped, one at a time, when the model
    without it fits the log as well (fit_without): the term makes it unnecessary, and it would stand in for nothing
    (issue #76).  Known values are not tried (the fit without one is another bench's); the verdict stands, the
    fit being as good."""
    if not any(is_term(f"{f.effect}:{f.axis}") for f in d.findings):
        return d
    kept, refused = list(d.findings), []
    for f in d.findings:
        key = f"{f.effect}:{f.axis}"
        if f.effect == "known_value" or is_term(key):
            continue
        rest = [g for g in kept if g is not f]
        if fit_without(replace(d, findings=kept), rest, log, p, law) is None:
            continue
        kept = rest
        refused.append({"effect": f.effect, "axis": f.axis, "parameter": float(f.parameter["value"]),
                        "reason": f"{UNNEEDED}: the model without it fits the log as well"})
    if not refused:
        return d
    keys = {f"{r['effect']}:{r['axis']}" for r in refused}
    return replace(d, findings=kept, steps=[s for s in d.steps if s.get("key") not in keys],
                   refused=d.refused + refused)


#: the model without a finding of no practical size fits "as well" when each angle's error RMS over its floor is at
#: most this factor of the findings' model's, or within the verdict's threshold (adequacy.RMS_OVER_NOISE) where the
#: findings' model was (measured: the CE150's tail-motor lag kept, 25 000x without it against 0.0066x; a dead zone
#: the grid left at a wrong width refused, 2.53x without it against 2.94x)
INERT_FIT_RATIO = 1.01


def fit_without(d: Diagnosis, kept: list, log: Log, p: dict, law: str) -> dict | None:
    """The model of the findings ``kept``'s error RMS over the floors (angle -> ratio) when it fits the log as well
    as d's findings' model (INERT_FIT_RATIO), else None.  Both by diagnose's output-error check (oe.Fitter.check:
    J/B, the torque terms and the start states refitted, the floors the seed check says); None when either cannot
    be fitted (nothing is refused on an assumption)."""
    from .held_out import final_model
    from .oe import Fitter
    from .trials import jb_start

    # one fitter for both: ``kept`` differs from d's findings by input modifications only, so the known values the
    # findings change (final_model's third part) are the same, and the fitter's floors are measured once
    fitter = Fitter(log, {**p, **final_model(kept, p)[2]}, law, check=d.seed_check or None)
    theta0 = jb_start(d.augmented or d.nominal, p)

    def ratios(findings):
        model, values, _ = final_model(findings, p)
        return fitter.check(model, values, theta0)

    with np.errstate(all="ignore"):
        before, after = ratios(d.findings), ratios(kept)
    if before is None or after is None:
        return None
    return dict(after) if fits_as_well(before, after) else None


def fits_as_well(before: dict, after: dict) -> bool:
    """Does a model with fewer findings (its error RMS over the floors ``after``, angle -> ratio) fit as well as
    the findings' (``before``): within INERT_FIT_RATIO of it on each angle, or within the verdict's threshold
    (adequacy.RMS_OVER_NOISE) where the findings' model was?"""
    from ..numerics.adequacy import RMS_OVER_NOISE

    return all(after[a] <= max(INERT_FIT_RATIO * before[a], RMS_OVER_NOISE if before[a] <= RMS_OVER_NOISE else 0.0)
               for a in before)


#: why a term found where the log stays unexplained is refused (short_terms)
TERM_SHORT = "a term outside the library that leaves the log unexplained"
#: the verdicts under which a term found stands: the model with it at the noise floor (short_terms' guard)
TERM_STANDS_UNDER = ("explained", "consistent")


def short_terms(d: Diagnosis) -> list[dict]:
    """The term findings (model/terms.py) of a diagnosis that does not explain the log, each as a refusal {"key",
    "effect", "axis", "parameter", "reason"}: a term is the data's description of a torque, not physics the
    library names, so it stands only where it brings the model to the noise floor; where the log stays unexplained
    it may stand in for what the model lacks (measured: a pitch torque 0.0033 beta'^2 named for a gyroscopic coupling
    twice the table's Kg, tests/test_sparse_correction.py; a 0.0014 N m pitch friction term for a thrust that
    changes with the pitch rate, outside.py --terms)."""
    if d.verdict in TERM_STANDS_UNDER:
        return []
    return [{"key": f"{f.effect}:{f.axis}", "effect": f.effect, "axis": f.axis,
             "parameter": float(f.parameter["value"]),
             "reason": f"{TERM_SHORT} (c = {float(f.parameter['value']):.4g}): it may stand in for what the model "
                       "lacks; searched again without the terms"}
            for f in d.findings if is_term(f"{f.effect}:{f.axis}")]


def short_terms_sentence(refused: list[dict]) -> str:
    """The verdict's words for the terms short_terms refused; empty when none."""
    told = [r for r in refused if str(r.get("reason", "")).startswith(TERM_SHORT)]
    if not told:
        return ""
    names = "; ".join(f"{r['effect']} on {r['axis']} (c = {r['parameter']:.4g})" for r in told)
    return (f" Not findings: {names}: a term outside the library stands only where it brings the model to the noise "
            "floor; with it the log stayed unexplained, so it may describe something else the model lacks.")


#: diagnose runs its search again without the effects whose model simulated an axis worse on held-out samples
#: than the seed model (held_out.lowering) at most this many times; after that the verdict only cautions
HELD_OUT_RERUNS = 2
