"""An input modification's value estimated with J/B: a profile of the output-error fit over the value.

A bench file's dead zone, saturation, transport delay, second-order motor or motor time constant changes what drives
the plant, not its equations (model/bench.py), so the refinement has no sensitivity to follow for it (a dead zone's
cost is even piecewise constant in its width); a saturation is the exception, placed by one round of its profile and
then fitted by the refinement with J/B (model.bench.NATIVE_FREE_KEYS).  ``--free dead_zone:yaw`` and the like are
fitted as diagnose fits them (diagnosis/oe.py's profiles): the estimate is first made at the file's value; then the
output-error fit is repeated on the voltages modified at trial values (J/B, the torque effects freed and the start
states refitted from that estimate, a few Gauss-Newton iterations each), bounded Brent search over the logarithm of
the value within PROFILE_SPAN of the file's (where its best leaves the angles far from their noise floors, the
span screened first at diagnose's spacing, as diagnose's profiles are), then a grid within 8 % of the best and Brent
again between its best point's neighbours (the cost is rugged); the estimate is made again at the best value and the
search repeated around it, narrower, until the value moves less than a quarter of a percent (ROUNDS at most).

The value's standard error is the batch-means one of diagnose's profiles (oe.profile_se: the blocks' cost slopes at
the minimum over the profile's curvature, never below what white errors give); its 95 % interval is Student t over
the blocks.  A dead zone's is the run of steps of its staircase cost whose fits are no worse than the best's beyond
chance (oe.step_interval): its edges are logged |u|.  The intervals of J/B and of the parameters the refinement frees
with them are widened by what that uncertainty moves them (the delta method: their slopes along the profile times
the value's half-width, added in quadrature): they then hold whether or not the value was known.  A value the bench
file holds with its 95 % interval (exported by diagnose, or from another log) widens them alike, its slopes from two
fits a quarter of the interval either side: the intervals then hold over the file's own uncertainty.  A profiled
value's own interval is widened by the held ones too: how far each moves the profile's minimum (the cost's cross
derivative over its curvature) times its half-width, in quadrature.  Pure numerics on a validated log: no files.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.special import stdtrit

from .errors import IdentificationError, SettingsError, TrmsError
from .identify import identify, noise_floors, refine_first, refined_interval, under_model
from .model.bench import KERNEL_KEYS, MIN_KERNEL_LAG_S, MODIFICATION_KEYS, NATIVE_FREE_KEYS
from .model.effects import BY_KEY, SENSOR_LAG
from .numerics.parallel import fan_out
from .numerics.refine import trial_options
from .params import ESTIMATED, merge

#: the profile searches within this factor of the file's value either way
PROFILE_SPAN = 4.0
#: Gauss-Newton iterations per trial value, from the estimate at the file's value (diagnose's PROFILE_ITERATIONS)
ITERATIONS = 8
#: the search stops when the bracket is this narrow in the logarithm of the value (0.2 %)
LOG_TOLERANCE = 2e-3
#: profile rounds at most: the estimate remade at the best value, the profile searched again around it
ROUNDS = 3
#: after the Brent search over the span, a grid of 2 NEAR_POINTS + 1 values within NEAR_SPAN (in the logarithm:
#: 8 %) of the best so far, then Brent between the best grid point's neighbours (a rugged cost: _search)
NEAR_SPAN = math.log(1.08)
NEAR_POINTS = 8
#: the three fits whose block costs give the standard error sit this far apart, relative to the value
SE_STEP = 0.02


def identify_with_profiles(log, settings, start: dict | None = None):
    """identify's Result, with each input modification of settings.free (a bench file's, --free
    dead_zone:yaw, ...) estimated by its profile: its estimate, ci95, se and how it was found in
    ``refined.freed[key]``.  A value the file holds with a 95 % interval (its ``ci95``: estimated elsewhere, by
    diagnose or another estimate) widens J/B's intervals by what it moves them, as a profiled one does (the
    refinement's note names them).  Without either, identify itself.  ``start``: identify's (a fit of the model
    made elsewhere, the refinements' first start)."""
    keys = [k for k in settings.free if k in MODIFICATION_KEYS]
    held = {k: ci for k, ci in settings.held_ci95.items()
            if (k in settings.effects or k in settings.overrides) and k not in settings.free and k != SENSOR_LAG}
    if not keys and not held:
        return identify(log, settings, start=start)
    if SENSOR_LAG in keys:
        raise SettingsError(f"--free {SENSOR_LAG}: an acquisition lag changes the angles the fit is scored on; "
                            "estimate holds it at the bench file's value (diagnose fits it)")
    settings = replace(settings, free=tuple(k for k in settings.free if k not in keys))
    found, uncertain = {}, {}  # uncertain: key -> (the estimates' slopes along it, its 95 % half-width)
    native, given = [], {}
    for key in keys:
        v0 = given[key] = float(settings.effects[key])
        value, span = v0, math.log(PROFILE_SPAN)
        # a saturation is placed by one round of its profile, then estimated by Gauss-Newton with J/B (below)
        for _ in range(1 if key in NATIVE_FREE_KEYS else ROUNDS):  # the estimate at the value, then its profile
            base = identify(log, settings, start=start)
            if base.refined is None:
                raise IdentificationError(f"{log.source}: --free {key} needs the output-error refinement, which did "
                                          f"not run ({base.refine_note})")
            fit, noise = _profile_fit(log, settings, key, base.refined)
            x, x0 = _search(fit, math.log(value), span, key, 2.0 * len(log))
            moved = abs(x - x0)
            value = math.exp(x)
            settings = replace(settings, effects={**settings.effects, key: value})
            if moved < 2.5e-3:  # within a quarter of a percent of where the estimate was made: settled
                break
            span = max(4.0 * moved, 0.05)
        at_edge = bool(abs(math.log(value / v0)) > math.log(PROFILE_SPAN) - 10 * LOG_TOLERANCE)
        if key in NATIVE_FREE_KEYS:
            native.append((key, at_edge))
            continue
        # batch-means standard error from three fits around the minimum (diagnose's profile_se)
        base = identify(log, settings, start=start)
        fit, noise = _profile_fit(log, settings, key, base.refined)
        trial = [value * (1.0 - SE_STEP), value, value * (1.0 + SE_STEP)]
        fits = [fit(v) for v in trial]
        from .diagnosis.oe import block_costs, profile_se  # (not loaded by an estimate that profiles nothing)

        floors = {k: max(v, 1e-12) for k, v in noise.items()}  # as diagnose's profiles weigh them
        blocks = np.array([block_costs(log, f.prediction, floors) for f in fits])

        se = profile_se(np.array(trial), blocks, value)
        nb = blocks.shape[1]
        tq = float(stdtrit(max(nb - 1, 1), 0.975))
        lo, hi = value - tq * se, value + tq * se
        if key.startswith("dead_zone:"):  # a staircase in its width: the run of steps as good as the best's
            lo, hi = _dead_zone_interval(log, settings, key, value, fit, floors)
            se = (hi - lo) / (2.0 * tq)
        half = max(value - lo, hi - value)
        uncertain[key] = (_slopes(fits[0], fits[2], trial[2] - trial[0]), half)
        # a value the file holds with an interval moves the profile's minimum too: its interval widened alike
        def cost_at(h: str, dh: float, _key=key, _r0=base.refined):  # the profile's cost with h moved by dh
            fit_h, _ = _profile_fit(log, _holding(settings, h, _held(settings, h) + dh), _key, _r0)
            return lambda v: float(fit_h(v).cost)

        moved_by = _minimum_slopes(cost_at, trial, [float(f.cost) for f in fits],
                                   {h: _held_step(settings, h, ci) for h, ci in held.items()})
        extra = math.sqrt(sum((slope * hw) ** 2 for slope, hw in moved_by.values()))
        ci95 = [value - math.hypot(value - lo, extra), value + math.hypot(hi - value, extra)]
        found[key] = {"estimate": value, "ci95": ci95, "se": se,
                      "table_or_file_value": v0, "profiled": True, "at_search_edge": at_edge,
                      "unit": BY_KEY[key].unit}
    # the saturations from where their profiles placed them, with J/B: their intervals are the refinement's, from
    # the same covariance as J/B's (held values widen them below as they widen every freed parameter)
    settings = replace(settings, free=settings.free + tuple(k for k, _ in native))
    res = identify(log, settings, start=start)
    if res.refined is None:
        return res
    slopes_of, unmeasured = _held_slopes(log, settings, res.refined, held)
    uncertain.update(slopes_of)
    ci95 = dict(res.refined.ci95)
    for k in ESTIMATED:  # the delta method: each value's half-width moves J/B along its slope, in quadrature
        ci95[k] = _widened(res.refined.estimate[k], ci95[k], k, uncertain)
    freed = dict(res.refined.freed)
    for k, f in freed.items():  # the parameters the refinement freed with J/B (a torque effect, a known value)
        freed[k] = {**f, "ci95": list(_widened(f["estimate"], f["ci95"], k, uncertain))}
    for k, at_edge in native:
        freed[k] = {**freed[k], "table_or_file_value": given[k], "profiled": False, "at_search_edge": at_edge,
                    "unit": BY_KEY[k].unit}
    settings = replace(settings, effects={**settings.effects, **{k: freed[k]["estimate"] for k, _ in native}})
    freed.update(found)
    refined = replace(res.refined, freed=freed, ci95=ci95)
    res = _with_refined(res, refined, settings)
    if held and res.headline == "refined":
        widened = [f"{k} {_held(settings, k):.4g} [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in held.items()
                   if k not in unmeasured]
        note = ("; the intervals of J/B and of the parameters freed with them include the uncertainty of the "
                f"values the bench file holds with their 95 % intervals ({', '.join(widened)})") if widened else ""
        if unmeasured:
            note += (f"; held as exact although the file gives an interval: {', '.join(unmeasured)} (the fits "
                     "either side of its value failed)")
        res = replace(res, refine_note=res.refine_note + note)
    return res


def _dead_zone_interval(log, settings, key: str, value: float, fit, floors: dict) -> tuple[float, float]:
    """A freed dead zone's 95 % interval [V]: oe.step_interval over the distinct |u| its motor's voltage takes
    (the log's, through the bench's modifications before it), each step's cost from ``fit``."""
    from .diagnosis.model import dead_zone_levels
    from .diagnosis.oe import block_costs, step_interval

    levels = dead_zone_levels(log, settings.effects, key, settings.free)

    def blocks_at(v: float):
        try:
            r = fit(v)
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError, TrmsError):
            return None
        return block_costs(log, r.prediction, floors) if math.isfinite(r.cost) else None

    return step_interval(levels, value, blocks_at)


