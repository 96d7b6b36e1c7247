"""The Humusoft CE150 helicopter as its authors published it, as an independent test plant.

Ported from the Simulink diagram Model_HeliCE150_PID_FFCwithNN.slx (subsystem "Humusoft CE150 Helicopter":
simulink/systems/system_10.xml, _13, _22 and _31 of the .slx zip) and its parameter file
Param_HeliCE150_PID_FFCwithNN.m, in the public repository JurCag/NN_for_FF_Compensation; the code is ours.
It is not the plant of eq. (1):

    w_i   = 1 / (T_i s + 1)^2  u_i                    second-order motors driven by the inputs u_i [MU]
    Tau_i = a_i w_i^2 + b_i w_i                        thrust torques [N m]
    I psi''       = Tau_1 - B_psi psi' - K_Gyro cos(psi) phi' u1 - Tau_g sin(psi)   (elevation)
    I_phi phi''   = Tau_2 - B_phi phi' - K_r (T_0r s + 1)/(T_pr s + 1) u1             (azimuth)
                    [- F_c sign(phi'): not in the published model, F_c 0 unless given]

The gyroscopic torque and the reaction torque are driven by the input u1 itself, not by a motor state; the
elevation runs between end stops at 45 and 135 degrees and the azimuth between -130 and +130 degrees (Simulink's
Second-Order Integrator with position limits: at a stop the position holds and the rate is zero until the
acceleration points away from it).  It starts on the 45 degree stop.  Angles come out in radians here (the
diagram's outputs are degrees; its published simulations, ../shared/real_logs/ce150, are in degrees).

The CE150's psi is eq. (1)'s alpha and phi its beta (trms_ident/benches/humusoft_ce150.toml).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Param_HeliCE150_PID_FFCwithNN.m; F_c [N m], a Coulomb friction on the azimuth, is not in it (0: the published
#: model), but the authors' azimuth sweeps show one of ~4e-4 N m (benchmarks/ce150_sweep.py)
P = dict(a_1=0.105, b_1=0.00936, a_2=0.033, b_2=0.0294, B_psi=0.00184, I=0.00437, B_phi=0.00869, I_phi=0.00414,
         T_1=0.3, T_2=0.25, K_r=0.00162, T_0r=2.7, T_pr=0.75, K_Gyro=0.015, Tau_g=0.0383, F_c=0.0)
#: F_c's sign smoothed as tanh(phi' / FRICTION_SMOOTH_RAD_S) [rad/s] (a smooth right side for RK4 and for least
#: squares; the tool's own friction uses the same width)
FRICTION_SMOOTH_RAD_S = 1e-3
_ORDER = tuple(P)
#: the integrators' position limits [rad]: elevation 45-135 deg, azimuth +-130 deg
PSI_STOPS = (math.pi / 4, 3 * math.pi / 4)
PHI_STOPS = (-130 * math.pi / 180, 130 * math.pi / 180)
#: the input range of the bench [MU]
U_MAX = 1.0


def vector(p: dict | None = None) -> np.ndarray:
    return np.array([{**P, **(p or {})}[k] for k in _ORDER], dtype=float)


@njit(cache=True)
def _deriv(x, u1, u2, q, d):
    a1, b1, a2, b2, b_psi, inertia, b_phi, i_phi, t1, t2, k_r, t0r, tpr, k_gyro, tau_g, f_c = (
        q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11], q[12], q[13], q[14], q[15])
    psi, dpsi, phi, dphi, z1, w1, z2, w2, r = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8]
    tau1 = a1 * w1 * w1 + b1 * w1
    tau2 = a2 * w2 * w2 + b2 * w2
    reaction = k_r * (r + t0r * (u1 - r) / tpr)  # K_r (T_0r s + 1)/(T_pr s + 1) u1, r its lag's state
    d[0] = dpsi
    d[1] = (tau1 - b_psi * dpsi - k_gyro * math.cos(psi) * dphi * u1 - tau_g * math.sin(psi)) / inertia
    d[2] = dphi
    d[3] = (tau2 - b_phi * dphi - reaction - f_c * math.tanh(dphi / FRICTION_SMOOTH_RAD_S)) / i_phi
    d[4] = (u1 - z1) / t1  # 1/(T s + 1)^2 as two lags in cascade
    d[5] = (z1 - w1) / t1
    d[6] = (u2 - z2) / t2
    d[7] = (z2 - w2) / t2
    d[8] = (u1 - r) / tpr


@njit(cache=True)
def _stop(x, i, lo, hi, acc):
    """Simulink's Second-Order Integrator at a position limit: the position held, the rate zero, while the
    acceleration ``acc`` points out of the range."""
    if x[i] <= lo and (x[i + 1] < 0.0 or (x[i + 1] == 0.0 and acc <= 0.0)):
        x[i], x[i + 1] = lo, 0.0
    elif x[i] >= hi and (x[i + 1] > 0.0 or (x[i + 1] == 0.0 and acc >= 0.0)):
        x[i], x[i + 1] = hi, 0.0


@njit(cache=True)
def _rk4(x, u1, u2, q, h, k1, k2, k3, k4, xt):
    """x advanced by h [s] with the inputs held, classical RK4, no position limit."""
    _deriv(x, u1, u2, q, k1)
    xt[:] = x + 0.5 * h * k1
    _deriv(xt, u1, u2, q, k2)
    xt[:] = x + 0.5 * h * k2
    _deriv(xt, u1, u2, q, k3)
    xt[:] = x + h * k3
    _deriv(xt, u1, u2, q, k4)
    x += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


@njit(cache=True)
def _step(x, u1, u2, q, h, stops, k1, k2, k3, k4, xt):
    """One step of h [s] with the position limits as Simulink's solver meets them, zero-crossing detection on: an
    angle that would pass its stop within the step is advanced to the moment it reaches it (bisection in time),
    set there with zero rate, and the rest of the step integrated from there; one resting on its stop stays while
    the acceleration points out of the range (_stop)."""
    left = h
    for _ in range(4):  # a few stop events within one step at most
        y = x.copy()
        _rk4(y, u1, u2, q, left, k1, k2, k3, k4, xt)
        first, at, edge = left, -1, 0.0
        for i in (0, 2):
            lo, hi = stops[i], stops[i + 1]
            if (x[i] > lo and y[i] < lo) or (x[i] < hi and y[i] > hi):
                e = lo if y[i] < lo else hi
                a, b = 0.0, left
                for _ in range(60):  # the crossing's time to round-off
                    m = 0.5 * (a + b)
                    z = x.copy()
                    _rk4(z, u1, u2, q, m, k1, k2, k3, k4, xt)
                    if (z[i] - e) * (x[i] - e) > 0.0:
                        a = m
                    else:
                        b = m
                if b < first:
                    first, at, edge = b, i, e
        if at < 0:
            x[:] = y
            break
        _rk4(x, u1, u2, q, first, k1, k2, k3, k4, xt)
        x[at], x[at + 1] = edge, 0.0
        left -= first
        if left <= 0.0:
            break
    _deriv(x, u1, u2, q, k1)
    _stop(x, 0, stops[0], stops[1], k1[1])
    _stop(x, 2, stops[2], stops[3], k1[3])


@njit(cache=True)
def _open_loop(t, u1, u2, q, x0, stops, h_max, out):
    x = x0.copy()
    k1, k2, k3, k4, xt = np.empty(9), np.empty(9), np.empty(9), np.empty(9), np.empty(9)
    for k in range(t.size):
        out[k, 0], out[k, 1] = x[0], x[2]
        if k == t.size - 1:
            break
        ns = max(1, int(math.ceil((t[k + 1] - t[k]) / h_max)))
        h = (t[k + 1] - t[k]) / ns
        for j in range(ns):
            # the inputs linear over the interval (a continuous controller's output sampled by To Workspace)
            s = (j + 0.5) / ns
            _step(x, u1[k] + s * (u1[k + 1] - u1[k]), u2[k] + s * (u2[k + 1] - u2[k]), q, h, stops, k1, k2, k3,
                  k4, xt)


def rest_state(u1: float = 0.0, u2: float = 0.0, psi: float = PSI_STOPS[0], phi: float = 0.0) -> np.ndarray:
    """States at rest with the motors and the reaction's lag settled at held inputs u1, u2 [MU]."""
    return np.array([psi, 0.0, phi, 0.0, u1, u1, u2, u2, u1])


