"""Filter design from the data, 95 % intervals and identifiability."""
import math

import numpy as np
import pytest

from trms_ident.errors import IdentificationError
from trms_ident.identify import Settings, identify
from trms_ident.log import validated
from trms_ident.numerics.design import angle_noise_rad, design_filters, noise_std, quantization_step
from trms_ident.numerics.stats import confidence_interval

from .conftest import as_log, sim_cached


def test_noise_estimate_recovers_known_sigma():
    t = np.arange(100000) * 1e-3
    rng = np.random.default_rng(5)
    for sigma in (1e-4, 1e-3):
        x = 0.4 * np.sin(0.7 * t) + sigma * rng.standard_normal(t.size)
        assert noise_std(x) == pytest.approx(sigma, rel=0.02)


def test_the_noise_estimate_leaves_out_an_arms_strikes_on_its_stop():
    """An angle that strikes an end stop (its rate jumps to zero) leaves a few third differences hundreds of times
    any noise's: they are no noise, and the estimate leaves them out, on uniform and on jittered stamps; an
    encoder's rounding keeps every difference (the plain mean square)."""
    from trms_ident.numerics.design import noise_std_stamped

    def plain(x):
        return math.sqrt(np.mean(np.diff(x, 3) ** 2) / 20.0)

    t = np.arange(60000) * 1e-2
    smooth = np.maximum(0.5 * np.sin(0.4 * t), 0.1)  # rests on a stop at 0.1 rad a third of each period
    assert plain(smooth) > 1e-5 and noise_std(smooth) < 1e-8  # 76 strikes: the plain mean square reads them
    rng = np.random.default_rng(3)
    x = smooth + 1e-6 * rng.standard_normal(t.size)
    assert plain(x) > 10e-6 and noise_std(x) == pytest.approx(1e-6, rel=0.03)
    stamps = t + rng.uniform(0.0, 2e-3, t.size)
    struck = np.maximum(0.5 * np.sin(0.4 * stamps), 0.1) + 1e-6 * rng.standard_normal(t.size)
    assert noise_std_stamped(struck, stamps) == pytest.approx(1e-6, rel=0.03)
    q = 2 * math.pi / 4096
    for dt in (1e-2, 1e-3):  # rounding is all the noise, bounded: nothing is left out
        rounded = q * np.round(0.4 * np.sin(0.7 * np.arange(200000) * dt) / q)
        assert noise_std(rounded) == pytest.approx(plain(rounded), rel=1e-12)


def test_encoder_quantum_is_found_and_sets_the_noise_floor():
    q = 2 * math.pi / 4096
    t = np.arange(200000) * 1e-3  # 1 kHz: the angle moves less than a quantum per sample
    x = q * np.round((0.4 * np.sin(0.7 * t) + 0.01) / q)
    assert quantization_step(x) == pytest.approx(q, rel=1e-9)
    assert noise_std(x) < 0.7 * q / math.sqrt(12)  # third differences miss correlated rounding
    assert angle_noise_rad(x) == pytest.approx(q / math.sqrt(12), rel=1e-9)
    noisy = 0.4 * np.sin(0.7 * t) + 1e-3 * np.random.default_rng(2).standard_normal(t.size)
    assert quantization_step(noisy) == 0.0 and angle_noise_rad(noisy) == pytest.approx(1e-3, rel=0.02)


def test_design_slows_the_filters_for_noisy_logs():
    clean = sim_cached("sine", 1000.0, 120.0)
    noisy = sim_cached("sine", 1000.0, 120.0, 1e-3)
    d_clean = design_filters(clean.alpha_rad, clean.beta_rad, 1e-3)
    d_noisy = design_filters(noisy.alpha_rad, noisy.beta_rad, 1e-3)
    assert d_clean.a_rad_s == 10.0 and d_noisy.a_rad_s < d_clean.a_rad_s
    assert d_noisy.noise_rad["alpha"] == pytest.approx(1e-3, rel=0.05)
    assert d_clean.b_rad_s == 2 * d_clean.a_rad_s


def test_interval_coverage_on_correlated_noise():
    # eps = phi q + r with r strongly autocorrelated (AR(1), 0.999): ~95 % of intervals cover q
    rng = np.random.default_rng(0)
    n, q, hits = 40000, 2.0, 0
    trials = 200
    t = np.arange(n) * 1e-3
    phi = 1.0 + 0.5 * np.sin(0.9 * t)
    for _ in range(trials):
        w = rng.standard_normal(n)
        r = np.empty(n)
        r[0] = w[0]
        for k in range(1, n):  # numba-free but short enough
            r[k] = 0.999 * r[k - 1] + w[k]
        ci = confidence_interval(phi * q + 0.01 * r, phi, block=4000)
        hits += ci.low <= q <= ci.high
    assert 0.88 <= hits / trials <= 0.995


def test_intervals_cover_truth_on_noisy_simulation():
    r = sim_cached("multisine", 200.0, 120.0, 1e-3)
    res = identify(as_log(r))
    for k, v in r.truth["estimated"].items():
        ci = res.intervals[k]
        assert ci.low <= v <= ci.high, (k, ci)
        assert ci.identifiable


def test_unexcited_axis_is_refused():
    n = 2000
    t = np.arange(n) * 0.01
    log = validated(t, 0.5 * np.sin(t), np.zeros(n), 0.1 * np.sin(t), np.zeros(n))
    with pytest.raises(IdentificationError, match="the yaw axis is not excited"):
        identify(log)


def test_weak_excitation_gives_no_number():
    # yaw barely moves and the angles are noisy: B2/J2 must not come out as precise-looking numbers
    r = sim_cached("square", 200.0, 30.0)
    rng = np.random.default_rng(1)
    n = r.t_s.size
    beta = 1e-4 * np.sin(0.3 * r.t_s) + 2e-3 * rng.standard_normal(n)
    log = validated(r.t_s, r.u1_v, 0.01 * np.ones(n), r.alpha_rad, beta)
    res = identify(log, Settings())
    bad = [k for k in ("J2", "B2") if res.estimates[k] is None]
    assert bad, {k: res.intervals[k] for k in ("J2", "B2")}
    assert all(not res.intervals[k].identifiable for k in bad)
    assert math.isfinite(res.offline["J2"])  # the raw number stays available in the JSON
