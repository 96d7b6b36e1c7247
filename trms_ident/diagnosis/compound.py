"""Two differences at once: an effect the search found, with a known value off its table.

A real bench differs from eq. (1) with Table 1's values in several ways at once (its own known values, a
second-order motor, a cable).  The effect search (search.py) finds the first difference well, but it works at the
table's known values, so a second difference that is a known value (Mg 10 % low beside a yaw cable) is then
explained by invented physics (thrust asymmetry, a centre-of-mass offset).  The known-value search
(known_values.py) frees one value at a time in eq. (1) alone, so it cannot reach the noise floor while the
effect is missing.  Here the two meet.

Each hypothesis is one of the effect search's findings, or a torque-effect look-alike of one, put into the
model as a bench file's effect (model/bench.py: an input modification applied to the voltages at its found value,
a torque effect, a saturation's level or a shifted dead zone's width freed beside J/B) and the log estimated under
it as `estimate --params` does (identify): its adequacy check says whether the model with that one effect fits
the log, and when it does not, its known-value search frees each known value with the effect in the model.  The
rule is weigh.py's, over more hypotheses:

- the explanation with the fewest parameters that brings both angles to their noise floors wins: the effect alone
  (one parameter; the search had left it "partly explained" because its own fits stopped early) before an effect
  with a known value (two);
- among those with as many parameters, the one that leaves the angles nearest their floors is named and the
  others that reach the floors are its look-alikes (the log cannot tell them apart);
- the effect search's other findings are then refused as unnecessary, each with that reason.

None when no hypothesis reaches the noise floor: the effect search's verdict stands.

The other order (value_first): a known value off its table makes the effect search, run at the table's values,
invent physics first (thrust asymmetry and a cable for kc 31 % low beside a pitch drag), so none of its findings
leads anywhere.  When neither the findings nor known values together reach the floor, the known values the
seed check's search ranked best (lowest output-error cost, each leaving the angles within
VALUE_FIRST_OVER_NOISE of their floors when refitted alone) are taken one at a time: the effect search runs
again with that value at its refit, and each of its findings is estimated under as above, from the values given
(so the known value is refitted beside the effect, not held at its biased refit alone).  The joint search's set
of values, when it does not reach the floor, leads first (joint_lead): its values are freed together beside each
effect from their joint refit (_with_leads), since the known-value search under the effect frees one value at a
time and need not rank them (two values and an effect: three differences, each a finding).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .. import known_values
from ..log import Log
from ..model import effects as room
from ..model.bench import MODIFICATION_KEYS, NATIVE_FREE_KEYS, TORQUE_KEYS
from ..numerics.adequacy import RMS_OVER_NOISE
from ..numerics.parallel import fan_out
from .oe import OWN_TIME_CONSTANT, SECOND_ORDER_OF, motor_states  # (a motor's forms: hypotheses, lead_of)
from .model import settings_of
from .result import Finding, known_value_finding

#: at most this many hypotheses (findings first, then their torque-effect look-alikes) are estimated under: each
#: is one estimate with its known-value search, 4-6 s on a 60 s log at 500 Hz
MAX_HYPOTHESES = 4
#: when nothing else explains the log (weigh.py's last step), at most this many more effects are tried: the first
#: round's best by the equation error's held-out gain, passed or not (ranked(); each is one estimate with its
#: known-value search, as above)
MAX_RANKED = 3
#: library effects that are a known value of eq. (1) under another name (the motor time constant the motor_lag
#: candidate fits is T11 (T21) itself): a known value named under one is not a second difference but the
#: effect's own value moved again
SAME = {"motor_lag:pitch": "T11", "motor_lag:yaw": "T21"}
#: where that further lag's profile starts when no fit gave it a value [s] (its profile screens its range)
SECOND_LAG_START_S = 0.05
#: value_first: at most this many known values lead, each one effect search run again (4-150 s)
MAX_LEADS = 2
#: and only those whose refit alone left the worst angle within this factor of its floor and at most half as far
#: from it as the seed model (measured: kc refitted alone beside a concealed pitch drag left 1.3x, b2 beside a
#: pitch dead zone 6.5x, from 27x; a real recording's 434x brought to 100x is not one value and an effect away)
VALUE_FIRST_OVER_NOISE = 10.0


@dataclass
class Hypothesis:
    """One effect in the model, estimated under (identify), and what its estimate's checks said."""
    key: str  # "cable_stiffness:yaw"
    value: float  # its value given to the estimate (the finding's)
    finding: int | None  # index of the effect search's finding it is (None: a look-alike of one)
    fitted: float = math.nan  # the effect's value after the estimate (a torque effect is freed beside J/B)
    fitted_ci95: tuple | None = None  # its 95 % interval there, when the estimate freed it
    fits_alone: bool = False  # the estimate's adequacy check: the effect alone brings both angles to their floors
    over_noise: dict = field(default_factory=dict)  # angle -> error RMS over its floor, alone or with ``value_fit``
    value_fit: dict | None = None  # the known value its known-value search named (KnownValueFit's JSON)
    more_values: list = field(default_factory=list)  # further known values freed beside it (value_first's joint lead)
    look_alikes: list = field(default_factory=list)  # known values that reach the floor with it as well
    error: str = ""
    ranked_by: dict | None = None  # its first-round equation-error test when ranked() proposed it (d.tested's row)
    every_motor: bool = False  # proposed by freed_modifications (on each motor, whatever the equation error's rank)

    @property
    def parameters(self) -> int:
        return (1 if self.fits_alone else 2) + len(self.more_values)

    @property
    def explains(self) -> bool:
        return self.fits_alone or self.value_fit is not None

    def label(self) -> str:
        return self.key + ("" if self.value_fit is None else f" with {self.value_names()}")

    def value_names(self) -> str:
        """The known values freed beside the effect, as text ("T0" or "T0, T11")."""
        return ", ".join(v["name"] for v in ([self.value_fit] if self.value_fit else []) + self.more_values)