def _slopes(lo_fit, hi_fit, width: float) -> dict:
    """The estimates' slopes between two output-error fits ``width`` apart in one held value: J/B's and those of
    the parameters the refinement freed with them (per unit of the value)."""
    out = {k: (hi_fit.estimate[k] - lo_fit.estimate[k]) / width for k in ESTIMATED}
    out.update({k: (hi_fit.freed[k]["estimate"] - lo_fit.freed[k]["estimate"]) / width
                for k in hi_fit.freed if k in lo_fit.freed})
    return out


def _widened(estimate: float, ci95, name: str, moved: dict) -> tuple[float, float]:
    """``ci95`` of ``name`` widened by the delta method: each held or profiled value's 95 % half-width moves the
    estimate along its slope (``moved``: key -> (slopes, half-width)), in quadrature with the interval's own."""
    lo, hi = ci95
    extra = math.sqrt(sum((slopes.get(name, 0.0) * half) ** 2 for slopes, half in moved.values()))
    half = math.hypot((hi - lo) / 2.0, extra)
    return estimate - half, estimate + half


def _held_slopes(log, settings, r0, held: dict) -> dict:
    """key -> (the estimates' slopes along the value (_slopes), the value's 95 % half-width) for each value
    the bench file holds with an interval (Settings.held_ci95): central differences of the output-error fit a
    quarter of the interval either side of the value, from the estimate ``r0``; and the keys whose fits failed
    (held as exact, and said so)."""
    out, failed = {}, []
    for key, ci in held.items():
        step_half = _held_step(settings, key, ci)
        if step_half is None:
            continue
        (step, half), v0 = step_half, _held(settings, key)
        fit, _ = _profile_fit(log, settings, key, r0)
        try:  # (a known value stepped out of its physical range is refused by merge: no slope there either)
            lo_fit, hi_fit = fan_out(fit, (v0 - step, v0 + step))
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError, TrmsError):
            failed.append(key)
            continue
        out[key] = (_slopes(lo_fit, hi_fit, 2.0 * step), half)
    return out, failed


