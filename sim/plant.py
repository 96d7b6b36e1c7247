"""Compiled closed-loop kernel: TRMS plant (paper eq. 1) under a digital PID (paper eq. 9).

Written independently of the estimator (``trms_ident``): tests that feed simulated
logs to the estimator are a real cross-check.  State vector:
``[alpha, alpha', beta, beta', tau1, tau2, zeta, v1, v2]`` with zeta the lag state of the
main-rotor reaction moment M_R = kc (T0 s + 1)/(Tp s + 1) tau1, and v1, v2 the drive a second-order motor
follows (the voltage through 1/(T2 s + 1), effect motor_second_lag; the voltage itself when it is off).

The controller samples the (noisy, quantized) angles at t_k, holds the voltage
over [t_k, t_k+1) and the plant is integrated with classical RK4 sub-steps.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from trms_ident.numerics.kernel_args import HELPER

# Order of the plant parameter vector.
PARAM_ORDER = ("J1", "B1", "J2", "B2", "a1", "b1", "a2", "b2", "Mg", "Kg",
               "k1", "k2", "T11", "T10", "T21", "T20", "kc", "T0", "Tp")
OMEGA_SMOOTH = 1e-3  # rad/s: Coulomb sign() is smoothed as tanh(omega / OMEGA_SMOOTH)


@njit(cache=True)
def _thrust(tau, a, b, law):
    if law == 1:
        return a * tau * abs(tau) + b * tau
    return a * tau * tau + b * tau


@njit(cache=True)
def _deadzone_sat(u, w, big_u, shift=0.0):
    """A motor's drive: the cut-off dead zone (|u| < w gives 0, larger u unchanged), the shifted one of the
    modelling tools' Dead Zone blocks (0 inside [-shift, shift], u - shift sign(u) outside), then the clip."""
    if abs(u) < w or abs(u) <= shift:
        return 0.0
    if shift > 0.0:
        u = u - shift if u > 0.0 else u + shift
    return min(max(u, -big_u), big_u)


@njit(cache=True)
def _factor(code, al, dal, be, dbe, tau1, tau2, M1, M2, MR, u1, u2):
    """A term's factor (sim.effects.TERM_FACTORS) from the true states; 1 for code 0 (no factor)."""
    if code == 1:
        return al
    if code == 2:
        return be
    if code == 3:
        return math.sin(al)
    if code == 4:
        return math.cos(al)
    if code == 5:
        return dal
    if code == 6:
        return dbe
    if code == 7:
        return abs(dal)
    if code == 8:
        return abs(dbe)
    if code == 9:
        return math.tanh(dal / OMEGA_SMOOTH)
    if code == 10:
        return math.tanh(dbe / OMEGA_SMOOTH)
    if code == 11:
        return tau1
    if code == 12:
        return tau2
    if code == 13:
        return M1
    if code == 14:
        return M2
    if code == 15:
        return MR
    if code == 16:
        return u1
    if code == 17:
        return u2
    return 1.0


