"""The hypotheses tested by the equation error: one candidate of the library added to the current model, its
regression refitted and its held-out blocks scored (select.py), and what that test needs around it (the
search grids of the input modifications, the exact pitch offsets, the practical size, the look-alike
measure).  diagnosis/search.py's rounds call try_candidate for each candidate; judge.py asks the output-error fit."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..log import Log
from ..model.effects import SENSOR_LAG, Candidate
from ..model.structure import of_bench, reaction_voltage
from ..numerics import safe
from . import oe
from .model import Model, regression
from .select import block_ids, compare, score

#: a motor time constant found off the table that, given the later findings, comes back within this fraction of
#: the table's value stood in for them (measured: a 0.25 s second-order yaw motor first named as a yaw motor time
#: constant, which went back to 1.0001 s once the further lag was in)
MOTOR_LAG_NEUTRAL = 0.01

def axes_of(c: Candidate, p: dict | None = None) -> tuple[str, ...]:
    """The axes candidate c acts on, on the bench ``p`` (its structure: model.structure.of_bench)."""
    if c.effect in ("input_delay",):
        return ("pitch", "yaw")
    if c.kind == "grid" and c.axis == "pitch":  # u1 also drives the yaw axis through M_R
        # ... through the main motor's state in eq. (1); where the bench's reaction follows the voltage u1 itself
        # (model/structure.py), the main motor's own dynamics (its lags) stay on the pitch
        if not (c.effect in ("motor_lag", "motor_second_lag") and reaction_voltage(of_bench(p))):
            return ("pitch", "yaw")
    return (c.axis,) if c.axis != "both" else ("pitch", "yaw")


def value_grid(c: Candidate, log: Log, p: dict) -> tuple[float, ...]:
    dt = log.sample_time_s
    if c.effect == "input_delay":
        g = [dt * s for s in (0.5, 1, 1.5, 2, 3, 4, 5, 6, 8, 10, 12, 15, 19, 24, 30, 38, 48)]
        return tuple(d for d in g if d <= 0.25)
    if c.effect == "motor_lag":
        nominal = p["T11" if c.axis == "pitch" else "T21"]
        return tuple(nominal * 0.55 * 1.07 ** i for i in range(18))
    if c.effect == "input_saturation":  # below the largest logged command, down to 55 % of it
        umax = float(np.max(np.abs(log.u1_v if c.axis == "pitch" else log.u2_v)))
        return tuple(umax * 0.995 * 0.965 ** i for i in range(18))
    return c.grid


def _refine(grid, gains, best_i, log_space: bool = True) -> float:
    """Vertex of the parabola through the best grid point and its neighbours (grids need not be evenly
    spaced; ``log_space`` for positive parameters searched on geometric-like grids)."""
    if 0 < best_i < len(grid) - 1:
        x = np.array(grid[best_i - 1:best_i + 2], dtype=float)
        x = np.log(x) if log_space else x
        y = np.array(gains[best_i - 1:best_i + 2], dtype=float)
        coef = safe.polyfit(x, y, 2)  # gains of a model that overflowed are not finite: keep the grid point
        curv, slope = (coef[0], coef[1]) if coef is not None else (0.0, 0.0)
        if curv < 0:
            v = float(np.clip(-slope / (2 * curv), x.min(), x.max()))  # grids may descend
            return float(np.exp(v)) if log_space else v
    return float(grid[best_i])


def params_of(axes) -> list[str]:
    return [k for axis in axes for k in (("J1", "B1") if axis == "pitch" else ("J2", "B2"))]


#: on logs longer than this [s], an input modification's grid is searched on the log's first GRID_SPAN_S seconds
#: (GridSpan) and its held-out test runs on the whole log at the value found there: on an hour at 1 kHz the nine
#: grids' ~150 regressions of 3.6 million samples each took 17 s of a 57 s diagnosis
GRID_SPAN_S = 600.0


@dataclass
class GridSpan:
    """The samples a long log's grids are searched on: the log's head, its regressions' cache, its held-out
    blocks' ids, and the current model's score there (set by the search each round)."""
    log: Log
    cache: dict
    ids: np.ndarray
    score_now: object = None


def grid_span(log: Log, block: int, start: dict | None) -> GridSpan | None:
    """The GridSpan of a log longer than GRID_SPAN_S (blocks of ``block`` samples, the motors' ``start``
    states at its first sample); None for a shorter log (its grids use all of it)."""
    n = int(GRID_SPAN_S / log.sample_time_s)
    if len(log) <= n:
        return None
    # its cache keeps the current targets only (a grid's points are not asked again; 0: just those kept)
    return GridSpan(log.head(n), {("start_states",): start, ("bytes",): 0}, block_ids(n, block))


def try_candidate(c, log, p, law, a, current, cache, ids, score_now, n_tests, span: GridSpan | None = None):
    """Candidate c added to the current model and tested by the equation error: {"c", "model", "reg", "score",
    "test", "value"}, or None (a grid with no point).  An input modification's value is the best of its grid
    (on ``span``'s samples when given), refined by a parabola, and tested on the whole log."""
    axes_c = axes_of(c, p)
    if c.kind == "linear":
        model = current.with_linear(c.key)
        reg = regression(log, p, law, a, model, cache)
        sc = score(reg, ids, ("pitch", "yaw"))
        value = float(sc.theta[c.axis][reg.names[c.axis].index(c.key)])
    else:
        grid = value_grid(c, log, p)
        if not grid:
            return None
        gains = []
        on = span or GridSpan(log, cache, ids, score_now)
        for v in grid:
            model = current.with_mod(c.key, v)
            reg = sc = None  # the last grid point's columns go before the next are built (memory on long logs)
            reg = regression(on.log, p, law, a, model, on.cache)
            sc = score(reg, on.ids, axes_c)  # the gain reads the candidate's axes only (at_value scores both)
            gains.append(compare(on.score_now, sc, reg, axes_c, n_tests).gain)
        i = int(np.argmax(gains))
        reg = sc = None
        value = _refine(grid, gains, i)
        if span is not None and c.key == SENSOR_LAG:  # tested on the head first: a lag's regression of the whole
            # log is the de-lagged log's own columns beside the log's (measured: +440 MB on an hour at 1 kHz)
            res = at_value(c, value, span.log, p, law, a, current, span.cache, span.ids, span.score_now, n_tests)
            if not res["test"].passed:
                res["reg"] = None  # the head's columns: never mixed with the whole log's
                return res
            res = None  # the head's columns go before the whole log's are built
        return at_value(c, value, log, p, law, a, current, cache, ids, score_now, n_tests)
    if c.effect in EXACT_OFFSETS and value != 0.0:
        reg = sc = None
        model, reg, sc, value = _exact_offset(c, value, log, p, law, a, current, cache, ids, score_now, n_tests)
    test = compare(score_now, sc, reg, axes_c, n_tests)
    return {"c": c, "model": model, "reg": reg, "score": sc, "test": test, "value": value}


def at_value(c, value, log, p, law, a, current, cache, ids, score_now, n_tests):
    """A grid candidate (an input modification) at ``value``: its model, regression and held-out test."""
    model = current.with_mod(c.key, value)
    reg = regression(log, p, law, a, model, cache)
    sc = score(reg, ids, ("pitch", "yaw"))
    return {"c": c, "model": model, "reg": reg, "score": sc, "test": compare(score_now, sc, reg, axes_of(c, p), n_tests),
            "value": value}


#: offsets fitted linearly first, then exactly (sin(alpha + delta), or the whole pitch equation at
#: alpha - delta): at delta ~ 0.01 rad the second-order terms decide between the two look-alikes
EXACT_OFFSETS = ("com_offset", "sensor_offset")


def _exact_offset(c, delta0, log, p, law, a, current, cache, ids, score_now, n_tests):
    grid = [delta0 * f for f in (0.85, 0.95, 1.0, 1.05, 1.15)]
    gains = []
    for d in grid:
        model = current.with_mod(c.key, d)
        reg = sc = None  # as in try_candidate: one grid point's columns at a time
        reg = regression(log, p, law, a, model, cache)
        sc = score(reg, ids, ("pitch", "yaw"))
        gains.append(compare(score_now, sc, reg, ("pitch",), n_tests).gain)
    best = _refine(grid, gains, int(np.argmax(gains)), log_space=False)  # offsets take either sign
    model = current.with_mod(c.key, best)
    reg = sc = None
    reg = regression(log, p, law, a, model, cache)
    return model, reg, score(reg, ids, ("pitch", "yaw")), best


#: the pitch offsets, found by the equation error (which fits them exactly, EXACT_OFFSETS), are held to the floor
#: oe.passes asks of every candidate the output-error fit judges (oe.MIN_TORQUE_SHARE of the thrust torque) before
#: that fit judges them: on a noise-free log any consistent residual passes the
#: held-out test (measured: a 2.6e-5 rad encoder offset, 0.004 % of the thrust torque, named beside a 10 ms
#: input delay on a noise-free 100 Hz log, and once that was refused a centre-of-mass offset of the same size;
#: the smallest offsets of the diagnose benchmark, 0.005 rad, are 0.77-1.2 %)
SIZE_FLOORED = ("com_offset:pitch", "sensor_offset:pitch")


def practical(c: Candidate, v: float, log: Log, p: dict, law: str) -> bool:
    """Is the candidate's value of practical size?  SIZE_FLOORED candidates by their torque share; a motor time
    constant must differ from the table's by MOTOR_LAG_NEUTRAL (measured: the equation error passed a yaw
    motor time constant of 1.0001 s, the table's 1.0 s, with an 8.5 % held-out drop beside a second-order yaw
    motor's further lag: a modification that changes nothing)."""
    if c.effect == "motor_lag":
        return abs(v / p["T11" if c.axis == "pitch" else "T21"] - 1.0) >= MOTOR_LAG_NEUTRAL
    return c.key not in SIZE_FLOORED or oe.torque_share(c.key, v, log, p, law) >= oe.MIN_TORQUE_SHARE


def axis_residual(reg, sc, axis: str) -> np.ndarray:
    """The axis' equation error [N m] of a fitted regression: g - X theta."""
    return reg.g[axis] - reg.x[axis] @ sc.theta[axis]


#: two candidates whose fitted contributions correlate this much and whose gains are this close
#: cannot be told apart with the log's excitation
ALIAS_CORRELATION = 0.95


ALIAS_GAIN_RATIO = 0.8


def aliased(a: dict, b: dict) -> bool:
    """Do two fitted candidates change the residual in the same way?"""
    corr = []
    for axis in ("pitch", "yaw"):
        ra = axis_residual(a["reg"], a["score"], axis)
        rb = axis_residual(b["reg"], b["score"], axis)
        if np.std(ra) > 0 and np.std(rb) > 0:
            corr.append(float(np.corrcoef(ra, rb)[0, 1]))
    return bool(corr) and min(corr) >= ALIAS_CORRELATION


#: the better of two look-alike candidates must explain this much more of the residual to be told apart
SEPARATION_MARGIN = 0.05


def separable(best: dict, other: dict) -> bool:
    """Is ``best`` better than ``other`` block by block, beyond chance (one-sided 5 %) and by a margin?"""
    axes = sorted(set(axes_of(best["c"])) | set(axes_of(other["c"])))
    test = compare(other["score"], best["score"], best["reg"], axes, 1, alpha=0.05)
    return test.p < 0.05 and best["test"].gain - other["test"].gain >= SEPARATION_MARGIN * best["test"].gain


def jb_estimates(sc, reg) -> dict:
    return {"J1": float(sc.theta["pitch"][0]), "B1": float(sc.theta["pitch"][1]),
            "J2": float(sc.theta["yaw"][0]), "B2": float(sc.theta["yaw"][1])}


def effect_values(model: Model, sc, reg, decided: dict | None = None) -> dict:
    """The model's findings' values: input modifications at theirs, torque terms as the regression fits them;
    ``decided`` (key -> value): the values the output-error fits decided, which replace those of the model's
    findings."""
    vals = dict(model.mods)
    for key in model.linear:
        axis = key.split(":")[1]
        vals[key] = float(sc.theta[axis][reg.names[axis].index(key)])
    vals.update({k: v for k, v in (decided or {}).items() if k in model.keys})
    return vals


def jb_start(est: dict, p: dict) -> dict:
    """J/B an output-error fit starts from: ``est``'s when all are finite and positive, else the table's
    (``p``)."""
    jb = ("J1", "B1", "J2", "B2")
    ok = all(math.isfinite(est.get(k, math.nan)) and est[k] > 0 for k in jb)
    return {k: float(est[k] if ok else p[k]) for k in jb}
