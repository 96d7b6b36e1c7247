"""Data-driven choice of the filter bandwidths a (F, eq. 3) and b (H, eq. 5).

Measurement noise on the angles enters the regressor F s^2[x] and biases J towards zero
(errors in variables, model.md item 4).  White noise of standard deviation sigma passes
F s^2 = a^2 s^2/(s + a)^2 with variance ~ sigma^2 a^4, while the signal part of F s^2[x]
shrinks as a falls below the excitation band.  We estimate sigma from third differences,
measure the signal power for each candidate a with one compiled filter pass, and take the
largest candidate whose predicted relative bias SAFETY * N/S stays below TARGET_BIAS.
Below a = 1 rad/s, B1 degrades at low sample rates (measured), so that is the floor.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .coefficients import bilinear_second_order
from .fused import biquad

CANDIDATES_RAD_S = (10.0, 5.0, 3.0, 2.0, 1.0)
B_OVER_A = 2.0
TARGET_BIAS = 5e-4
#: the mixing (products of filtered signals in det M) amplifies the simple ratio; measured 3-4x
SAFETY = 5.0


@dataclass(frozen=True)
class FilterDesign:
    a_rad_s: float
    b_rad_s: float
    noise_rad: dict  # estimated sigma per angle
    predicted_bias: dict  # predicted relative J bias per axis at the chosen a
    reason: str


#: third differences beyond this many robust standard deviations (1.4826 x the median absolute value of those not
#: exactly 0, as at rest on a stop or between an encoder's steps) are no noise and are left out of the noise
#: estimate: a log's few non-smooth instants (an angle striking its end stop, a glitch) give ones hundreds of times
#: any noise's (a noise-free simulation of the CE150's published model, whose arms strike their stops, read 1.3e-5
#: rad from them, and its own model then "did not fit" at 146x that floor: tests/test_structure.py).  Gaussian
#: noise passes whole (a chance of 2e-9 beyond 6), an encoder's rounding too (bounded at 3.1)
OUTLIER_SIGMAS = 6.0


def _mean_square(d: np.ndarray, w: np.ndarray | None = None) -> float:
    """sigma^2 from differences d of variance sigma^2 w (w: 1 when None), those beyond OUTLIER_SIGMAS left out."""
    z = np.abs(d) if w is None else np.abs(d) / np.sqrt(w)
    moving = z[z > 0.0]  # the scale from the differences that are not exactly 0 (an angle resting on its stop)
    if moving.size == 0:
        return 0.0
    inside = z <= OUTLIER_SIGMAS * 1.4826 * float(np.median(moving))
    kept = d[inside]
    return float(np.dot(kept, kept) / (kept.size if w is None else np.sum(w[inside])))


def noise_std(x: np.ndarray) -> float:
    """sigma of white measurement noise from the third difference (variance 20 sigma^2), its outliers left out
    (OUTLIER_SIGMAS)."""
    if x.size < 8:
        return 0.0
    return math.sqrt(_mean_square(np.diff(x, 3)) / 20.0)


def quantization_step(x: np.ndarray, max_samples: int = 200_000) -> float:
    """The encoder's quantum [rad] when every step of x is a whole multiple of one (0 when not).

    An encoder reading moves in whole quanta; the smallest nonzero step is then the quantum, and
    every step divides by it.  Third differences underestimate such noise at high sample rates,
    where the angle moves less than a quantum per sample and the rounding error is correlated."""
    d = np.abs(np.diff(x[:max_samples]))
    d = d[d > 0]
    if d.size < 10:
        return 0.0
    q = float(d.min())
    k = d / q
    return q if float(np.max(np.abs(k - np.round(k)))) < 1e-3 else 0.0


def noise_std_stamped(x: np.ndarray, t: np.ndarray) -> float:
    """sigma of white measurement noise on jittered stamps, from third divided differences.

    A smooth signal's third divided difference is its third derivative / 6 (small); white noise gives each
    one the variance sigma^2 sum_i w_i^2 with w_i = 1 / prod_{j != i}(t_i - t_j), so
    sigma^2 = sum D^2 / sum W, over the differences noise_std's rule keeps (of D / sqrt(W)).  On uniform stamps
    this is noise_std's estimate exactly."""
    if x.size < 8:
        return 0.0
    tt = np.stack([t[i:t.size - 3 + i] for i in range(4)])
    xx = np.stack([x[i:x.size - 3 + i] for i in range(4)])
    w = np.empty_like(tt)
    for i in range(4):
        w[i] = 1.0 / np.prod([tt[i] - tt[j] for j in range(4) if j != i], axis=0)
    d = np.sum(w * xx, axis=0)
    return math.sqrt(_mean_square(d, np.sum(w * w, axis=0)))


