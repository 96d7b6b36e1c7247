"""The output-error estimate's spread from an encoder's rounding (issue #35: intervals on quantized logs).

A quantized angle's error is the rounding of its motion.  Where the angle moves less than a quantum per sample
the rounding error follows the motion for many samples, so it is neither white nor independent between the
batch-means blocks, and neither the white-noise bound (q / sqrt(12) per sample, numerics/fisher.py) nor the
batch-means interval (numerics/refine.py) need describe the estimate's real error.  Measured on a 12-bit log at
1 kHz (square waves of 0.17 and 0.27 rad): J1's error was 3.7 of its batch-means standard errors and 4 of the
white-noise bound's, while B1's was a quarter of that bound.

Here the spread is measured from the run itself: the model's angles are rounded on OFFSETS grids shifted by
fractions of the quantum (where the encoder's zero sits is unknown), two Gauss-Newton steps of the refinement are
taken on each rounded run from the estimate (J/B with the motors' start states and the windows' starts), and where
they land is the estimate's error that rounding would make.  Their mean square is the rounding covariance.  One
step is not enough: on the paper's square for 120 s at 1 kHz (12-bit, bench B of benchmarks/design.py) the first
step put J1's error at up to 0.050 % on some grids where the refinement lands at 0.004 %, and estimate's J1
interval came out 7-11x the spread of J1's real errors.  Two steps land where ten do to 4 digits there, at two
passes over the log per grid (the refinement run to convergence takes three).  Pure numerics: no I/O.
"""
from __future__ import annotations

import numpy as np

from .refine import NAMES, refine, scaled_inverse, schur

#: grids tried, each shifted by a further 1 / OFFSETS of the quantum (the two angles' shifts in another order)
OFFSETS = 8


def rounded(x: np.ndarray, quantum_rad: float, offset_rad: float) -> np.ndarray:
    """x [rad] read by an encoder of this quantum whose grid sits ``offset_rad`` off zero (0 quantum: x)."""
    if not quantum_rad > 0:
        return np.asarray(x, dtype=float)
    return quantum_rad * np.round((x - offset_rad) / quantum_rad) + offset_rad


def rounding_covariance(u1_v: np.ndarray, u2_v: np.ndarray, angles_rad: np.ndarray, dt_s: float, params: dict,
                        law: str, theta: dict, noise_rad: dict, quantum_rad: dict,
                        **refine_kw) -> tuple[np.ndarray, np.ndarray]:
    """(4, 4) the covariance of J1, B1, J2, B2 (refine's NAMES order) that rounding ``angles_rad`` ((n, 2): the
    model's alpha, beta at ``theta``, noise-free) on the encoder grids of ``quantum_rad`` = {"alpha": q, "beta": q}
    [rad] causes in the output-error estimate, and (4, 4) the batch-means covariance the refinement reports on
    such rounded angles after the first step (the mean over the grids: what estimate's batch-means interval would
    say, for design's prediction; NaN when no grid gave one); ``refine_kw``: refine's options for this log (t_s,
    switch_delay_s, free, effects, start_states0, ...)."""
    steps, batch = [], []
    for k in range(OFFSETS):
        oa = (k + 0.5) / OFFSETS * quantum_rad["alpha"]
        ob = ((3 * k + 1) % OFFSETS + 0.5) / OFFSETS * quantum_rad["beta"]
        r = refine(u1_v, u2_v, rounded(angles_rad[:, 0], quantum_rad["alpha"], oa),
                   rounded(angles_rad[:, 1], quantum_rad["beta"], ob), dt_s, params, law, theta, noise_rad,
                   max_iterations=1, **refine_kw)
        # the first step taken and evaluated (r.fit: the normal equations where it landed), the second solved
        s_mat, s_rhs, _ = schur(r.fit.a, r.fit.b, r.fit.a.shape[1] - 4)
        second = (scaled_inverse(s_mat) @ s_rhs)[:4]
        steps.append(np.array([r.estimate[k] - theta[k] for k in NAMES]) + second)
        if r.cov_jb is not None:
            batch.append(r.cov_jb)
    steps = np.array(steps)
    return steps.T @ steps / len(steps), (np.mean(batch, axis=0) if batch else np.full((4, 4), np.nan))