def open_loop(t: np.ndarray, u1: np.ndarray, u2: np.ndarray, x0: np.ndarray | None = None, p: dict | None = None,
              h_max: float = 1e-3) -> np.ndarray:
    """psi, phi [rad] (n x 2) at the stamps t [s] for the inputs u1, u2 [MU] at those stamps (linear between
    them), from ``x0`` (rest_state of the first inputs on the 45 degree stop by default)."""
    t, u1, u2 = (np.ascontiguousarray(v, dtype=float) for v in (t, u1, u2))
    x0 = rest_state(u1[0], u2[0]) if x0 is None else np.asarray(x0, dtype=float)
    out = np.empty((t.size, 2))
    _open_loop(t, u1, u2, vector(p), x0, np.array(PSI_STOPS + PHI_STOPS), h_max, out)
    return out


@njit(cache=True)
def _closed_loop(t, psi_ref, phi_ref, q, x0, stops, gains, u1_ff, quantum, noise, h_max, out_u, out_y):
    """A digital PID per axis on the logged angles (the inputs held over each sample), the elevation's added to
    the feedforward input u1_ff [MU] of each sample."""
    kp1, ki1, kd1, kp2, ki2, kd2, tf = gains[0], gains[1], gains[2], gains[3], gains[4], gains[5], gains[6]
    x = x0.copy()
    k1, k2, k3, k4, xt = np.empty(9), np.empty(9), np.empty(9), np.empty(9), np.empty(9)
    i1 = i2 = d1 = d2 = 0.0
    pa = pb = 0.0
    for k in range(t.size):
        ya = x[0] + noise[k, 0]
        yb = x[2] + noise[k, 1]
        if quantum > 0.0:
            ya = quantum * math.floor(ya / quantum + 0.5)
            yb = quantum * math.floor(yb / quantum + 0.5)
        out_y[k, 0], out_y[k, 1] = ya, yb
        dt = t[k + 1] - t[k] if k + 1 < t.size else t[k] - t[k - 1]
        if k == 0:
            pa, pb = ya, yb
        e1, e2 = psi_ref[k] - ya, phi_ref[k] - yb
        c = tf / (tf + dt)
        d1 = c * d1 + (1 - c) * (ya - pa) / dt
        d2 = c * d2 + (1 - c) * (yb - pb) / dt
        pa, pb = ya, yb
        v1 = u1_ff[k] + kp1 * e1 + i1 - kd1 * d1
        v2 = kp2 * e2 + i2 - kd2 * d2
        u1 = min(max(v1, -U_MAX), U_MAX)
        u2 = min(max(v2, -U_MAX), U_MAX)
        if u1 == v1:  # integrate only while the output is not clipped (anti-windup)
            i1 += ki1 * e1 * dt
        if u2 == v2:
            i2 += ki2 * e2 * dt
        out_u[k, 0], out_u[k, 1] = u1, u2
        if k == t.size - 1:
            break
        ns = max(1, int(math.ceil(dt / h_max)))
        for _ in range(ns):
            _step(x, u1, u2, q, dt / ns, stops, k1, k2, k3, k4, xt)