def hypotheses(d) -> list[Hypothesis]:
    """The effect search's findings that a bench file holds, then their torque-effect look-alikes at the value the
    output-error fit gave them (d.oe_tested), at most MAX_HYPOTHESES."""
    out: list[Hypothesis] = []
    seen = set()
    for i, f in enumerate(d.findings):
        key = f"{f.effect}:{f.axis}"
        if f.effect != "known_value" and key in TORQUE_KEYS + MODIFICATION_KEYS and key not in seen:
            out.append(Hypothesis(key, float(f.parameter["value"]), i))
            seen.add(key)
    tested = {f"{t['effect']}:{t['axis']}": t["parameter"] for t in d.oe_tested
              if math.isfinite(t.get("parameter", math.nan))}
    for f in d.findings:
        for alt in f.alternatives:
            start = tested.get(alt, 0.0)  # never fitted: from zero, where its range allows (an offset)
            if alt in TORQUE_KEYS and alt not in seen and room.BY_KEY[alt].plausible(start):
                out.append(Hypothesis(alt, float(start), None))
                seen.add(alt)
        # a motor time constant found off the table that leaves the log short of the floor: that motor of second
        # order, its further lag profiled with the time constant freed (lead_of), from the lag's output-error
        # value when it has one (measured: a 0.069 s main-motor lag beside T11 0.938 s was named as a main-motor
        # time constant of 1.013 s, their sum, partly explained)
        second = SECOND_ORDER_OF.get(f"{f.effect}:{f.axis}")
        if second is not None and second not in seen:
            out.append(Hypothesis(second, float(tested.get(second, SECOND_LAG_START_S)), None))
            seen.add(second)
    return out[:MAX_HYPOTHESES]


def ranked(d, seen: set) -> list[Hypothesis]:
    """The first round's effects (``d.tested``, the equation error's tests on the seed model) that a bench file holds,
    not in ``seen``, ranked by their held-out gain (positive only), passed or not, at their equation-error values
    where plausible, at most MAX_RANKED.  A known value off its table leaves its misfit in every effect's test, so an
    effect that is the other difference need not pass alone (diagnosed_model.py's seed 29: a 0.015 rad centre-of-mass
    offset beside Mg 15 % low, held-out gain 0.52, p 0.26; a thrust asymmetry, gain 0.85, passed and was named).
    Then freed_modifications(d, ...), which no rank decides."""
    out = []
    for t in sorted(d.tested, key=lambda t: -t.get("held_out_gain", -math.inf)):
        key, value = f"{t['effect']}:{t['axis']}", float(t.get("parameter", math.nan))
        if not t.get("held_out_gain", -math.inf) > 0 or len(out) == MAX_RANKED:
            break
        if key in seen or key not in TORQUE_KEYS + MODIFICATION_KEYS or not room.BY_KEY[key].plausible(value):
            continue
        out.append(Hypothesis(key, value, None, ranked_by=t))  # (d.tested holds one row per key)
    return out + freed_modifications(d, seen | {h.key for h in out})


def freed_modifications(d, seen: set) -> list[Hypothesis]:
    """Each input modification the refinement frees itself (NATIVE_FREE_KEYS: a shifted dead zone or a saturation,
    on either motor) not in ``seen``, whatever the equation error made of it, from its first-round value where that
    is plausible (else the middle of its grid).  Estimated under, its width is freed beside every known value the
    search refits (estimate_under), so these four cover "a known value and one such modification" whole, which the
    equation error cannot rank: a known value off its table leaves J/B unphysical or biased there (measured,
    independent.py: k2 24-37 % high beside a 0.14-0.19 V yaw dead zone, seed 64502 bench 23 and seed 23562 bench
    21, and Mg 22 % high beside a 0.114 V one, seed 23562 bench 20: the yaw dead zone had no held-out gain, a
    saturation was invented instead; estimated under from 0.05-0.4 V, each named both at the bench's values)."""
    rows = {f"{t['effect']}:{t['axis']}": t for t in d.tested}
    out = []
    for key in NATIVE_FREE_KEYS:
        if key in seen:
            continue
        c = room.BY_KEY[key]
        value = float(rows.get(key, {}).get("parameter", math.nan))
        if not c.plausible(value):
            value = float(np.median(c.grid))
        out.append(Hypothesis(key, value, None, ranked_by=rows.get(key), every_motor=True))
    return out


