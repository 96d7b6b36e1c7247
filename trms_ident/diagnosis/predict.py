"""Multi-step prediction fit of each axis (NRMSE %), with or without the fitted effects.

The model is run for HORIZON_S seconds from an initial angle and velocity, driven by the
logged voltages (through the motor lags) and, for pitch, the measured yaw rate; then it
restarts.  Each window's initial angle and velocity are estimated (least squares over the
window, one Gauss-Newton step from the measured angle and a smoothed velocity, kept where
it lowers the window's error), as
identification tools do when they compare a model with data: a noisy restart state would
otherwise dominate the error, and the fit would judge the velocity estimate, not the model.  A free run over the whole log would be
meaningless for yaw: with no restoring force its angle integrates every small torque error
and drifts without bound.  Fit = 100 (1 - |y - y_hat| / |y - mean y|).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..model.plant import (centrifugal_pitch, coriolis_yaw, coulomb_sign, friction, pitch_torque, reversed_gain, thrust,
                           yaw_torque)
from ..numerics.kernel_args import HELPER, readonly

HORIZON_S = 2.0
#: the entries of a prediction's effect vector ``fx`` (_rhs: the effects' values, the gyroscope's drive, the stops)
N_FX = 10


def _checked(fx: np.ndarray) -> np.ndarray:
    """``fx`` as the kernel reads it: N_FX entries (a shorter one would be read past its end)."""
    fx = np.asarray(fx, dtype=float)
    if fx.shape != (N_FX,):
        raise ValueError(f"the effect vector fx has {fx.size} entries, the predictions read {N_FX} (predict._rhs)")
    return fx


@njit(cache=True, **HELPER)
def _rhs(pitch, x, v, tau_m, other, s2, scw, ext, th, fx):
    # th: J, B, a, b, Mg, Kg, signed;  fx: Fc, c, k_cable, com_delta, sensor_delta, thrust asymmetry s, yaw dJ,
    # the gyroscope driven by the voltage (1: the bench's structure, ``other`` is then u1 beta'; 0: eq. 1), the
    # axis' end stops low, high [rad] (none when low >= high);
    # s2 = sin^2(alpha), scw = sin(alpha) cos(alpha) alpha' (measured; used by the yaw axis only);
    # ext: an extra torque [N m] from the measured states (a data-driven correction, diagnosis/sparse.py)
    m = reversed_gain(tau_m, fx[5]) * thrust(tau_m, th[2], th[3], th[6] > 0)  # eq. (1), with thrust asymmetry
    fric = friction(coulomb_sign(v) if fx[0] != 0.0 else 0.0, v, fx[0], fx[1]) + ext  # no tanh without a Coulomb
    if pitch:
        gd = m + fx[7] * (1.0 - m)  # M1 (eq. 1) or 1, the voltage being in ``other`` (model/structure.py)
        acc = pitch_torque(m, gd, math.sin(x + fx[3]), math.cos(x), other, th[4], th[5]) + fric  # eq. (1), pitch
        acc += centrifugal_pitch(fx[6], math.sin(x), math.cos(x), other)  # J'(alpha) beta'^2 / 2
        return (acc - th[1] * v) / th[0]
    acc = yaw_torque(m, other) - fx[2] * x + fric + coriolis_yaw(fx[6], 1.0, scw, 1.0, v)  # eq. (1), yaw
    return (acc - th[1] * v) / (th[0] - fx[6] * s2)  # over yaw_inertia(J2, dJ, sin alpha), s2 = sin^2 alpha


@njit(cache=True, nogil=True)  # the GIL released: diagnosis/fits.py's prediction_fits predicts both axes at once
def _predict(pitch, x_start, v_start, x_off, v_off, tau, other, s2, scw, ext, dt, horizon, th, fx, out):
    """Angle predictions [rad] into ``out``, restarted every ``horizon`` samples from x_start + x_off[window]
    (logged angle) and v_start + v_off[window] [rad/s] at the restart sample; inputs (tau, other = beta' or
    M_R, s2, scw, ext: see _rhs) are linear between samples."""
    n = x_start.size
    x = 0.0
    v = 0.0
    for k in range(n):
        if k % horizon == 0:
            x = x_start[k] + x_off[k // horizon] - fx[4]
            v = v_start[k] + v_off[k // horizon]
        out[k] = x + fx[4]
        if k == n - 1:
            break
        t0, t1 = tau[k], tau[k + 1]
        o0, o1 = other[k], other[k + 1]
        p0, p1 = s2[k], s2[k + 1]
        q0, q1 = scw[k], scw[k + 1]
        e0, e1 = ext[k], ext[k + 1]
        tm, om, pm, qm, em = 0.5 * (t0 + t1), 0.5 * (o0 + o1), 0.5 * (p0 + p1), 0.5 * (q0 + q1), 0.5 * (e0 + e1)
        a1 = _rhs(pitch, x, v, t0, o0, p0, q0, e0, th, fx)
        a2 = _rhs(pitch, x + 0.5 * dt * v, v + 0.5 * dt * a1, tm, om, pm, qm, em, th, fx)
        a3 = _rhs(pitch, x + 0.5 * dt * (v + 0.5 * dt * a1), v + 0.5 * dt * a2, tm, om, pm, qm, em, th, fx)
        a4 = _rhs(pitch, x + dt * (v + 0.5 * dt * a2), v + dt * a3, t1, o1, p1, q1, e1, th, fx)
        x += dt * (v + dt / 6.0 * (a1 + a2 + a3))
        v += dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        if fx[8] < fx[9] and ((x <= fx[8] and v <= 0.0) or (x >= fx[9] and v >= 0.0)):
            x = fx[8] if x <= fx[8] else fx[9]  # an end stop holds the angle (inelastic): it leaves when the
            v = 0.0  # torques point away (the next step's)


def _windows(n: int, horizon: int) -> int:
    return (n + horizon - 1) // horizon


def predict(pitch, x_start, v_start, tau, other, s2, scw, ext, dt, horizon, th, fx) -> np.ndarray:
    """Angle predictions [rad], restarted every ``horizon`` samples from x_start and v_start (see _predict)."""
    x_start = readonly(x_start)  # one compiled _predict (numerics.kernel_args)
    fx = _checked(fx)
    zero = np.zeros(_windows(x_start.size, horizon))
    out = np.empty(x_start.size)
    _predict(pitch, x_start, v_start, zero, zero, tau, other, s2, scw, ext, dt, horizon, th, fx, out)
    return out


@njit(cache=True, nogil=True)
def _normal_sums(x, y0, yx, yv, hx, hv, horizon, sums):
    """Per window: the Gauss-Newton normal equations of (start angle, start velocity) from the finite-difference
    sensitivities (yx - y0)/hx, (yv - y0)/hv: columns a11, a12, a22, b1, b2 of ``sums``."""
    for k in range(x.size):
        w = k // horizon
        sx = (yx[k] - y0[k]) / hx
        sv = (yv[k] - y0[k]) / hv
        e = x[k] - y0[k]
        sums[w, 0] += sx * sx
        sums[w, 1] += sx * sv
        sums[w, 2] += sv * sv
        sums[w, 3] += sx * e
        sums[w, 4] += sv * e


@njit(cache=True, nogil=True)
def _keep_better(x, y0, y1, horizon):
    """Per window, y0 takes y1 where y1's squared error is lower (in place)."""
    n = x.size
    for w0 in range(0, n, horizon):
        w1 = min(w0 + horizon, n)
        e0 = 0.0
        e1 = 0.0
        for k in range(w0, w1):
            e0 += (x[k] - y0[k]) ** 2
            e1 += (x[k] - y1[k]) ** 2
        if e1 < e0:
            for k in range(w0, w1):
                y0[k] = y1[k]


