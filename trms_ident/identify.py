"""The identification pipeline: Log -> plant regressors -> filters -> DREM -> refinement -> Result.

Pure: arrays and settings in, a Result out.  No files, no printing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .errors import IdentificationError, SettingsError
from .log import Log
from .model.bench import KERNEL_KEYS
from .numerics.design import FilterDesign, angle_noise_rad, design_filters, quantization_step
from .numerics.quantization import OFFSETS as QUANTIZATION_OFFSETS
from .numerics.fused import drem_summaries, start_unknowns
from .numerics.adequacy import (NOT_CONVERGED, NUMERICAL_FLOOR_RAD, RMS_OVER_NOISE, SMOOTHED_FLOOR_RAD, UNMEASURABLE,
                                judging_floors, model_check)
from . import known_values
from .known_values import over_noise as _over_noise
from .numerics.refine import SHOOTING_WINDOW_S, WINDOW_S, Refined, refine, substeps
from .numerics.stats import (IDENTIFIABLE_REL_HALF_WIDTH, MIN_BLOCKS, Z95, Interval, block_length,
                             interval_from_sums)
from .params import ESTIMATED, merge
from .settings import AXES, GAIN_CONVENTIONS, HEADLINES, MAX_TRACE_POINTS, REFINE_AUTO_MAX_STEPS, Settings

__all__ = ["AXES", "GAIN_CONVENTIONS", "HEADLINES", "AxisResult", "Result", "Settings", "identify"]

@dataclass
class AxisResult:
    axis: str
    phi_energy: float  # sum(phi^2) dt of det M(t), eq. (7): how much the log excites this axis (convention-
    # dependent scale); phi and eps themselves are not kept (on an hour-long log they are 87 MB per axis)


@dataclass
class Result:
    t_s: np.ndarray  # times of the trace points [s]
    traces: dict[str, np.ndarray]  # DREM estimate traces, eq. (8), every trace_step-th sample
    trace_step: int
    drem_final: dict[str, float]
    offline: dict[str, float]  # sum(eps phi) / sum(phi^2) per parameter
    offline_intervals: dict[str, Interval]  # 95 % intervals of the offline optimum; identifiability
    refined: Refined | None  # prediction-error refinement (None when not run)
    refine_note: str  # whether the refinement ran or was used, and why
    headline: str  # which estimate the headline numbers are: "refined", "offline" or "drem"
    intervals: dict[str, Interval]  # 95 % intervals of the headline numbers; identifiability
    estimates: dict[str, float | None]  # headline numbers; None where not identifiable
    axes: dict[str, AxisResult]
    parameters: dict[str, float]  # every model value used (table + overrides)
    settings: Settings  # as used: designed bandwidths filled in
    design: FilterDesign | None  # how the bandwidths were chosen (None when given)
    sample_time_s: float
    model_check: dict  # the adequacy verdict (numerics/adequacy.py): does the model fit this log?
    simulated: np.ndarray | None  # (m, 2) the check's simulated alpha, beta [rad] at the first m samples


def resolve_filters(log: Log, settings: Settings) -> tuple[Settings, FilterDesign | None]:
    """Fill in data-designed bandwidths where the settings leave them open."""
    if settings.filter_a_rad_s is not None:
        b = settings.filter_b_rad_s if settings.filter_b_rad_s is not None else 2.0 * settings.filter_a_rad_s
        return replace(settings, filter_b_rad_s=b), None
    design = design_filters(log.alpha_rad, log.beta_rad, log.sample_time_s)
    b = settings.filter_b_rad_s if settings.filter_b_rad_s is not None else design.b_rad_s
    if b == design.a_rad_s:
        raise SettingsError(f"--b {b} equals the designed a; choose another b")
    return replace(settings, filter_a_rad_s=design.a_rad_s, filter_b_rad_s=b), design


def on_uniform_grid(log: Log, params: dict, structure: dict | None = None) -> tuple[Log, tuple | None]:
    """DREM's filters run on a uniform grid.  A jittered log is evaluated on the grid of its mean step:
    angles by cubic-spline interpolation (continuous signals), the motor and M_R states exactly, with every
    voltage held over its real interval (numerics/hold.py; M_R driven by u1 itself where the bench's ``structure``
    says so).  Uniform logs pass unchanged (motor None)."""
    if log.held_at_stamps:
        return log, None
    from .numerics.hold import motor_states_on_grid

    if log.uniform:
        grid = log.t_s
        ang = np.column_stack([log.alpha_rad, log.beta_rad])
    else:
        from scipy.interpolate import CubicSpline

        grid = log.t_s[0] + np.arange(len(log)) * log.sample_time_s
        grid[-1] = min(grid[-1], log.t_s[-1])
        ang = CubicSpline(log.t_s, np.column_stack([log.alpha_rad, log.beta_rad]))(grid)
    from .model.structure import reaction_voltage

    sw = log.t_s[:, None] + log.switch_offsets_s()
    m = motor_states_on_grid(sw[:, 0], log.u1_v, log.u2_v, grid, params, t2_s=sw[:, 1],
                             reaction_voltage=reaction_voltage(structure))
    motor = (m[:, 0], m[:, 1], reaction_moment_on_grid(sw[:, 0], log.u1_v, log.u2_v, grid, params, structure, m))
    held = np.searchsorted(log.t_s, grid, side="right") - 1  # the voltage in force (plots; a voltage gyroscope)
    return replace(log, t_s=grid, u1_v=log.u1_v[held], u2_v=log.u2_v[held], alpha_rad=ang[:, 0],
                   beta_rad=ang[:, 1], u_switch_s=None), motor


def reaction_moment_on_grid(t_s: np.ndarray, u1_v: np.ndarray, u2_v: np.ndarray, grid_s: np.ndarray, params: dict,
                            structure: dict | None, motor: np.ndarray | None = None) -> np.ndarray:
    """M_R [N m] at the grid times with every voltage held from its stamp ``t_s`` (numerics/hold.py): eq. (1)'s,
    driven by tau1, or (the bench's ``structure``: model/structure.py) driven by the voltage u1 itself, whose direct
    term takes the voltage in force at each grid time.  ``motor``: motor_states_on_grid's result under the same
    structure when the caller has it."""
    from .model.structure import reaction_voltage
    from .numerics.hold import motor_states_on_grid, reaction_moment

    rv = reaction_voltage(structure)
    if motor is None:
        motor = motor_states_on_grid(t_s, u1_v, u2_v, grid_s, params, reaction_voltage=rv)
    drive = u1_v[np.maximum(np.searchsorted(t_s, grid_s, side="right") - 1, 0)] if rv else motor[:, 0]
    return reaction_moment(drive, motor[:, 2], params)


def under_model(log: Log, params: dict, effects: dict, kernel: bool = False, free: tuple = ()
                ) -> tuple[Log, dict]:
    """The log and known values as the bench's model sees them (model/bench.py): the voltages through its input
    modifications (dead zone, saturation, transport delay, second-order motor), a motor time constant in place of
    T11 or T21, the angles with an acquisition lag undone (diagnosis.model.observed_log).  Its torque effects are
    the refinement's (model_kw).  Unchanged without modifications.  ``kernel``: as the output-error refinement
    sees it, the modifications it integrates itself (model.bench.KERNEL_KEYS: a second-order motor's further
    lag, exact within each sample interval; model_kw hands it over) left out of the voltages, and so are the
    saturations ``free`` names (model.bench.NATIVE_FREE_KEYS: the refinement clips the voltages itself)."""
    from .model.bench import MODIFICATION_KEYS, inside_fit
    from .model.effects import SENSOR_LAG

    mods = {k: v for k, v in effects.items() if k in MODIFICATION_KEYS and not (kernel and k in inside_fit(free))}
    if not mods:
        return log, params
    from .diagnosis.model import modified_inputs, observed_log

    lag = mods.pop(SENSOR_LAG, None)
    if lag is not None:
        log = observed_log(log, lag)
    u1, u2, changes = modified_inputs(log, mods)
    return replace(log, u1_v=np.array(u1, dtype=float), u2_v=np.array(u2, dtype=float)), {**params, **changes}


def model_name(settings: Settings) -> str:
    """'eq. (1)', or 'eq. (1) + a second-order tail motor (T2 = 0.463 s)' under a bench file's effects."""
    from .model.bench import BenchEffect, describe
    from .model.structure import phrases

    return describe(tuple(BenchEffect(k, float(v)) for k, v in settings.effects.items())) + "".join(
        f" + {p}" for p in phrases(settings.structure))


def refined_free(settings: Settings) -> tuple:
    """The values the refinement estimates with J/B: known values, torque effects and saturation levels (--free);
    another input modification's value freed is profiled outside it (model_profile.py)."""
    from .model.bench import MODIFICATION_KEYS, NATIVE_FREE_KEYS

    return tuple(k for k in settings.free if k not in MODIFICATION_KEYS or k in NATIVE_FREE_KEYS)


def model_kw(settings: Settings, values: dict | None = None, log: Log | None = None, params: dict | None = None,
             n: int | None = None, start: dict | None = None) -> dict:
    """refine's ``effects``: the bench's torque effects at their values (``values``: freed ones' estimates in
    their place), the modifications the kernel integrates (model.bench.KERNEL_KEYS, and the saturations freed:
    NATIVE_FREE_KEYS, on voltages from under_model(..., kernel=True, free=settings.free)) and the bench's structure
    (model.structure.slot_values); empty under eq. (1) alone.  With the bench's terms (model/terms.py) and ``log``
    (the refinement's, its first ``n`` samples) and ``params``, refine's ``torques`` too: each term's torque per
    unit c from the log's angles, smoothed rates and the motor states its voltages drive (term_torques) from
    ``start`` (a fit's start_states) when given."""
    from .model.bench import inside_fit, is_term, is_torque
    from .model.structure import slot_values

    inside = inside_fit(settings.free)
    effects = {k: (values or {}).get(k, v) for k, v in settings.effects.items() if is_torque(k) or k in inside}
    effects.update(slot_values(settings.structure))
    out = {"effects": effects} if effects else {}
    terms = tuple(k for k in settings.effects if is_term(k))
    if terms and log is not None:
        # the motor states a term reads see the voltages through the modifications the fit applies itself too
        out["torques"] = term_torques(log, params, settings.thrust_law, terms, n,
                                      {k: v for k, v in settings.effects.items() if k in inside}, start)
    return out


def term_torques(log: Log, params: dict, law: str, keys: tuple, n: int | None = None, inside: dict | None = None,
                 start: dict | None = None) -> dict:
    """key -> (n, 2) torque per unit c [N m / unit] on pitch and yaw of each term ``keys`` names (model/terms.py), on
    the first ``n`` samples of ``log``: the signals of the whole log (its smoothed rates, the motor states its
    voltages drive under ``params``; diagnosis.oe.unit_torques), cut after.  ``inside``: the modifications the
    output-error fit applies itself (a second-order motor's lag, a freed saturation: key -> value), which the
    voltages go through first (as diagnose's fit does).  ``start``: the motor states' start (a fit's start_states;
    default: the steady state of the first voltages)."""
    from .diagnosis.model import modified_inputs
    from .diagnosis.oe import unit_torques

    n = len(log) if n is None else n
    u1, u2 = modified_inputs(log, inside)[:2] if inside else (None, None)
    return {k: np.ascontiguousarray(t[:n])
            for k, t in unit_torques(log, params, law, keys, u1, u2, start=start).items()}


def timing(log: Log, n: int | None = None) -> dict:
    """The refinement's view of the first n samples' time: stamps when they jitter, voltage switch delays
    when the voltages act at their own times (refine's ``t_s`` and ``switch_delay_s``)."""
    n = len(log) if n is None else n
    return {"t_s": None if log.uniform else log.t_s[:n],
            "switch_delay_s": None if log.u_switch_s is None else log.switch_offsets_s()[:n]}


def identify(log: Log, settings: Settings | None = None, halves: bool = True, start: dict | None = None) -> Result:
    """Estimate J1, B1, J2, B2 from a validated log with the DREM procedure (eqs. 3-8).  ``halves``: when the
    log's noise floor cannot be measured and the verdict is not decided, each half of the log is estimated too
    (_halves_check).  ``start``: a fit of the same model made elsewhere (diagnose's with its findings), J1, B1, J2,
    B2 and, under "start_states", the motor start states: the refinement's first start, before DREM's (_refine)."""
    settings = settings or Settings()
    given = log
    settings.validate()
    from .model.bench import MODIFICATION_KEYS, NATIVE_FREE_KEYS

    profiled = [k for k in settings.free if k in MODIFICATION_KEYS and k not in NATIVE_FREE_KEYS]
    if profiled:  # the refinement has no sensitivity for them: model_profile.identify_with_profiles fits them
        raise SettingsError(f"--free {', '.join(profiled)}: an input modification's value is profiled "
                            "(model_profile.identify_with_profiles), not estimated by identify")
    params = merge(settings.overrides, source="parameter overrides")
    given_params = params
    # the refinement's voltages (model_kw)
    log, params = under_model(log, params, settings.effects, kernel=True, free=settings.free)
    # DREM's regressions see every modification, the kernel's lags too (the same log when there are none)
    drem_log = (under_model(given, given_params, settings.effects)[0]
                if _lagged(settings) else log)
    _long_enough(log, params)
    grid_log, motor = on_uniform_grid(drem_log, params, settings.structure)
    settings, design = resolve_filters(grid_log, settings)
    dt = log.sample_time_s
    f_gain, h_gain = settings.filter_gains()
    block = block_length(len(log), dt, 1.0 / min(settings.filter_a_rad_s, settings.filter_b_rad_s))
    step = max(1, math.ceil(len(log) / MAX_TRACE_POINTS))
    gamma = {axis: tuple(settings.gamma.get(name) if settings.gamma else None for name in AXES[axis]) for axis in AXES}
    # eqs. (1), (3), (5)-(8) in compiled passes per axis, the axes in parallel; phi and eps are summed, not kept
    skip = stop_samples(grid_log, settings.structure, settings.filter_a_rad_s, settings.filter_b_rad_s)
    for axis, left in (skip or {}).items():
        if left.all():
            from .model.structure import phrases

            raise IdentificationError(
                f"{log.source}: the {axis} angle sits at or near its end stops "
                f"({'; '.join(phrases(settings.structure))}) on every sample"
                + (" or settles after the yaw's strike on its own" if axis == "pitch" else "") + ", so no sample tells "
                f"{', '.join(AXES[axis])}; check the angles' unit (--angle-unit) and the stops of the bench file's "
                "[structure]")
    summaries = drem_summaries(grid_log.u1_v, grid_log.u2_v, grid_log.alpha_rad, grid_log.beta_rad, dt, params,
                               settings.thrust_law, settings.filter_a_rad_s, settings.filter_b_rad_s, f_gain, h_gain,
                               motor, block=block, gamma=gamma, rate_per_s=math.log(100.0) / settings.settle_time_s,
                               step=step, structure=settings.structure, skip=skip)
    # known bias bounds added to the interval: errors in variables (designed filters only) and the bilinear
    # transform's relative magnitude error at the fastest filter pole, (w dt)^2 / 12
    warp = (max(settings.filter_a_rad_s, settings.filter_b_rad_s) * dt) ** 2 / 12.0
    traces, drem_final, offline, intervals, axes = {}, {}, {}, {}, {}
    for axis, sm in summaries.items():
        if not (math.isfinite(sm.energy) and sm.energy > 0):
            raise IdentificationError(
                f"{log.source}: the {axis} axis is not excited: det M is zero over the whole log "
                f"(constant input and angle?); {', '.join(AXES[axis])} cannot be identified")
        bias = (design.predicted_bias[axis] if design else 0.0) + warp
        # the start taken as unknown, not as rest (fused.start_unknowns)
        off = start_unknowns(axis, sm, grid_log.u1_v, grid_log.u2_v, grid_log.alpha_rad, grid_log.beta_rad, dt,
                             params, settings.thrust_law, settings.filter_a_rad_s, settings.filter_b_rad_s, f_gain,
                             h_gain, motor, block, structure=settings.structure, left=(skip or {}).get(axis))
        # blocks whose every sample sat at a stop hold nothing: counted, their zero scores would narrow the interval
        used = sm.block_sums[:, 0] > 0 if axis in (skip or {}) else np.ones(len(sm.block_sums), dtype=bool)
        for i, name in enumerate(AXES[axis]):
            traces[name], drem_final[name] = sm.trace[:, i], float(sm.final[i])  # eq. (8)
            intervals[name] = interval_from_sums(float(off.energy[i]), float(off.cross[i]), off.block_energy[used, i],
                                                 off.block_cross[used, i], bias_bound=bias)
            offline[name] = intervals[name].estimate
        axes[axis] = AxisResult(axis, sm.energy * dt)

    refined, note, usable = _refine(log, settings, params, offline, start)
    check, simulated = _model_check(log, settings, params, refined, offline)
    headline = settings.headline
    if headline == "refined" and not usable:
        headline = "offline"
    if headline == "refined":
        head_intervals = {k: refined_interval(refined, k) for k in ESTIMATED}
        chosen = refined.estimate
    else:
        head_intervals = intervals
        chosen = offline if headline == "offline" else drem_final
    estimates = {k: (chosen[k] if head_intervals[k].identifiable else None) for k in ESTIMATED}
    if halves and check.get("undecided_because") == UNMEASURABLE:
        _halves_check(given, settings, check)
    return Result(grid_log.t_s[::step], traces, step, drem_final, offline, intervals, refined, note, headline,
                  head_intervals, estimates, axes, params, settings, design, dt, check, simulated)


#: how long after an angle leaves its end stop DREM's regressions still carry the stop's contact torque, in the
#: slower filter's time constants 1/a: the double pole's impulse response t e^(-a t) falls below 1e-4 of its peak
#: after about 12/a
STOP_SETTLE_TIME_CONSTANTS = 12.0


def stop_tolerance_rad(log: Log, x: np.ndarray) -> float:
    """How close to an end stop an angle ``x`` of ``log`` rests on it [rad]: three encoder steps, four times its
    noise level, or 1e-4 rad, whichever is largest."""
    t = None if log.uniform else log.t_s
    return max(3.0 * quantization_step(x), 4.0 * angle_noise_rad(x, t), 1e-4)


def at_stops(log: Log, structure: dict) -> dict:
    """{axis: (n,) bool}: where the angle rests on an end stop of the bench's structure (model/structure.py): within
    stop_tolerance_rad of it; only the axes with stops that reach them."""
    from .model.structure import stops

    out = {}
    for axis, x in (("pitch", log.alpha_rad), ("yaw", log.beta_rad)):
        s = stops(structure, axis)
        if s is None:
            continue
        tol = stop_tolerance_rad(log, x)
        at = (x <= s[0] + tol) | (x >= s[1] - tol)
        if at.any():
            out[axis] = at
    return out


#: an angle that lies at its smallest or largest value (within stop_tolerance_rad) this long in all [s] may rest
#: on an end stop there (resting_extremes).  A beam on its stop lies there until the thrust lifts it: the CE150's
#: published model from rest, 1.2-1.5 s; at 0.5 s a saturated pitch and a yaw held by Coulomb friction of our
#: simulator (seed 3, 40 s at 200 Hz), 0.6 s each at their extremes, were taken for stops (diagnosis.run)
MIN_STOP_REST_S = 1.0


def resting_extremes(log: Log) -> list[dict]:
    """Where each angle lies at its smallest or largest value for at least MIN_STOP_REST_S in all: the end stops the
    log may show, [{"axis", "side" ("low"/"high"), "rad" (the extreme), "at" ((n,) bool, the samples resting
    there), "tol_rad"}].  The data say only that the angle went no further; whether a stop held it there, not the
    torques, is for a fit to say (diagnosis.run)."""
    out = []
    need = int(math.ceil(MIN_STOP_REST_S / log.sample_time_s))
    for axis, x in (("pitch", log.alpha_rad), ("yaw", log.beta_rad)):
        tol = stop_tolerance_rad(log, x)
        for side, edge in (("low", float(np.min(x))), ("high", float(np.max(x)))):
            at = (x <= edge + tol) if side == "low" else (x >= edge - tol)
            if np.count_nonzero(at) >= need:
                out.append({"axis": axis, "side": side, "rad": edge, "at": at, "tol_rad": tol})
    return out


def stop_samples(log: Log, structure: dict, a_rad_s: float, b_rad_s: float) -> dict | None:
    """{axis: (n,) bool}: the samples DREM leaves out of an axis' regression: where its angle rests on an end stop
    of the bench's structure (at_stops: within a few encoder steps or noise levels of it), and the samples
    after it while the filters still carry the stop's contact torque (eq. 1 has none: the stop holds the angle,
    not the torques); on the pitch also the instants the yaw strikes or leaves its stop and the filters' settling
    after them (the gyroscope reads beta').  None when the structure has no stops, or the angles never reach them."""
    out = {}
    settle = int(math.ceil(STOP_SETTLE_TIME_CONSTANTS / min(a_rad_s, b_rad_s) / log.sample_time_s))
    n = len(log)

    def reached(idx: np.ndarray) -> np.ndarray:  # the samples idx and the next `settle` after each
        reach = np.zeros(n + 1, dtype=np.int64)
        np.add.at(reach, idx, 1)
        np.add.at(reach, np.minimum(idx + settle + 1, n), -1)
        return np.cumsum(reach[:-1]) > 0

    contacts = at_stops(log, structure)
    for axis, at in contacts.items():
        out[axis] = reached(np.flatnonzero(at))
    if "yaw" in contacts:
        # the pitch's torque reads beta' (eq. 1's gyroscope), which jumps where the yaw strikes or leaves its stop,
        # and beta' by central difference is wrong there: those instants reach the pitch's filters too (the CE150's
        # azimuth sweep: its second half's J1 rested on its one strike at +130 deg, +13 % with a = 10 rad/s)
        edges = np.flatnonzero(np.diff(contacts["yaw"].astype(np.int8))) + 1
        near = np.unique(np.clip(np.concatenate([edges - 2, edges - 1, edges]), 0, n - 1))
        struck = reached(near)
        out["pitch"] = out["pitch"] | struck if "pitch" in out else struck
    return out or None


#: the halves check's family-wise level: the chance that J/B the halves both determine are said to differ when the
#: model is right (over every value compared)
HALVES_LEVEL = 0.01


def _halves_check(log: Log, settings: Settings, check: dict) -> None:
    """A log whose noise floor cannot be measured (smoothed or interpolated angles) leaves a verdict undecided:
    the model simulates it as well as a black box, and a finer misfit cannot be told from noise.  What the log
    can still show is whether the model's J/B stay the same along it: each half is estimated alone, and the
    values both halves determine are compared (z of their difference over both intervals, family-wise at
    HALVES_LEVEL).  Halves that differ are a misfit this log measures: the verdict becomes "does not fit",
    and the intervals, which measure the noise alone, are then read as conditional.  Halves that agree leave
    it undecided; ``check["halves"]`` records what was compared either way."""
    from scipy.special import ndtri

    n = len(log)
    parts = {}
    for name, part in (("first", log.span(0, n // 2)), ("second", log.span(n // 2, n))):
        try:
            r = identify(part, settings, halves=False)
        except (IdentificationError, SettingsError, np.linalg.LinAlgError, FloatingPointError) as exc:
            check["halves"] = {"compared": [], "why_not": f"the {name} half could not be estimated ({exc})"}
            return
        parts[name] = {k: (r.estimates[k], r.intervals[k].low, r.intervals[k].high) for k in ESTIMATED
                       if r.estimates[k] is not None and math.isfinite(r.intervals[k].low)}
    both = [k for k in ESTIMATED if k in parts["first"] and k in parts["second"]]
    z = {}
    for k in both:
        (a, alo, ahi), (b, blo, bhi) = parts["first"][k], parts["second"][k]
        se = math.hypot((ahi - alo) / 2.0, (bhi - blo) / 2.0) / Z95
        z[k] = abs(a - b) / se if se > 0 else math.inf
    crit = float(-ndtri(HALVES_LEVEL / (2 * max(len(both), 1))))  # the normal's upper quantile
    differ = [k for k in both if z[k] > crit]
    check["halves"] = {"compared": both, "z": z, "critical_z": crit, "level": HALVES_LEVEL, "differ": differ,
                       "first": parts["first"], "second": parts["second"]}
    if not both:
        check["halves"]["why_not"] = "no value is determined by both halves"
        return
    if not differ:
        check["sentence"] += (f" Each half of the log alone gives the same {', '.join(both)} within their intervals "
                              "(the halves check): no misfit this log can measure.")
        return
    def told_apart(k: str) -> str:  # as many digits as tell the two halves' values and intervals apart
        (a, alo, ahi), (b, blo, bhi) = parts["first"][k], parts["second"][k]
        d = next((d for d in range(4, 10) if len({f"{v:.{d}g}" for v in (a, b, alo, ahi)}) == 4 and
                  len({f"{v:.{d}g}" for v in (a, b, blo, bhi)}) == 4), 10)
        return (f"{k} {a:.{d}g} [{alo:.{d}g}, {ahi:.{d}g}] on the first half, {b:.{d}g} [{blo:.{d}g}, {bhi:.{d}g}] "
                f"on the second (z = {z[k]:.3g})")

    said = "; ".join(told_apart(k) for k in differ)
    check["adequate"] = False
    check["undecided_because"] = None
    fits = ", ".join(f"{a} {v['fit_percent']:.2f} %" for a, v in check["axes"].items())
    check["sentence"] = (
        "The model does NOT fit this log: its J/B change along it: " + said + f", beyond what the halves' "
        f"intervals allow (|z| > {crit:.3g}, family-wise {100 * HALVES_LEVEL:g} %; simulation fit {fits}). The "
        "angles carry less noise than any encoder leaves, so the noise floor cannot be measured, and the model "
        "simulates them as well as a flexible black-box model does: this drift is the misfit the log shows. The "
        "estimates are those of a model that misses something, and their intervals, which measure the noise "
        "alone, are conditional on it; run `trms-ident diagnose` on the log, and check the known values.")


def slowest_time_constant_s(params: dict) -> tuple[float, str]:
    """The slowest time constant of eq. (1)'s known dynamics [s], and its name: the motor lags T11/T10, T21/T20
    and the reaction lag Tp, whose states when the log begins are unknowns the estimate must determine."""
    lags = {"the main motor's lag T11/T10": params["T11"] / params["T10"],
            "the tail motor's lag T21/T20": params["T21"] / params["T20"], "the reaction lag Tp": params["Tp"]}
    name = max(lags, key=lags.get)
    return lags[name], name


def _long_enough(log: Log, params: dict) -> None:
    """A log shorter than the slowest time constant it must determine is refused, with the length it needs: the
    motor and lag states it starts in cannot be told from J and B over it (a 0.05 s slice gave B1 8 000x the
    table under "does not fit")."""
    need, name = slowest_time_constant_s(params)
    if log.duration_s < need:
        raise IdentificationError(
            f"{log.source}: the log is {log.duration_s:.3g} s long; expected at least {need:.3g} s ({name} = "
            f"{need:.3g} s with these known values: the motor and lag states the log starts in are unknowns, and "
            "a shorter log cannot tell them from J and B)")


#: the refined fit must leave angle errors within this factor of the noise level, or the model misses
#: something and its (precise-looking) refined numbers are not used (the adequacy verdict's own threshold)
ADEQUATE_RMS_OVER_NOISE = RMS_OVER_NOISE


#: when the refinement did not run, the check's own output-error fit covers at most this many integration
#: steps (about 4 min at 1 kHz, ~0.5 s): enough samples for the verdict, a bounded cost on hour-long logs
CHECK_MAX_STEPS = REFINE_AUTO_MAX_STEPS // 4


def _usable_start(offline: dict) -> bool:
    """DREM's offline optimum can start the refinement only when every value is finite and positive."""
    return all(math.isfinite(offline[k]) and offline[k] > 0 for k in ESTIMATED)


def refine_first(log: Log, n: int, params: dict, settings: Settings, start: dict, noise: dict,
                 free: tuple = (), **options) -> Refined:
    """The refinement on the log's first n samples, with its stamps and voltage switch times; ``options``:
    refine's (window_s, start_states0).  Under a bench's terms (model/terms.py), whose torques are computed outside
    the fit from the motor states the voltages drive, those motor states start where the fit's own do
    (diagnosis.oe.settled_starts)."""
    def run(s, kw, **o):
        return refine(log.u1_v[:n], log.u2_v[:n], log.alpha_rad[:n], log.beta_rad[:n], log.sample_time_s, params,
                      settings.thrust_law, s, noise, free=free, **kw, **timing(log, n), **o)

    kw = model_kw(settings, log=log, params=params, n=n)
    r = run(start, kw, **options)
    if "torques" not in kw:
        return r
    from .diagnosis.oe import settled_starts, steady_start

    def again(at, prev):
        first = {k: prev.estimate[k] for k in ESTIMATED}
        if not _usable_start(first):
            return None
        return run(first, model_kw(settings, log=log, params=params, n=n, start=at),
                   **{**options, "start_states0": at})

    return settled_starts(again, r, steady_start(log.u1_v, log.u2_v, params))



#: motor and reaction-lag start states at rest, a second way into the fit when the steady state of the first
#: voltages leads to a wrong basin
MOTORS_AT_REST = {"tau1_0": 0.0, "tau2_0": 0.0, "zeta_0": 0.0, "lag1_0": 0.0, "lag2_0": 0.0}


def _settled(r: Refined, noise: dict) -> bool:
    """The fit converged and leaves both angles at the noise level: no further start can do better."""
    return r.converged and max(_over_noise(r, noise).values()) <= ADEQUATE_RMS_OVER_NOISE


def noise_floors(log: Log, n: int) -> dict:
    """The angles' measurement-noise floor [rad] over the first n samples."""
    t = None if log.uniform else log.t_s[:n]
    return {"alpha": angle_noise_rad(log.alpha_rad[:n], t), "beta": angle_noise_rad(log.beta_rad[:n], t)}


def _model_check(log: Log, settings: Settings, params: dict, r: Refined | None, offline: dict
                 ) -> tuple[dict, np.ndarray | None]:
    """The adequacy verdict from the best fit the model reaches: the refinement's simulation when it ran,
    else an output-error fit made for the check alone over at most CHECK_MAX_STEPS integration steps."""
    dt = log.sample_time_s
    scope = (f"output-error simulation of {model_name(settings)} at the refined parameters, in {WINDOW_S:g} s "
             "windows from fitted starts (start states estimated)")
    n = len(log) if r is not None else min(len(log), max(CHECK_MAX_STEPS // substeps(dt), 10))
    noise = noise_floors(log, n)
    if r is None:
        start = offline if _usable_start(offline) else {k: params[k] for k in ESTIMATED}
        try:
            r = refine_first(log, n, params, settings, start, noise)
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError) as e:
            return {"adequate": False, "axes": {}, "simulation": "none", "caution": None,
                    "sentence": f"The model could not be fitted to this log for the adequacy check ({e}); treat "
                                "every number as unverified."}, None
        scope = (f"output-error fit of {model_name(settings)} made for this check over the first {n * dt:.6g} s (of "
                 f"{log.duration_s:.6g} s), in {WINDOW_S:g} s windows from fitted starts; the headline estimate "
                 "is not this fit")
    y = np.column_stack([log.alpha_rad[:n], log.beta_rad[:n]])
    u = np.column_stack([log.u1_v[:n], log.u2_v[:n]])
    check = model_check(y, r.prediction, u, noise, dt, scope, window_s=r.window_s)
    check["converged"] = bool(r.converged)
    if not check["adequate"] and not r.converged and _could_still_fit(r, n):
        _undecided(check, r)
        return check, r.prediction
    if check["adequate"] is False:
        _blame(check, log, settings, params)
    if check["caution"]:  # said last, after what the data blame
        check["sentence"] += check["caution"]
    return check, r.prediction


def _lagged(settings: Settings) -> bool:
    """Does the model hold a second-order motor (a further lag, whose start state the refinement estimates too)?"""
    return any(k in settings.effects for k in KERNEL_KEYS)


def _could_still_fit(r: Refined, n: int) -> bool:
    """Could the fit that stopped short still reach the adequacy threshold?  Its cost (noise-weighted squared
    angle errors over 2 angles x n samples) less what one more full Gauss-Newton step predicts it would remove,
    against the cost at which both angles sit at RMS_OVER_NOISE x their floor.  A real CE150 sweep left 3.3e20
    with 1.7e19 to gain: that misfit is decided whether or not the fit had converged."""
    return r.cost - max(r.pending_decrease, 0.0) <= 2.0 * n * RMS_OVER_NOISE ** 2 + 1e-9 * r.cost


def _undecided(check: dict, r: Refined) -> None:
    """A fit that stopped short of its optimum decides nothing: the errors it leaves are an unfinished fit's,
    not the model's.  ``adequate`` is then None (neither fits nor does not fit), and the sentence says so."""
    ratios = ", ".join(f"{a} {v['rms_over_noise']:.3g}x" for a, v in check["axes"].items())
    check["adequate"] = None
    check["caution"] = None
    check["undecided_because"] = NOT_CONVERGED
    check["sentence"] = (
        f"Not decided: the output-error fit did not converge (Gauss-Newton stopped after {r.iterations} "
        f"iteration(s) while still lowering the angle error; it left {ratios} the noise level), so this log "
        "says neither that the model fits nor that it does not. The estimates carry no adequacy verdict. Try a "
        "longer recording, or one with more excitation; the intervals are those of DREM where shown.")


#: the known-value search (known_values.py) runs about three dozen passes over the log: on at most this many
#: integration steps of its beginning
SUSPECT_MAX_STEPS = REFINE_AUTO_MAX_STEPS // 4


def known_value_fit(log: Log, settings: Settings, check: dict | None = None
                    ) -> tuple[known_values.Fit, dict, int]:
    """The output-error fit the known-value searches run (known_values.search, and diagnose's known_values.joint):
    (fit, the angles' floors [rad] there, samples), on the log's first SUSPECT_MAX_STEPS integration steps.
    ``check``: the seed model's model_check, whose black-box floor stands in for a noise floor the log cannot
    measure (adequacy.judging_floors), for the fits' weights and for the verdict on them alike."""
    n = min(len(log), max(SUSPECT_MAX_STEPS // substeps(log.sample_time_s), 10))
    noise = judging_floors(check, noise_floors(log, n))[0]

    def fit(free_now: tuple, theta0: dict, values: dict, **options) -> Refined:
        return refine_first(log, n, values, settings, theta0, noise, free_now, **options)

    return fit, noise, n


def _blame(check: dict, log: Log, settings: Settings, params: dict) -> None:
    """Which known value do the data blame for the misfit?  The known-value search (known_values.py: each value
    of the table a one-parameter hypothesis, refitted by multiple shooting then in the standard windows) on the
    log's first SUSPECT_MAX_STEPS integration steps; a value is named only if freeing it alone makes the model
    fit.  ``check["known_values"]`` keeps the search for diagnose, which reads this same result."""
    fit, noise, n = known_value_fit(log, settings, check)
    free = refined_free(settings)
    try:
        found = known_values.search(fit, params, noise, n, free=free)
    except (np.linalg.LinAlgError, FloatingPointError, ValueError, ZeroDivisionError):
        return
    check["known_values"] = found.to_json()
    check["suspect_known_values"] = found.scores
    if found.best is not None:
        b = found.best
        check["suspect"] = {"name": b.name, "refitted_value": b.value, "rms_over_noise_after": max(b.over_noise.values()),
                            "look_alikes": list(found.look_alikes)}
    scope = "" if n == len(log) else f" (searched on the first {n * log.sample_time_s:.6g} s)"
    check["sentence"] += known_values.sentence(found).rstrip(".") + scope + "."


def _refine(log: Log, settings: Settings, params: dict, offline: dict, given: dict | None = None
            ) -> tuple[Refined | None, str, bool]:
    """Prediction-error refinement from DREM's offline optimum, when the settings and the log allow it; from
    ``given`` first (identify's ``start``) when it is one."""
    dt = log.sample_time_s
    steps = len(log) * substeps(dt)
    if settings.refine == "off":
        return None, "refinement off (--refine off)", False
    if settings.refine == "auto" and steps > REFINE_AUTO_MAX_STEPS and not settings.free and not model_kw(settings):
        return None, (f"refinement skipped: the log needs {steps:,} integration steps, more than the automatic "
                      f"limit of {REFINE_AUTO_MAX_STEPS:,} (use --refine on to force it); DREM's offline "
                      "optimum is the estimate"), False
    noise = noise_floors(log, len(log))

    # starts in turn until one converges at the noise level: DREM's offline optimum, then the table's J/B. DREM's
    # numbers can be no start at all (a value not positive: a log cut mid-run starts its filters off their steady
    # state) or start Gauss-Newton in another basin (a wrong known value made J1 3x too large)
    # (name, J/B, motor start states or None: the first voltages' steady state)
    usable = _usable_start(offline)
    starts = ([("DREM's offline optimum", offline, None)] if usable else []) + [
        ("the table's J/B" + (" (DREM's optimum led to a worse fit)" if usable else
                              " (DREM's offline optimum is no start: a value is not positive)"),
         {k: params[k] for k in ESTIMATED}, None)]
    # a fit of this model made elsewhere (diagnose's with its findings) starts Gauss-Newton next to the optimum:
    # on an hour at 1 kHz with a cable, three passes over the log instead of five from DREM's
    if given is not None and all(isinstance(given.get(k), float) for k in ESTIMATED) and _usable_start(given):
        starts.insert(0, (given.get("from") or "the fit given with the model", {k: given[k] for k in ESTIMATED},
                          given.get("start_states") or None))
    r, origin, failed = None, "", None
    free = refined_free(settings)

    def attempt(start: dict, **options) -> Refined | None:
        """One start's fit; None when it fails (a start far off, e.g. a J that DREM could not determine, left
        near 0, makes the simulation overflow): the next start is tried."""
        nonlocal failed
        try:
            return refine_first(log, len(log), params, settings, start, noise, free, **options)
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError) as e:
            failed = e
            return None

    for name, start, states in starts:
        cand = attempt(start, start_states0=states)
        if cand is None and name.startswith("DREM"):
            starts[-1] = (f"the table's J/B (from DREM's offline optimum the fit failed: {failed})", *starts[-1][1:])
        if cand is not None and (r is None or cand.cost < r.cost):
            r, origin = cand, name
        if r is not None and _settled(r, noise):
            break
    if r is None:
        return None, f"refinement failed ({failed}); DREM's offline optimum is the estimate", False
    # where no start reached the noise level, the motor and lag start states may sit in a wrong basin (a log
    # cut mid-run: the tail motor's fitted at twice what the voltage limit can drive). Two more ways in, from
    # the best J/B so far: the motors from rest; and multiple shooting, short windows first (each restarts
    # from its own fitted angles and rates, so a start-state error cannot pile up), then the standard windows
    # from there, carrying J/B and the start states
    if not _settled(r, noise):
        start = r.estimate if _usable_start(r.estimate) else {k: params[k] for k in ESTIMATED}
        base = origin.split(" (")[0]
        cand = attempt(start, start_states0=MOTORS_AT_REST)
        if cand is not None and cand.cost < r.cost:
            r, origin = cand, f"{base}, then the motors started from rest"
        if not _settled(r, noise):
            short = attempt(start, window_s=SHOOTING_WINDOW_S)
            if short is not None and _usable_start(short.estimate):
                cand = attempt(short.estimate, start_states0=short.start_states)
                if cand is not None and cand.cost < r.cost:
                    r, origin = cand, f"{base}, then through {SHOOTING_WINDOW_S:g} s windows first"
    ratio = _over_noise(r, noise)
    lagged = _lagged(settings)
    base = (f"prediction-error refinement from {origin}: {r.iterations} Gauss-Newton iteration(s), "
            f"{r.windows} window(s) of {len(log) * dt / r.windows:.3g} s, start states estimated"
            + (" (a second-order motor's further lag's too)" if lagged else "") +
            f", angle error RMS alpha {r.rms_rad['alpha']:.3g} rad, beta {r.rms_rad['beta']:.3g} rad (noise "
            f"{noise['alpha']:.3g}, {noise['beta']:.3g} rad)")
    if max(ratio.values()) > ADEQUATE_RMS_OVER_NOISE:
        worst = max(ratio, key=ratio.get)
        if noise[worst] < SMOOTHED_FLOOR_RAD:  # no measurable noise: the adequacy check's words, not a misfit's
            return r, (base + f"; NOT used: its error stays above the integrator's precision ({worst} "
                       f"{r.rms_rad[worst]:.3g} rad against {NUMERICAL_FLOOR_RAD:g} rad), and the angles carry no "
                       "measurable noise to say whether that is a misfit or the recording's smoothing; DREM's "
                       "offline optimum is the estimate"), False
        return r, (base + f"; NOT used: the {worst} error is {ratio[worst]:.3g}x its noise level, so the model "
                   "misses something in this log (try `trms-ident diagnose`) and DREM's offline optimum is the "
                   "estimate"), False
    if not r.converged:
        return r, base + "; NOT used: Gauss-Newton did not converge", False
    if r.blocks < MIN_BLOCKS:
        return r, base + f"; NOT used: {r.blocks} block(s) after the start are too few for an interval", False
    r, widened = _with_rounding(log, settings, params, r, noise)
    return r, base + widened, True


def _with_rounding(log: Log, settings: Settings, params: dict, r: Refined, noise: dict) -> tuple[Refined, str]:
    """On a log whose angles sit on an encoder's grid, each interval is the wider of the batch-means one and the
    spread the grid's rounding causes (numerics/quantization.py, at the estimate, from the model's own angles);
    the covariance of J/B is scaled alike.  (The refined result, the words added to the refinement's note.)"""
    from .numerics.quantization import rounding_covariance

    quantum = {"alpha": quantization_step(log.alpha_rad), "beta": quantization_step(log.beta_rad)}
    if not any(q > 0 for q in quantum.values()):
        return r, ""
    freed = {k: v["estimate"] for k, v in r.freed.items()}
    known = {k: v for k, v in freed.items() if k in params}
    try:
        cov, _ = rounding_covariance(log.u1_v, log.u2_v, r.prediction, log.sample_time_s, {**params, **known},
                                     settings.thrust_law, r.estimate, noise, quantum, free=tuple(freed),
                                     start_states0=r.start_states, window_starts=r.fit.starts,
                                     **model_kw(settings, freed, log=log, params=params, start=r.start_states),
                                     **timing(log, len(log)))
    except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError):
        return r, "; the encoder's rounding spread could not be evaluated (intervals: batch means only)"
    ci95, ratio, wider = dict(r.ci95), np.ones(4), []
    for i, k in enumerate(ESTIMATED):
        lo, hi = r.ci95[k]
        half, half_q = (hi - lo) / 2.0, Z95 * math.sqrt(max(float(cov[i, i]), 0.0))
        if half_q > half:
            est = r.estimate[k]
            ci95[k], ratio[i] = (est - half_q, est + half_q), half_q / half if half > 0 else 1.0
            wider.append(f"{k} x{ratio[i]:.2g}")
    if not wider:
        return r, ""
    cov_jb = None if r.cov_jb is None else r.cov_jb * np.outer(ratio, ratio)
    return replace(r, ci95=ci95, cov_jb=cov_jb), (
        f"; intervals widened to the spread the encoder's rounding causes (quantum {max(quantum.values()):.3g} rad, "
        f"{QUANTIZATION_OFFSETS} grid offsets): {', '.join(wider)}")


def refined_interval(r: Refined, name: str) -> Interval:
    est = r.estimate[name]
    lo, hi = r.ci95[name]
    rel = (hi - lo) / 2 / est
    ok = est > 0 and rel <= IDENTIFIABLE_REL_HALF_WIDTH
    reason = f"95 % interval ±{100 * rel:.2g} %" if ok else f"weakly excited: 95 % interval is ±{100 * rel:.3g} % of the value"
    return Interval(est, lo, hi, r.blocks, ok, reason)
