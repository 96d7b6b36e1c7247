"""DREM mixing identity and the discretized gradient law (eqs. 5-8)."""
import math
import numpy as np
import pytest

from trms_ident.numerics.drem import extend_and_mix, gradient_estimator
from trms_ident.numerics.filters import discretize, second_order_lowpass


def _exact_regression(n=20000, dt=1e-3, q=(0.068, 0.006), seed=1):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    m = np.column_stack([np.sin(1.3 * t) + 0.3 * np.sin(4.1 * t + 1), np.cos(0.7 * t) + 0.2 * rng.standard_normal(n)])
    g = m @ np.array(q)
    return g, m, dt, np.array(q)


def test_mixing_identity_on_data():
    # adj(M) M = det(M) I  =>  eps = adj(M) [g; Hg] = det(M) q exactly when g = m^T q (eq. 7)
    g, m, dt, q = _exact_regression()
    mix = extend_and_mix(g, m, dt, 2.0, 4.0)
    scale = np.max(np.abs(mix.phi))
    np.testing.assert_allclose(mix.eps[:, 0], mix.phi * q[0], atol=1e-12 * scale)
    np.testing.assert_allclose(mix.eps[:, 1], mix.phi * q[1], atol=1e-12 * scale)
    # and the matrix form, built from the same filtered signals
    num, den = second_order_lowpass(2.0, 4.0)
    h = discretize(num, den, dt, "bilinear")
    M = np.stack([np.column_stack([m[:, 0], m[:, 1]]), np.column_stack([h.apply(m[:, 0]), h.apply(m[:, 1])])], 1)
    adj = np.stack([np.column_stack([M[:, 1, 1], -M[:, 0, 1]]), np.column_stack([-M[:, 1, 0], M[:, 0, 0]])], 1)
    prod = adj @ M
    np.testing.assert_allclose(prod[:, 0, 0], np.linalg.det(M), atol=1e-12 * scale)
    np.testing.assert_allclose(prod[:, 0, 1], 0.0, atol=1e-12 * scale)
    np.testing.assert_allclose(mix.phi, np.linalg.det(M), atol=1e-12 * scale)
    assert mix.excitation > 0.01


def test_gradient_law_matches_analytic_solution():
    # constant phi, eps = phi q: q_hat(t) = q (1 - exp(-gamma phi^2 t))
    dt, gamma, phi0, q = 1e-3, 50.0, 0.4, 2.5
    n = 3000
    phi = np.full(n, phi0)
    trace, final = gradient_estimator(phi * q, phi, gamma, dt)
    assert final == trace[-1]
    t = (np.arange(n) + 1) * dt
    np.testing.assert_allclose(trace, q * (1 - np.exp(-gamma * phi0 ** 2 * t)), rtol=1e-12)


def test_gradient_law_is_monotone_and_stable_for_huge_gain():
    # forward Euler would diverge once gamma phi^2 dt > 2; the exact step lands on eps/phi
    phi = np.full(100, 3.0)
    trace, _ = gradient_estimator(phi * 0.1, phi, 1e9, 0.01)
    assert np.all(np.isfinite(trace))
    np.testing.assert_allclose(trace, 0.1, rtol=1e-12)
    rng = np.random.default_rng(0)
    phi = rng.standard_normal(5000)
    trace, _ = gradient_estimator(phi * 0.7, phi, 1e4, 1e-3)
    assert np.all(np.diff(trace) >= -1e-15) and trace[-1] == pytest.approx(0.7, rel=1e-12)


def test_gradient_skips_samples_without_excitation():
    phi = np.zeros(10)
    np.testing.assert_array_equal(gradient_estimator(phi, phi, 1.0, 0.1, q0=0.3)[0], 0.3)


def test_normalized_gain_is_scale_free_and_converges_at_its_rate():
    rng = np.random.default_rng(2)
    phi = rng.standard_normal(20000)
    a, _ = gradient_estimator(0.3 * phi, phi, None, 1e-3, rate_per_s=2.0)
    b, _ = gradient_estimator(0.3 * 1e-4 * phi, 1e-4 * phi, None, 1e-3, rate_per_s=2.0)
    np.testing.assert_allclose(a, b, rtol=1e-9)
    # stationary excitation: error ~ exp(-rate t); at t = 5 s about exp(-10)
    assert abs(a[5000] / 0.3 - 1) < 1e-3 and abs(a[1000] / 0.3 - 1) > 0.05