def predict_fitted_start(pitch, x_meas, v_guess, tau, other, s2, scw, ext, dt, horizon, th, fx) -> np.ndarray:
    """Predictions with each window's initial angle and velocity fitted to the window's measurements (one
    Gauss-Newton step, kept where it lowers the window's error: friction makes the start non-smooth).  Three
    prediction buffers, no other temporaries the length of the log."""
    x_meas = readonly(x_meas)  # one compiled _predict, _normal_sums, _keep_better (numerics.kernel_args)
    fx = _checked(fx)
    n, nw = x_meas.size, _windows(x_meas.size, horizon)
    zero = np.zeros(nw)
    args = (tau, other, s2, scw, ext, dt, horizon, th, fx)
    y0, yx, yv = np.empty(n), np.empty(n), np.empty(n)
    hx = 1e-6 * max(float(np.max(np.abs(x_meas))), 1.0)  # rad
    hv = 1e-5 * max(float(np.max(np.abs(v_guess))), 1.0)  # rad/s
    _predict(pitch, x_meas, v_guess, zero, zero, *args, y0)
    _predict(pitch, x_meas, v_guess, zero + hx, zero, *args, yx)
    _predict(pitch, x_meas, v_guess, zero, zero + hv, *args, yv)
    sums = np.zeros((nw, 5))
    _normal_sums(x_meas, y0, yx, yv, hx, hv, horizon, sums)
    del yx
    a11, a12, a22, b1, b2 = sums.T
    ridge = 1e-12 * (a11 + a22) + 1e-300
    det = (a11 + ridge) * (a22 + ridge) - a12 * a12
    dx = ((a22 + ridge) * b1 - a12 * b2) / det
    dv = ((a11 + ridge) * b2 - a12 * b1) / det
    y1 = yv  # reuse the buffer
    _predict(pitch, x_meas, v_guess, dx, dv, *args, y1)
    _keep_better(x_meas, y0, y1, horizon)
    return y0


def fit_text(fit: float, decimals: int = 2) -> str:
    """A prediction fit for people: NaN means the model had no physical J or B to predict with."""
    return f"{fit:.{decimals}f} %" if math.isfinite(fit) else "n/a (J or B not physical: no prediction)"


def fit_change(before: float, after: float, arrow: str = "->") -> str:
    """'before -> after' with as many decimals (2 to 4) as it takes to show that they differ."""
    decimals = 2
    while decimals < 4 and math.isfinite(before) and math.isfinite(after) and before != after and \
            f"{before:.{decimals}f}" == f"{after:.{decimals}f}":
        decimals += 1
    return f"{fit_text(before, decimals)} {arrow} {fit_text(after, decimals)}"


def nrmse_fit(y: np.ndarray, y_hat: np.ndarray) -> float:
    den = float(np.linalg.norm(y - y.mean()))
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / den) if den > 0 else math.nan