def estimate_under(h: Hypothesis, log: Log, law: str, overrides: dict) -> Hypothesis:
    """``h`` filled in from the estimate of ``log`` with h's effect in the model (identify, as `estimate --params`
    with that effect in the bench file does)."""
    from ..errors import TrmsError
    from ..identify import identify

    torque = h.key in TORQUE_KEYS
    # a saturation's level or a shifted dead zone's width is a Gauss-Newton unknown of the refinement itself
    # (NATIVE_FREE_KEYS): freed, it is a nuisance of the known-value search's score test and refitted beside each
    # value, so a value off its table is ranked and refitted with the modification free rather than at a width the
    # value biased (independent.py: kc, k1, k2 beside a shifted yaw or pitch dead zone held at the equation error's
    # width were ranked low and missed; freed, each was named at the bench's value, the width with it)
    native = h.key in NATIVE_FREE_KEYS
    settings = settings_of(overrides, law, effects={h.key: h.value},
                           free=(h.key,) if torque or native else ())
    try:
        with np.errstate(all="ignore"):
            res = identify(log, settings, halves=False)  # judged by the angles' floors, as the search judges
    except (TrmsError, np.linalg.LinAlgError, FloatingPointError, ValueError, ZeroDivisionError) as exc:
        return replace(h, error=str(exc))
    check = res.model_check
    freed = res.refined.freed if res.refined is not None else {}
    fitted = float(freed[h.key]["estimate"]) if h.key in freed else (h.value if not torque else math.nan)
    h = replace(h, fitted_ci95=_ci95(freed.get(h.key)))
    ratio = _over_noise(check)
    if check.get("adequate") is True and _physical(res, h.key, fitted):
        return replace(h, fitted=fitted, fits_alone=True, over_noise=ratio)
    kv = check.get("known_values") or {}
    named = kv.get("named")
    if named is None and not torque and not native:
        return _profiled_with_lead(h, log, law, overrides, kv, replace(h, fitted=fitted, over_noise=ratio))
    if named is not None and named == OWN_TIME_CONSTANT.get(h.key):
        # a second-order motor's own time constant named beside its lag held where the search put it, which the
        # table's time constant biased: the two profiled together first
        joint = _profiled_with_lead(h, log, law, overrides, kv, replace(h, fitted=fitted, over_noise=ratio))
        if joint.explains:
            return joint
    if named is None or named == SAME.get(h.key):
        return replace(h, fitted=fitted, over_noise=ratio)
    fit = next(f for f in kv["fits"] if f["name"] == named)
    beside = fit.get("with_free", {}).get(h.key)
    if beside is not None:  # freed beside the known value: its value and interval there
        fitted, h = beside.get("estimate", fitted), replace(h, fitted_ci95=_ci95(beside))
    return replace(h, fitted=float(fitted), over_noise=dict(fit["over_noise"]), value_fit=fit,
                   look_alikes=list(kv.get("look_alikes", [])))


def estimated_under(hs: list[Hypothesis], log: Log, law: str, overrides: dict) -> list[Hypothesis]:
    """[estimate_under(h, ...) for h in hs], the hypotheses spread over the cores (numerics.parallel.fan_out: in
    order, each estimate the same in any thread).  Each is an identify of its own, mostly serial inside (one
    Gauss-Newton fit, a bounded scalar search over a profiled value): run one after another they kept one core busy
    while the other waited (measured with py-spy on independent.py seed 8642 bench 20: 42 % of diagnose's busy
    time in this list, all of it in the main thread)."""
    return fan_out(lambda h: estimate_under(h, log, law, overrides), hs)


def _physical(res, key: str, fitted: float) -> bool:
    """An estimate under one effect describes a bench: J/B credible (params.not_credible) and the effect's value in
    its plausible range (a fit that reaches a smoothed log's floor with J2 4.6e4 kg m^2 describes none)."""
    from ..params import not_credible

    est = res.refined.estimate if res.refined is not None else res.estimates
    return not not_credible(est) and room.BY_KEY[key].plausible(fitted)


def _ci95(freed: dict | None) -> tuple | None:
    """A freed value's 95 % interval (refine's or a profile's ``freed`` entry), when it has a finite one."""
    ci = (freed or {}).get("ci95")
    if ci is None or len(ci) != 2 or not all(math.isfinite(float(x)) for x in ci):
        return None
    return float(ci[0]), float(ci[1])


def _over_noise(check: dict) -> dict:
    """A model check's angle errors over their floors: angle -> ratio."""
    return {v["angle"]: float(v["rms_over_noise"]) for v in check.get("axes", {}).values()
            if "rms_over_noise" in v and "angle" in v}


