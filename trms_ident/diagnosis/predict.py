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

HORIZON_S = 2.0


@njit(cache=True)
def _rhs(pitch, x, v, tau_m, other, s2, scw, ext, th, fx):
    # th: J, B, a, b, Mg, Kg, signed;  fx: Fc, c, k_cable, com_delta, sensor_delta, thrust asymmetry s, yaw dJ
    # s2 = sin^2(alpha), scw = sin(alpha) cos(alpha) alpha' (measured; used by the yaw axis only);
    # ext: an extra torque [N m] from the measured states (a data-driven correction, diagnosis/sparse.py)
    m = th[2] * tau_m * (abs(tau_m) if th[6] > 0 else tau_m) + th[3] * tau_m
    if tau_m < 0.0:
        m *= 1.0 + fx[5]
    fric = -fx[0] * math.tanh(v / 1e-3) - fx[1] * v * abs(v) + ext
    if pitch:
        acc = m - th[4] * math.sin(x + fx[3]) - th[5] * m * other * math.cos(x) + fric
        acc -= fx[6] * math.sin(x) * math.cos(x) * other * other  # centrifugal: J'(alpha) beta'^2 / 2
        return (acc - th[1] * v) / th[0]
    acc = m - other - fx[2] * x + fric + 2.0 * fx[6] * scw * v
    return (acc - th[1] * v) / (th[0] - fx[6] * s2)


@njit(cache=True)
def predict(pitch, x_start, v_start, tau, other, s2, scw, ext, dt, horizon, th, fx):
    """Angle predictions [rad], restarted every ``horizon`` samples from x_start (logged angle) and
    v_start [rad/s] at the restart sample; inputs (tau, other = beta' or M_R, s2, scw, ext: see _rhs) are linear
    between samples."""
    n = x_start.size
    out = np.empty(n)
    x = 0.0
    v = 0.0
    for k in range(n):
        if k % horizon == 0:
            x = x_start[k] - fx[4]
            v = v_start[k]
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
    return out


def predict_fitted_start(pitch, x_meas, v_guess, tau, other, s2, scw, ext, dt, horizon, th, fx) -> np.ndarray:
    """Predictions with each window's initial angle and velocity fitted to the window's measurements."""
    y0 = predict(pitch, x_meas, v_guess, tau, other, s2, scw, ext, dt, horizon, th, fx)
    hx = 1e-6 * max(float(np.max(np.abs(x_meas))), 1.0)  # rad
    hv = 1e-5 * max(float(np.max(np.abs(v_guess))), 1.0)  # rad/s
    sx = (predict(pitch, x_meas + hx, v_guess, tau, other, s2, scw, ext, dt, horizon, th, fx) - y0) / hx
    sv = (predict(pitch, x_meas, v_guess + hv, tau, other, s2, scw, ext, dt, horizon, th, fx) - y0) / hv
    e = x_meas - y0
    n = x_meas.size
    starts = np.arange(0, n, horizon)
    sums = lambda z: np.add.reduceat(z, starts)  # noqa: E731
    a11, a12, a22 = sums(sx * sx), sums(sx * sv), sums(sv * sv)
    b1, b2 = sums(sx * e), sums(sv * e)
    ridge = 1e-12 * (a11 + a22) + 1e-300
    det = (a11 + ridge) * (a22 + ridge) - a12 * a12
    dx = ((a22 + ridge) * b1 - a12 * b2) / det
    dv = ((a11 + ridge) * b2 - a12 * b1) / det
    w = np.arange(n) // horizon
    y1 = predict(pitch, x_meas + dx[w], v_guess + dv[w], tau, other, s2, scw, ext, dt, horizon, th, fx)
    # keep a window's step only where it lowers that window's error (friction makes the start non-smooth)
    better = sums((x_meas - y1) ** 2) < sums(e * e)
    return np.where(better[w], y1, y0)


def nrmse_fit(y: np.ndarray, y_hat: np.ndarray) -> float:
    den = float(np.linalg.norm(y - y.mean()))
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / den) if den > 0 else math.nan
