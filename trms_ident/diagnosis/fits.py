"""The 2 s prediction fits diagnose reports for each model it judges (the seed model, each finding's step, the
findings' model), and the motors' start states each model predicts from.

A room of its own: search.py (the search), weigh.py (the rule) and the report read these numbers; nothing here
chooses a finding.  predict.py holds the compiled predictions; this file feeds them the model's inputs.
"""
from __future__ import annotations

import math
import weakref
from concurrent.futures import ThreadPoolExecutor
from typing import Callable

import numpy as np

from ..log import Log
from . import oe
from ..model.effects import SENSOR_LAG, angle_lag
from ..model.structure import gyroscope_voltage, of_bench, stops
from .model import (AXIS_ANGLE, Model, modified_inputs, observed_log, restart_velocity, smoothed_velocity,
                    voltage_drive)
from .predict import HORIZON_S, N_FX, nrmse_fit, predict_fitted_start


#: how much of the log's beginning decides the motors' start states (search._choose_start, best_start) [s]
START_JUDGE_S = 60.0
#: the motors at rest at the first sample
REST = {"tau1_0": 0.0, "tau2_0": 0.0, "zeta_0": 0.0}


def best_start(log: Log, p: dict, law: str, model: Model, values: dict, est: dict, options: list) -> dict | None:
    """The motors' start states ``model`` predicts best from (on the leading START_JUDGE_S), among ``options``
    (the first wins a tie): the seed model's choice, the steady state, rest, the seed check's estimate and the
    output-error fits' estimates with the findings in.  A start estimated with a model that misses a delay
    left the yaw prediction of a log cut mid-run 10x its noise level for its first 5 s."""
    if len(options) == 1:
        return options[0]
    head = log.head(start_samples(log))
    best, best_cost = options[0], math.inf
    for opt in options:
        cost = start_cost(prediction_fits(head, p, law, model, values, est, start=opt)[0])
        if cost < best_cost:
            best, best_cost = opt, cost
    return best


def start_samples(log: Log) -> int:
    """How many leading samples judge the motors' start states: START_JUDGE_S of the log (the start is forgotten
    within a few motor time constants; an hour-long log would otherwise pay full regressions and predictions)."""
    return min(len(log), max(int(START_JUDGE_S / log.sample_time_s), 1))


def start_cost(fits: dict) -> float:
    """What a start-state option costs: the sum over axes of (1 - prediction fit)^2, infinite without a fit."""
    return sum((1.0 - fits[ax] / 100.0) ** 2 if math.isfinite(fits[ax]) else math.inf for ax in fits)


