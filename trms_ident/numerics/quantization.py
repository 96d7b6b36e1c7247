"""The output-error estimate's spread from an encoder's rounding (issue #35: intervals on quantized logs).

A quantized angle's error is the rounding of its motion.  Where the angle moves less than a quantum per sample
the rounding error follows the motion for many samples, so it is neither white nor independent between the
batch-means blocks, and neither the white-noise bound (q / sqrt(12) per sample, numerics/fisher.py) nor the
batch-means interval (numerics/refine.py) need describe the estimate's real error.  Measured on a 12-bit log at
1 kHz (square waves of 0.17 and 0.27 rad): J1's error was 3.7 of its batch-means standard errors and 4 of the
white-noise bound's, while B1's was a quarter of that bound.

Here the spread is measured from the run itself: the model's angles are rounded on OFFSETS grids shifted by
fractions of the quantum (where the encoder's zero sits is unknown), and the Gauss-Newton step of the output-error
refinement from the estimate (J/B with the motors' start states and the windows' starts) on each grid's rounding
error is the estimate's error that rounding would make.  Their mean square is the rounding covariance.  The step
is linear in the rounding error, so one pass over the log gives every grid's: the kernel rounds its own
prediction on each grid as it goes (refine.windows_pass's ``grids``).  It replaced two refinement steps per grid
from the rounded angles (16 passes over the log; one step from there was not enough, the rounded angles' rates
being far off, and put J1's error at up to 12x where the refinement lands).  Measured against those two steps,
on the paper's square for 120 s at 1 kHz (12-bit), a 300 s multisine at 500 Hz with a cable in the model and a
200 s sine cut mid-run at 200 Hz: the spread's standard errors within 0.25 %, design's batch-means ones within
3.3 %, each grid's step within 1.8 % of the spread (tests/test_quantization.py); on an hour at 1 kHz with a
cable, 2.7 s where they took 35.5 s.  Pure numerics: no I/O.
"""
from __future__ import annotations

import numpy as np

from .refine import batch_covariance, scaled_inverse, schur, setup, start_step

#: grids tried, each shifted by a further 1 / OFFSETS of the quantum (the two angles' shifts in another order)
OFFSETS = 8
#: Gauss-Newton iterations that place the windows' starts on noise-free angles the refinement did not make
START_ITERATIONS = 3


def rounded(x: np.ndarray, quantum_rad: float, offset_rad: float) -> np.ndarray:
    """x [rad] read by an encoder of this quantum whose grid sits ``offset_rad`` off zero (0 quantum: x)."""
    if not quantum_rad > 0:
        return np.asarray(x, dtype=float)
    return quantum_rad * np.round((x - offset_rad) / quantum_rad) + offset_rad


def rounding_covariance(u1_v: np.ndarray, u2_v: np.ndarray, angles_rad: np.ndarray, dt_s: float, params: dict,
                        law: str, theta: dict, noise_rad: dict, quantum_rad: dict,
                        window_starts: np.ndarray | None = None, batch_means: bool = False,
                        **refine_kw) -> tuple[np.ndarray, np.ndarray]:
    """(4, 4) the covariance of J1, B1, J2, B2 (refine's NAMES order) that rounding the model's angles at
    ``theta`` on the encoder grids of ``quantum_rad`` = {"alpha": q, "beta": q} [rad] causes in the output-error
    estimate (the mean square of rounding_steps), and (4, 4) with ``batch_means`` the batch-means covariance the
    refinement reports on such rounded angles where it lands (the mean over the grids: what estimate's
    batch-means interval would say, for design's prediction; one more pass over the log per grid), else NaN.
    ``window_starts``, ``refine_kw``: rounding_steps'."""
    steps, batch = rounding_steps(u1_v, u2_v, angles_rad, dt_s, params, law, theta, noise_rad, quantum_rad,
                                  window_starts, batch_means, **refine_kw)
    return steps.T @ steps / len(steps), (np.mean(batch, axis=0) if batch else np.full((4, 4), np.nan))


def rounding_steps(u1_v: np.ndarray, u2_v: np.ndarray, angles_rad: np.ndarray, dt_s: float, params: dict,
                   law: str, theta: dict, noise_rad: dict, quantum_rad: dict,
                   window_starts: np.ndarray | None = None, batch_means: bool = False,
                   **refine_kw) -> tuple[np.ndarray, list]:
    """(OFFSETS, 4): on each grid, the error in J1, B1, J2, B2 [SI] that the output-error estimate makes when the
    model's angles at ``theta`` are read by encoders of ``quantum_rad`` = {"alpha": q, "beta": q} [rad]; with
    ``batch_means`` also each grid's (4, 4) batch-means covariance where the estimate lands (else []).
    ``window_starts`` (windows, 4): alpha, alpha', beta, beta' at each refinement window's start where the model
    made ``angles_rad`` ((n, 2), noise-free), e.g. the refinement's own (Refined.fit.starts) with
    ``start_states0`` its start states; without them they are fitted to ``angles_rad`` first, J/B held (the
    rounding pattern is that of the model's own prediction, and rates differenced from the angles put it up to
    1.8 mrad off them, more than a 12-bit quantum).  ``refine_kw``: refine's options for this log (t_s,
    switch_delay_s, free, effects, start_states0, ...)."""
    su = setup(u1_v, u2_v, angles_rad[:, 0], angles_rad[:, 1], dt_s, params, law, theta, noise_rad, **refine_kw)
    prob, ng, out = su.prob, len(su.theta), np.empty((su.n, 2))
    point, starts = su.theta, su.starts if window_starts is None else np.asarray(window_starts, dtype=float)
    for _ in range(START_ITERATIONS if window_starts is None else 0):
        # Gauss-Newton on the start states alone (refine's hold), on angles without noise: full steps
        _, a, b, _ = prob.evaluate(point, starts, out)
        s_mat, s_rhs, per_window = schur(a, b, ng)
        step = start_step(s_mat, s_rhs, su.start_idx)
        point, starts = point + step, starts + _starts_step(per_window, step)
    grids = np.array([[(k + 0.5) / OFFSETS * quantum_rad["alpha"],
                       ((3 * k + 1) % OFFSETS + 0.5) / OFFSETS * quantum_rad["beta"]] for k in range(OFFSETS)])
    quanta = np.array([quantum_rad["alpha"], quantum_rad["beta"]], dtype=float)
    _, a, _, _, b_grid, scores_grid = prob.evaluate(point, starts, out, rounding=(quanta, grids))
    steps, batch = [], []
    for k in range(OFFSETS):
        s_mat, s_rhs, per_window = schur(a, b_grid[:, k, :], ng)
        step = scaled_inverse(s_mat) @ s_rhs
        steps.append(step[:4] + point[:4] - su.theta[:4])
        if batch_means:  # the refinement's own interval where it lands on this grid's rounded angles
            prob.y = np.ascontiguousarray(np.column_stack([rounded(out[:, i], quanta[i], grids[k, i])
                                                           for i in range(2)]))
            _, a_k, b_k, scores_k = prob.evaluate(point + step, starts + _starts_step(per_window, step),
                                                  np.empty_like(out))
            s_k, _, per_window_k = schur(a_k, b_k, ng)
            batch.append(batch_covariance(s_k, per_window_k, scores_k, su.win, su.block)[:4, :4])
    return np.array(steps), batch


def _starts_step(per_window: list, step: np.ndarray) -> np.ndarray:
    """(windows, 4) the windows' starts' step that goes with the global unknowns' ``step`` (refine's)."""
    ng = step.size
    return np.array([k[:, ng] - k[:, :ng] @ step for k in per_window])
