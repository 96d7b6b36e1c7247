"""Multi-step prediction fit of each axis (NRMSE %), with or without the fitted effects.

The model is run from the measured angle and a smoothed velocity, driven by the logged
voltages (through the motor lags) and, for pitch, the measured yaw rate, for HORIZON_S
seconds; then it restarts from the measurement.  A free run over the whole log would be
meaningless for yaw: with no restoring force its angle integrates every small torque error
and drifts without bound.  Fit = 100 (1 - |y - y_hat| / |y - mean y|).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

HORIZON_S = 2.0


@njit(cache=True)
def _rhs(pitch, x, v, tau_m, other, th, fx):
    # th: J, B, a, b, Mg, Kg, signed;  fx: Fc, c, k_cable, com_delta, sensor_delta
    m = th[2] * tau_m * (abs(tau_m) if th[6] > 0 else tau_m) + th[3] * tau_m
    fric = -fx[0] * math.tanh(v / 1e-3) - fx[1] * v * abs(v)
    if pitch:
        acc = m - th[4] * math.sin(x + fx[3]) - th[5] * m * other * math.cos(x) + fric
    else:
        acc = m - other - fx[2] * x + fric
    return (acc - th[1] * v) / th[0]


@njit(cache=True)
def predict(pitch, x_meas, v_meas, tau, other, dt, horizon, th, fx):
    """Angle predictions; inputs (tau, other = beta' or M_R) are linear between samples."""
    n = x_meas.size
    out = np.empty(n)
    x = 0.0
    v = 0.0
    for k in range(n):
        if k % horizon == 0:
            x = x_meas[k] - fx[4]
            v = v_meas[k]
        out[k] = x + fx[4]
        if k == n - 1:
            break
        t0, t1 = tau[k], tau[k + 1]
        o0, o1 = other[k], other[k + 1]
        tm, om = 0.5 * (t0 + t1), 0.5 * (o0 + o1)
        a1 = _rhs(pitch, x, v, t0, o0, th, fx)
        a2 = _rhs(pitch, x + 0.5 * dt * v, v + 0.5 * dt * a1, tm, om, th, fx)
        a3 = _rhs(pitch, x + 0.5 * dt * (v + 0.5 * dt * a1), v + 0.5 * dt * a2, tm, om, th, fx)
        a4 = _rhs(pitch, x + dt * (v + 0.5 * dt * a2), v + dt * a3, t1, o1, th, fx)
        x += dt * (v + dt / 6.0 * (a1 + a2 + a3))
        v += dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return out


def nrmse_fit(y: np.ndarray, y_hat: np.ndarray) -> float:
    den = float(np.linalg.norm(y - y.mean()))
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / den) if den > 0 else math.nan
