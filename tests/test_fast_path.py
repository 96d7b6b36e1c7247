"""The fast path against its oracles: closed-form coefficients vs scipy, fused kernel vs reference path."""
import numpy as np
import pytest
from scipy import signal

from trms_ident.numerics.coefficients import bilinear_second_order, zoh_first_order, zoh_reaction
from trms_ident.numerics.drem import extend_and_mix
from trms_ident.numerics.fused import biquad, mixed_regressions
from trms_ident.numerics.regressors import filtered_regression, plant_signals
from trms_ident.params import defaults

from .conftest import sim_cached


def _scipy(num, den, dt, method):
    b, a, _ = signal.cont2discrete((num, den), dt, method=method)
    b = np.atleast_1d(np.squeeze(b))  # coefficients of powers of z^-1: pad at the end
    return np.concatenate([b, np.zeros(3 - b.size)]) / a[0], np.concatenate([a, np.zeros(3 - a.size)]) / a[0]


@pytest.mark.parametrize("dt", [1e-3, 1e-2])
def test_coefficients_match_scipy(dt):
    b, a = zoh_first_order(0.8, 1.0, 1.0, dt)
    rb, ra = _scipy([0.8], [1.0, 1.0], dt, "zoh")
    np.testing.assert_allclose(b, rb, atol=1e-14)
    np.testing.assert_allclose(a, ra, atol=1e-14)
    for tp in (2.0, 1.1, 1.1 + 1e-9):  # distinct, equal and nearly equal poles
        b, a = zoh_reaction(-0.2, 1.1, 3.5, tp, 1.1, 1.0, dt)
        rb, ra = _scipy(-0.22 * np.array([3.5, 1.0]), np.polymul([tp, 1.0], [1.1, 1.0]), dt, "zoh")
        np.testing.assert_allclose(b, rb, atol=1e-13)
        np.testing.assert_allclose(a, ra, atol=1e-13)
    for order in range(3):
        b, a = bilinear_second_order(2.0, 4.0, order, dt)
        rb, ra = _scipy([4.0] + [0.0] * order, [1.0, 4.0, 4.0], dt, "bilinear")
        np.testing.assert_allclose(b, rb, atol=1e-12)
        np.testing.assert_allclose(a, ra, atol=1e-14)


def test_biquad_matches_lfilter_with_steady_state_start():
    rng = np.random.default_rng(0)
    x = 0.3 + rng.standard_normal(5000)
    b, a = bilinear_second_order(3.0, 9.0, 1, 1e-3)
    ref = signal.lfilter(b, a, x, zi=signal.lfilter_zi(b, a) * x[0])[0]
    np.testing.assert_allclose(biquad(b, a, x), ref, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("law", ["quadratic", "signed"])
def test_fused_kernel_equals_reference_path(law):
    r = sim_cached("multisine", 200.0, 40.0, 0.0, 2 * np.pi / 4096)
    p, dt = defaults(), 1 / 200.0
    fused = mixed_regressions(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, dt, p, law, 1.0, 2.0, 1.0, 4.0)
    ps = plant_signals(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, dt, p, law)
    for axis, y, x in (("pitch", ps.y_pitch_nm, r.alpha_rad), ("yaw", ps.y_yaw_nm, r.beta_rad)):
        g, m = filtered_regression(y, x, dt, 1.0, 1.0)
        mix = extend_and_mix(g, m, dt, 2.0, 4.0)
        phi, eps = fused[axis]
        # equal up to round-off of equivalent coefficients in poles near z = 1
        np.testing.assert_allclose(phi, mix.phi, atol=1e-9 * np.abs(mix.phi).max())
        np.testing.assert_allclose(eps, mix.eps, atol=1e-9 * np.abs(mix.eps).max())


@pytest.mark.parametrize("gamma", [(None, None), (50.0, None)])
def test_summaries_equal_estimator_and_interval_on_held_regressions(gamma):
    """drem_summaries (phi, eps summed in passes, never held) gives eq. (8)'s trace and the batch-means interval
    of the same regressions held whole (mixed_regressions -> gradient_estimator, confidence_interval)."""
    from trms_ident.numerics.drem import gradient_estimator
    from trms_ident.numerics.fused import drem_summaries
    from trms_ident.numerics.stats import confidence_interval, interval_from_sums

    r = sim_cached("multisine", 200.0, 40.0, 0.0, 2 * np.pi / 4096)
    p, dt, block, step = defaults(), 1 / 200.0, 700, 7
    args = (r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, dt, p, "quadratic", 1.0, 2.0, 1.0, 4.0)
    held = mixed_regressions(*args)
    summed = drem_summaries(*args, None, block=block, gamma={"pitch": gamma, "yaw": gamma}, rate_per_s=1.5, step=step)
    for axis, (phi, eps) in held.items():
        s = summed[axis]
        trace, final = gradient_estimator(eps, phi, list(gamma), dt, rate_per_s=1.5, step=step)
        np.testing.assert_allclose(s.trace, trace, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(s.final, final, rtol=1e-9)
        assert s.block_sums.shape == (phi.size // block, 3)  # 11 whole blocks; the 300 left-over samples
        assert s.energy == pytest.approx(float(np.dot(phi, phi)), rel=1e-12)  # count in the totals only
        for i in range(2):
            ref = confidence_interval(eps[:, i], phi, block, bias_bound=0.01)
            got = interval_from_sums(s.energy, float(s.cross[i]), s.block_sums[:, 0], s.block_sums[:, 1 + i],
                                     bias_bound=0.01)
            assert got.blocks == ref.blocks == 11
            for field in ("estimate", "low", "high"):
                assert getattr(got, field) == pytest.approx(getattr(ref, field), rel=1e-9)


def test_estimate_leaves_the_slow_imports_out(tmp_path):
    """estimate on a log imports neither scipy.stats nor scipy.optimize (0.26 s and 0.2 s of import: estimate of
    the hour at 1 kHz took 1.2x as long when known_values.py and model_profile.py imported them at the top)."""
    import subprocess
    import sys
    from pathlib import Path

    log = Path(__file__).resolve().parents[1] / "sample_logs" / "paper_square.csv"
    # the command's own app (the console script's run() ends the process without returning to this check)
    code = ("import sys\nfrom trms_ident.cli import app\n"
            "try:\n    app(['estimate', sys.argv[1], '-o', sys.argv[2], '--no-report'])\nexcept SystemExit as e:\n"
            "    assert not e.code, e.code\n"
            "print(sorted(m for m in ('scipy.stats', 'scipy.optimize', 'pandas', 'matplotlib') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code, str(log), str(tmp_path)], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split("\n")[-2] == "[]", out.stdout + out.stderr
