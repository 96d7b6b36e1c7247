"""Tell a centre-of-mass offset from a pitch encoder offset with the output-error fit.

Both change the gravity term alike: Mg sin(alpha + delta) for the centre of mass, the whole pitch
equation at alpha - delta for the encoder.  They differ only in the gyroscopic term
Kg M1 beta' cos(alpha), which the encoder offset shifts too.  In the equation error that
difference drowns in the noise that F s^2 amplifies; in the angle itself it accumulates over
seconds of motion.  So each hypothesis is fitted by the prediction-error refinement
(numerics/refine.py: J1, B1, J2, B2 and the offset together by Gauss-Newton, the offset's sensitivity exact:
model/plant.py carries both), and the one with the smaller noise-weighted squared angle error wins when the gap
is at least MIN_COST_GAP and its fit reaches the noise level.  Both models have the same number of parameters, so
the gap is twice the log likelihood ratio under white angle noise; 10 is "very strong" evidence (a likelihood
ratio of e^5 ~ 150) on the usual scale of Kass and Raftery.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..log import Log
from ..numerics.adequacy import RMS_OVER_NOISE as ADEQUATE_RMS_OVER_NOISE  # the winner must fit (estimate's test)
from ..numerics.design import angle_noise_rad
from ..numerics.refine import refine

PAIR = ("com_offset:pitch", "sensor_offset:pitch")
MIN_COST_GAP = 10.0


@dataclass(frozen=True)
class Verdict:
    winner: str | None  # PAIR member, or None when the fit cannot tell them apart
    gap: float  # noise-weighted squared error of the loser minus the winner's
    offsets_rad: dict  # key -> fitted offset [rad]
    reason: str


def tell_offsets_apart(log: Log, u1: np.ndarray, u2: np.ndarray, p: dict, law: str, theta0: dict,
                       delta0: dict) -> Verdict:
    """Fit both offset hypotheses (``delta0``: key -> starting offset, each in its own sign convention)."""
    noise = {"alpha": angle_noise_rad(log.alpha_rad), "beta": angle_noise_rad(log.beta_rad)}
    dt = log.sample_time_s
    fits = {}
    for key in PAIR:  # each offset free from the equation error's value, in the sign convention of EFFECT_SLOTS
        try:
            r = refine(u1, u2, log.alpha_rad, log.beta_rad, dt, p, law, theta0, noise, free=(key,),
                       effects={key: delta0[key]})
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError):
            return Verdict(None, 0.0, {}, f"the output-error fit with {key} failed (it overflowed on this log)")
        fits[key] = (float(r.freed[key]["estimate"]), r)
    offsets = {k: v[0] for k, v in fits.items()}
    unconverged = [k for k, (_, r) in fits.items() if not r.converged]
    if unconverged:
        return Verdict(None, 0.0, offsets, f"the output-error fit with {unconverged[0]} did not converge")
    (k_win, (d_win, r_win)), (k_lose, (_, r_lose)) = sorted(fits.items(), key=lambda kv: kv[1][1].cost)
    gap = r_lose.cost - r_win.cost
    ratio = max(r_win.rms_rad[a] / noise[a] for a in ("alpha", "beta") if noise[a] > 0)
    if ratio > ADEQUATE_RMS_OVER_NOISE:
        return Verdict(None, gap, offsets, f"the output-error fit does not reach the noise level ({ratio:.3g}x)")
    if gap < MIN_COST_GAP:
        return Verdict(None, gap, offsets, f"the output-error fits differ by only {gap:.3g} (noise-weighted squared "
                                           f"error; {MIN_COST_GAP:g} needed)")
    return Verdict(k_win, gap, offsets, f"told apart from {k_lose} by the output-error fit: noise-weighted squared "
                                        f"angle error lower by {gap:.3g} (likelihood ratio e^{gap / 2:.3g})")