def _minimum_slopes(cost_at, trial: list, costs: list, steps: dict) -> dict:
    """How far the profile's minimum moves per unit of each held value: held key -> (slope, the value's 95 %
    half-width).  ``cost_at(h, dh)``: the output-error cost as a function of the profiled value, with the held
    value h moved by dh; ``trial``, ``costs``: the profile's three values (evenly spaced) and its costs there;
    ``steps``: held key -> (its step, its half-width) or None (not steppable).  At the minimum, dv*/dh = -C_vh /
    C_vv, the cross derivative from four costs at (v* +/- dv, h +/- step) over the profile's curvature; a key
    whose fits fail, or a profile with no curvature, moves nothing (its slope is not measured)."""
    dv = (trial[2] - trial[0]) / 2.0
    cvv = (costs[0] - 2.0 * costs[1] + costs[2]) / dv ** 2
    out = {}
    if not cvv > 0:
        return out
    for h, step_half in steps.items():
        if step_half is None:
            continue
        step, half = step_half
        try:
            moved = {j: cost_at(h, j * step) for j in (-1, 1)}
            c = {(i, j): moved[j](trial[i]) for i in (0, 2) for j in (-1, 1)}
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError, TrmsError):
            continue
        if not all(math.isfinite(x) for x in c.values()):
            continue
        cvh = (c[2, 1] - c[2, -1] - c[0, 1] + c[0, -1]) / (2.0 * dv * 2.0 * step)
        out[h] = (-cvh / cvv, half)
    return out


