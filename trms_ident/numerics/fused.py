"""Compiled passes per axis from the logged samples to the mixed regressions (eqs. 1, 3, 5-7) and DREM's results.

``mixed_regressions``: the same computation as ``regressors`` + ``drem.extend_and_mix`` (the reference path
built on scipy.signal, kept for tests and diagnostics), fused into a single loop so that a one-hour 1 kHz log
costs one pass over memory instead of some twenty; tested against the reference path to 1e-12.
``drem_summaries`` (what identify uses): the same regressions summed as they are made, with eq. (8) run in
the same loop, so that phi and eps are never held (tested against mixed_regressions + gradient_estimator +
confidence_interval).
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..model.plant import pitch_torque, reaction_moment, thrust, yaw_torque
from ..model.structure import gyroscope_voltage, of_bench, reaction_voltage
from .coefficients import bilinear_second_order, zoh_first_order, zoh_lead_lag, zoh_reaction
from .drem import gradient_step
from .kernel_args import HELPER, readonly

# filter slots: motor lag, M_R path, F, F s^2, F s, H on g, H on m1, H on m2
TAU, MR, F0, F2, F1, HG, HM1, HM2 = range(8)


@njit(cache=True, nogil=True, **HELPER)
def _init(b, a, i, x0, z):
    y0 = (b[i, 0] + b[i, 1] + b[i, 2]) / (a[i, 0] + a[i, 1] + a[i, 2]) * x0
    z[i, 1] = b[i, 2] * x0 - a[i, 2] * y0
    z[i, 0] = b[i, 1] * x0 - a[i, 1] * y0 + z[i, 1]


@njit(cache=True, nogil=True, **HELPER)
def _step(b, a, i, x, z):
    y = b[i, 0] * x + z[i, 0]  # direct form II transposed, as scipy.signal.lfilter
    z[i, 0] = b[i, 1] * x - a[i, 1] * y + z[i, 1]
    z[i, 1] = b[i, 2] * x - a[i, 2] * y
    return y


@njit(cache=True, nogil=True, **HELPER)
def _angle_part(k, x, b, a, z):
    """Sample k of the regressor m = F [s^2 x, s x] (eq. 3) and H m (eq. 5): (m1, m2, Hm1, Hm2)."""
    if k == 0:
        _init(b, a, F2, x[0], z)
        _init(b, a, F1, x[0], z)
    m1 = _step(b, a, F2, x[k], z)
    m2 = _step(b, a, F1, x[k], z)
    if k == 0:
        _init(b, a, HM1, m1, z)
        _init(b, a, HM2, m2, z)
    return m1, m2, _step(b, a, HM1, m1, z), _step(b, a, HM2, m2, z)


@njit(cache=True, nogil=True, **HELPER)
def _sample(k, pitch, u_tau, u1, x, beta, dt, b, a, th_a, th_b, signed, mg, kg, gv, z):
    """Sample k of one axis' mixed regression: (phi, eps_J, eps_B); the filters' states z advance one step.
    u1: the main motor's voltage (pitch: the gyroscope's drive when ``gv``, the bench's structure) or, on the yaw,
    M_R's input (the voltage, or M_R itself on a jittered log's grid: the filter passes it through)."""
    n = x.size
    first = k == 0
    if first:
        _init(b, a, TAU, u_tau[0], z)
    tau = _step(b, a, TAU, u_tau[k], z)
    m = thrust(tau, th_a, th_b, signed)  # eq. (1)
    if pitch:
        # beta' by central difference (edges: second-order one-sided, as numpy.gradient)
        if k == 0:
            db = (-3.0 * beta[0] + 4.0 * beta[1] - beta[2]) / (2.0 * dt)
        elif k == n - 1:
            db = (3.0 * beta[k] - 4.0 * beta[k - 1] + beta[k - 2]) / (2.0 * dt)
        else:
            db = (beta[k + 1] - beta[k - 1]) / (2.0 * dt)
        y = pitch_torque(m, u1[k] if gv else m, math.sin(x[k]), math.cos(x[k]), db, mg, kg)  # eq. (1), pitch
    else:
        if first:
            _init(b, a, MR, u1[0], z)
        y = yaw_torque(m, _step(b, a, MR, u1[k], z))  # eq. (1), yaw: M2 - M_R
    if first:
        _init(b, a, F0, y, z)
    g = _step(b, a, F0, y, z)  # eq. (3)
    if first:
        _init(b, a, HG, g, z)
    hg = _step(b, a, HG, g, z)  # eq. (5)
    m1, m2, hm1, hm2 = _angle_part(k, x, b, a, z)
    # eq. (7): phi = det M, eps = adj(M) [g; Hg]
    return m1 * hm2 - m2 * hm1, hm2 * g - m2 * hg, m1 * hg - hm1 * g


@njit(cache=True, nogil=True)
def _axis(pitch, u_tau, u1, x, beta, dt, b, a, th_a, th_b, signed, mg, kg, gv, phi, eps):
    z = np.zeros((8, 2))
    for k in range(x.size):
        phi[k], eps[k, 0], eps[k, 1] = _sample(k, pitch, u_tau, u1, x, beta, dt, b, a, th_a, th_b, signed, mg, kg, gv,
                                               z)


@njit(cache=True, nogil=True)
def _axis_summary(pitch, u_tau, u1, x, beta, dt, b, a, th_a, th_b, signed, mg, kg, gv, block, sums, totals,
                  gamma, rate, floor_fraction, out, step, skip):
    """The axis' DREM results without holding phi and eps: two passes over the samples.

    Pass 1, the angle's filters alone: phi's mean square (eq. 8's gain floor needs it before the first step).
    Pass 2: totals = (sum phi^2, sum phi eps_J, sum phi eps_B), the same sums per block of ``block`` samples
    (rows of ``sums``; the samples after the last whole block count in the totals only), and eq. (8) for both
    parameters (drem.gradient_estimator's recursion), every ``step``-th value into ``out``.  Returns the final
    estimates.  ``skip`` (n,) True where a sample is left out of the sums and of eq. (8) (an angle at an end stop,
    and the samples its contact torque reaches through the filters), or empty: none."""
    n = x.size
    some = skip.size > 0
    z = np.zeros((8, 2))
    energy = 0.0
    used = 0
    for k in range(n):
        m1, m2, hm1, hm2 = _angle_part(k, x, b, a, z)
        if some and skip[k]:
            continue
        ph = m1 * hm2 - m2 * hm1  # eq. (7)
        energy += ph * ph
        used += 1
    floor = floor_fraction * energy / max(used, 1)
    z[:, :] = 0.0
    q = np.zeros(2)
    nb = sums.shape[0]
    seen = 0
    for k in range(n):
        ph, e0, e1 = _sample(k, pitch, u_tau, u1, x, beta, dt, b, a, th_a, th_b, signed, mg, kg, gv, z)
        if some and skip[k]:
            if k % step == 0:
                out[k // step, 0] = q[0]
                out[k // step, 1] = q[1]
            continue
        seen += 1
        totals[0] += ph * ph
        totals[1] += ph * e0
        totals[2] += ph * e1
        i = k // block
        if i < nb:
            sums[i, 0] += ph * ph
            sums[i, 1] += ph * e0
            sums[i, 2] += ph * e1
        norm = max(totals[0] / seen, floor)
        gradient_step(q, 0, e0, ph, gamma[0], norm, rate, dt)  # eq. (8)
        gradient_step(q, 1, e1, ph, gamma[1], norm, rate, dt)
        if k % step == 0:
            out[k // step, 0] = q[0]
            out[k // step, 1] = q[1]
    return q


def _coefficients(pitch: bool, p: dict, dt: float, a_rad_s: float, b_rad_s: float, f_gain: float, h_gain: float,
                  structure: dict | None = None):
    b = np.zeros((8, 3))
    a = np.zeros((8, 3))
    a[:, 0] = 1.0
    k, t1, t0 = (p["k1"], p["T11"], p["T10"]) if pitch else (p["k2"], p["T21"], p["T20"])
    b[TAU], a[TAU] = zoh_first_order(k, t1, t0, dt)
    b[MR], a[MR] = (zoh_lead_lag(p["kc"], p["T0"], p["Tp"], dt) if reaction_voltage(structure) else
                    zoh_reaction(p["kc"], p["k1"], p["T0"], p["Tp"], p["T11"], p["T10"], dt))
    for slot, order in ((F0, 0), (F2, 2), (F1, 1)):
        b[slot], a[slot] = bilinear_second_order(a_rad_s, f_gain, order, dt)
    for slot in (HG, HM1, HM2):
        b[slot], a[slot] = bilinear_second_order(b_rad_s, h_gain, 0, dt)
    return b, a


def _axis_inputs(axis: str, u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, p: dict, law: str, a_rad_s: float,
                 b_rad_s: float, f_gain: float, h_gain: float, motor, structure: dict | None = None) -> tuple:
    """The leading arguments of the axis kernels (_axis, _axis_summary) for "pitch" or "yaw".  ``structure``: the
    bench's (model/structure.py; None: eq. 1)."""
    pitch = axis == "pitch"
    b, a = _coefficients(pitch, p, dt_s, a_rad_s, b_rad_s, f_gain, h_gain, structure)
    drive, reaction = (u1_v if pitch else u2_v), u1_v
    if motor is not None:
        for slot in (TAU, MR):
            b[slot], a[slot] = (1.0, 0.0, 0.0), (1.0, 0.0, 0.0)
        drive, reaction = motor[0 if pitch else 1], (u1_v if pitch else motor[2])
    th_a, th_b = (p["a1"], p["b1"]) if pitch else (p["a2"], p["b2"])
    drive, reaction, angle, beta = map(readonly, (drive, reaction, alpha_rad if pitch else beta_rad, beta_rad))
    return (pitch, drive, reaction, angle, beta, dt_s, b, a, th_a, th_b,
            law == "signed", p["Mg"], p["Kg"], gyroscope_voltage(structure))


def mixed_regressions(u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, p: dict, law: str,
                      a_rad_s: float, b_rad_s: float, f_gain: float, h_gain: float,
                      motor: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None, structure: dict | None = None
                      ) -> dict:
    """{axis: (phi, eps (n, 2))} for "pitch" and "yaw", both axes computed in parallel.

    ``motor``: tau1, tau2 and M_R [N m] already on the samples (jittered logs: numerics/hold.py); the
    voltages are then not used and the motor and M_R filters pass these through."""
    n = alpha_rad.size
    out = {}

    def run(axis: str):
        phi, eps = np.empty(n), np.empty((n, 2))
        _axis(*_axis_inputs(axis, u1_v, u2_v, alpha_rad, beta_rad, dt_s, p, law, a_rad_s, b_rad_s, f_gain, h_gain,
                            motor, structure), phi, eps)
        out[axis] = (phi, eps)

    with ThreadPoolExecutor(max_workers=2) as pool:
        list(pool.map(run, ("pitch", "yaw")))
    return out


@dataclass(frozen=True)
class AxisSummary:
    """What identification needs of one axis' mixed regressions eps = phi q (eq. 7), without phi and eps."""

    energy: float  # sum phi^2 over the log
    cross: np.ndarray  # (2,) sum phi eps_J, sum phi eps_B
    block_sums: np.ndarray  # (K, 3) the same three sums per block (stats.interval_from_sums)
    trace: np.ndarray  # (m, 2) eq. (8)'s estimates of J, B at every step-th sample
    final: np.ndarray  # (2,) eq. (8)'s last estimates


def drem_summaries(u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, p: dict, law: str, a_rad_s: float, b_rad_s: float,
                   f_gain: float, h_gain: float, motor, *, block: int, gamma: dict, rate_per_s: float,
                   step: int, floor_fraction: float = 0.02, structure: dict | None = None,
                   skip: dict | None = None) -> dict[str, AxisSummary]:
    """{axis: AxisSummary}: the same numbers as mixed_regressions followed by drem.gradient_estimator and
    stats.confidence_interval (tested), in memory independent of the log's length (an hour at 1 kHz held
    phi and eps as 174 MB).  ``gamma``: {axis: (gamma_J, gamma_B)}, None for the normalized gain.  ``structure``:
    the bench's (model/structure.py).  ``skip``: {axis: (n,) bool}, the samples left out of that axis' sums
    (stop_samples), or None."""
    n = alpha_rad.size
    out = {}

    def run(axis: str):
        sums, totals = np.zeros((n // block, 3)), np.zeros(3)
        trace = np.empty(((n + step - 1) // step, 2))
        gam = np.array([-1.0 if g is None else float(g) for g in gamma[axis]])
        left = (skip or {}).get(axis)
        final = _axis_summary(*_axis_inputs(axis, u1_v, u2_v, alpha_rad, beta_rad, dt_s, p, law, a_rad_s, b_rad_s,
                                            f_gain, h_gain, motor, structure),
                              block, sums, totals, gam, float(rate_per_s), float(floor_fraction), trace, int(step),
                              readonly(np.zeros(0, dtype=np.bool_) if left is None else
                                       np.asarray(left, dtype=np.bool_)))
        out[axis] = AxisSummary(float(totals[0]), totals[1:].copy(), sums, trace, final)

    with ThreadPoolExecutor(max_workers=2) as pool:
        list(pool.map(run, ("pitch", "yaw")))
    return out


@njit(cache=True, nogil=True)
def _biquad(b, a, x, y):
    z = np.zeros((1, 2))
    bb = b.reshape(1, 3)
    aa = a.reshape(1, 3)
    _init(bb, aa, 0, x[0], z)
    for k in range(x.size):
        y[k] = _step(bb, aa, 0, x[k], z)


def biquad(b: np.ndarray, a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """lfilter(b, a, x) for one second-order section, starting in the steady state of x[0]."""
    y = np.empty(x.size)
    _biquad(np.ascontiguousarray(b, dtype=float), np.ascontiguousarray(a, dtype=float),
            readonly(x), y)
    return y


def warm_up() -> None:
    """Load every compiled kernel from numba's cache on a tiny input.

    The first load initialises numba's code generator (~0.5 s); commands call this in a
    background thread while the log is being read, so that the wait overlaps the parse.
    """
    x = np.linspace(0.0, 1.0, 16)
    p = {"k1": 1.0, "T11": 1.0, "T10": 1.0, "k2": 1.0, "T21": 1.0, "T20": 1.0, "kc": -0.2, "T0": 3.5, "Tp": 2.0,
         "a1": 0.01, "b1": 0.1, "a2": 0.01, "b2": 0.1, "Mg": 0.3, "Kg": 0.05}
    sm = drem_summaries(x, x, x, x, 0.01, p, "quadratic", 1.0, 2.0, 1.0, 4.0, None, block=4,
                        gamma={"pitch": (None, None), "yaw": (None, None)}, rate_per_s=1.0, step=1)
    biquad(np.array([1.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0]), x)
    start_unknowns("yaw", sm["yaw"], x, x, x, x, 0.01, p, "quadratic", 1.0, 2.0, 1.0, 4.0, None, 4)


@njit(cache=True, nogil=True)
def _motor_states(u1, u2, ur, c1, c2, kc, t0, tp, rv, x0, out):
    """Rows 0, 1, 4 of ``out`` (tau1, tau2, M_R) from given start states x0 = (tau1, tau2, zeta), the voltages
    held over each sample: c1 = zoh_motor_lag_states of the main motor and the reaction lag (e1, e2, phi21, g1,
    g2), c2 = (e, g) of the tail motor.  eq. (1): M_R = kc (T0/Tp tau1 + (1 - T0/Tp) zeta); ``rv`` (the bench's
    structure): kc (T0/Tp ur + (1 - T0/Tp) zeta), zeta the lag of the voltage ``ur`` itself (u1 before a
    second-order motor's further lag, which acts on the motor alone)."""
    t1, t2, z = x0[0], x0[1], x0[2]
    for k in range(u1.size):
        out[0, k] = t1
        out[1, k] = t2
        out[4, k] = reaction_moment(ur[k] if rv else t1, z, kc, t0, tp)
        if rv:
            t1, z = c1[0] * t1 + c1[3] * u1[k], c1[1] * z + (1.0 - c1[1]) * ur[k]
        else:
            t1, z = c1[0] * t1 + c1[3] * u1[k], c1[2] * t1 + c1[1] * z + c1[4] * u1[k]
        t2 = c2[0] * t2 + c2[1] * u2[k]


#: which rows _plant_signals writes (np.empty's pages in the others are never touched, never resident: each
#: row is 29 MB an hour at 1 kHz, and writing all eight was most of a candidate's cost on long logs)
ROWS_ALL, ROWS_MOTORS, ROWS_TARGETS = 0, 1, 2
ROWS = {"all": ROWS_ALL, "motors": ROWS_MOTORS, "targets": ROWS_TARGETS}


@njit(cache=True, nogil=True)
def _plant_signals(u1, u2, ur, ug, sin_a, cos_a, beta, dt, b, a, a1, b1, a2, b2, signed, mg, kg, gv, delta, given,
                   rows, out):
    """One pass of regressors.plant_signals (eq. 1): out rows tau1, tau2, M1, M2, M_R, beta', y_p, y_y.
    ``rows``: ROWS_ALL, ROWS_MOTORS (tau1, tau2, M_R, beta'; sin_a, cos_a not read) or ROWS_TARGETS (y_p, y_y);
    the other rows are not touched.  sin_a, cos_a: sin and cos of alpha (computed once by the caller, reused
    across candidates).  ``ur``: what drives M_R's filter (u1 itself in eq. 1); ``ug``: the gyroscope's drive
    where ``gv`` (the bench's structure)."""
    n = beta.size
    sd, cd = math.sin(delta), math.cos(delta)
    z = np.zeros((3, 2))
    motors = rows != ROWS_TARGETS
    torques = rows != ROWS_MOTORS
    for k in range(n):
        if k == 0:
            _init(b, a, 0, u1[0], z)
            _init(b, a, 1, u2[0], z)
            _init(b, a, 2, ur[0], z)
        if given:  # motor states from their estimated start (rows 0, 1, 4 filled by _motor_states)
            t1, t2, mr = out[0, k], out[1, k], out[4, k]
        else:
            t1 = _step(b, a, 0, u1[k], z)  # eq. (1): motor lags, zero-order hold
            t2 = _step(b, a, 1, u2[k], z)
            mr = _step(b, a, 2, ur[k], z)  # eq. (1): M_R from u1 in one ZOH step
        if n < 3:
            db = 0.0
        elif k == 0:  # beta' as numpy.gradient(edge_order=2)
            db = (-3.0 * beta[0] + 4.0 * beta[1] - beta[2]) / (2.0 * dt)
        elif k == n - 1:
            db = (3.0 * beta[k] - 4.0 * beta[k - 1] + beta[k - 2]) / (2.0 * dt)
        else:
            db = (beta[k + 1] - beta[k - 1]) / (2.0 * dt)
        if motors:
            out[0, k] = t1
            out[1, k] = t2
            out[4, k] = mr
            out[5, k] = db
        if torques:
            m1 = thrust(t1, a1, b1, signed)
            m2 = thrust(t2, a2, b2, signed)
            if rows == ROWS_ALL:
                out[2, k] = m1
                out[3, k] = m2
            s_ad = sin_a[k] if delta == 0.0 else sin_a[k] * cd + cos_a[k] * sd  # sin(alpha + delta)
            out[6, k] = pitch_torque(m1, ug[k] if gv else m1, s_ad, cos_a[k], db, mg, kg)  # eq. (1), pitch
            out[7, k] = yaw_torque(m2, mr)  # eq. (1), yaw


def plant_signals(u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, p: dict, law: str, gravity_offset_rad: float = 0.0,
                  trig: tuple | None = None, start: dict | None = None, rows: str = "all",
                  structure: dict | None = None, drive_v: np.ndarray | None = None):
    """regressors.plant_signals in one compiled pass (the same ZOH coefficients, the same steady start);
    equal to the reference to round-off (tested).  For the diagnosis, which rebuilds these signals for
    every candidate and grid point; ``trig``: (sin alpha, cos alpha) when the caller keeps them; ``start``: the
    motor and reaction-lag states at the first sample (tau1_0, tau2_0, zeta_0, as the refinement estimates
    them) instead of the steady state of the first voltage (a log that begins mid-run).  ``rows="motors"``: the
    motor states, M_R and beta' only (the other fields None); ``rows="targets"``: y_pitch_nm, y_yaw_nm only (a
    candidate's regression targets; a quarter of the memory traffic).  ``structure``: the bench's (model/structure.py;
    None: eq. 1).  ``drive_v``: the voltage u1 as the gyroscope and M_R see it where the structure drives them by
    the voltage (default u1_v): u1 before a second-order motor's further lag, which acts on the motor alone (the
    output-error kernel's drives, numerics.refine._motor_rhs)."""
    from .filters import discretize
    from .regressors import PlantSignals

    b = np.zeros((3, 3))
    a = np.zeros((3, 3))
    structure = structure if structure is not None else of_bench(p)  # diagnose's bench holds it (model.structure)
    rv = reaction_voltage(structure)
    ud = u1_v if drive_v is None else drive_v  # the gyroscope's and (rv) M_R's drive; eq. (1): u1 through M_R's
    ur = ud if rv else u1_v  # filter (kc k1 (T0 s + 1) / ((Tp s + 1) (T11 s + T10))), which holds the motor lag
    for i, f in enumerate((discretize([p["k1"]], [p["T11"], p["T10"]], dt_s, "zoh"),
                           discretize([p["k2"]], [p["T21"], p["T20"]], dt_s, "zoh"),
                           discretize(p["kc"] * p["k1"] * np.array([p["T0"], 1.0]),
                                      np.polymul([p["Tp"], 1.0], [p["T11"], p["T10"]]), dt_s, "zoh"))):
        b[i, :f.b.size], a[i, :f.a.size] = f.b, f.a
    if rv:  # M_R driven by u1 itself (the bench's structure), not through the main motor
        b[2], a[2] = zoh_lead_lag(p["kc"], p["T0"], p["Tp"], dt_s)
    out = np.empty((8, alpha_rad.size))
    if start is not None:
        from .coefficients import zoh_first_order, zoh_motor_lag_states

        c1 = np.array(zoh_motor_lag_states(p["k1"], p["Tp"], p["T11"], p["T10"], dt_s))
        bb, aa = zoh_first_order(p["k2"], p["T21"], p["T20"], dt_s)
        _motor_states(readonly(u1_v), readonly(u2_v), readonly(ur), c1,
                      np.array([-aa[1], bb[1]]), p["kc"], p["T0"], p["Tp"], rv,
                      np.array([start["tau1_0"], start["tau2_0"], start["zeta_0"]], dtype=float), out)
    mode = ROWS[rows]
    if mode == ROWS_MOTORS:
        sin_a = cos_a = np.empty(0)
    else:
        sin_a, cos_a = trig if trig is not None else (np.sin(alpha_rad), np.cos(alpha_rad))
    _plant_signals(readonly(u1_v), readonly(u2_v), readonly(ur), readonly(ud),
                   readonly(sin_a), readonly(cos_a), readonly(beta_rad),
                   float(dt_s), b, a, p["a1"], p["b1"], p["a2"], p["b2"], law == "signed", p["Mg"], p["Kg"],
                   gyroscope_voltage(structure), float(gravity_offset_rad), start is not None, mode, out)
    if mode == ROWS_MOTORS:
        return PlantSignals(out[0], out[1], None, None, out[4], out[5], None, None)
    if mode == ROWS_TARGETS:
        return PlantSignals(None, None, None, None, None, None, out[6], out[7])
    return PlantSignals(*out)


#: a log that does not start at rest: every filter above starts in the steady state of its first sample, which is the
#: angles' and motors' true history only when the bench was at rest with the first voltages held before the log
#: began (model.md, "Unknown start").  Otherwise each regression carries, besides q, a term of the filters' and the
#: motor's free responses, which the offline estimate takes as unknowns (start_unknowns).  Those responses fall as
#: t e^(-t / T), T the slowest of their time constants: by 30 T below 1e-11 of their start, the window over which
#: they are fitted.
START_TIME_CONSTANTS = 30.0


@dataclass(frozen=True)
class Offline:
    """The sums of ``interval_from_sums`` per parameter of one axis (J, B) with the start's unknowns taken out."""

    energy: np.ndarray  # (2,) sum phi^2, phi without the part the start's responses explain
    cross: np.ndarray  # (2,) sum phi eps
    block_energy: np.ndarray  # (K, 2)
    block_cross: np.ndarray  # (K, 2)


@njit(cache=True, nogil=True)
def _free(den, n, j, out):
    """The solution of den's homogeneous recurrence (y_k = -den[1] y_(k-1) - den[2] y_(k-2)) that starts at the
    unit vector j of its first two values: every free response of a filter with this denominator is a combination
    of those for j < its order."""
    if n > 0:
        out[0] = 1.0 if j == 0 else 0.0
    if n > 1:  # first order (den[2] 0): y_1 = -den[1] y_0 already
        out[1] = (1.0 if j == 1 else 0.0) if den[2] != 0.0 else -den[1] * out[0]
    for k in range(2, n):
        out[k] = -den[1] * out[k - 1] - den[2] * out[k - 2]


def _time_constant_samples(den: np.ndarray) -> float:
    """The time constant of a filter's slowest pole, in samples (0 for a filter without poles)."""
    rho = max((abs(r) for r in np.roots(den)), default=0.0) if den[1] != 0.0 or den[2] != 0.0 else 0.0
    return -1.0 / math.log(rho) if 0.0 < rho < 1.0 else 0.0


def _free_responses(den: np.ndarray, n: int) -> list[np.ndarray]:
    order = 2 if den[2] != 0.0 else (1 if den[1] != 0.0 else 0)
    out = []
    for j in range(order):
        y = np.empty(n)
        _free(np.ascontiguousarray(den, dtype=float), n, j, y)
        out.append(y)
    return out


def start_unknowns(axis: str, summary: AxisSummary, u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, p: dict, law: str,
                   a_rad_s: float, b_rad_s: float, f_gain: float, h_gain: float, motor, block: int,
                   structure: dict | None = None, left: np.ndarray | None = None) -> Offline:
    """The axis' offline sums (eq. 7 least squares) with the log's start taken as unknown, not as rest.

    With the filters started in the steady state of the first samples, g = m^T q + r exactly, r a combination of
    the free responses of the F filters (two: their angles' and torque's histories), of the motor state's start
    error passed through the thrust (its first and, for the quadratic law, second power) and of the reaction
    lag's free responses (on a jittered log's grid, where the motor and M_R states come computed, from the lags'
    time constants).  Mixing (eq. 7) keeps it linear:
    eps_J = phi J + psi_J c, eps_B = phi B + psi_B c, with psi_J = -(Hm2 r - m2 H r), psi_B = -(m1 H r - Hm1 r)
    per response r.  The sums are those of phi and eps with c fitted (least squares, each parameter's regression on
    its own): phi and eps less their projections on the psi columns over the first START_TIME_CONSTANTS time
    constants of the slowest response, where they live.  A second-order motor's further lag (an input
    modification) keeps its start assumption.  ``left``: the axis' samples left out of the sums (stop_samples), or None."""
    (pitch, drive, reaction, angle, beta, dt, b, a, th_a, th_b, signed, mg, kg, gv) = _axis_inputs(
        axis, u1_v, u2_v, alpha_rad, beta_rad, dt_s, p, law, a_rad_s, b_rad_s, f_gain, h_gain, motor, structure)
    n = angle.size
    if motor is None:  # the motor's and the reaction's lags run here: their poles are those of their filters
        motor_pole = -a[TAU][1]
        lags = [_time_constant_samples(a[s]) for s in (TAU, MR)]
    else:  # a jittered log's grid: the states come computed from the same start (numerics/hold.py), the lags' poles
        t_motor = (p["T11"] / p["T10"] if pitch else p["T21"] / p["T20"]) / dt  # time constants > 0 (params.py)
        reaction_s = () if pitch else tuple(t / dt for t in ((p["Tp"],) if reaction_voltage(structure) else
                                                              (p["T11"] / p["T10"], p["Tp"])))
        motor_pole, lags = math.exp(-1.0 / t_motor), [t_motor, *reaction_s]
    # the slowest of the responses fitted (the filters', the motor's lag, the reaction's), in samples
    slowest = max([_time_constant_samples(a[s]) for s in (F0, HG)] + lags)
    w = min(n, int(math.ceil(START_TIME_CONSTANTS * slowest)) + 1)
    m = min(n, w + 1)  # one more sample: beta' at the window's last sample by the central difference, as the log's
    if m < 3:  # no window to fit the responses in (START_TIME_CONSTANTS 0: the start assumed at rest)
        return Offline(np.repeat(summary.energy, 2), summary.cross.copy(),
                       np.repeat(summary.block_sums[:, :1], 2, axis=1), summary.block_sums[:, 1:].copy())
    phi, eps = np.empty(m), np.empty((m, 2))
    _axis(pitch, *(np.ascontiguousarray(v[:m]) for v in (drive, reaction, angle, beta)), dt, b, a, th_a, th_b, signed,
          mg, kg, gv, phi, eps)
    phi, eps, x = phi[:w], eps[:w], angle[:w]
    m1, m2 = biquad(b[F2], a[F2], x), biquad(b[F1], a[F1], x)
    hm1, hm2 = biquad(b[HM1], a[HM1], m1), biquad(b[HM2], a[HM2], m2)
    cols = _free_responses(a[F0], w)  # the F filters' start (one denominator: bilinear_second_order)
    if motor_pole > 0.0:  # the motor state's start error decays with the lag's pole
        decay = motor_pole ** np.arange(w, dtype=float)
        tau = drive[:w] if motor is not None else biquad(b[TAU], a[TAU], np.ascontiguousarray(drive[:w]))
        torque_per_thrust = np.ones(w)
        if pitch and not gv:  # the gyroscope of eq. (1) is driven by the thrust M1
            db = np.gradient(np.asarray(beta[:m], dtype=float), dt, edge_order=2)[:w]
            torque_per_thrust -= kg * db * np.cos(x)
        slope = 2.0 * th_a * (np.abs(tau) if signed else tau) + th_b
        cols.append(biquad(b[F0], a[F0], torque_per_thrust * slope * decay))
        if not signed:
            cols.append(biquad(b[F0], a[F0], torque_per_thrust * th_a * decay * decay))
    if not pitch:  # the reaction's lags (M_R enters the yaw's torque with its sign)
        modes = (_free_responses(a[MR], w) if motor is None else
                 [math.exp(-1.0 / t) ** np.arange(w, dtype=float) for t in reaction_s])
        cols += [biquad(b[F0], a[F0], r) for r in modes]
    hr = [biquad(b[HG], a[HG], r) for r in cols]
    keep = np.ones(w, dtype=bool) if left is None else ~np.asarray(left[:w], dtype=bool)
    energy, cross = np.empty(2), np.empty(2)
    nb = summary.block_sums.shape[0]
    be = np.repeat(summary.block_sums[:, :1], 2, axis=1)
    bc = summary.block_sums[:, 1:].copy()
    idx = np.arange(w) // block
    inside = keep & (idx < nb)
    for i in range(2):
        psi = np.column_stack([-(hm2 * r - m2 * h) if i == 0 else -(m1 * h - hm1 * r) for r, h in zip(cols, hr)])
        psi[~keep] = 0.0
        scale = np.sqrt(np.sum(psi * psi, axis=0))
        psi = psi[:, scale > 0] / scale[scale > 0]
        ph, ep = np.where(keep, phi, 0.0), np.where(keep, eps[:, i], 0.0)
        if psi.shape[1]:
            coef, *_ = np.linalg.lstsq(psi, np.column_stack([ph, ep]), rcond=1e-10)
            ph_out, ep_out = ph - psi @ coef[:, 0], ep - psi @ coef[:, 1]
        else:
            ph_out, ep_out = ph, ep
        energy[i] = summary.energy - ph @ ph + ph_out @ ph_out
        cross[i] = summary.cross[i] - ph @ ep + ph_out @ ep_out
        np.add.at(be[:, i], idx[inside], ph_out[inside] ** 2 - ph[inside] ** 2)
        np.add.at(bc[:, i], idx[inside], ph_out[inside] * ep_out[inside] - ph[inside] * ep[inside])
    return Offline(energy, cross, be, bc)