@njit(cache=True, **HELPER)  # no reference counting (trms_ident/numerics/kernel_args.py)
def _deriv(x, u1, u2, p, law, fx, dx):
    J1, B1, J2, B2 = p[0], p[1], p[2], p[3]
    a1, b1, a2, b2, Mg, Kg = p[4], p[5], p[6], p[7], p[8], p[9]
    k1, k2, T11, T10, T21, T20 = p[10], p[11], p[12], p[13], p[14], p[15]
    kc, T0, Tp = p[16], p[17], p[18]
    al, dal, be, dbe, tau1, tau2, zeta = x[0], x[1], x[2], x[3], x[4], x[5], x[6]
    M1 = _thrust(tau1, a1, b1, law)
    M2 = _thrust(tau2, a2, b2, law)
    if tau1 < 0.0:  # thrust asymmetry: a reversed rotor pushes (1 + s) times the law
        M1 *= 1.0 + fx[13]
    if tau2 < 0.0:
        M2 *= 1.0 + fx[14]
    MR = kc * (T0 / Tp * tau1 + (1.0 - T0 / Tp) * zeta)
    extra1 = -fx[0] * math.tanh(dal / OMEGA_SMOOTH) - fx[2] * dal * abs(dal)
    extra2 = -fx[1] * math.tanh(dbe / OMEGA_SMOOTH) - fx[3] * dbe * abs(dbe) - fx[4] * be
    if fx.size > 21:  # terms (sim.effects.TERM_FACTORS): c x the product of up to three factors on one axis
        for i in range(int(fx[21])):
            b = 22 + 5 * i
            v = fx[b + 1]
            for j in range(3):
                v *= _factor(int(fx[b + 2 + j]), al, dal, be, dbe, tau1, tau2, M1, M2, MR, u1, u2)
            if fx[b] == 0.0:
                extra1 += v
            else:
                extra2 += v
    # pitch-dependent yaw inertia J(alpha) = J2 - dJ sin^2(alpha) (Lagrange: kinetic energy J(alpha) beta'^2 / 2):
    # pitch gains J'(alpha) beta'^2 / 2 = -dJ sin cos beta'^2, yaw d/dt(J beta') = J beta'' + J'(alpha) alpha' beta'
    dj = fx[15]
    sc = math.sin(al) * math.cos(al)
    dx[0] = dal
    dx[1] = (M1 - B1 * dal - Mg * math.sin(al + fx[5]) - Kg * M1 * dbe * math.cos(al) + extra1
             - dj * sc * dbe * dbe) / J1
    dx[2] = dbe
    dx[3] = (M2 - B2 * dbe - MR + extra2 + 2.0 * dj * sc * dal * dbe) / (J2 - dj * math.sin(al) ** 2)
    # a second-order motor: the drive follows the voltage through a further first-order lag (the cascade of two
    # linear lags is the same in either order, so the thrust sees the doubly lagged state)
    drive1, drive2 = u1, u2
    if dx.size > 8 and x.size > 8 and fx.size > 17:  # numba checks no bounds: a 7-state caller stays first order
        dx[7] = 0.0
        dx[8] = 0.0
        if fx[16] > 0.0:
            drive1 = x[7]
            dx[7] = (u1 - x[7]) / fx[16]
        if fx[17] > 0.0:
            drive2 = x[8]
            dx[8] = (u2 - x[8]) / fx[17]
    dx[4] = (k1 * drive1 - T10 * tau1) / T11
    dx[5] = (k2 * drive2 - T20 * tau2) / T21
    dx[6] = (tau1 - zeta) / Tp


@njit(cache=True)
def _rk4(x, u1, u2, p, law, fx, h, nsteps):
    n = x.size
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    xt = np.empty(n)
    for _ in range(nsteps):
        _deriv(x, u1, u2, p, law, fx, k1)
        for i in range(n):
            xt[i] = x[i] + 0.5 * h * k1[i]
        _deriv(xt, u1, u2, p, law, fx, k2)
        for i in range(n):
            xt[i] = x[i] + 0.5 * h * k2[i]
        _deriv(xt, u1, u2, p, law, fx, k3)
        for i in range(n):
            xt[i] = x[i] + h * k3[i]
        _deriv(xt, u1, u2, p, law, fx, k4)
        for i in range(n):
            x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def _quantize(v, q):
    if q > 0.0:
        return q * math.floor(v / q + 0.5)
    return v