def test_decimated_trace_keeps_exact_final_value():
    rng = np.random.default_rng(3)
    phi = rng.standard_normal(1001)
    eps = phi * 2.0 + 0.01 * rng.standard_normal(1001)
    full, f1 = gradient_estimator(eps, phi, 5.0, 1e-3)
    part, f2 = gradient_estimator(eps, phi, 5.0, 1e-3, step=10)
    np.testing.assert_array_equal(part, full[::10])
    assert f1 == f2 == full[-1]


@pytest.mark.parametrize("ref, start_s", [("square", 30.0), ("multisine", 40.0)])
def test_a_log_that_starts_mid_run_gives_the_offline_estimate_of_one_that_starts_at_rest(ref, start_s):
    """DREM's filters start in the steady state of the first samples: the truth only for a log that begins at rest.
    Cut mid-run (moving arms, motors and the reaction lag away from the first voltages' steady state), the
    regressions carry the filters' and the lags' free responses; taken as unknowns (fused.start_unknowns), the
    offline estimate of a noise-free log is as exact as from rest.  Before, the square's offline B1 was 59 % low
    with the designed filters and 64x off with a = 1 rad/s, J2 3x."""
    import trms_ident as ti
    from sim import SimSettings, simulate

    from .conftest import as_log

    for start in (0.0, start_s):
        r = simulate(SimSettings(ref=ref, sample_rate_hz=200.0, duration_s=40.0, seed=3, start_s=start))
        truth = r.truth["estimated"]
        for filters in ({}, dict(filter_a_rad_s=1.0, filter_b_rad_s=2.0)):
            res = ti.estimate(as_log(r), refine="off", **filters).result
            for k in ("J1", "B1", "J2", "B2"):
                assert res.offline[k] == pytest.approx(truth[k], rel=3e-4), (start, filters, k)


def test_the_start_unknowns_leave_a_log_from_rest_as_it_was():
    """From rest the filters' start is the truth: fitting the start's responses changes the offline sums by no
    more than their noise (12-bit encoder), and the estimate of the log stays within a tenth of its interval."""
    import trms_ident as ti
    from trms_ident.numerics import fused
    from sim import SimSettings, simulate

    from .conftest import as_log

    r = simulate(SimSettings(ref="multisine", sample_rate_hz=200.0, duration_s=60.0, seed=5,
                             quantization_rad=2 * math.pi / 4096))
    res = ti.estimate(as_log(r), refine="off").result
    keep = fused.START_TIME_CONSTANTS
    try:
        fused.START_TIME_CONSTANTS = 0.0  # a window of one sample: the steady-state start assumed, as before
        before = ti.estimate(as_log(r), refine="off").result
    finally:
        fused.START_TIME_CONSTANTS = keep
    for k in ("J1", "B1", "J2", "B2"):
        iv = before.intervals[k]
        assert abs(res.offline[k] - before.offline[k]) <= 0.1 * (iv.high - iv.low) / 2, k


def test_a_jittered_log_cut_mid_run_gives_the_offline_estimate_of_one_at_rest():
    """On a jittered log DREM runs on a uniform grid with the motor and M_R states computed exactly from the held
    voltages (numerics/hold.py), from the first voltages' steady state: their start errors are fitted too, from the
    lags' time constants.  Before, this log's offline B1 came out 9 % high (7.8 % with only the filters' start)."""
    import trms_ident as ti
    from sim import SimSettings, simulate

    from .conftest import as_log

    r = simulate(SimSettings(ref="steps", sample_rate_hz=100.0, duration_s=120.0, seed=0, start_s=30.0, jitter=0.2))
    res = ti.estimate(as_log(r), refine="off").result
    for k, v in r.truth["estimated"].items():
        assert res.offline[k] == pytest.approx(v, rel=5e-4), k
