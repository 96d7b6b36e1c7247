"""Closed-form discrete coefficients of the few filters the fast path needs.

scipy.signal.cont2discrete computes the same numbers (the tests check it to 1e-12) but
importing scipy.signal costs about 1 s, a third of the time budget for a one-hour log, so
the hot path uses these formulas.  Conventions: b, a of length 3, a[0] = 1, lfilter form.
The motor/lag transition is compiled (numba) so that hold.py's per-interval exact hold calls the same code.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def _phi1(x: float) -> float:
    """(e^x - 1)/x, exact near 0."""
    return math.expm1(x) / x if x != 0.0 else 1.0


def zoh_first_order(k: float, t1: float, t0: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH of k/(t1 s + t0): y[n] = e y[n-1] + (k/t0)(1 - e) u[n-1], e = exp(-t0 dt/t1)."""
    p = t0 / t1
    e = math.exp(-p * dt)
    gain_step = k / t1 * dt * _phi1(-p * dt)  # = (k/t0)(1 - e), also valid for t0 -> 0
    return np.array([0.0, gain_step, 0.0]), np.array([1.0, -e, 0.0])


@njit(cache=True, nogil=True)
def zoh_motor_lag_states(k1: float, tp: float, t11: float, t10: float, dt: float
                         ) -> tuple[float, float, float, float, float]:
    """Exact one-sample transition of tau = k1/(t11 s + t10) u and zeta = tau/(tp s + 1), u held:
    tau[n+1] = e1 tau[n] + g1 u[n],  zeta[n+1] = phi21 tau[n] + e2 zeta[n] + g2 u[n].
    Returns (e1, e2, phi21, g1, g2).

    States tau (motor, pole p1 = t10/t11) and zeta (lag, pole p2 = 1/tp); the transition
    matrix of this lower-triangular system has a closed form with divided differences.
    """
    p1, p2 = t10 / t11, 1.0 / tp
    e1, e2 = math.exp(-p1 * dt), math.exp(-p2 * dt)
    # Phi = expm(A dt), A = [[-p1, 0], [1/tp, -p2]];  Phi21 = (e1 - e2)/(p2 - p1) / tp
    dd = dt * e2 * _phi1((p2 - p1) * dt)  # (e1 - e2)/(p2 - p1), stable for p1 ~ p2
    phi21 = dd / tp
    # Gamma = int_0^dt expm(A s) ds [k1/t11, 0]
    g1 = k1 / t11 * dt * _phi1(-p1 * dt)  # (1 - e1)/p1 * k1/t11
    # int_0^dt (e^{-p1 s} - e^{-p2 s})/(p2 - p1) ds / tp * k1/t11
    i1 = dt * _phi1(-p1 * dt)
    i2 = dt * _phi1(-p2 * dt)
    g2 = k1 / t11 / tp * ((i1 - i2) / (p2 - p1) if abs(p2 - p1) * dt > 1e-6 else _dd_int(p1, dt))
    return e1, e2, phi21, g1, g2


def zoh_reaction(kc: float, k1: float, t0: float, tp: float, t11: float, t10: float, dt: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """ZOH of kc k1 (t0 s + 1)/((tp s + 1)(t11 s + t10)), the u1 -> M_R path of eq. (1)."""
    e1, e2, phi21, g1, g2 = zoh_motor_lag_states(k1, tp, t11, t10, dt)
    # output M_R = kc (t0/tp tau + (1 - t0/tp) zeta) = c . x
    c1, c2 = kc * t0 / tp, kc * (1.0 - t0 / tp)
    # transfer function of x[n+1] = Phi x[n] + Gamma u[n], y = c x  (strictly proper)
    a1 = -(e1 + e2)
    a2 = e1 * e2
    # numerator: c adj(zI - Phi) Gamma
    b1 = c1 * g1 + c2 * g2
    b2 = c1 * (-e2 * g1) + c2 * (phi21 * g1 - e1 * g2)
    return np.array([0.0, b1, b2]), np.array([1.0, a1, a2])


def zoh_lead_lag(kc: float, t0: float, tp: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH of kc (t0 s + 1)/(tp s + 1) on a held input: M_R driven by the voltage u1 itself (the bench's structure,
    model/structure.py).  State form: tp zeta' = u - zeta, y = kc (t0/tp u + (1 - t0/tp) zeta); with
    e = exp(-dt/tp), zeta[k+1] = e zeta[k] + (1 - e) u[k], so y[k] = kc (r u[k] + (1 - r) zeta[k]), r = t0/tp:
    Y/U = kc (r + ((1 - r)(1 - e) - r e) z^-1) / (1 - e z^-1), its steady-state gain kc."""
    e = math.exp(-dt / tp)
    r = t0 / tp
    return np.array([kc * r, kc * ((1.0 - r) * (1.0 - e) - r * e), 0.0]), np.array([1.0, -e, 0.0])


@njit(cache=True, nogil=True)
def _dd_int(p: float, dt: float) -> float:
    """Limit of (i1 - i2)/(p2 - p1) as p2 -> p1 = p: int_0^dt s e^{-p s} ds."""
    if p * dt < 1e-8:
        return dt * dt / 2.0
    return (1.0 - math.exp(-p * dt) * (1.0 + p * dt)) / (p * p)


def bilinear_second_order(a: float, gain: float, order: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear (Tustin) form of gain s^order/(s + a)^2, order 0, 1 or 2 (F, F s, F s^2)."""
    k = 2.0 / dt
    r = (k - a) / (k + a)
    scale = gain / (k + a) ** 2
    num = {0: (1.0, 2.0, 1.0), 1: (k, 0.0, -k), 2: (k * k, -2.0 * k * k, k * k)}[order]
    return np.array(num) * scale, np.array([1.0, -2.0 * r, r * r])
