"""Known values as hypotheses: which value of eq. (1)'s table, set free alone, makes the model fit the log?

One engine for ``estimate`` (identify's adequacy check names the value in its sentence) and ``diagnose`` (the
value becomes a finding, weighed against the effect library): both read the same :class:`KnownValueSearch`,
computed once per log by identify, so the two commands cannot name different values.

A lab's bench differs from the manual's table more often than it has new physics.  When the model does not
fit, each known value is a one-parameter hypothesis.  The search:

1. fits the seed model by multiple shooting (the output-error fit of numerics/refine.py in SHOOTING_WINDOW_S
   windows, each restarting from its own fitted angles and rates): a wrong known value then cannot carry the
   simulated yaw far off in a 40 s window, so the fit stays in the basin of the right J/B (measured: with the
   reaction gain kc at half its table value, 40 s windows left the yaw 550x its noise level with J/B in a wrong
   basin, and freeing kc from there stopped at 69x after 25 iterations; through 1 s windows the same refit
   converged in 3 iterations to the noise level and to kc's true value);
2. ranks every known value by a score test at that fit (numerics/refine.suspect_known_values: the share of the
   excess cost one Gauss-Newton step with the value free would remove);
3. refits the TOP ranked by multiple shooting with that value free, from the table's J/B;
4. refits those whose shooting fit reaches the noise level again in the standard windows, from the shooting
   fit's J/B, value and start states.  The shooting model contains the standard one (a 40 s window is 1 s
   windows joined), so a value whose shooting fit stays above the noise level cannot reach it in 40 s windows;
5. a value *explains* the log when its standard-window refit converged with both angles within
   RMS_OVER_NOISE of their noise floors.  The explaining value with the lowest cost is named; the others that
   explain the log too are its look-alikes: this log cannot tell them apart.

No value is named on a fit that did not reach the noise level: a value that only lowers the misfit is a lead,
reported with its refit, never a finding.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np

from .numerics.adequacy import RMS_OVER_NOISE
from .numerics.refine import Refined, suspect_known_values
from .params import BY_NAME, ESTIMATED, KNOWN

#: every known value of eq. (1) (Table 1's "known" rows), each a hypothesis
HYPOTHESES = KNOWN
#: the angle a known value acts on first (the equation it enters; the main motor's values drive the pitch)
AXIS = {"a1": "pitch", "b1": "pitch", "Mg": "pitch", "Kg": "pitch", "k1": "pitch", "T11": "pitch", "T10": "pitch",
        "a2": "yaw", "b2": "yaw", "k2": "yaw", "T21": "yaw", "T20": "yaw", "kc": "yaw", "T0": "yaw", "Tp": "yaw"}
#: the windows of the multiple-shooting fits [s]: about one motor time constant (identify's fallback uses the same)
SHOOTING_WINDOW_S = 1.0
#: this many of the score test's first ranked values are refitted (measured on 12 logs with one known value off:
#: the right one ranked first on 11, second on 1, with 0.022 against 0.023)
TOP = 4


@dataclass
class KnownValueFit:
    """One known value refitted alone (J/B, start states and window starts free too)."""
    name: str
    table: float  # the value the model was given (Table 1 or --params)
    value: float  # refitted
    ci95: tuple  # its 95 % interval (batch means)
    unit: str
    axis: str
    score: float  # the score test's share of the excess cost (the ranking)
    stage: str  # "shooting" (stopped there: the shooting fit stayed above the noise level) or "windows"
    converged: bool
    over_noise: dict  # angle -> error RMS over its noise floor after the refit
    cost: float  # noise-weighted squared angle error after the refit
    explains: bool  # converged in the standard windows with both angles within RMS_OVER_NOISE
    estimates: dict = field(default_factory=dict)  # J1, B1, J2, B2 of the refit
    start_states: dict = field(default_factory=dict)  # the motors' states at the first sample of the refit

    def to_json(self) -> dict:
        return {**asdict(self), "ci95": list(self.ci95)}


@dataclass
class KnownValueSearch:
    samples: int  # the log's first samples the search used
    scores: dict  # name -> score test share, largest first
    fits: list  # KnownValueFit, refitted ones, lowest cost first
    best: KnownValueFit | None  # the value named (explains the log, lowest cost), or None
    look_alikes: list = field(default_factory=list)  # other values that explain the log as well
    base_over_noise: dict = field(default_factory=dict)  # the shooting fit without a value free

    def to_json(self) -> dict:
        return {"samples": self.samples, "scores": self.scores, "fits": [f.to_json() for f in self.fits],
                "named": self.best.name if self.best else None, "look_alikes": list(self.look_alikes),
                "shooting_over_noise": self.base_over_noise}


#: fit(free, theta0, params, **options) -> Refined: the output-error fit of the log's first samples (identify's)
Fit = Callable[..., Refined]


def over_noise(r: Refined, noise: dict) -> dict:
    """Each angle's error RMS after the fit over its noise floor (inf when the floor is zero)."""
    return {ax: r.rms_rad[ax] / noise[ax] if noise[ax] > 0 else math.inf for ax in ("alpha", "beta")}