def _profiled_with_lead(h: Hypothesis, log: Log, law: str, overrides: dict, kv: dict, none: Hypothesis
                        ) -> Hypothesis:
    """An input modification ``h`` whose known-value search named nothing: the modification was profiled at the
    values given, so a known value off the table biased it (a transport delay 0.028 s for 0.029 s beside Mg 17 % low
    leaves the yaw at 1.3x its floor with Mg refitted right).  The value the search ranked best (lead_of) is freed
    together with the modification, profiled again (model_profile.identify_with_profiles, as `estimate --free KEY
    --free NAME` does); ``none`` when that does not make the model fit either.  One profile per hypothesis (4-30 s;
    up to five more when it does not fit, below), however far that value's refit alone left the angles from their
    floors: the modification held at a value the known value biased is what kept the refit off (measured,
    independent.py seed 8642 bench 20: a2 24 % high beside a 0.29 V yaw dead zone held at the equation error's
    0.18 V; a2's refit alone left the yaw at 16.6x, the two freed together reached the floor at 0.02472 and 0.29 V;
    under a 2x gate nothing was tried and the log was "unexplained").

    When that lead does not reach the floor and the modification is a cut-off dead zone on one motor's voltage
    (_VOLTAGE_MODIFICATIONS), every known value on that motor's path (MOTOR_PATH) is freed beside it in turn, the
    search's score order first: held at its biased value, the modification took up what such a value moves, so
    neither the value's refit alone nor its score test ranks it.  Of those that reach the floor the one nearest it
    is the explanation, the others its look-alikes.  (Measured when shifted dead zones came here too, independent.py
    seed 34773: k1 27 % high beside a 0.259 V pitch dead zone named at 0.189 V, k1 seventh by score; freed together,
    both at the bench's values.  A shifted dead zone and a saturation are now freed inside the known-value search
    itself, estimate_under, which ranks and refits every value with the width free.)"""
    first = lead_of(kv, h.key)
    lead = None if first is None else first["name"]
    got = none if lead is None else _with_lead(h, lead, log, law, overrides, none)
    if got.explains:
        return got
    if h.key in OWN_TIME_CONSTANT:
        # a second-order motor whose own time constant freed beside its lag does not reach the floor: the value the
        # refits under the lag rank best leads instead (measured, diagnosed_model.py seed 9: a 0.142 s main-motor
        # lag beside Kg 1.71x, the lag held at its found 0.147 s; Kg refitted alone under it left 1.47x, T11 freed
        # beside the lag did not fit, and Kg was never freed with the lag: "partly explained", Kg's change
        # described outside the library as a gyroscopic term)
        other = lead_of(kv, h.key, own=False)
        if other is not None and other["name"] != lead:
            got = _with_lead(h, other["name"], log, law, overrides, none)
            if got.explains:
                return got
    path = [n for n in kv.get("scores", {}) if n in _motor_path(h.key) and n != lead]
    tried = fan_out(lambda name: _with_lead(h, name, log, law, overrides, none), path)
    explaining = sorted((t for t in tried if t.explains),
                        key=lambda t: (t.parameters, sum(v * v for v in t.over_noise.values())))
    if not explaining:
        return none
    alikes = [t.value_fit["name"] for t in explaining[1:] if t.value_fit is not None]
    return replace(explaining[0], look_alikes=alikes)


#: the known values on each motor's path from its voltage to its thrust (eq. 1: the motor's gain and time
#: constants, the thrust curve), which a modification of that voltage can take the place of
MOTOR_PATH = {"pitch": ("a1", "b1", "k1", "T11", "T10"), "yaw": ("a2", "b2", "k2", "T21", "T20")}
#: the modifications of one motor's voltage that reach _profiled_with_lead (which widens their leads to that
#: motor's path): the cut-off dead zone, profiled; a shifted dead zone and a saturation are freed in the refinement
#: itself (NATIVE_FREE_KEYS), their known-value search frees their value beside each known value (estimate_under)
_VOLTAGE_MODIFICATIONS = ("dead_zone",)


def _motor_path(key: str) -> tuple:
    """The known values a modification ``key`` can take the place of: its motor's path, for one of one motor's
    voltage; none for any other."""
    effect, _, axis = key.partition(":")
    return MOTOR_PATH.get(axis, ()) if effect in _VOLTAGE_MODIFICATIONS else ()


def _with_lead(h: Hypothesis, lead: str, log: Log, law: str, overrides: dict, none: Hypothesis,
               table: float | None = None) -> Hypothesis:
    """``h``'s modification and the known value ``lead`` freed together (_profiled_with_lead); ``none`` when the
    model does not fit with them.  ``table``: the value the bench was given, when ``overrides`` start the lead
    elsewhere (value_first's joint lead); its change and plausibility are judged against it."""
    return _with_leads(h, (lead,), log, law, overrides, none, None if table is None else {lead: table})