def _held_step(settings, key: str, ci95) -> tuple[float, float] | None:
    """(the step either side of a held value for its slopes, its 95 % half-width): a quarter of the interval,
    within a positive width, lag or delay; None for an interval of no width."""
    v0, half = _held(settings, key), (float(ci95[1]) - float(ci95[0])) / 2.0
    if not half > 0:
        return None
    step = half / 2.0
    if key in MODIFICATION_KEYS and v0 - step <= 0:  # a width, a lag, a delay: positive
        step = 0.5 * v0
    return step, half


def _holding(settings, key: str, v: float):
    """The settings with ``key`` (an effect's key or a known value's name) held at v."""
    return (replace(settings, effects={**settings.effects, key: v}) if key in settings.effects else
            replace(settings, overrides={**settings.overrides, key: v}))


def _held(settings, key: str) -> float:
    """The value the settings hold for an effect key or a known value's name."""
    return float(settings.effects[key] if key in settings.effects else settings.overrides[key])


def _profile_fit(log, settings, key: str, r0):
    """(value -> the output-error fit with ``key`` (an effect's key, or a known value's name) at that value, from
    ``r0``'s J/B and start states, its values, cost and predictions without an interval; the angles' noise
    floors)."""
    n, noise = len(log), noise_floors(log, len(log))

    def fit(v: float, iterations: int = ITERATIONS):
        if key in KERNEL_KEYS and v < MIN_KERNEL_LAG_S:  # below what the kernel integrates: no fit there
            raise FloatingPointError(f"{key} = {v:g} s is shorter than {MIN_KERNEL_LAG_S:g} s")
        at = _holding(settings, key, v)
        params0 = merge(at.overrides, source="parameter overrides")
        lg, pp = under_model(log, params0, at.effects, kernel=True, free=at.free)
        return refine_first(lg, n, pp, at, r0.estimate, noise, tuple(settings.free),
                            max_iterations=iterations, start_states0=r0.start_states, **trial_options(noise))

    return fit, noise


