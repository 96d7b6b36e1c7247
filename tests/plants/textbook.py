"""The TRMS of eq. (1) with its effects in the forms modelling tools give them: an independent test plant.

Written from the model (shared notes, model.md: eq. (1), Table 1, kc/T0/Tp) and from the blocks' documentation,
not from sim/ or trms_ident/: the tests that diagnose its logs then check the tool against physics it did not
shape.  The effect forms are the textbook ones:

- a dead zone as Simulink's Dead Zone block (and Simscape's, Modelica's Blocks.Nonlinear.DeadZone, PLECS's)
  writes it: 0 inside [start, end], u - end above, u - start below; symmetric when start = -end.  The motor sees
  the command shifted by the width, not cut off below it;
- a saturation as Simulink's Saturation block: clip(u, lower, upper);
- a motor of second order with both time constants free: k / (T10 (Ta s + 1)(T2 s + 1)) with Ta = T11/T10 as
  given (off Table 1 if asked) and a second lag T2 in front.

The bench is driven as labs drive it: a digital PID per axis (parallel form, filtered derivative on the measured
angle) computes the voltage at each sample from the logged angles and holds it; the logged voltage is the command,
what the motor sees passes through the effects above.  Angles are logged through a 12-bit encoder or with Gaussian
noise.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Table 1 of the paper, with kc, T0, Tp of the public Feedback model code (shared notes, model.md)
TABLE = dict(J1=0.068, J2=0.02, B1=0.006, B2=0.1, a1=0.0135, b1=0.0924, a2=0.02, b2=0.09, Mg=0.32, Kg=0.05,
             k1=1.1, k2=0.8, T11=1.1, T10=1.0, T21=1.0, T20=1.0, kc=-0.2, T0=3.5, Tp=2.0)
_ORDER = tuple(TABLE)
#: PID gains per axis [V/rad, V/(rad s), V s/rad] and the derivative filter [s]
GAINS = (1.0, 2.0, 4.0, 3.5, 1.25, 2.2, 0.02)
U_MAX_V = 2.5


@njit(cache=True)
def _dead_zone(u, start, end):
    # Simulink Dead Zone block: zero inside [start, end], the input less the zone's edge outside it
    if u > end:
        return u - end
    if u < start:
        return u - start
    return 0.0


@njit(cache=True)
def _deriv(x, v1, v2, q, lag2, d):
    (J1, J2, B1, B2, a1, b1, a2, b2, Mg, Kg, k1, k2, T11, T10, T21, T20, kc, T0, Tp) = (
        q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11], q[12], q[13], q[14], q[15],
        q[16], q[17], q[18])
    alpha, dalpha, beta, dbeta, tau1, tau2, r, z1, z2 = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8]
    # a second-order motor: its drive z follows the voltage through the extra lag; a first-order one sees v
    drive1 = z1 if lag2[0] > 0.0 else v1
    drive2 = z2 if lag2[1] > 0.0 else v2
    m1 = a1 * tau1 * tau1 + b1 * tau1  # thrust moments
    m2 = a2 * tau2 * tau2 + b2 * tau2
    dtau1 = (k1 * drive1 - T10 * tau1) / T11  # T11 tau1' + T10 tau1 = k1 u1
    mr = kc * (r + T0 * (tau1 - r) / Tp)  # kc (T0 s + 1)/(Tp s + 1) tau1, r the lag's state
    d[0] = dalpha
    d[1] = (m1 - B1 * dalpha - Mg * math.sin(alpha) - Kg * m1 * dbeta * math.cos(alpha)) / J1
    d[2] = dbeta
    d[3] = (m2 - B2 * dbeta - mr) / J2
    d[4] = dtau1
    d[5] = (k2 * drive2 - T20 * tau2) / T21
    d[6] = (tau1 - r) / Tp
    d[7] = (v1 - z1) / lag2[0] if lag2[0] > 0.0 else 0.0
    d[8] = (v2 - z2) / lag2[1] if lag2[1] > 0.0 else 0.0


@njit(cache=True)
def _run(t, aref, bref, q, zone, clip, lag2, gains, x0, u0, quantum, noise, h_max, out_u, out_y):
    """Closed loop over the stamps t: at each sample the controller reads the logged angles, sets the held
    command; the plant integrates (RK4, steps <= h_max) with the effects applied to that command."""
    kp1, ki1, kd1, kp2, ki2, kd2, tf = gains[0], gains[1], gains[2], gains[3], gains[4], gains[5], gains[6]
    x = x0.copy()
    k_1, k_2, k_3, k_4, xt = np.empty(9), np.empty(9), np.empty(9), np.empty(9), np.empty(9)
    i1 = i2 = 0.0
    df1 = df2 = 0.0
    prev_a = prev_b = 0.0
    for k in range(t.size):
        ya = x[0] + noise[k, 0]
        yb = x[2] + noise[k, 1]
        if quantum > 0.0:
            ya = quantum * math.floor(ya / quantum + 0.5)  # to the nearest code (a truncating encoder reads
            yb = quantum * math.floor(yb / quantum + 0.5)  # half a quantum low: a true encoder offset)
        out_y[k, 0], out_y[k, 1] = ya, yb
        dt = t[k + 1] - t[k] if k + 1 < t.size else t[k] - t[k - 1]
        if k == 0:
            prev_a, prev_b = ya, yb
            u1, u2 = u0[0], u0[1]
            # integrators that hold the first command (a controller already driving)
            i1, i2 = u0[0] - kp1 * (aref[0] - ya), u0[1] - kp2 * (bref[0] - yb)
        else:
            e1, e2 = aref[k] - ya, bref[k] - yb
            i1 += ki1 * e1 * dt
            i2 += ki2 * e2 * dt
            c = tf / (tf + dt)  # derivative on the measurement through a first-order filter
            df1 = c * df1 + (1 - c) * (ya - prev_a) / dt
            df2 = c * df2 + (1 - c) * (yb - prev_b) / dt
            prev_a, prev_b = ya, yb
            i1 = min(max(i1, -U_MAX_V), U_MAX_V)
            i2 = min(max(i2, -U_MAX_V), U_MAX_V)
            u1 = min(max(kp1 * e1 + i1 - kd1 * df1, -U_MAX_V), U_MAX_V)
            u2 = min(max(kp2 * e2 + i2 - kd2 * df2, -U_MAX_V), U_MAX_V)
        out_u[k, 0], out_u[k, 1] = u1, u2
        if k == t.size - 1:
            break
        v1 = min(max(_dead_zone(u1, zone[0], zone[1]), clip[0]), clip[1])
        v2 = min(max(_dead_zone(u2, zone[2], zone[3]), clip[2]), clip[3])
        ns = max(1, int(math.ceil(dt / h_max)))
        h = dt / ns
        for _ in range(ns):
            _deriv(x, v1, v2, q, lag2, k_1)
            xt[:] = x + 0.5 * h * k_1
            _deriv(xt, v1, v2, q, lag2, k_2)
            xt[:] = x + 0.5 * h * k_2
            _deriv(xt, v1, v2, q, lag2, k_3)
            xt[:] = x + h * k_3
            _deriv(xt, v1, v2, q, lag2, k_4)
            x += h / 6.0 * (k_1 + 2 * k_2 + 2 * k_3 + k_4)


def reference(kind: str, t: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Pitch and yaw references [rad]: ``multisine`` (eight sines 0.04-1 Hz, amplitudes falling as 1/sqrt(f), random phases, ramped in over 2 s) or ``steps``
    (a new random level every 2-6 s)."""
    ramp = np.clip(t / 2.0, 0.0, 1.0)  # from rest without a jump
    if kind == "multisine":
        f = np.geomspace(0.04, 1.0, 8)
        amp = (f / f[0]) ** -0.5
        ph = rng.uniform(0, 2 * np.pi, (2, 8))
        pa = (amp * np.sin(2 * np.pi * t[:, None] * f + ph[0])).sum(1)
        pb = (amp * np.sin(2 * np.pi * t[:, None] * f + ph[1])).sum(1)
        return 0.5 * ramp * pa / np.abs(pa).max(), 0.5 * ramp * pb / np.abs(pb).max()
    if kind == "steps":
        a, b = np.empty_like(t), np.empty_like(t)
        k = 0
        while k < t.size:
            m = max(1, int(rng.uniform(2.0, 6.0) / (t[1] - t[0])))
            a[k:k + m], b[k:k + m] = rng.uniform(-0.3, 0.4), rng.uniform(-0.8, 0.8)
            k += m
        return a, b
    raise ValueError(f"unknown reference {kind!r}; expected multisine or steps")