def _with_leads(h: Hypothesis, leads: tuple, log: Log, law: str, overrides: dict, none: Hypothesis,
                tables: dict | None = None) -> Hypothesis:
    """_with_lead for one or more known values ``leads`` freed together beside ``h``'s modification (value_first's
    joint lead: the joint search's set, freed from its joint refit in ``overrides``; ``tables`` the values the
    bench was given).  Each value must be plausible; those that did not move (known_values.PRACTICAL_CHANGE) are
    not findings, and with none moved the modification explains the log alone."""
    from ..errors import TrmsError
    from ..model_profile import identify_with_profiles
    from ..params import BY_NAME, merge

    settings = settings_of(overrides, law, effects={h.key: h.value}, free=(h.key, *leads))
    try:
        with np.errstate(all="ignore"):
            res = identify_with_profiles(log, settings)
    except (TrmsError, np.linalg.LinAlgError, FloatingPointError, ValueError, ZeroDivisionError):
        return none
    check = res.model_check
    freed = res.refined.freed if res.refined is not None else {}
    if check.get("adequate") is not True or any(k not in freed for k in leads) or h.key not in freed:
        return none
    given = merge(dict(overrides), source="parameter overrides")
    fits = []
    for lead in leads:
        table = given[lead] if tables is None else tables[lead]
        value = float(freed[lead]["estimate"])
        if not known_values.plausible_value(value, table):
            return none  # (known_values.PLAUSIBLE_VALUE_FACTOR: a value no bench has explains nothing)
        if known_values.practical_change(value, table):
            fits.append({"name": lead, "value": value, "table": float(table),
                         "ci95": [float(x) for x in freed[lead]["ci95"]], "unit": BY_NAME[lead].unit,
                         "over_noise": _over_noise(check),
                         "estimates": {k: float(v) for k, v in res.refined.estimate.items()},
                         "start_states": {k: float(v) for k, v in res.refined.start_states.items()},
                         "how": f"freed with {h.key}, whose value was profiled again beside it"})
    if not fits:
        # the lead did not move (known_values.PRACTICAL_CHANGE): the modification profiled again explains the log
        # alone, one parameter (measured: a2 named at 0.02001 for 0.02 beside a yaw saturation, twice)
        return replace(h, fitted=float(freed[h.key]["estimate"]), fitted_ci95=_ci95(freed[h.key]), fits_alone=True,
                       over_noise=_over_noise(check))
    return replace(h, fitted=float(freed[h.key]["estimate"]), fitted_ci95=_ci95(freed[h.key]),
                   over_noise=fits[0]["over_noise"], value_fit=fits[0], more_values=fits[1:])


def lead_of(kv: dict, key: str, own: bool = True) -> dict | None:
    """The known value freed beside the modification ``key`` (_profiled_with_lead).  A second-order motor's further
    lag: that motor's own time constant (OWN_TIME_CONSTANT), whatever its refit alone did, because a second-order
    motor has both its time constants free (a lag added to the table's time constant is another model when the
    table's value is wrong, and that value refitted alone cannot reach the floor while the lag is missing:
    measured, a 0.076 s main-motor lag beside T11 1.012 s for 1.1 s left the log unexplained, the lag's profile at
    the table's T11 at its grid's end; freed together, 0.076 s and 1.012 s at the floor).  Else, of the seed check's
    plausible refits alone (``kv``), the one that reached the floor in the shooting windows (the lowest cost of
    those in the standard windows), or failing that the one with the lowest cost, wherever it left the angles
    (None when no refit is plausible).  The known value that is ``key`` under another name (SAME) is not its
    lead.  ``own`` False: the refits' lead for a second-order motor's lag too (its own time constant tried first)."""
    if own and key in OWN_TIME_CONSTANT:
        return {"name": OWN_TIME_CONSTANT[key]}
    fits = [f for f in kv.get("fits", []) if math.isfinite(f.get("cost", math.nan)) and f["name"] != SAME.get(key)
            and known_values.plausible_value(f["value"], f["table"])]
    if not fits:
        return None
    # a refit that reached the floor in the shooting windows went on to the standard ones (known_values._refit):
    # one value away from the floor but for what the modification, held at its value, leaves over the longer
    # windows.  It leads; the costs of the two stages' windows are not compared (measured: b1 21 % high beside a
    # 0.269 V pitch dead zone held at 0.2689 V, on a log whose pitch command hovers at the zone's edge: b1's refit
    # 0.12097 for 0.12101 left the yaw at 4.7x over the standard windows, Mg's shooting cost was the lower)
    shot = [f for f in fits if f.get("stage") == "windows"]
    return min(shot or fits, key=lambda f: f["cost"])


def best(tried: list[Hypothesis]) -> tuple[Hypothesis | None, list[Hypothesis]]:
    """The explaining hypothesis with the fewest parameters, then the angles nearest their floors (sum of squared
    ratios), and the others with as many parameters that explain the log too (its look-alikes)."""
    explaining = [h for h in tried if h.explains]
    if not explaining:
        return None, []
    fewest = min(h.parameters for h in explaining)
    same = sorted((h for h in explaining if h.parameters == fewest),
                  key=lambda h: sum(v * v for v in h.over_noise.values()))
    return same[0], same[1:]


def together(d, log: Log, p: dict, law: str, overrides: dict | None, refit, tries: list[Hypothesis] | None = None
             ) -> tuple[object | None, list]:
    """(the diagnosis ``d`` -- the effect search's, not at the noise floor, no known value alone reaching it --
    with one of its findings and, where needed, a known value together explaining the log (module docstring), or
    None when no hypothesis reaches the noise floor; the hypotheses tried, as settings["together"] lists them).
    ``refit(pp, est, start, findings)``: the findings' model's 2 s prediction fits, overlay and residual
    (weigh._refitted).  ``tries``: the hypotheses to estimate under (default: hypotheses(d))."""
    tried = estimated_under(hypotheses(d) if tries is None else tries, log, law, dict(overrides or {}))
    chosen, alikes = best(tried)
    record = [_record(t) for t in tried]
    if chosen is None:
        return None, record
    return _diagnosis(d, log, p, chosen, alikes, record, refit), record


def ranked_together(d, log: Log, p: dict, law: str, overrides: dict | None, refit, seen: set
                    ) -> tuple[object | None, list]:
    """together() over ranked(d, seen): the equation error's next-best effects of the first round, each estimated
    under with every known value freed in turn beside it (the last step of weigh.py's rule, when nothing before it
    reached the noise floor; ``seen``: the effects tried before, in together())."""
    out, record = together(d, log, p, law, overrides, refit, ranked(d, seen))
    if out is not None:
        out.settings["rule"] += ("; an effect the equation error ranked in its first round, passed or not, or a "
                                 "dead zone or saturation on either motor with its value freed (ranked)")
    return out, record