def _within(ratio: dict) -> bool:
    return max(ratio.values()) <= RMS_OVER_NOISE


def _usable(est: dict) -> bool:
    return all(math.isfinite(est[k]) and est[k] > 0 for k in ESTIMATED)


def search(fit: Fit, params: dict, noise: dict, samples: int, candidates: tuple = HYPOTHESES,
           free: tuple = ()) -> KnownValueSearch:
    """The known-value hypotheses of a log the model does not fit (module docstring).  ``fit`` runs the
    output-error fit on the log's first ``samples``; ``params`` the values the model was given; ``noise`` the
    angles' noise floors [rad]; ``free``: values already estimated (--free), never hypotheses."""
    table_jb = {k: params[k] for k in ESTIMATED}
    candidates = tuple(k for k in candidates if k not in free)
    with np.errstate(all="ignore"):
        base = fit(tuple(free), table_jb, params, window_s=SHOOTING_WINDOW_S)
        scores = suspect_known_values(base, candidates)
    base_ratio = over_noise(base, noise)
    fits = []
    for name in list(scores)[:TOP]:
        fits.append(_refit(fit, name, params, noise, scores[name], table_jb, tuple(free)))
    fits = [f for f in fits if f is not None]
    fits.sort(key=lambda f: (not f.explains, f.cost))
    explaining = [f for f in fits if f.explains]
    best = explaining[0] if explaining else None
    return KnownValueSearch(samples, scores, fits, best, [f.name for f in explaining[1:]], base_ratio)


_FAILED = (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError, ValueError)


def _refit(fit: Fit, name: str, params: dict, noise: dict, score: float, theta0: dict, free: tuple
           ) -> KnownValueFit | None:
    """``name`` set free alone: multiple shooting, then the standard windows when the shooting fit reaches the
    noise level (module docstring); None when the fit fails (a value that drives the model to non-numbers)."""
    p = BY_NAME[name]
    try:
        with np.errstate(all="ignore"):
            r = fit(free + (name,), theta0, params, window_s=SHOOTING_WINDOW_S)
            stage = "shooting"
            ratio = over_noise(r, noise)
            value = r.freed[name]["estimate"]
            if _within(ratio) and _usable(r.estimate) and math.isfinite(value):
                moved = {**params, name: value}
                r = fit(free + (name,), r.estimate, moved, start_states0=r.start_states)
                stage = "windows"
                ratio = over_noise(r, noise)
    except _FAILED:
        return None
    f = r.freed.get(name)
    if f is None or not math.isfinite(f["estimate"]):
        return None
    return KnownValueFit(name, float(params[name]), float(f["estimate"]), tuple(float(x) for x in f["ci95"]), p.unit,
                         AXIS[name], float(score), stage, bool(r.converged), {k: float(v) for k, v in ratio.items()},
                         float(r.cost), stage == "windows" and bool(r.converged) and _within(ratio),
                         {k: float(v) for k, v in r.estimate.items()}, {k: float(v) for k, v in r.start_states.items()})


def sentence(s: KnownValueSearch) -> str:
    """What the search found, for estimate's adequacy sentence and diagnose's verdict."""
    if s.best is None:
        tried = ", ".join(f"{f.name} ({max(f.over_noise.values()):.3g}x)" for f in s.fits) or "none could be fitted"
        return (" No single known value explains the misfit (refitted alone, the most likely leave the angles "
                f"above their noise level: {tried}): the model leaves out physics, or several known values are "
                "off; `trms-ident diagnose` weighs the effect library against them.")
    b = s.best
    alike = (f"; {', '.join(s.look_alikes)} would explain the data as well (this log cannot tell them apart)"
             if s.look_alikes else "")
    return (f" The data blame a known value: with {b.name} estimated too (it comes out {b.value:.4g} instead of "
            f"{b.table:.4g}) the model fits to the noise level{alike}. Check it, or estimate it with --free {b.name}; "
            "`trms-ident diagnose` weighs it against the effect library.")
