"""Predicted precision (numerics/fisher.py, the core of issue #35's design): the Fisher information of the
output-error estimate against the Monte Carlo spread of that estimate over closed-loop runs on the simulator."""
import numpy as np
import pytest

from sim import SimSettings, simulate
from trms_ident.numerics.fisher import predicted_precision
from trms_ident.numerics.refine import NAMES, refine
from trms_ident.params import defaults


@pytest.mark.parametrize("ref, rate, sigma", [("sine", 100.0, 1e-3), ("square", 200.0, 5e-4)])
def test_predicted_standard_errors_match_the_monte_carlo_spread_within_30_percent(ref, rate, sigma):
    p = defaults()
    noise = {"alpha": sigma, "beta": sigma}
    run = dict(ref=ref, duration_s=30.0, sample_rate_hz=rate)
    clean = simulate(SimSettings(**run))  # the run as designed: noise-free
    pred = predicted_precision(clean.u1_v, clean.u2_v, clean.alpha_rad, clean.beta_rad, 1 / rate, p, "quadratic",
                               noise)
    est = []
    for seed in range(40):  # the same reference, the closed loop run again with its own noise
        r = simulate(SimSettings(**run, seed=seed, noise_std_rad=sigma))
        f = refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / rate, p, "quadratic", {k: p[k] for k in NAMES},
                   noise)
        est.append([f.estimate[k] for k in NAMES])
    spread = np.std(est, axis=0, ddof=1)
    for k, s in zip(NAMES, spread):
        assert s == pytest.approx(pred[k]["se"], rel=0.3), k
        assert pred[k]["relative"] == pytest.approx(1.959963984540054 * pred[k]["se"] / p[k])
    # and halving the noise halves the predicted standard errors (the information grows as 1 / sigma^2)
    half = predicted_precision(clean.u1_v, clean.u2_v, clean.alpha_rad, clean.beta_rad, 1 / rate, p, "quadratic",
                               {"alpha": sigma / 2, "beta": sigma / 2})
    for k in NAMES:
        assert half[k]["se"] == pytest.approx(pred[k]["se"] / 2, rel=1e-6)


def test_an_effects_predicted_standard_error_matches_its_monte_carlo_spread():
    # a 0.002 N m pitch Coulomb friction in the bench and free in the fit beside J/B
    from trms_ident.numerics.fisher import covariance, detection_power

    p = defaults()
    key, size, sigma = "coulomb_friction:pitch", 0.002, 1e-3
    noise = {"alpha": sigma, "beta": sigma}
    run = dict(ref="sine", duration_s=30.0, sample_rate_hz=100.0,
               effects=[{"effect": "coulomb_friction", "axis": "pitch", "value": size}])
    clean = simulate(SimSettings(**run))
    cov = covariance(clean.u1_v, clean.u2_v, clean.alpha_rad, clean.beta_rad, 0.01, p, "quadratic", noise, (key, size))
    assert cov.shape == (5, 5)
    se = float(np.sqrt(cov[4, 4]))
    est = []
    for seed in range(40):
        r = simulate(SimSettings(**run, seed=seed, noise_std_rad=sigma))
        f = refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 0.01, p, "quadratic", {k: p[k] for k in NAMES}, noise,
                   free=(key,), effects={key: size})
        est.append(f.freed[key]["estimate"])
    assert np.std(est, ddof=1) == pytest.approx(se, rel=0.3)
    assert np.mean(est) == pytest.approx(size, abs=3 * se)
    # the power of a two-sided Bonferroni test: at the critical value one half, far above it one, at zero alpha / 20
    z = 3.0233414397  # norm.isf(0.05 / 20 / 2)
    assert detection_power(z * se, se, 20, 0.05) == pytest.approx(0.5, abs=1e-3)
    assert detection_power(10 * z * se, se, 20, 0.05) == pytest.approx(1.0)
    assert detection_power(0.0, se, 20, 0.05) == pytest.approx(0.05 / 20)
