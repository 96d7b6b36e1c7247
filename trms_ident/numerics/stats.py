"""Uncertainty of the DREM scalar regressions eps = phi q + r (eq. 7), valid for correlated r.

The residual r is filtered (F and H), hence strongly autocorrelated: sample-based
least-squares errors would be far too optimistic.  Batch means: the record is cut into K
blocks longer than the filters' memory, the per-block scores S_b = sum(phi r) are nearly
independent, and Var(sum phi r) ~ K/(K-1) sum S_b^2.  The interval uses Student's t with
K - 1 degrees of freedom.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.special import stdtrit


#: a parameter whose 95 % half-width exceeds this fraction of its value is not identifiable
IDENTIFIABLE_REL_HALF_WIDTH = 0.25
#: two-sided 95 % normal quantile
Z95 = 1.959963984540054
MIN_BLOCKS = 4


@dataclass(frozen=True)
class Interval:
    estimate: float
    low: float
    high: float
    blocks: int
    identifiable: bool
    reason: str  # plain words for the report

    @property
    def rel_half_width(self) -> float:
        return (self.high - self.low) / 2 / abs(self.estimate) if self.estimate else math.inf


@njit(cache=True, nogil=True)
def _block_sums(eps, phi, block, k):
    """Per block b < k of ``block`` samples: sum phi^2 and sum phi eps, without temporaries the size of the log."""
    out = np.zeros((k, 2))
    for b in range(k):
        for i in range(b * block, (b + 1) * block):
            out[b, 0] += phi[i] * phi[i]
            out[b, 1] += phi[i] * eps[i]
    return out


def block_length(n: int, dt_s: float, memory_s: float, max_blocks: int = 40) -> int:
    """Samples per block: at least 5 filter memories, and no more than max_blocks blocks."""
    return max(int(math.ceil(5.0 * memory_s / dt_s)), int(math.ceil(n / max_blocks)), 1)


def confidence_interval(eps: np.ndarray, phi: np.ndarray, block: int, level: float = 0.95,
                        bias_bound: float = 0.0) -> Interval:
    """Offline optimum sum(eps phi)/sum(phi^2) with its batch-means interval.

    ``bias_bound`` (relative to the estimate) is a known bound on bias, e.g. errors in
    variables, added to the half-width.
    """
    k = phi.size // block
    sums = _block_sums(np.ascontiguousarray(eps, dtype=float), np.ascontiguousarray(phi, dtype=float), block, k)
    return interval_from_sums(float(np.dot(phi, phi)), float(np.dot(eps, phi)), sums[:, 0], sums[:, 1], level,
                              bias_bound)


def interval_from_sums(energy: float, cross: float, block_energy: np.ndarray, block_cross: np.ndarray,
                       level: float = 0.95, bias_bound: float = 0.0) -> Interval:
    """The same interval from sums alone (a log need not be held whole): ``energy`` = sum phi^2 and
    ``cross`` = sum phi eps over the record, ``block_energy``, ``block_cross`` the same sums per block.

    The optimum q = cross / energy; the block scores S_b = sum_b phi (eps - phi q) = (sum_b phi eps) -
    q (sum_b phi^2)."""
    if not energy > 0:
        return Interval(math.nan, math.nan, math.nan, 0, False, "not excited: det M is zero throughout")
    q = cross / energy
    k = block_energy.size
    if k < MIN_BLOCKS:
        return Interval(q, math.nan, math.nan, k, False,  # a number without an interval is no estimate
                        f"no interval: the log holds {k} independent blocks, {MIN_BLOCKS} are needed")
    score = block_cross - q * block_energy
    score -= score.mean()
    se = math.sqrt(k / (k - 1) * float(np.dot(score, score))) / energy
    half = float(stdtrit(k - 1, 0.5 + level / 2)) * se + abs(q) * bias_bound
    rel = half / abs(q) if q else math.inf
    if q <= 0:
        ok, reason = False, f"estimate {q:.3g} is not positive: the log does not determine it"
    elif rel > IDENTIFIABLE_REL_HALF_WIDTH:
        ok, reason = False, f"weakly excited: 95 % interval is ±{100 * rel:.3g} % of the value"
    else:
        ok, reason = True, f"95 % interval ±{100 * rel:.2g} %"
    return Interval(q, q - half, q + half, k, ok, reason)
