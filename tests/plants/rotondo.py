"""The nonlinear TRMS model of Rotondo, Nejjari and Puig (2013), as a test plant with its own parameter values.

Ported from the model's equations and published values (the public CHRONOS-MPC / MPC-LPV examples,
examples/TRMS/TRMS.m); the code is ours.  It is not the plant of eq. (1): rotor speeds are states with
armature dynamics, thrust is quadratic in the rotor speed with different coefficients forwards and in
reverse, the yaw inertia depends on the pitch angle (cos^2/sin^2), the yaw has a restoring cable torque
with its own coefficients per side, and gravity acts through cos/sin of the pitch with a counterweight.
A tool that fits eq. (1) to its logs must say that the model does not fit.

States x = [Wh, Omh, Thth, Wv, Omv, Thtv]: tail-rotor speed, yaw rate, yaw angle, main-rotor speed,
pitch rate, pitch angle [rad, rad/s].  Inputs uh (tail, yaw) and uv (main, pitch) [V].
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

P = dict(k_g=0.2, l_t=0.282, l_m=0.246, l_b=0.29, l_cb=0.276, r_ts=0.1, r_ms=0.155, m_cb=0.068, m_b=0.022,
         m_m=0.014, m_mr=0.236, m_ms=0.219, k_a=0.0202, B_tr=0.0086, B_mr=0.0026, k_tvp=0.0168, k_tvn=0.0155,
         k_fhp=0.0566, k_fhn=0.0660, k_fvp=0.3819, k_fvn=0.2197, k_chp=0.0158, k_chn=0.0111, k_cvp=0.0623,
         k_cvn=0.0563, m_t=0.015, m_tr=0.221, m_ts=0.119, J_tr=0.0059, J_mr=0.0254, R_a=8.0, k_m=0.0017,
         k_1=6.5, k_2=8.5, k_oh=0.0185, k_ov=0.1026, k_thp=0.0027, k_thn=0.0028, g=9.81,
         thtv0=-0.619426178368110)
_ORDER = tuple(P)


def _vector(p: dict) -> np.ndarray:
    return np.array([p[k] for k in _ORDER], dtype=float)


@njit(cache=True)
def _signed_sq(w, kp, kn):
    return kp * w * w if w >= 0.0 else -kn * w * w


@njit(cache=True)
def _deriv(x, uh, uv, q, d):
    (k_g, l_t, l_m, l_b, l_cb, r_ts, r_ms, m_cb, m_b, m_m, m_mr, m_ms, k_a, B_tr, B_mr, k_tvp, k_tvn, k_fhp,
     k_fhn, k_fvp, k_fvn, k_chp, k_chn, k_cvp, k_cvn, m_t, m_tr, m_ts, J_tr, J_mr, R_a, k_m, k_1, k_2, k_oh,
     k_ov, k_thp, k_thn, g, thtv0) = (q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11],
                                     q[12], q[13], q[14], q[15], q[16], q[17], q[18], q[19], q[20], q[21], q[22],
                                     q[23], q[24], q[25], q[26], q[27], q[28], q[29], q[30], q[31], q[32], q[33],
                                     q[34], q[35], q[36], q[37], q[38], q[39])
    wh, omh, thth, wv, omv, thtv = x[0], x[1], x[2], x[3], x[4], x[5]
    ka = (0.5 * m_t + m_tr + m_ts) * l_t
    kb = (0.5 * m_m + m_mr + m_ms) * l_m
    kcc = 0.5 * m_b * l_b + m_cb * l_cb
    kd = (m_m / 3 + m_mr + m_ms) * l_m ** 2 + (m_t / 3 + m_tr + m_ts) * l_t ** 2
    ke = m_b * l_b ** 2 / 3 + m_cb * l_cb ** 2
    kf = m_ms * r_ms ** 2 + 0.5 * m_ts * r_ts ** 2
    kh = ka * l_t + kb * l_m + 0.5 * m_b * l_b ** 2 + m_cb * l_cb
    c, s = math.cos(thtv), math.sin(thtv)
    jh = kd * c * c + ke * s * s + kf  # yaw inertia: depends on the pitch angle
    f1 = _signed_sq(wh, k_thp, k_thn)
    f2 = _signed_sq(wh, k_fhp, k_fhn)
    f3 = k_chp * thth if thth >= 0.0 else k_chn * thth  # cable
    f4 = _signed_sq(wv, k_tvp, k_tvn)
    f5 = _signed_sq(wv, k_fvp, k_fvn)
    dv = thtv - thtv0
    f6 = k_cvp * dv * dv if thtv >= thtv0 else k_cvn * dv * dv
    d[0] = k_a * k_1 / (J_tr * R_a) * uh - (B_tr / J_tr + k_a ** 2 / (J_tr * R_a)) * wh - f1 / J_tr
    d[1] = ((l_t * f2 * c - k_oh * omh - f3 + f6) / jh
            + k_m * wv * s * omv * (kd * c * c - ke * s * s - kf - 2 * ke * c * c) / (jh * jh)
            + k_m * c * ((k_a * k_2 / R_a) * uv - (B_mr + k_a ** 2 / R_a) * wv - f4) / (J_mr * jh))
    d[2] = omh
    jv = (m_mr * l_m ** 2 + m_m * l_m ** 2 / 3 + m_cb * l_cb ** 2 + m_b * l_b ** 2 / 3 + m_tr * l_t ** 2
          + m_t * l_t ** 2 / 3 + 0.5 * m_ms * r_ms ** 2 + m_ms * l_m ** 2 + 0.5 * m_ts * r_ts ** 2 + m_ts * l_t ** 2)
    d[3] = k_a * k_2 / (J_mr * R_a) * uv - (B_mr / J_mr + k_a ** 2 / (J_mr * R_a)) * wv - f4 / J_mr
    d[4] = ((l_m * f5 + k_g * omh * f5 * c - k_ov * omv) / jv
            + (g * ((ka - kb) * c - kcc * s) - omh * omh * kh * s * c) / jv)
    d[5] = omv


@njit(cache=True)
def _run(t, uh, uv, q, x0, h_max, out):
    x = x0.copy()
    k1, k2, k3, k4, xt = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    for k in range(t.size):
        out[k, 0], out[k, 1] = x[5], x[2]
        if k == t.size - 1:
            break
        ns = max(1, int(math.ceil((t[k + 1] - t[k]) / h_max)))
        h = (t[k + 1] - t[k]) / ns
        for _ in range(ns):
            _deriv(x, uh[k], uv[k], q, k1)
            xt[:] = x + 0.5 * h * k1
            _deriv(xt, uh[k], uv[k], q, k2)
            xt[:] = x + 0.5 * h * k2
            _deriv(xt, uh[k], uv[k], q, k3)
            xt[:] = x + h * k3
            _deriv(xt, uh[k], uv[k], q, k4)
            x += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def simulate_log(duration_s: float = 120.0, rate_hz: float = 100.0, seed: int = 0, noise_rad: float = 5e-4):
    """An open-loop identification experiment on this plant: held random-step voltages (a new level every
    0.5-3 s), from rest at the pitch equilibrium.  Returns t [s], u1 (main, pitch) [V], u2 (tail, yaw) [V],
    alpha (pitch) [rad], beta (yaw) [rad], the columns of a trms-ident log."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    u = np.empty((n, 2))
    k = 0
    while k < n:
        m = int(rng.uniform(0.5, 3.0) * rate_hz)
        u[k:k + m] = [rng.uniform(-1.0, 1.0), rng.uniform(0.0, 1.5)]  # tail, main
        k += m
    x0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, P["thtv0"]])
    out = np.empty((n, 2))
    _run(t, u[:, 0].copy(), u[:, 1].copy(), _vector(P), x0, 2.5e-3, out)
    noise = rng.standard_normal((n, 2)) * noise_rad
    return t, u[:, 1].copy(), u[:, 0].copy(), out[:, 0] + noise[:, 0], out[:, 1] + noise[:, 1]