def _record(t: Hypothesis, lead: str | None = None) -> dict:
    return {"effect": t.key, "value": t.value, "fitted": t.fitted, "fits_alone": t.fits_alone,
            "known_value": t.value_names() if t.value_fit else None, "over_noise": t.over_noise,
            "error": t.error or None, **({"searched_under": lead} if lead else {}),
            **({"ranked_by_equation_error": True} if t.ranked_by is not None and not t.every_motor else {}),
            **({"on_each_motor": True} if t.every_motor else {})}


def leads(kv: dict, seed_worst: float) -> list[dict]:
    """The known values value_first tries, best-ranked first: plausible refits alone (the seed check's search,
    ``kv``) that left the worst angle within VALUE_FIRST_OVER_NOISE of its floor and within half the seed model's
    ``seed_worst`` (its worst angle over its floor), at most MAX_LEADS."""
    fits = [f for f in kv.get("fits", []) if math.isfinite(f.get("cost", math.nan)) and f.get("over_noise")
            and known_values.plausible_value(f["value"], f["table"])
            and max(f["over_noise"].values()) <= min(VALUE_FIRST_OVER_NOISE, 0.5 * seed_worst)]
    return sorted(fits, key=lambda f: f["cost"])[:MAX_LEADS]


def joint_lead(j, seed_worst: float) -> dict | None:
    """The joint search's set (known_values.KnownValueSet ``j``) as value_first's first lead: when it does not
    explain the log but left the worst angle as near its floor as a single value must to lead (leads()).  The
    forward search's best set of known values is the model the next difference is searched under, as a single
    value's refit is (measured, any_bench.py seed 33274 bench 33: yaw Coulomb friction beside T0 1.42x; no single
    refit freed T0, the score test ranking it last; the joint search took T0 to 4.90 for 4.97, and under that T0 the
    effect search finds the friction and the two, T0 freed beside it, explain the log)."""
    if j is None or j.explains or not j.over_noise:
        return None
    worst = max(j.over_noise.values())
    if not worst <= min(VALUE_FIRST_OVER_NOISE, 0.5 * seed_worst):
        return None
    return {"values": dict(j.values), "tables": dict(j.table), "how": "the joint search's refit"}


def value_first(d, log: Log, p: dict, law: str, overrides: dict | None, kv: dict, refit, search, joint=None
                ) -> tuple[object | None, list]:
    """(the diagnosis explained by a known value and the effects the search finds once that value is set, or None;
    the hypotheses tried).  ``search(overrides)``: the effect search's Diagnosis of ``log`` under those values
    (search.effect_search); ``refit`` as in together().  ``joint``: the joint search's set of known values
    (known_values.joint), which leads first where it may (joint_lead) and is not one of the single leads."""
    record = []
    given = dict(overrides or {})
    seed = [v.get("rms_over_noise", math.nan) for v in d.seed_check.get("axes", {}).values()]
    seed_worst = max((v for v in seed if math.isfinite(v)), default=math.nan)
    ordered = [{"values": {f["name"]: f["value"]}, "tables": {f["name"]: f["table"]}, "how": "its refit alone"}
               for f in leads(kv, seed_worst)]
    first = joint_lead(joint, seed_worst)
    if first is not None and not any(set(first["values"]) == set(s["values"]) for s in ordered):
        ordered.insert(0, first)
    for lead in ordered:
        name = ", ".join(lead["values"])
        try:
            with np.errstate(all="ignore"):
                d2 = search({**given, **lead["values"]})
        except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
            record.append({"searched_under": name, "error": str(exc)})
            continue
        tried = estimated_under(hypotheses(d2), log, law, given)
        if lead is first:
            # the joint search's values, which the known-value search under an effect need not rank (no single
            # refit freed T0 in the measured case, nor did it beside the effect): freed together beside each effect
            # that does not fit alone, from their joint refit
            at = {**given, **lead["values"]}
            tried = fan_out(lambda t: t if t.explains else _with_leads(t, tuple(lead["values"]), log, law, at, t,
                                                                       tables=lead["tables"]), tried)
        record += [_record(t, name) for t in tried]
        chosen, alikes = best(tried)
        if chosen is None:
            continue
        listed = ", ".join(f"{k} = {v:.4g}" for k, v in lead["values"].items())
        tables = ", ".join(f"{v:.4g}" for v in lead["tables"].values())
        again = f"; found by the effect search run again with {listed} ({lead['how']}) instead of {tables}"
        found = [replace(f, fit_before=d.fit_before.get(f.axis, f.fit_before), evidence=f.evidence + again)
                 for f in d2.findings]
        merged = replace(d, findings=found, steps=d2.steps, oe_tested=d2.oe_tested)
        out = _diagnosis(merged, log, p, chosen, alikes, record, refit)
        why = (f"with {name} refitted, the effect search finds {chosen.key} instead, and the two bring both angles to "
               "their noise floors: this finding is not needed")
        out.refused = out.refused + [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter["value"],
                                      "reason": why} for f in d.findings]
        out.settings["rule"] += "; the effect search run again under a known value's refit (value_first)"
        return out, record
    return None, record


