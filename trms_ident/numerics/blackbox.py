"""What fit a log allows when its noise floor cannot be measured: a flexible black-box model's held-out error.

A recording whose angles were smoothed before they were logged (third differences far below any encoder's
resolution, adequacy.SMOOTHED_FLOOR_RAD) has no measurable noise floor: "the error is 1e6 x the floor" then
says nothing about the model.  What the log can still measure is how well *any* model of moderate flexibility
predicts its angles from its voltages.  This module fits a nonlinear ARX model per angle (past angles of both
axes, sin and cos of the pitch, past voltages, their squares and signed squares) at DECIMATED_RATE_HZ by least
squares, cross-fitted: windows alternate between fitting and judging, each model simulated (free run from the
measured history at the window's start, no angle fed back) over the windows it did not see.  The RMS of that
held-out simulation error is the achievable floor: eq. (1), simulated in windows of the same length, fits the
log when its error is within adequacy.RMS_OVER_NOISE of it.  Even a poor black box shows a misfit when eq. (1)
does worse than it; but one whose held-out fit is below MIN_FIT_PERCENT cannot show that eq. (1) fits.
"""
from __future__ import annotations

import math

import numpy as np

from . import safe

#: the black box runs at about this rate [Hz] (the adequacy residual tests' rate)
RATE_HZ = 25.0
#: past samples of each angle and voltage it uses
ORDER = 4
#: a black box whose held-out simulation fit (NRMSE, %) is below this gives no floor
MIN_FIT_PERCENT = 50.0
#: ridge on the scaled normal equations (keeps a collinear regressor set solvable)
RIDGE = 1e-8


def _features(y: np.ndarray, u: np.ndarray, k: int) -> np.ndarray:
    """Regressors for step k from the samples before it (y: (m, 2) angles, u: (m, 2) voltages)."""
    past_y = y[k - ORDER:k][::-1].ravel()
    past_u = u[k - ORDER:k][::-1]
    a = y[k - 1, 0]
    return np.concatenate([past_y, [math.sin(a), math.cos(a), 1.0], past_u.ravel(), (past_u ** 2).ravel(),
                           (past_u * np.abs(past_u)).ravel()])


def _design(y: np.ndarray, u: np.ndarray, rows: np.ndarray) -> np.ndarray:
    return np.stack([_features(y, u, k) for k in rows])


def _simulate(coef: np.ndarray, y: np.ndarray, u: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Free run over [start, stop) from the measured samples before ``start``; (stop - start, 2)."""
    sim = y.copy()
    for k in range(start, stop):
        f = _features(sim, u, k)
        sim[k] = sim[k - 1] + f @ coef
        if not np.all(np.isfinite(sim[k])) or np.any(np.abs(sim[k]) > 1e3):
            sim[k:stop] = np.nan
            break
    return sim[start:stop]


def achievable_error_rad(y: np.ndarray, u: np.ndarray, dt_s: float, window_s: float) -> dict:
    """Per angle ("alpha", "beta"): the black box's held-out simulation error RMS [rad] (decimated samples) and
    its held-out NRMSE fit [%]; rms None when its free run is not finite.  ``y``, ``u``: (n, 2)
    angles [rad] and voltages [V]; ``window_s``: the windows eq. (1) is simulated in."""
    step = max(1, int(round(1.0 / (RATE_HZ * dt_s))))
    m = y.shape[0] // step
    yd = y[:m * step].reshape(m, step, 2).mean(axis=1)
    ud = u[:m * step].reshape(m, step, 2).mean(axis=1)
    w = max(int(round(window_s / (dt_s * step))), 4 * ORDER)
    w = min(w, max(m // 4, 2 * ORDER))
    windows = [(s, min(s + w, m)) for s in range(ORDER, m, w) if min(s + w, m) - s > ORDER]
    out = {"alpha": {"rms_rad": None, "fit_percent": math.nan}, "beta": {"rms_rad": None, "fit_percent": math.nan}}
    if len(windows) < 2:
        return out
    err = np.full((m, 2), np.nan)
    for fold in (0, 1):
        train = np.concatenate([np.arange(a, b) for i, (a, b) in enumerate(windows) if i % 2 == fold])
        x = _design(yd, ud, train)
        d = yd[train] - yd[train - 1]
        scale = np.sqrt(np.maximum(np.sum(x * x, axis=0), 1e-300))
        xs = x / scale
        try:
            coef = safe.lstsq(xs.T @ xs + RIDGE * np.eye(xs.shape[1]), xs.T @ d) / scale[:, None]
        except np.linalg.LinAlgError:
            return out
        for i, (a, b) in enumerate(windows):
            if i % 2 != fold:
                err[a:b] = yd[a:b] - _simulate(coef, yd, ud, a, b)
    for j, ang in enumerate(("alpha", "beta")):
        rows = np.concatenate([np.arange(a, b) for a, b in windows])
        e = err[rows, j]
        if not np.all(np.isfinite(e)):
            continue
        ys = yd[rows, j]
        spread = float(np.linalg.norm(ys - ys.mean()))
        fit = 100.0 * (1.0 - float(np.linalg.norm(e)) / spread) if spread > 0 else math.nan
        out[ang]["fit_percent"] = fit
        out[ang]["rms_rad"] = float(np.sqrt(np.mean(e * e)))
    return out
