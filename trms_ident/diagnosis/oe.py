"""Candidates fitted and judged by output error: the angles simulated, not the filtered equation.

The equation-error test (select.py) filters the log with F s^2 and so amplifies the angle noise; a small
friction torque or drag that changes the angles by a fraction of the noise level per sample is lost in it,
and the seed model then "fits to the noise level" although thousands of samples agree on the effect.  Here a
candidate is put into the output-error model of the refinement (numerics/refine.py: both axes of eq. (1)
simulated in 40 s windows from fitted starts, the motors' start states estimated) with its parameter free
beside J1, B1, J2, B2 and the accepted findings' own parameters.  Forward sensitivities give the
Gauss-Newton system; the parameter's standard error comes from batch means of its scores (1 s blocks, valid
for correlated errors such as quantization).  A candidate passes when its parameter differs from 0 beyond
chance for the whole family of candidates (two-sided Student t, Bonferroni, FAMILY_ALPHA), it lowers the
noise-weighted squared angle error by at least MIN_COST_DROP of the current model's, the angle-error
energy it removes is at least MIN_SIGNAL_SHARE of the angle's (the equation-error test's round-off floor),
and its torque is at least MIN_TORQUE_SHARE of its axis' thrust torque (a physical size).
The batch-means t alone is optimistic on noise-free quantized logs (t ~ 5 for a 6e-6 rad offset on a clean
square-wave log); the practical size decides there.

Which effects the output-error model carries: numerics.refine.EFFECT_SLOTS (Coulomb friction and quadratic
drag on either axis, the yaw cable, a reversed rotor's thrust asymmetry, the centre-of-mass offset); the
other findings (input modifications, the encoder offset, the pitch-dependent yaw inertia) are not in it
with a free parameter, so once one of them is a finding only the equation error judges.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import stdtr

from ..log import Log
from ..numerics.design import angle_noise_rad
from ..numerics.refine import EFFECT_SLOTS, substeps
from ..numerics.refine import refine as oe_refine
from ..numerics.regressors import thrust
from .model import Model
from .select import MIN_SIGNAL_SHARE

#: candidates the output-error fit can carry
OE_KEYS = tuple(EFFECT_SLOTS)
#: a passing candidate must lower the noise-weighted squared angle error by this fraction of the current one
#: (a practical size: on clean logs the drop was at most 2e-4 of it, on a 0.002 N m pitch friction 3e-2)
MIN_COST_DROP = 0.01
#: the output-error fits cover at most this many integration steps of the log's beginning (bounded time and
#: memory; as estimate's adequacy check, about 4 min at 1 kHz)
MAX_STEPS = 250_000


#: what a fit on a log with nothing to fit raises (the normal equations not finite, a zero step)
_FAILED = (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError)


@dataclass(frozen=True)
class OEFit:
    key: str
    value: float  # the candidate's parameter, fitted with J/B and the current findings' parameters
    se: float  # its batch-means standard error
    t: float
    p: float  # two-sided, Student t with blocks - 1 degrees of freedom
    cost_drop: float  # noise-weighted squared angle error: current model's minus this one's, over the current
    explained: float  # the angle-error energy it removes over the angle's own energy (largest axis)
    excess_share: float  # the share of the current model's misfit above the noise floor that it removes
    torque_share: float  # its torque over its axis' thrust torque (RMS)
    estimates: dict  # J1, B1, J2, B2 of this fit
    samples: int  # how many of the log's samples the fit used


def representable(model: Model) -> bool:
    """Can the output-error fit carry the model's findings with every parameter free?  (An input
    modification's value would stay at the equation error's estimate, and a fixed, slightly wrong dead zone or
    saturation leaves yaw drift that a tiny extra term then absorbs: measured, "cable 8e-5 N m/rad".)"""
    return all(k == "com_offset:pitch" for k, _ in model.mods) and all(k in OE_KEYS for k in model.linear)


#: a candidate's torque must reach this share of its axis' thrust torque (RMS over the log): in 40 s windows
#: the yaw, which has no restoring force, turns a tiny stabilising term (a 5e-5 N m/rad cable, a thrust
#: asymmetry of 1e-4) into a large drop in angle error when some other effect (a dead zone) is missing; a
#: 0.002 N m pitch friction is 1.7 % of the main rotor's thrust torque
MIN_TORQUE_SHARE = 0.005


def torque_share(key: str, value: float, log: Log, p: dict, law: str) -> float:
    """RMS of the candidate's torque over the RMS of its axis' thrust torque M(tau) (tau at the steady state
    of the logged voltages), both over the log."""
    axis = key.split(":")[1]
    pitch = axis == "pitch"
    u = log.u1_v if pitch else log.u2_v
    k, t0, a, b = (p["k1"], p["T10"], p["a1"], p["b1"]) if pitch else (p["k2"], p["T20"], p["a2"], p["b2"])
    tau = k / t0 * u
    m = thrust(tau, a, b, law)  # eq. (1) thrust law
    x = log.alpha_rad if pitch else log.beta_rad
    w = np.gradient(x, log.sample_time_s)
    rms = lambda v: float(np.sqrt(np.mean(np.square(v))))  # noqa: E731
    effect = key.split(":")[0]
    torque = {"coulomb_friction": lambda: abs(value),
              "quadratic_drag": lambda: abs(value) * rms(w * np.abs(w)),
              "cable_stiffness": lambda: abs(value) * rms(x),
              "thrust_asymmetry": lambda: abs(value) * rms(np.where(tau < 0, m, 0.0)),
              "com_offset": lambda: abs(value) * p["Mg"] * rms(np.cos(x))}[effect]()
    scale = rms(m)
    return torque / scale if scale > 0 else 0.0


class Fitter:
    """Output-error fits of one log: the current model (cached per model) and the model with one candidate."""

    def __init__(self, log: Log, p: dict, law: str):
        self.log, self.p, self.law = log, p, law
        self.n = min(len(log), max(MAX_STEPS // substeps(log.sample_time_s), 10))
        self.noise = {"alpha": angle_noise_rad(log.alpha_rad[:self.n]), "beta": angle_noise_rad(log.beta_rad[:self.n])}
        self.var = {"alpha": float(np.var(log.alpha_rad[:self.n])), "beta": float(np.var(log.beta_rad[:self.n]))}
        self._base: dict = {}

    def _fit(self, model: Model, values: dict, theta0: dict, extra_key: str | None):
        """The refinement of the log's first n samples with the model's effects (representable: linear ones and
        the centre-of-mass offset, all free) and, when given, ``extra_key`` free from 0."""
        n, log = self.n, self.log
        effects = {k: values[k] for k in model.linear}
        effects.update({k: v for k, v in model.mods if k == "com_offset:pitch"})
        free = tuple(effects) + ((extra_key,) if extra_key else ())
        return oe_refine(log.u1_v[:n], log.u2_v[:n], log.alpha_rad[:n], log.beta_rad[:n], log.sample_time_s, self.p,
                         self.law, theta0, self.noise, free=free, effects=effects)

    def base(self, model: Model, values: dict, theta0: dict):
        """The current model's fit (its findings' parameters free), or None when it cannot be fitted (a log
        with nothing to fit: the normal equations are not finite)."""
        if model not in self._base:
            try:
                self._base[model] = self._fit(model, values, theta0, None)
            except _FAILED:
                self._base[model] = None
        return self._base[model]

    def candidate(self, model: Model, values: dict, theta0: dict, key: str) -> OEFit | None:
        """The model with candidate ``key`` added and fitted; None when a fit fails or does not converge."""
        base = self.base(model, values, theta0)
        if base is None or not base.converged:
            return None
        try:  # from the current model's fit: Gauss-Newton then starts next to the answer
            r = self._fit(model, values, base.estimate, key)
        except _FAILED:
            return None
        if not r.converged:
            return None
        f = r.freed[key]
        se = f["se"]
        t = f["estimate"] / se if se > 0 else math.inf
        dof = max(r.blocks - 1, 1)
        p = float(2.0 * stdtr(dof, -abs(t))) if math.isfinite(t) else 0.0
        explained = max((base.rms_rad[ax] ** 2 - r.rms_rad[ax] ** 2) / v if v > 0 else 0.0
                        for ax, v in self.var.items())
        floor = 2.0 * self.n  # the noise-weighted squared error of a model that fits to the noise level
        excess = max(base.cost - floor, MIN_COST_DROP * base.cost)
        return OEFit(key, float(f["estimate"]), float(se), float(t), p, float((base.cost - r.cost) / base.cost),
                     float(explained), float((base.cost - r.cost) / excess),
                     torque_share(key, float(f["estimate"]), self.log, self.p, self.law), dict(r.estimate), self.n)


def passes(fit: OEFit, n_tests: int, alpha: float) -> bool:
    """Beyond chance for the family (Bonferroni), of practical size, and above round-off (on a noise-free log
    the integrators' differences, ~1e-12 rad, pass for significant otherwise)."""
    return (fit.p < alpha / max(n_tests, 1) and fit.cost_drop >= MIN_COST_DROP
            and fit.explained >= MIN_SIGNAL_SHARE and fit.torque_share >= MIN_TORQUE_SHARE)


def evidence(fit: OEFit, dt_s: float) -> str:
    return (f"output-error fit with the effect's parameter free: {fit.value:.4g} +/- {fit.se:.2g} (t = {fit.t:.1f}, "
            f"p = {fit.p:.1e}), noise-weighted squared angle error {-100 * fit.cost_drop:+.1f} % over the first "
            f"{fit.samples * dt_s:.4g} s")