def _effect_finding(d, h: Hypothesis, alikes: list[Hypothesis]) -> Finding:
    """The effect's finding: the search's own (its value the estimate's when freed), or the look-alike's new one."""
    others = [a.label() for a in alikes]
    c = room.BY_KEY[h.key]
    if h.finding is not None:
        f = d.findings[h.finding]
        value = h.fitted if math.isfinite(h.fitted) else f.parameter["value"]
        moved = float(value) != f.parameter["value"]
        again = (f"; estimated again in the model with {h.value_names()} free beside it: {value:.4g}"
                 if h.value_fit is not None and (h.key in TORQUE_KEYS or moved) else "")
        param = {**f.parameter, "value": float(value)}
        if moved:  # the search's interval was for its own value: the estimate's
            param.pop("ci95", None)  # (an interval that bench files carry, so estimate widens J/B's by it)
            if h.fitted_ci95 is not None and math.isfinite(h.fitted):  # value is then h.fitted
                param["ci95"] = list(h.fitted_ci95)
        # the sentence says the value the finding reports (it said the search's: "T2 = 0.232 s" above "a further
        # lag of 0.451 s", a second-order tail motor estimated again beside T21)
        return replace(f, parameter=param, evidence=f.evidence + again,
                       explanation=c.said(value) if moved else f.explanation,
                       alternatives=list(dict.fromkeys(f.alternatives + others)))
    value = h.fitted if math.isfinite(h.fitted) else h.value  # an input modification applied at its value
    beside = f" and {h.value_names()}" if h.value_fit is not None else ""
    param = {"name": c.parameter, "value": float(value), "unit": c.unit,
             **({"ci95": list(h.fitted_ci95)} if h.fitted_ci95 is not None and math.isfinite(h.fitted) else {})}
    explanation = c.said(value)
    if h.every_motor:  # freed_modifications: tried on each motor beside the known values, not ranked
        t = h.ranked_by or {}
        gain = (f" (the equation error's first round: held-out gain {t['held_out_gain']:.3g}, p = {t['p']:.3g})"
                if "held_out_gain" in t and "p" in t else "")
        return Finding(c.effect, c.axis, param, d.fit_before.get(c.axis, math.nan), math.nan,
                       f"an input modification the refinement estimates, tried on each motor with the known values "
                       f"refitted beside its freed value whatever the equation error made of it{gain}; estimated "
                       f"with J1, B1, J2, B2{beside}", explanation, float(t.get("held_out_gain", math.nan)),
                       float(t.get("t", math.nan)), float(t.get("p", math.nan)), others)
    if h.ranked_by is not None:  # proposed by the equation error's ranking (ranked()), not by the search's rounds
        t = h.ranked_by
        alone = ("it passed there but the search did not take it" if t.get("passed") else
                 "it did not pass alone, beside a difference the model still had")
        return Finding(c.effect, c.axis, param, d.fit_before.get(c.axis, math.nan), math.nan,
                       f"ranked by the equation error's first round (held-out gain {t['held_out_gain']:.3g}, p = "
                       f"{t['p']:.3g}: {alone}), put into the model and estimated with J1, B1, J2, B2{beside}",
                       explanation, float(t["held_out_gain"]), float(t["t"]), float(t["p"]), others)
    grown = next((f for f in d.findings if SECOND_ORDER_OF.get(f"{f.effect}:{f.axis}") == h.key), None)
    if grown is not None and not any(h.key in f.alternatives for f in d.findings):  # (hypotheses(): its motor)
        return Finding(c.effect, c.axis, param, grown.fit_before, math.nan,
                       f"that motor of second order in place of the search's {grown.effect}:{grown.axis} (a time "
                       f"constant off the table that left the log short of its floor): its further lag profiled and "
                       f"estimated with J1, B1, J2, B2{beside}", explanation, math.nan, math.nan, math.nan, others)
    origin = next(f for f in d.findings if h.key in f.alternatives)
    return Finding(c.effect, c.axis, param, origin.fit_before, math.nan,
                   f"put into the model in place of {origin.effect}:{origin.axis} (the effect search's finding, "
                   f"which it cannot tell from this one by the equation error) and estimated with J1, B1, J2, "
                   f"B2{beside}", explanation, math.nan, math.nan, math.nan,
                   [f"{origin.effect}:{origin.axis}"] + others)