#: PID gains [MU/rad, MU/(rad s), MU s/rad] per axis and the derivative filter [s]: the elevation open loop (its
#: gravity holds it below 90 deg, and a PID through the 0.6 s of its second-order motor limit-cycles), the
#: azimuth, whose damping is its only restoring torque, under a PID
GAINS = (0.0, 0.0, 0.0, 0.5, 0.05, 0.2, 0.02)


def hover(psi_rad: float, p: dict | None = None) -> float:
    """The input u1 [MU] whose thrust holds the arm at elevation psi [rad] against gravity (eq. Tau_1 = Tau_g
    sin psi solved for the motor's steady speed, which equals u1)."""
    q = {**P, **(p or {})}
    a, b = q["a_1"], q["b_1"]
    return math.sqrt(q["Tau_g"] * math.sin(psi_rad) / a + (b / (2 * a)) ** 2) - b / (2 * a)


def excitation(kind: str, t: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The main motor's feedforward u1 [MU] (the hover input for 65 deg plus a zero-mean excitation of +-0.015
    MU: the elevation's static gain near hover is about 10 rad/MU, and above the hover input for 90 deg, 0.561 MU,
    nothing holds the arm off its 135 deg stop) and the azimuth reference [rad]:
    ``multisine`` (six sines 0.03-0.6 Hz, random phases), ``steps`` (a new level every 3-8 s) or ``ramp``
    (the published runs' kind: slow sweeps, the azimuth -90 -> 90 deg and back)."""
    ramp = np.clip(t / 3.0, 0.0, 1.0)  # from rest without a jump
    u0 = hover(math.radians(65))
    if kind == "multisine":
        f = np.geomspace(0.03, 0.6, 6)
        ph = rng.uniform(0, 2 * np.pi, (2, 6))
        a = np.sin(2 * np.pi * t[:, None] * f + ph[0]).sum(1)
        b = np.sin(2 * np.pi * t[:, None] * f + ph[1]).sum(1)
        return u0 + 0.015 * ramp * a / np.abs(a).max(), ramp * math.radians(70) * b / np.abs(b).max()
    if kind == "steps":
        a, b = np.empty_like(t), np.empty_like(t)
        k = 0
        while k < t.size:
            m = max(1, int(rng.uniform(3.0, 8.0) / (t[1] - t[0])))
            a[k:k + m], b[k:k + m] = u0 + rng.uniform(-0.015, 0.015), math.radians(rng.uniform(-80, 80))
            k += m
        return a, b
    if kind == "ramp":
        s = 0.5 - 0.5 * np.cos(2 * np.pi * t / t[-1])
        return u0 - 0.015 + 0.03 * s, math.radians(-90) + math.radians(180) * s
    raise ValueError(f"unknown excitation {kind!r}; expected multisine, steps or ramp")


def simulate_log(duration_s: float = 60.0, rate_hz: float = 100.0, seed: int = 0, ref: str = "multisine",
                 encoder_bits: int | None = 12, noise_rad: float = 0.0, p: dict | None = None, gains=GAINS):
    """A log of this model: t [s], u1, u2 [MU], psi (alpha), phi (beta) [rad] as logged (an encoder of
    ``encoder_bits`` per turn, and/or Gaussian noise of ``noise_rad``), from rest on the 45 degree stop; the
    main motor driven by ``excitation``, the azimuth by a PID on its reference."""
    rng = np.random.default_rng(seed)
    n = int(round(duration_s * rate_hz)) + 1
    t = np.arange(n) / rate_hz
    u1_ff, b_ref = excitation(ref, t, rng)
    quantum = 2 * math.pi / 2 ** encoder_bits if encoder_bits else 0.0
    noise = rng.standard_normal((n, 2)) * noise_rad
    out_u, out_y = np.empty((n, 2)), np.empty((n, 2))
    _closed_loop(t, np.full(n, math.radians(70)), b_ref, vector(p), rest_state(), np.array(PSI_STOPS + PHI_STOPS),
                 np.asarray(gains, dtype=float), u1_ff, quantum, noise, 1e-3, out_u, out_y)
    return t, out_u[:, 0].copy(), out_u[:, 1].copy(), out_y[:, 0].copy(), out_y[:, 1].copy()
