"""The output-error estimate's spread from an encoder's rounding (issue #35: intervals on quantized logs).

A quantized angle's error is the rounding of its motion.  Where the angle moves less than a quantum per sample
the rounding error follows the motion for many samples, so it is neither white nor independent between the
batch-means blocks, and neither the white-noise bound (q / sqrt(12) per sample, numerics/fisher.py) nor the
batch-means interval (numerics/refine.py) need describe the estimate's real error.  Measured on a 12-bit log at
1 kHz (square waves of 0.17 and 0.27 rad): J1's error was 3.7 of its batch-means standard errors and 4 of the
white-noise bound's, while B1's was a quarter of that bound.

Here the spread is measured from the run itself: the model's angles are rounded on OFFSETS grids shifted by
fractions of the quantum (where the encoder's zero sits is unknown), and the Gauss-Newton step each rounding
causes from the estimate (J/B with the motors' start states and the windows' starts eliminated, refine's own
normal equations) is the estimate's error that rounding would make.  Their mean square is the rounding
covariance.  Pure numerics: no I/O.
"""
from __future__ import annotations

import numpy as np

from .refine import NAMES, _scaled_inverse, _schur, refine

#: grids tried, each shifted by a further 1 / OFFSETS of the quantum (the two angles' shifts in another order)
OFFSETS = 8


def rounded(x: np.ndarray, quantum_rad: float, offset_rad: float) -> np.ndarray:
    """x [rad] read by an encoder of this quantum whose grid sits ``offset_rad`` off zero (0 quantum: x)."""
    if not quantum_rad > 0:
        return np.asarray(x, dtype=float)
    return quantum_rad * np.round((x - offset_rad) / quantum_rad) + offset_rad


def rounding_covariance(u1_v: np.ndarray, u2_v: np.ndarray, angles_rad: np.ndarray, dt_s: float, params: dict,
                        law: str, theta: dict, noise_rad: dict, quantum_rad: dict, iterations: int = 0,
                        **refine_kw) -> tuple[np.ndarray, np.ndarray]:
    """(4, 4) the covariance of J1, B1, J2, B2 (refine's NAMES order) that rounding ``angles_rad`` ((n, 2): the
    model's alpha, beta at ``theta``, noise-free) on the encoder grids of ``quantum_rad`` = {"alpha": q, "beta": q}
    [rad] causes in the output-error estimate, and (4, 4) the batch-means covariance the refinement reports on
    such rounded angles (the mean over the grids: what estimate's own interval would say; NaN unless
    ``iterations``); ``refine_kw``: refine's options for this log (t_s, switch_delay_s, free, effects,
    start_states0, ...).  ``iterations`` 0: each rounding's error is the first Gauss-Newton step from ``theta``
    (one pass per grid, estimate's check); more: the refinement run on each rounded run from ``theta`` (at most
    that many iterations), its estimate's error and its batch-means covariance at its own optimum (design's
    prediction of what estimate reports)."""
    steps, batch = [], []
    for k in range(OFFSETS):
        oa = (k + 0.5) / OFFSETS * quantum_rad["alpha"]
        ob = ((3 * k + 1) % OFFSETS + 0.5) / OFFSETS * quantum_rad["beta"]
        r = refine(u1_v, u2_v, rounded(angles_rad[:, 0], quantum_rad["alpha"], oa),
                   rounded(angles_rad[:, 1], quantum_rad["beta"], ob), dt_s, params, law, theta, noise_rad,
                   max_iterations=iterations, **refine_kw)
        if iterations == 0:
            ng = r.fit.a.shape[1] - 4
            s_mat, s_rhs, _ = _schur(r.fit.a, r.fit.b, ng)
            steps.append((_scaled_inverse(s_mat) @ s_rhs)[:4])
        else:
            steps.append(np.array([r.estimate[k] - theta[k] for k in NAMES]))
            if r.cov_jb is not None:
                batch.append(r.cov_jb)
    steps = np.array(steps)
    return steps.T @ steps / len(steps), (np.mean(batch, axis=0) if batch else np.full((4, 4), np.nan))
