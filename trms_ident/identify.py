"""The identification pipeline: Log -> plant regressors -> filters -> DREM -> Result.

Pure: arrays and settings in, a Result out.  No files, no printing.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from .errors import IdentificationError, SettingsError
from .log import Log
from .numerics.drem import extend_and_mix, gradient_estimator, normalized_gain, offline_optimum
from .numerics.regressors import filtered_regression, plant_signals
from .params import ESTIMATED, THRUST_LAWS, UNITS, merge

AXES = {"pitch": ("J1", "B1"), "yaw": ("J2", "B2")}
GAIN_CONVENTIONS = ("unit", "paper")
HEADLINES = ("offline", "drem")


@dataclass
class Settings:
    """Every choice that changes the numbers; recorded verbatim in the report."""

    filter_a_rad_s: float = 1.0  # F(s) bandwidth, eq. (3)
    filter_b_rad_s: float = 2.0  # H(s) bandwidth, eq. (5)
    gain_convention: str = "unit"  # "unit": a^2/(s+a)^2, b^2/(s+b)^2; "paper": a/(s+a)^2, b/(s+b)^2
    gamma: dict | None = None  # fixed gains per parameter; None = normalized gain (auto)
    settle_time_s: float = 2.5  # auto gain: mean error decays to 1 % in this time
    thrust_law: str = "quadratic"
    headline: str = "offline"  # which number is "the estimate": offline optimum or DREM final
    overrides: dict = field(default_factory=dict)  # known-parameter values replacing the table's

    def validate(self) -> None:
        for name in ("filter_a_rad_s", "filter_b_rad_s", "settle_time_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SettingsError(f"{name} must be a positive number, got {v!r}")
        if self.filter_a_rad_s == self.filter_b_rad_s:
            raise SettingsError("filter bandwidths a and b must differ, or the extended regressor "
                                f"matrix is singular (eq. 6); got a = b = {self.filter_a_rad_s} rad/s")
        if self.gain_convention not in GAIN_CONVENTIONS:
            raise SettingsError(f"gain convention must be one of {GAIN_CONVENTIONS}, got {self.gain_convention!r}")
        if self.thrust_law not in THRUST_LAWS:
            raise SettingsError(f"thrust law must be one of {tuple(THRUST_LAWS)}, got {self.thrust_law!r}")
        if self.headline not in HEADLINES:
            raise SettingsError(f"headline must be one of {HEADLINES}, got {self.headline!r}")
        if self.gamma is not None:
            for name, v in self.gamma.items():
                if name not in ESTIMATED:
                    raise SettingsError(f"gamma given for {name!r}; expected one of {ESTIMATED}")
                if not (math.isfinite(v) and v >= 0):
                    raise SettingsError(f"gamma for {name} must be >= 0, got {v!r}")

    def filter_gains(self) -> tuple[float, float]:
        """Numerator constants of F and H for the chosen convention (model.md, item 1)."""
        a, b = self.filter_a_rad_s, self.filter_b_rad_s
        return (a * a, b * b) if self.gain_convention == "unit" else (a, b)


@dataclass
class AxisResult:
    axis: str
    phi: np.ndarray  # det M(t), eq. (7)
    eps: np.ndarray  # (n, 2) mixed regressands, eq. (7)
    gamma: np.ndarray  # gain used at each sample [1/(s phi^2)]
    excitation: float  # rms(phi) / (rms(m1) rms(Hm2) + rms(m2) rms(Hm1)): 0 none, O(0.1) good


@dataclass
class Result:
    t_s: np.ndarray
    traces: dict[str, np.ndarray]  # DREM estimate traces, eq. (8)
    drem_final: dict[str, float]
    offline: dict[str, float]  # sum(eps phi) / sum(phi^2) per parameter
    estimates: dict[str, float]  # the headline numbers (settings.headline)
    axes: dict[str, AxisResult]
    parameters: dict[str, float]  # every model value used (table + overrides)
    settings: Settings
    sample_time_s: float

    def settings_dict(self) -> dict:
        return asdict(self.settings)


def identify(log: Log, settings: Settings | None = None) -> Result:
    """Estimate J1, B1, J2, B2 from a validated log with the DREM procedure (eqs. 3-8)."""
    settings = settings or Settings()
    settings.validate()
    params = merge(settings.overrides, source="parameter overrides")
    dt = log.sample_time_s
    ps = plant_signals(log.u1_v, log.u2_v, log.alpha_rad, log.beta_rad, dt, params, settings.thrust_law)
    f_gain, h_gain = settings.filter_gains()
    traces, drem_final, offline, axes = {}, {}, {}, {}
    for axis, y, x in (("pitch", ps.y_pitch_nm, log.alpha_rad), ("yaw", ps.y_yaw_nm, log.beta_rad)):
        g, m = filtered_regression(y, x, dt, settings.filter_a_rad_s, f_gain)  # eq. (3)
        mix = extend_and_mix(g, m, dt, settings.filter_b_rad_s, h_gain)  # eqs. (5)-(7)
        if not np.all(np.isfinite(mix.phi)) or not np.any(mix.phi):
            raise IdentificationError(
                f"the {axis} axis is not excited: det M is zero over the whole log "
                f"(constant input and angle?); {', '.join(AXES[axis])} cannot be identified")
        for i, name in enumerate(AXES[axis]):
            if settings.gamma is not None and name in settings.gamma:
                gamma = np.full(mix.phi.size, float(settings.gamma[name]))
            else:
                gamma = normalized_gain(mix.phi, math.log(100.0) / settings.settle_time_s)
            trace = gradient_estimator(mix.eps[:, i], mix.phi, gamma, dt)  # eq. (8)
            traces[name] = trace
            drem_final[name] = float(trace[-1])
            offline[name] = offline_optimum(mix.eps[:, i], mix.phi)
        axes[axis] = AxisResult(axis, mix.phi, mix.eps, gamma, mix.excitation)
    estimates = offline if settings.headline == "offline" else drem_final
    return Result(log.t_s, traces, drem_final, offline, dict(estimates), axes, params, settings, dt)


def units_of(name: str) -> str:
    return UNITS[name]