def simulate_log(duration_s: float = 90.0, rate_hz: float = 1000.0, seed: int = 0, ref: str = "multisine",
                 dead_zone_v: tuple[float, float] | None = None, zone_pitch: tuple[float, float] | None = None,
                 zone_yaw: tuple[float, float] | None = None, saturation_v: tuple[float, float] | None = None,
                 second_lag_s: tuple[float, float] = (0.0, 0.0), values: dict | None = None,
                 encoder_bits: int | None = 12, noise_rad: float = 0.0, start_s: float = 0.0,
                 gains: tuple = GAINS):
    """A closed-loop log of this plant: t [s], u1, u2 [V] (the commands), alpha, beta [rad] (as logged).

    ``dead_zone_v``: symmetric dead-zone widths (pitch, yaw) [V]; ``zone_pitch``/``zone_yaw``: an asymmetric
    zone (start, end) [V] instead.  ``saturation_v``: clip levels (pitch, yaw) [V].  ``second_lag_s``: each
    motor's second lag T2 [s] (0: first order).  ``values``: Table 1 entries off the table (T11, Mg, ...).
    ``encoder_bits``: the angles' quantisation (None: none), ``noise_rad``: Gaussian noise std [rad].
    ``start_s``: the log starts this far into the run (mid-run: motors and controller already moving).
    ``gains``: the PID's (Kp1, Ki1, Kd1, Kp2, Ki2, Kd2, Tf), as GAINS."""
    rng = np.random.default_rng(seed)
    q = np.array([{**TABLE, **(values or {})}[k] for k in _ORDER], dtype=float)
    skip = int(round(start_s * rate_hz))
    n = int(round(duration_s * rate_hz)) + 1 + skip
    t = np.arange(n) / rate_hz
    aref, bref = reference(ref, t, rng)
    zone = np.zeros(4)
    if dead_zone_v is not None:
        zone[:] = (-dead_zone_v[0], dead_zone_v[0], -dead_zone_v[1], dead_zone_v[1])
    if zone_pitch is not None:
        zone[0:2] = zone_pitch
    if zone_yaw is not None:
        zone[2:4] = zone_yaw
    clip = np.array([-np.inf, np.inf, -np.inf, np.inf])
    if saturation_v is not None:
        clip[:] = (-saturation_v[0], saturation_v[0], -saturation_v[1], saturation_v[1])
    quantum = 2 * math.pi / 2 ** encoder_bits if encoder_bits else 0.0
    noise = rng.standard_normal((n, 2)) * noise_rad
    out_u, out_y = np.empty((n, 2)), np.empty((n, 2))
    x0 = np.zeros(9)  # at rest, motors off: the controller starts from 0 V
    _run(t, aref, bref, q, zone, clip, np.asarray(second_lag_s, dtype=float), np.asarray(gains, dtype=float), x0,
         np.zeros(2), quantum, noise, 1e-3, out_u, out_y)
    cut = slice(skip, None)
    return t[cut], out_u[cut, 0], out_u[cut, 1], out_y[cut, 0], out_y[cut, 1]
