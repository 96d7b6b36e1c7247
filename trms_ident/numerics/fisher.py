"""Predicted precision of J1, B1, J2, B2 for a run that has not been recorded yet (the core of issue #35's
experiment design).

The output-error estimate (numerics/refine.py) fits J/B, the motors' start states and each window's angles and
rates to the logged angles, given the logged voltages.  Given the voltages and angles a run would produce (the
closed-loop simulator's, noise-free) and the angles' noise standard deviation, its Fisher information is the
refinement's own normal matrix at the true values: the noise-weighted Gauss-Newton matrix with the windows'
starts eliminated (refine.schur).  Its inverse is the covariance an unbiased estimate reaches when the errors
are white at that standard deviation (Cramer-Rao); the closed loop enters through the voltages, which the
estimate takes as given.  Pure numerics: no I/O.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.stats import norm

from .refine import NAMES, NG, NL, scaled_inverse, schur
from .stats import Z95
from .refine import refine as oe_refine

#: the motors' states where a planned run starts: at rest, as the simulator's runs do. The information is the
#: Gauss-Newton matrix along the model's own trajectory from these states; refine's default start (the motors'
#: steady state for the first voltages) differs from the run's when the first voltage is not 0, and a square
#: wave that switched at t = 0 was predicted 30-60x more precise than estimate then was (B1 0.17 % against 10-16 %)
AT_REST = {"tau1_0": 0.0, "tau2_0": 0.0, "zeta_0": 0.0, "lag1_0": 0.0, "lag2_0": 0.0}


def covariance(u1_v: np.ndarray, u2_v: np.ndarray, alpha_rad: np.ndarray, beta_rad: np.ndarray, dt_s: float,
               params: dict, law: str, noise_rad: dict, effect: tuple[str, float] | None = None,
               start_states0: dict = AT_REST, fixed: dict | None = None) -> np.ndarray:
    """(4, 4) the Cramer-Rao covariance of J1, B1, J2, B2 (NAMES' order) for a run with these voltages [V] and
    noise-free angles [rad] at uniform steps ``dt_s`` [s], the bench ``params`` (J/B and the known values of
    eq. (1)) and ``noise_rad`` = {"alpha": sd, "beta": sd} [rad], the logged angles' white noise (an encoder
    quantum q: q / sqrt(12)); the motors' start states and the windows' starts are unknowns beside J/B.
    ``effect`` = (key, value): a torque effect the refinement's kernel carries (model.plant.EFFECT_SLOTS) in the
    model at that value with its parameter free; the matrix is then (5, 5), its last row and column the effect's.
    ``start_states0``: the motors' states where the run starts (AT_REST).  ``fixed``: the bench's torque effects
    (key -> value, a bench file's [effects]) in the model at their values, held."""
    theta = {k: float(params[k]) for k in NAMES}
    kw = {"effects": dict(fixed)} if fixed else {}
    if effect is not None:
        kw = {"effects": {**kw.get("effects", {}), effect[0]: float(effect[1])}, "free": (effect[0],)}
    r = oe_refine(u1_v, u2_v, alpha_rad, beta_rad, dt_s, params, law, theta, noise_rad, max_iterations=0,
                  start_states0=start_states0, **kw)
    fit = r.fit
    ng = fit.a.shape[1] - NL  # the globals: J/B, the start states (refine's NG), the freed effect, the lags' starts
    s_mat, _, _ = schur(fit.a, fit.b, ng)
    cov = scaled_inverse(s_mat)
    keep = [0, 1, 2, 3] + ([NG] if effect is not None else [])  # the freed effect right after the motors' starts
    return cov[np.ix_(keep, keep)]


def predicted_precision(u1_v: np.ndarray, u2_v: np.ndarray, alpha_rad: np.ndarray, beta_rad: np.ndarray,
                        dt_s: float, params: dict, law: str, noise_rad: dict, quantum_rad: float = 0.0) -> dict:
    """J1, B1, J2, B2 -> {"se", "half_width" (95 %), "relative" (half-width over the value)}: covariance()'s
    diagonal (same arguments); with an encoder's ``quantum_rad`` [rad], what estimate would report on the rounded
    angles instead (with_rounding)."""
    cov = covariance(u1_v, u2_v, alpha_rad, beta_rad, dt_s, params, law, noise_rad)
    if quantum_rad > 0:
        cov = with_rounding(cov, u1_v, u2_v, alpha_rad, beta_rad, dt_s, params, law, noise_rad, quantum_rad)
    return precision_of(cov, params)


def with_rounding(cov: np.ndarray, u1_v: np.ndarray, u2_v: np.ndarray, alpha_rad: np.ndarray, beta_rad: np.ndarray,
                  dt_s: float, params: dict, law: str, noise_rad: dict, quantum_rad: float,
                  start_states0: dict = AT_REST, fixed: dict | None = None) -> np.ndarray:
    """``cov`` (J/B first) scaled so that each of J1, B1, J2, B2 has the variance estimate's interval would
    report when the encoder's rounding is the noise: the wider of the spread that rounding the run's noise-free
    angles on a grid of ``quantum_rad`` [rad] causes and the batch-means variance the refinement reports on those
    rounded angles (numerics/quantization.py; estimate's own rule, identify._with_rounding).  White noise of
    q / sqrt(12) is not what rounding slow motion at a high rate does (measured: J1's error 4x that bound on a
    12-bit log at 1 kHz, B1's a quarter).  ``fixed``: as covariance's."""
    from .quantization import rounding_covariance

    theta = {k: float(params[k]) for k in NAMES}
    spread, batch = rounding_covariance(u1_v, u2_v, np.column_stack([alpha_rad, beta_rad]), dt_s, params, law,
                                        theta, noise_rad, {"alpha": quantum_rad, "beta": quantum_rad},
                                        start_states0=start_states0, batch_means=True,
                                        **({"effects": dict(fixed)} if fixed else {}))
    ratio = np.ones(cov.shape[0])
    for i in range(4):
        target = max(spread[i, i], batch[i, i] if np.isfinite(batch[i, i]) else 0.0)
        if cov[i, i] > 0 and target > 0:
            ratio[i] = math.sqrt(target / cov[i, i])
    return cov * np.outer(ratio, ratio)


def encoder_covariance(runs: list, dt_s: float, params: dict, law: str, noise_rad: dict, quantum_rad: float,
                       effect: tuple[str, float] | None = None, fixed: dict | None = None) -> np.ndarray:
    """covariance() as estimate would report it on a run recorded with encoders of ``quantum_rad`` [rad], from
    ``runs``: (u1 [V], u2 [V], alpha [rad], beta [rad]) of the closed loop simulated with the encoders in it (the
    controller reads their rounded angles, and that changes the voltages it makes), the angles its noise-free
    ones, one run per place of the encoders' grid. For each, the information along its angles scaled to the
    rounding's spread (with_rounding); the variances averaged over the runs. (Rounding an encoder-free run instead
    predicted J2 at 0.4-0.6x what estimate then reported on one 120 s design at 1 kHz.)  ``fixed``: as covariance's."""
    covs = []
    for u1, u2, a, b in runs:
        cov = covariance(u1, u2, a, b, dt_s, params, law, noise_rad, effect, fixed=fixed)
        covs.append(with_rounding(cov, u1, u2, a, b, dt_s, params, law, noise_rad, quantum_rad, fixed=fixed))
    return np.mean(covs, axis=0)


def detection_power(value: float, se: float, n_tests: int, alpha: float) -> float:
    """The chance that a two-sided test of an effect's parameter at the family level ``alpha`` / ``n_tests``
    (Bonferroni, as diagnose's) finds it, when the estimate is normal about ``value`` with standard error ``se``."""
    if not se > 0:
        return 1.0
    z = float(norm.isf(alpha / n_tests / 2.0))
    c = abs(value) / se
    return float(norm.sf(z - c) + norm.cdf(-z - c))


def precision_of(cov: np.ndarray, params: dict) -> dict:
    """covariance()'s (4, 4) matrix as predicted_precision's dict, relative to ``params``' J/B."""
    out = {}
    for i, k in enumerate(NAMES):  # J/B: the first four rows whatever follows
        se = math.sqrt(max(float(cov[i, i]), 0.0))
        out[k] = {"se": se, "half_width": Z95 * se, "relative": Z95 * se / abs(float(params[k]))}
    return out
