"""Continuous transfer functions realised as causal discrete-time filters.

Discretization follows the measured facts in the shared notes (model.md, item 2):
zero-order hold for signals that are held between samples (motor voltages: exact),
bilinear (Tustin) for sampled continuous signals (angles and quantities computed
from them).  Filters start in the steady state of their first input sample, i.e.
the signal is assumed constant before the log begins (a bench at rest).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import signal

METHODS = ("zoh", "bilinear")


@dataclass(frozen=True)
class DiscreteFilter:
    """b/a coefficients of a discretized continuous transfer function num(s)/den(s)."""

    b: np.ndarray
    a: np.ndarray

    def apply(self, x: np.ndarray) -> np.ndarray:
        """Filter ``x``, starting in the steady state of ``x[0]``."""
        zi = signal.lfilter_zi(self.b, self.a) * x[0]
        y, _ = signal.lfilter(self.b, self.a, x, zi=zi)
        return y


def discretize(num, den, dt_s: float, method: str) -> DiscreteFilter:
    """Discretize num(s)/den(s) (coefficients highest power first) at sample time ``dt_s`` [s]."""
    return _discretize(tuple(np.atleast_1d(np.asarray(num, dtype=float)).tolist()),
                       tuple(np.atleast_1d(np.asarray(den, dtype=float)).tolist()), float(dt_s), method)


@functools.lru_cache(maxsize=256)
def _discretize(num: tuple, den: tuple, dt_s: float, method: str) -> DiscreteFilter:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    num = np.atleast_1d(np.asarray(num, dtype=float))
    den = np.atleast_1d(np.asarray(den, dtype=float))
    bd, ad, _ = signal.cont2discrete((num, den), dt_s, method=method)
    bd = np.atleast_1d(np.squeeze(bd))
    # pad numerator to the denominator's length (cont2discrete may return it shorter)
    bd = np.concatenate([np.zeros(ad.size - bd.size), bd]) if bd.size < ad.size else bd
    return DiscreteFilter(b=bd / ad[0], a=ad / ad[0])


def second_order_lowpass(omega: float, gain: float = 1.0):
    """gain / (s + omega)^2 as (num, den): the paper's F (eq. 3) and H (eq. 5) family."""
    return np.array([gain]), np.array([1.0, 2.0 * omega, omega * omega])
