"""Intervals on quantized logs (numerics/quantization.py): an encoder's rounding of slow motion at a high rate is
neither white nor independent between blocks; estimate's intervals are the wider of batch means and the spread
the rounding causes, and design predicts that spread."""
import math

import numpy as np
import pytest

from sim import SimSettings, simulate
from trms_ident.design import Square, shaped
from trms_ident.identify import identify
from trms_ident.log import validated
from trms_ident.numerics.fisher import predicted_precision
from trms_ident.numerics.fisher import AT_REST
from trms_ident.numerics.quantization import OFFSETS, rounded, rounding_steps
from trms_ident.numerics.refine import NAMES, refine, scaled_inverse, schur
from trms_ident.params import defaults

Q12 = 2 * math.pi / 2 ** 12


def _square_run(offset=(0.0, 0.0), q=Q12, noise=0.0):
    t = np.arange(60001) / 1000.0  # the design's square waves of 0.17 and 0.27 rad, 2 s, 60 s at 1 kHz
    a, b = shaped(t, 60.0, Square(0.17, 2.0), False), shaped(t, 60.0, Square(0.27, 2.0), True)
    return simulate(SimSettings(ref="file", ref_table=(t, a, b), duration_s=60.0, sample_rate_hz=1000.0,
                                quantization_rad=q, quantization_offset_rad=offset, noise_std_rad=noise))


def test_rounding_on_a_shifted_grid_stays_within_half_a_quantum_and_the_simulator_logs_it():
    x = np.linspace(-0.3, 0.3, 1001)
    for off in (0.0, 0.3 * Q12, 0.9 * Q12):
        y = rounded(x, Q12, off)
        assert np.max(np.abs(y - x)) <= Q12 / 2 + 1e-15
        assert np.allclose(((y - off) / Q12) % 1.0 * (1 - ((y - off) / Q12) % 1.0), 0.0, atol=1e-9)  # on the grid
    assert np.array_equal(rounded(x, 0.0, 0.1), x)
    r = simulate(SimSettings(duration_s=3.0, quantization_rad=Q12, quantization_offset_rad=(0.25 * Q12, 0.5 * Q12)))
    frac = ((r.alpha_rad + 0.25 * Q12) / Q12) % 1.0
    assert np.allclose(np.minimum(frac, 1 - frac), 0.0, atol=1e-9)  # logged = round((angle + o) / q) q - o
    assert np.max(np.abs(r.alpha_rad - r.true_state[:, 0])) <= Q12 / 2 + 1e-12


@pytest.mark.parametrize("offset", [(0.0, 0.0), (0.37 * Q12, 0.81 * Q12)])
def test_estimate_intervals_on_a_12_bit_log_at_1_khz_cover_the_truth(offset):
    """Measured when the rounding spread came in: on the first grid J1's error was 3.7 of its batch-means standard
    errors (interval 0.0680 +-1.9e-6, error -3.6e-6); the spread then gave +-5.5e-6 (the first Gauss-Newton step
    per grid). Then (two steps per grid, now one pass for all): +-6.3e-6, J1's error -2.3e-6."""
    r = _square_run(offset)
    res = identify(validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad"))
    p = defaults()
    assert res.headline == "refined"
    for k in ("J1", "B1", "J2", "B2"):
        iv = res.intervals[k]
        assert iv.low <= p[k] <= iv.high, (k, iv.low, iv.high, p[k])
    note = res.refine_note
    assert "intervals widened to the spread the encoder's rounding causes" in note and "J1 x" in note


def test_gaussian_noise_is_left_to_batch_means_and_design_predicts_what_estimate_reports_on_rounded_angles():
    r = _square_run(q=0.0, noise=1e-3)
    res = identify(validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad"))
    note = res.refine_note
    assert "rounding" not in note
    clean, p = _square_run(q=0.0), defaults()
    sd = {"alpha": Q12 / math.sqrt(12), "beta": Q12 / math.sqrt(12)}
    white = predicted_precision(clean.u1_v, clean.u2_v, clean.alpha_rad, clean.beta_rad, 1e-3, p, "quadratic", sd)
    enc = predicted_precision(clean.u1_v, clean.u2_v, clean.alpha_rad, clean.beta_rad, 1e-3, p, "quadratic", sd,
                              quantum_rad=Q12)
    # what estimate would report on the rounded angles replaces the bound: ~3x it for J1 here (the rounding's
    # spread), under it for B1 (the estimate's errors on this run: J1 3.6e-6 against a bound of 8.8e-7, B1 7.3e-7
    # against 2.8e-6)
    assert enc["J1"]["half_width"] > 2 * white["J1"]["half_width"]
    assert enc["B1"]["half_width"] < white["B1"]["half_width"]


def test_one_pass_gives_each_grid_the_step_the_refinement_takes_on_its_rounded_angles():
    """The rounding's effect on the estimate is linear in the rounding error, so one pass over the log (the kernel
    rounding its own prediction on every grid) gives each grid's error; here against the refinement's first two
    Gauss-Newton steps (where it lands: quantization.py) on the model's angles rounded on the same grids."""
    r, p = _square_run(q=0.0), defaults()
    sd = {"alpha": Q12 / math.sqrt(12), "beta": Q12 / math.sqrt(12)}
    quantum = {"alpha": Q12, "beta": Q12}
    fit = refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1e-3, p, "quadratic", {k: p[k] for k in NAMES}, sd,
                 start_states0=AT_REST)  # the model's own angles: the estimate's prediction on the clean run
    theta, pred = fit.estimate, fit.prediction
    at = {"start_states0": fit.start_states}

    def landed(a, b):
        g = refine(r.u1_v, r.u2_v, a, b, 1e-3, p, "quadratic", theta, sd, max_iterations=1, **at)
        s_mat, s_rhs, _ = schur(g.fit.a, g.fit.b, g.fit.a.shape[1] - 4)
        return np.array([g.estimate[k] - theta[k] for k in NAMES]) + (scaled_inverse(s_mat) @ s_rhs)[:4]

    reference = np.array([landed(rounded(pred[:, 0], Q12, (k + 0.5) / OFFSETS * Q12),
                                 rounded(pred[:, 1], Q12, ((3 * k + 1) % OFFSETS + 0.5) / OFFSETS * Q12))
                          for k in range(OFFSETS)])
    rms = np.sqrt(np.mean(reference ** 2, axis=0))
    assert np.all(rms > 0)
    # estimate's way: the refinement's own window starts
    steps, _ = rounding_steps(r.u1_v, r.u2_v, pred, 1e-3, p, "quadratic", theta, sd, quantum,
                              window_starts=fit.fit.starts, **at)
    assert steps.shape == (OFFSETS, 4)
    # measured: within 0.05 % of the spread for J1, J2, B2 on every grid, 1.8 % for B1 on one
    assert np.max(np.abs(steps - reference) / rms) < 0.03, (steps, reference)
    # design's way: angles the refinement did not make, the windows' starts fitted to them first
    steps, _ = rounding_steps(r.u1_v, r.u2_v, np.column_stack([r.alpha_rad, r.beta_rad]), 1e-3, p, "quadratic",
                              theta, sd, quantum, **at)
    assert np.max(np.abs(steps - reference) / rms) < 0.03, (steps, reference)