def angle_noise_rad(x: np.ndarray, t: np.ndarray | None = None) -> float:
    """Noise level of an angle [rad]: white noise from third differences (divided differences on the stamps
    ``t`` when they jitter), or an encoder's rounding error q/sqrt(12), whichever is larger."""
    white = noise_std(x) if t is None else noise_std_stamped(x, t)
    return max(white, quantization_step(x) / math.sqrt(12.0))


def predicted_bias(windows: np.ndarray, sigma: float, a: float, dt: float) -> float:
    """SAFETY * noise power / signal power of F s^2[x] over the windows (rows of ``windows``)."""
    num, den = bilinear_second_order(a, a * a, 2, dt)
    skip = min(int(5.0 / (a * dt)), windows.shape[1] // 2)  # each window's filter start-up
    power = np.mean([np.mean(biquad(num, den, w)[skip:] ** 2) for w in windows])
    signal_power = float(power) - sigma ** 2 * a ** 4
    if signal_power <= 0:
        return math.inf
    return SAFETY * sigma ** 2 * a ** 4 / signal_power


#: the design looks at up to this many samples, in evenly spread contiguous windows
DESIGN_SAMPLES = 240_000
DESIGN_WINDOWS = 8


def _windows(x: np.ndarray) -> np.ndarray:
    """Evenly spread contiguous windows of x, joined (filters restart in each: see predicted_bias)."""
    if x.size <= DESIGN_SAMPLES:
        return x[None, :]
    width = DESIGN_SAMPLES // DESIGN_WINDOWS
    starts = np.linspace(0, x.size - width, DESIGN_WINDOWS).astype(int)
    return np.stack([x[s:s + width] for s in starts])


def design_filters(alpha_rad: np.ndarray, beta_rad: np.ndarray, dt_s: float) -> FilterDesign:
    """Choose a, b for this log; long logs are judged on DESIGN_SAMPLES samples in windows."""
    wa, wb = _windows(alpha_rad), _windows(beta_rad)
    sig = {"alpha": float(np.median([noise_std(w) for w in wa])), "beta": float(np.median([noise_std(w) for w in wb]))}
    nyquist = math.pi / dt_s
    chosen, bias = None, {}
    for a in CANDIDATES_RAD_S:
        if B_OVER_A * a > 0.2 * nyquist:
            continue
        bias = {"pitch": predicted_bias(wa, sig["alpha"], a, dt_s), "yaw": predicted_bias(wb, sig["beta"], a, dt_s)}
        if max(bias.values()) <= TARGET_BIAS:
            chosen = a
            break
    if chosen is None:
        chosen = CANDIDATES_RAD_S[-1]
        bias = {"pitch": predicted_bias(wa, sig["alpha"], chosen, dt_s),
                "yaw": predicted_bias(wb, sig["beta"], chosen, dt_s)}
        reason = (f"noise (alpha {sig['alpha']:.2g} rad, beta {sig['beta']:.2g} rad) is high for the excitation: "
                  f"even the slowest candidate a = {chosen:g} rad/s predicts a J bias of "
                  f"{100 * max(bias.values()):.2g} %")
    else:
        slower = [c for c in CANDIDATES_RAD_S if c > chosen]
        reason = (f"estimated noise alpha {sig['alpha']:.2g} rad, beta {sig['beta']:.2g} rad; a = {chosen:g} rad/s is "
                  f"the fastest candidate whose predicted J bias (errors in variables through F s^2) is below "
                  f"{100 * TARGET_BIAS:g} %" + (f" (faster: {', '.join(f'{c:g}' for c in slower)} rejected)"
                                               if slower else ""))
    return FilterDesign(chosen, B_OVER_A * chosen, sig, bias, reason)