@njit(cache=True)
def closed_loop(dts, aref, bref, p, law, gains, u_lim, fx, noise_a, noise_b, q, h_max, x0, u_offset):
    """Run the loop for ``aref.size`` samples; returns (u1, u2, alpha_log, beta_log, state_true).

    dts[k] [s] is the actual interval from sample k to k + 1 (the voltage set at sample k is held
    over it; jittered stamps have unequal intervals); the controller itself assumes the nominal step.
    u_offset: the voltage computed at sample k reaches the motors u_offset x dts[k] after it (a controller
    that publishes after reading the angles); the previous voltage holds until then.

    gains = [Kp1, Ki1, Kd1, Kp2, Ki2, Kd2, Tf] (PID per axis, derivative on the
    measurement filtered with time constant Tf [s]).  u_lim [V] is the controller's
    output limit; the logged u is the commanded (applied) voltage.
    """
    if x0.size != 9 or fx.size < 21:
        raise ValueError("closed_loop needs 9 start states and an effect vector of sim.effects.N_EFFECT_SLOTS")
    n = aref.size
    x = x0.copy()
    u1_log = np.empty(n)
    u2_log = np.empty(n)
    a_log = np.empty(n)
    b_log = np.empty(n)
    true_state = np.empty((n, 4))
    integ1 = 0.0
    integ2 = 0.0
    d1 = 0.0
    d2 = 0.0
    prev_a = 0.0
    prev_b = 0.0
    tf = gains[6]
    dt = np.median(dts)
    delay = fx[12]
    m_del = int(math.floor(delay / dt + 1e-12))
    r_del = delay - m_del * dt
    lag = fx[18] if fx.size > 18 else 0.0  # the acquisition chain's first-order lag [s] (sensor_lag)
    fa = x[0]
    fb = x[2]
    for k in range(n):
        if lag > 0.0:  # a digital first-order lag of the sampled angles, at rest on the first ones
            if k > 0:
                c = math.exp(-dts[k - 1] / lag)
                fa = c * fa + (1.0 - c) * x[0]
                fb = c * fb + (1.0 - c) * x[2]
        else:
            fa = x[0]
            fb = x[2]
        a_meas = _quantize(fa + fx[6] + noise_a[k], q)
        b_meas = _quantize(fb + fx[7] + noise_b[k], q)
        a_log[k] = a_meas
        b_log[k] = b_meas
        true_state[k, 0] = x[0]
        true_state[k, 1] = x[1]
        true_state[k, 2] = x[2]
        true_state[k, 3] = x[3]
        if k == 0:
            prev_a = a_meas
            prev_b = b_meas
        # eq. (9): PID per axis, derivative on measurement (no kick on reference steps)
        e1 = aref[k] - a_meas
        e2 = bref[k] - b_meas
        d1 = (tf * d1 - (a_meas - prev_a)) / (tf + dt)
        d2 = (tf * d2 - (b_meas - prev_b)) / (tf + dt)
        prev_a = a_meas
        prev_b = b_meas
        v1 = gains[0] * e1 + integ1 + gains[2] * d1
        v2 = gains[3] * e2 + integ2 + gains[5] * d2
        u1 = min(max(v1, -u_lim), u_lim)
        u2 = min(max(v2, -u_lim), u_lim)
        # conditional integration (anti-windup)
        if u1 == v1 or (u1 > 0) != (e1 > 0):
            integ1 += gains[1] * e1 * dt
        if u2 == v2 or (u2 > 0) != (e2 > 0):
            integ2 += gains[4] * e2 * dt
        u1_log[k] = u1
        u2_log[k] = u2
        if k == n - 1:
            break
        # the plant sees u(t - delay): over [t_k, t_k + r) the older command, then the newer
        i_new = k - m_del
        i_old = i_new - 1
        ua1 = u1_log[i_old] if i_old >= 0 else 0.0
        ua2 = u2_log[i_old] if i_old >= 0 else 0.0
        ub1 = u1_log[i_new] if i_new >= 0 else 0.0
        ub2 = u2_log[i_new] if i_new >= 0 else 0.0
        r_k = r_del if delay > 0.0 else u_offset * dts[k]
        pieces_len = (min(r_k, dts[k]), dts[k] - min(r_k, dts[k]))
        pieces_u1 = (ua1, ub1)
        pieces_u2 = (ua2, ub2)
        for j in range(2):
            length = pieces_len[j]
            if length <= 0.0:
                continue
            ns = int(math.ceil(length / h_max - 1e-9))
            if ns < 1:
                ns = 1
            w1 = _deadzone_sat(pieces_u1[j], fx[8], fx[10], fx[19])
            w2 = _deadzone_sat(pieces_u2[j], fx[9], fx[11], fx[20])
            _rk4(x, w1, w2, p, law, fx, length / ns, ns)
    return u1_log, u2_log, a_log, b_log, true_state


@njit(cache=True)
def open_loop(dt, u1, u2, p, law, fx, h_max, x0):
    """Plant driven by logged, held voltages (no controller); returns true (alpha, beta) per sample.  ``x0``: the
    9 states (module docstring); ``fx``: the effect vector (sim.effects.pack's N_EFFECT_SLOTS)."""
    if x0.size != 9 or fx.size < 21:
        raise ValueError("open_loop needs 9 start states and an effect vector of sim.effects.N_EFFECT_SLOTS")
    n = u1.size
    x = x0.copy()
    out = np.empty((n, 2))
    ns = max(1, int(math.ceil(dt / h_max - 1e-9)))
    for k in range(n):
        out[k, 0] = x[0]
        out[k, 1] = x[2]
        if k < n - 1:
            _rk4(x, _deadzone_sat(u1[k], fx[8], fx[10], fx[19]),
                 _deadzone_sat(u2[k], fx[9], fx[11], fx[20]), p, law, fx, dt / ns, ns)
    return out
