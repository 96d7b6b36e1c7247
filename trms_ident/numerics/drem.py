"""DREM: regressor extension (eq. 5-6), mixing (eq. 7) and scalar gradient estimators (eq. 8)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .kernel_args import HELPER


@dataclass(frozen=True)
class MixedRegression:
    """Scalar regressions eps_i = phi * q_i (eq. 7), one per parameter of the axis."""

    phi: np.ndarray  # det M(t)
    eps: np.ndarray  # (n, 2): adj(M) [g; H g], columns J, B
    excitation: float  # rms(phi) / (rms(m1) rms(Hm2) + rms(m2) rms(Hm1)): 0 = singular mixing


def extend_and_mix(g: np.ndarray, m: np.ndarray, dt_s: float, b_rad_s: float,
                   gain: float) -> MixedRegression:
    """Extend g = m^T q with H = gain/(s+b)^2 (eq. 5), stack (eq. 6), multiply by adj(M) (eq. 7).

    Reference path (scipy.signal filters), used by tests and diagnostics; ``fused`` is the fast one.
    """
    from .filters import discretize, second_order_lowpass  # scipy.signal: ~1 s to import

    num, den = second_order_lowpass(b_rad_s, gain)
    h = discretize(num, den, dt_s, "bilinear")
    hg = h.apply(g)
    hm1 = h.apply(m[:, 0])
    hm2 = h.apply(m[:, 1])
    m1, m2 = m[:, 0], m[:, 1]
    # eq. (6): M = [[m1, m2], [Hm1, Hm2]];  eq. (7): phi = det M, eps = adj(M) [g; Hg]
    phi = m1 * hm2 - m2 * hm1
    eps = np.empty((g.size, 2))
    eps[:, 0] = hm2 * g - m2 * hg
    eps[:, 1] = m1 * hg - hm1 * g
    rms = lambda v: float(np.sqrt(np.mean(v * v)))  # noqa: E731
    scale = rms(m1) * rms(hm2) + rms(m2) * rms(hm1)
    return MixedRegression(phi, eps, rms(phi) / scale if scale > 0 else 0.0)


@njit(cache=True, nogil=True, **HELPER)
def gradient_step(q, j, e, ph, gamma, norm, rate, dt):
    """eq. (8) over one sample for q[j]: q moves towards e/ph by the fraction 1 - exp(-g ph^2 dt).

    gamma < 0 selects the normalized gain g = rate / norm (norm: running mean of phi^2, floored)."""
    g = gamma
    if g < 0.0:
        g = rate / norm if norm > 0.0 else 0.0
    x = g * ph * ph * dt
    if x > 0.0 and math.isfinite(x):
        q[j] += -math.expm1(-x) * (e / ph - q[j])


@njit(cache=True, nogil=True)
def _gradient(eps, phi, gamma, rate, floor, dt, q0, out, step):
    """eq. (8) stepped exactly for each column of eps (same phi, same gain)."""
    m = eps.shape[1]
    q = q0.copy()
    energy = 0.0
    for k in range(phi.size):
        ph = phi[k]
        energy += ph * ph
        norm = max(energy / (k + 1), floor)
        for j in range(m):
            gradient_step(q, j, eps[k, j], ph, gamma[j], norm, rate, dt)
            if k % step == 0:
                out[k // step, j] = q[j]
    return q


def gradient_estimator(eps: np.ndarray, phi: np.ndarray, gamma, dt_s: float, q0=0.0,
                       *, rate_per_s: float = 0.0, floor_fraction: float = 0.02, step: int = 1):
    """eq. (8): q' = gamma (eps phi - phi^2 q), discretized exactly for eps, phi held per sample.

    Over one sample q moves to the point eps/phi by the fraction 1 - exp(-gamma phi^2 dt):
    the step never overshoots, so the recursion is monotone and stable for any gamma >= 0
    and any sample time (forward Euler diverges once gamma phi^2 dt > 2).

    ``gamma=None`` selects the normalized gain gamma_k = rate / max(mean(phi^2 over samples 0..k),
    floor): the error then decays on average like exp(-rate t) whatever the scale of phi
    (filter convention, excitation level, units), so no one has to guess gamma.  The floor,
    ``floor_fraction`` times the mean of phi^2 over the whole log, keeps the first samples
    after the onset of motion (tiny phi, large relative error of eps/phi) from receiving a
    scale-free full weight; it is the only non-causal ingredient.

    ``eps`` may be one regression (n,) or several sharing phi (n, m), with ``gamma`` and ``q0``
    scalars or one per column.  Returns every ``step``-th value of the trace(s) and the final value(s).
    """
    phi = np.ascontiguousarray(phi, dtype=float)
    e = np.asarray(eps, dtype=float)
    single = e.ndim == 1
    e = np.ascontiguousarray(e.reshape(phi.size, -1))
    m = e.shape[1]
    gam = np.array([-1.0 if g is None else float(g) for g in np.broadcast_to(np.array(gamma, dtype=object), (m,))])
    q0v = np.broadcast_to(np.asarray(q0, dtype=float), (m,)).copy()
    floor = floor_fraction * float(np.dot(phi, phi)) / max(phi.size, 1)
    out = np.empty(((phi.size + step - 1) // step, m))
    final = _gradient(e, phi, gam, float(rate_per_s), floor, float(dt_s), q0v, out, int(step))
    if single:
        return out[:, 0], float(final[0])
    return out, final