def _search(fit, x0: float, span: float, key: str = "", floor_cost: float = math.inf) -> tuple[float, float]:
    """(the best log-value within ``span`` of x0 by bounded Brent, x0): never worse than x0.  ``floor_cost``: the
    noise-weighted cost of a fit at the angles' noise floors; where Brent's best leaves more than
    PROFILE_SCAN_OVER_FLOOR times it, the whole span is screened first, as diagnose's profiles screen theirs
    (diagnosis.oe.Fitter.profile, its constants)."""
    from scipy.optimize import minimize_scalar  # here: scipy.optimize costs 0.2 s of import on every estimate

    from .diagnosis.oe import PROFILE_SCAN_OVER_FLOOR  # (not loaded by an estimate that profiles nothing)

    costs: dict = {}

    def attempt(x: float, iterations: int = ITERATIONS) -> float:
        try:
            c = float(fit(math.exp(x), iterations).cost)
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError):
            return math.inf
        return c if math.isfinite(c) else math.inf

    def cost(x: float) -> float:
        x = float(x)
        if x not in costs:
            costs[x] = attempt(x)
        return costs[x]

    with np.errstate(invalid="ignore"):  # trial fits that all failed score inf: Brent's inf - inf is no answer
        best = minimize_scalar(cost, bounds=(x0 - span, x0 + span), method="bounded",
                               options={"xatol": LOG_TOLERANCE})
    x = float(min([float(best.x), x0], key=cost))
    if cost(x) > PROFILE_SCAN_OVER_FLOOR * floor_cost:
        # far from the noise floor: Brent may have followed a basin the span's far side does not share, or trial
        # fits that failed (measured, independent.py seed 9419 bench 19: a second-order main motor's lag started
        # at 0.0512 s with T11 freed beside it; every trial below 0.08 s ran off, Brent stayed low and the pair was
        # "not explaining", although at the bench's 0.109 s the log fits to its floor).  The span screened at
        # diagnose's spacing with its few iterations, its best few fitted in full
        x = _screened(attempt, cost, x0, span, key, x)
    # a dead zone's or saturation's cost is piecewise constant and rugged in its value: Brent over the whole span
    # can settle in another basin and leave the start standing, although a better value lies within a per cent
    # (measured: a pitch dead zone started at 0.2524 V, the bench's 0.2512 V, stayed there with b2 freed beside
    # it, the yaw at 1.95x its floor; at 0.2512 V 1.02x).  So a grid near the best so far, then Brent between
    # the best grid point's neighbours
    near = min(span, NEAR_SPAN)
    grid = [float(v) for v in x + near * np.linspace(-1.0, 1.0, 2 * NEAR_POINTS + 1)]
    fan_out(cost, grid)  # the grid's fits are independent: on both cores (each kept in costs, read by min)
    xg = min(grid, key=cost)
    step = float(grid[1] - grid[0])
    with np.errstate(invalid="ignore"):
        fine = minimize_scalar(cost, bounds=(xg - step, xg + step), method="bounded",
                               options={"xatol": LOG_TOLERANCE})
    return float(min([float(fine.x), xg, x], key=cost)), x0


def _screened(attempt, cost, x0: float, span: float, key: str, x: float) -> float:
    """The best log-value of ``x`` and the span's screen: values x0 - span to x0 + span at diagnose's screen
    spacing (finer for a staircase cost than for a smooth one), each fitted with its few iterations
    (``attempt(x, iterations)``), the best few of those in full (``cost``)."""
    from .diagnosis.oe import PROFILE_SCAN_ITERATIONS, PROFILE_SCAN_KEEP, screen_ratio

    ratio = screen_ratio(key)
    xs = [float(v) for v in np.linspace(x0 - span, x0 + span, int(math.ceil(2 * span / math.log(ratio))) + 1)]
    quick = fan_out(lambda v: attempt(v, PROFILE_SCAN_ITERATIONS), xs)
    keep = [v for c, v in sorted(zip(quick, xs)) if math.isfinite(c)][:PROFILE_SCAN_KEEP]
    fan_out(cost, keep)
    return min([x] + keep, key=cost)


def _with_refined(res, refined, settings):
    """The Result with its refinement's intervals widened (and its headline intervals when refined is the
    headline), and ``settings`` (the profiled values in its effects)."""
    res = replace(res, refined=refined, settings=replace(res.settings, effects=settings.effects))
    if res.headline != "refined":
        return res
    intervals = {k: refined_interval(refined, k) for k in ESTIMATED}
    return replace(res, intervals=intervals,
                   estimates={k: (refined.estimate[k] if intervals[k].identifiable else None) for k in ESTIMATED})