def yaw_inertia_signals(alpha_rad: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """sin^2(alpha) and sin(alpha) cos(alpha) alpha' of the measured pitch (the pitch-dependent yaw inertia's
    terms), in place where numpy allows (the same operations, in the same order, as the plain expressions)."""
    s = np.sin(alpha_rad)
    scw = np.cos(alpha_rad)
    scw *= s
    scw *= smoothed_velocity(alpha_rad, dt)
    s *= s
    return s, scw


#: (what, id(angle array)) -> (weak reference to the array, dt, the signal): prediction_fits predicts the same
#: log's angles for every model and start it judges, and the restart velocity and the pitch-dependent yaw
#: inertia's signals depend on the angles alone (measured on an hour at 1 kHz: 24 Savitzky-Golay passes, 5.6 s of
#: a 90 s diagnosis, for two distinct arrays).  A few entries at most; an entry goes with its angle array
_PER_ANGLES: dict = {}
_PER_ANGLES_KEPT = 6


def _per_angles(what: str, x: np.ndarray, dt: float, compute: Callable):
    """compute(x, dt), computed once per angle array and ``what`` (the caller must not write to the result)."""
    key = (what, id(x))
    hit = _PER_ANGLES.get(key)
    if hit is not None and hit[0]() is x and hit[1] == dt:
        return hit[2]
    got = compute(x, dt)
    while len(_PER_ANGLES) >= _PER_ANGLES_KEPT:
        _PER_ANGLES.pop(next(iter(_PER_ANGLES)), None)
    _PER_ANGLES[key] = (weakref.ref(x), dt, got)
    weakref.finalize(x, _PER_ANGLES.pop, key, None)  # the log is gone: so are its signals (memory in a batch)
    return got


#: logs at least this long predict their two axes in two threads (prediction_fits); shorter ones are done before
#: a thread would start paying off
PARALLEL_FITS_SAMPLES = 200_000


def prediction_fits(log: Log, p: dict, law: str, model: Model, values: dict, est: dict, extra: dict | None = None,
                    start: dict | None = None):
    """Prediction fit [%] and predictions per axis; ``extra``: axis -> extra torque [N m] per sample; ``start``:
    the motors' states at the first sample (plant_signals).  A model with an acquisition lag (effects.SENSOR_LAG)
    predicts the true angles and is scored against the de-lagged log (model.observed_log), restarting from it."""
    from ..numerics.fused import plant_signals

    lag = dict(model.mods).get(SENSOR_LAG)
    logged = log
    if lag is not None:
        log = observed_log(log, lag)
        model = Model(tuple((k, v) for k, v in model.mods if k != SENSOR_LAG), model.linear)
    dt = log.sample_time_s
    u1, u2, changes = modified_inputs(log, dict(model.mods))
    pp = {**p, **changes}
    drive = voltage_drive(log, p, dict(model.mods))  # u1 as the gyroscope and M_R see it (None: u1 itself)
    ps = plant_signals(u1, u2, log.alpha_rad, log.beta_rad, dt, pp, law, start=start, rows="motors", drive_v=drive)
    structure = of_bench(p)  # the bench's (model/structure.py): the gyroscope's drive, the end stops
    gyro_u1 = gyroscope_voltage(structure)
    pitch_other = (u1 if drive is None else drive) * ps.dbeta_rad_s if gyro_u1 else ps.dbeta_rad_s
    extra = {axis: (extra or {}).get(axis) for axis in ("pitch", "yaw")}
    for key, t in oe.unit_torques(log, pp, law, [k for k in model.linear if k in values], u1, u2).items():
        for j, axis in enumerate(("pitch", "yaw")):  # the model room's torque effects (model/effects.py)
            if np.any(t[:, j]):
                extra[axis] = values[key] * t[:, j] + (0.0 if extra[axis] is None else extra[axis])
    del u1, u2
    horizon = max(int(round(HORIZON_S / dt)), 1)
    zeros = np.zeros_like(log.alpha_rad)

    def predicted(axis: str) -> np.ndarray:
        x = getattr(log, AXIS_ANGLE[axis])
        fx = np.zeros(N_FX)
        fx[8:10] = stops(structure, axis) or (0.0, 0.0)
        fx[0] = values.get(f"coulomb_friction:{axis}", 0.0)
        fx[1] = values.get(f"quadratic_drag:{axis}", 0.0)
        fx[5] = values.get(f"thrust_asymmetry:{axis}", 0.0)
        fx[6] = values.get("yaw_inertia_pitch:yaw", 0.0)  # also on pitch: its centrifugal term
        if axis == "yaw":
            fx[2] = values.get("cable_stiffness:yaw", 0.0)
            th = np.array([est["J2"], est["B2"], pp["a2"], pp["b2"], 0.0, 0.0, law == "signed"], dtype=float)
            drive, other = ps.tau2, ps.MR_nm
        else:
            fx[3] = values.get("com_offset:pitch", 0.0)
            fx[4] = values.get("sensor_offset:pitch", 0.0)
            fx[7] = gyro_u1
            th = np.array([est["J1"], est["B1"], pp["a1"], pp["b1"], pp["Mg"], pp["Kg"], law == "signed"], dtype=float)
            drive, other = ps.tau1, pitch_other
        if not all(math.isfinite(q) and q > 0 for q in th[:2]):  # J or B not physical: nothing to predict with
            return np.full_like(x, np.nan)
        aux = (zeros, zeros) if axis == "pitch" else _per_angles("yaw inertia", log.alpha_rad, dt,
                                                                 yaw_inertia_signals)
        ext = zeros if extra[axis] is None else extra[axis]
        v = _per_angles("velocity", x, dt, restart_velocity)
        return predict_fitted_start(axis == "pitch", x, v, drive, other, *aux, ext, dt, horizon, th, fx)

    axes = ("pitch", "yaw")
    if len(log) >= PARALLEL_FITS_SAMPLES:  # the predictions release the GIL: both axes at once on two cores
        with ThreadPoolExecutor(max_workers=2) as pool:
            ys = list(pool.map(predicted, axes))
    else:
        ys = [predicted(axis) for axis in axes]
    preds = dict(zip(axes, ys))
    fits = {axis: nrmse_fit(getattr(log, AXIS_ANGLE[axis]), preds[axis]) for axis in axes}
    if lag is not None:  # drawn beside the logged angles: as the acquisition chain logs them
        preds = {axis: angle_lag(preds[axis], lag, dt, first=getattr(logged, AXIS_ANGLE[axis])[0]) for axis in axes}
    return fits, preds