def _diagnosis(d, log: Log, p: dict, h: Hypothesis, alikes: list, record: list, refit):
    effect = _effect_finding(d, h, alikes)
    findings = [effect]
    changes = {}
    words = f"{h.key} = {effect.parameter['value']:.4g} {effect.parameter.get('unit', '')}".rstrip()
    values = ([h.value_fit] if h.value_fit is not None else []) + list(h.more_values)
    for kv in values:
        name, value, table = kv["name"], kv["value"], kv["table"]
        changes[name] = value
        lo, hi = kv["ci95"]
        alternatives = list(h.look_alikes)
        others = [v["name"] for v in values if v["name"] != name]
        findings.append(known_value_finding(
            name, value, table, kv["unit"], (lo, hi), d.fit_before, math.nan,
            f"with {h.key} in the model (freed beside J/B where the refinement carries it), set free"
            f"{' together with ' + ', '.join(others) if others else ''} and refitted by "
            f"output error with J1, B1, J2, B2 and the start states, it brings the angles to "
            f"{kv['over_noise']['alpha']:.3g}x and {kv['over_noise']['beta']:.3g}x their noise floors; 95 % interval "
            f"{lo:.6g} to {hi:.6g} {kv['unit']}" + (f"; cannot be told apart with this log from "
                                                     f"{', '.join(alternatives)}" if alternatives else ""),
            alternatives=alternatives))
    if values:
        words += (" and the known value" + ("s " if len(values) > 1 else " ")
                  + ", ".join(f"{v['name']} = {v['value']:.4g} instead of {v['table']:.4g}" for v in values))
    est = dict(h.value_fit["estimates"]) if h.value_fit is not None else dict(d.augmented)
    start = (motor_states(h.value_fit.get("start_states") or {}) or None) if h.value_fit is not None else None
    fits_after, overlay, residual = refit({**p, **changes}, est, start, findings)
    for f in findings:
        f.fit_after = fits_after.get(f.axis, f.fit_after)
    kept = {d.findings[t.finding].effect + ":" + d.findings[t.finding].axis for t in [h] + alikes
            if t.finding is not None}  # the chosen one and its look-alikes are not refused
    why = (f"{words} bring both angles to their noise floors (the log estimated under that model, as "
           "`estimate --params` does): this finding is not needed")
    refused = list(d.refused) + [{"effect": f.effect, "axis": f.axis, "parameter": f.parameter["value"],
                                  "reason": why} for f in d.findings if f"{f.effect}:{f.axis}" not in kept]
    ratio = h.over_noise
    sentence = (f"the model fits the log to its noise level with {words} (both angles within "
                f"{RMS_OVER_NOISE:g}x their noise floors: {ratio.get('alpha', math.nan):.3g}x and "
                f"{ratio.get('beta', math.nan):.3g}x)")
    if len(values) == 1:
        sentence += (": two differences from the model it was given, an effect and a known value; neither alone "
                     "reaches the floor")
    elif values:
        sentence += (f": {len(values) + 1} differences from the model it was given, an effect and {len(values)} known "
                     "values; the values refitted together without the effect do not reach the floor")
    if alikes:
        sentence += (f"; {', '.join(a.label() for a in alikes)} would explain it as well with as many parameters: "
                     "this log cannot tell them apart")
    if h.value_fit is not None and h.look_alikes:
        sentence += f"; the known value could as well be {', '.join(h.look_alikes)}"
    sentence += "."
    settings = {**d.settings, "output_error_check": {"rms_over_noise": dict(ratio), "threshold": RMS_OVER_NOISE},
                "start_states_after": start, "estimates_augmented_from": "effect_with_known_value",
                "rule": "simplest explanation reaching the noise floor (diagnosis/weigh.py, diagnosis/compound.py)",
                "together": record}
    steps = [d.steps[h.finding]] if h.finding is not None and h.finding < len(d.steps) else []
    return replace(d, mismatch=True, findings=findings, augmented=est, fit_after=fits_after, overlay=overlay,
                   residual=residual, verdict="explained", verdict_sentence=sentence, refused=refused,
                   corrections=[], steps=steps, settings=settings)


def _worst(t: dict) -> str:
    """A try's record (_record) as its worst angle over its noise floor, for the verdict's words."""
    return f"{max(t['over_noise'].values()):.3g}x"


def tried_sentence(tried: list[dict]) -> str:
    """What the hypotheses left, for a verdict they did not change (settings["together"])."""
    if not tried:
        return ""
    parts = [f"{t['effect']} {_worst(t)}" for t in tried if t.get("over_noise")]
    return (" Each finding put into the model and the log estimated under it, with each known value freed in turn, "
            f"leaves the worst angle above its noise floor ({', '.join(parts)}).") if parts else ""


def later_tries_sentence(tried: list[dict]) -> str:
    """What the rule's later steps left, for a verdict they did not change: the effects the search found again under
    a known value's refit (value_first, ``searched_under``) and the equation error's next-ranked effects (ranked,
    ``ranked_by_equation_error``), each as its worst angle over its noise floor."""
    under = [f"{t['effect']} with {t['searched_under']} refitted {_worst(t)}" for t in tried
             if t.get("searched_under") and t.get("effect") and t.get("over_noise")]
    ranked = [f"{t['effect']} {_worst(t)}" for t in tried if t.get("ranked_by_equation_error") and t.get("over_noise")]
    each = [f"{t['effect']} {_worst(t)}" for t in tried if t.get("on_each_motor") and t.get("over_noise")]
    out = ""
    if under:
        out += (" The effect search run again under the known values whose refits came nearest the floor finds "
                f"effects that leave the worst angle above its noise floor too ({', '.join(under)}).")
    if ranked:
        out += (" The equation error's next-ranked effects of its first round, each estimated under with each known "
                f"value freed in turn, leave the worst angle above its floor too ({', '.join(ranked)}).")
    if each:
        out += (" A dead zone or a saturation on each motor, its value freed with each known value in turn, leaves "
                f"the worst angle above its floor too ({', '.join(each)}).")
    return out
