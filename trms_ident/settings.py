"""Identification settings: every choice that changes the numbers. Light to import (no numba)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from .errors import SettingsError
from .params import ESTIMATED, KNOWN, THRUST_LAWS

AXES = {"pitch": ("J1", "B1"), "yaw": ("J2", "B2")}
#: traces of longer logs keep every k-th sample (Result.trace_step = k); plenty for plots
MAX_TRACE_POINTS = 50_000
GAIN_CONVENTIONS = ("unit", "paper")
HEADLINES = ("refined", "offline", "drem")
REFINE_MODES = ("auto", "on", "off")
#: "auto" refines logs up to this many integration steps (samples x RK4 sub-steps): about 17 min at
#: 1 kHz, ~2 s of refinement; longer logs keep DREM's offline optimum (their intervals are narrow already)
REFINE_AUTO_MAX_STEPS = 1_000_000


@dataclass
class Settings:
    """Every choice that changes the numbers; recorded verbatim in the report."""

    filter_a_rad_s: float | None = None  # F(s) bandwidth, eq. (3); None = designed from the data
    filter_b_rad_s: float | None = None  # H(s) bandwidth, eq. (5); None = 2 a
    gain_convention: str = "unit"  # "unit": a^2/(s+a)^2, b^2/(s+b)^2; "paper": a/(s+a)^2, b/(s+b)^2
    gamma: dict | None = None  # fixed gains per parameter; None = normalized gain (auto)
    settle_time_s: float = 2.5  # auto gain: mean error decays to 1 % in this time
    thrust_law: str = "quadratic"
    headline: str = "refined"  # "the estimate": refined (falls back to offline), offline optimum, DREM final
    refine: str = "auto"  # prediction-error refinement after DREM: auto (by log length), on, off
    overrides: dict = field(default_factory=dict)  # known-parameter values replacing the table's
    free: tuple = ()  # known values estimated with J/B by the refinement (--free), started from table/file
    inputs_unit: str | None = None  # the input unit the known values take ([units] of --params); None: volts
    #: the bench's effects and structures beyond eq. (1) ([effects] of --params, model/bench.py): key -> value
    effects: dict = field(default_factory=dict)
    effect_sources: dict = field(default_factory=dict)  # key -> where its value came from ("" when not said)
    #: the bench's structure where it is not eq. (1)'s ([structure] of --params, model/structure.py: what drives the
    #: gyroscope and M_R, the end stops): its canonical dict, empty under eq. (1)
    structure: dict = field(default_factory=dict)
    #: effect key or known value's name -> the file's 95 % interval (low, high) of a value estimated elsewhere (its
    #: ci95): held at its value, it widens J/B's intervals by what it moves them (model_profile.py)
    held_ci95: dict = field(default_factory=dict)

    def validate(self) -> None:
        for name in ("filter_a_rad_s", "filter_b_rad_s", "settle_time_s"):
            v = getattr(self, name)
            if v is None and name != "settle_time_s":
                continue
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise SettingsError(f"{name} must be a positive number, got {v!r}")
        if self.filter_a_rad_s is not None and self.filter_a_rad_s == self.filter_b_rad_s:
            raise SettingsError("filter bandwidths a and b must differ, or the extended regressor "
                                f"matrix is singular (eq. 6); got a = b = {self.filter_a_rad_s} rad/s")
        if self.gain_convention not in GAIN_CONVENTIONS:
            raise SettingsError(f"gain convention must be one of {GAIN_CONVENTIONS}, got {self.gain_convention!r}")
        if self.thrust_law not in THRUST_LAWS:
            raise SettingsError(f"thrust law must be one of {tuple(THRUST_LAWS)}, got {self.thrust_law!r}")
        if self.refine not in REFINE_MODES:
            raise SettingsError(f"refine must be one of {REFINE_MODES}, got {self.refine!r}")
        if self.headline not in HEADLINES:
            raise SettingsError(f"headline must be one of {HEADLINES}, got {self.headline!r}")
        from .model.bench import MODIFICATION_KEYS, TORQUE_KEYS, BenchEffectError, is_term, is_torque, parse_effect

        for name in self.free:  # every known value can be freed (numerics.refine.FREEABLE; numba not loaded here)
            if name in MODIFICATION_KEYS and name in self.effects:
                continue  # profiled over its value (model_profile.identify_with_profiles)
            if is_torque(name) and name in self.effects:
                continue  # estimated with J/B by the refinement, from the bench file's value
            if name in TORQUE_KEYS + MODIFICATION_KEYS or is_term(name):
                raise SettingsError(f"--free {name}: the model has no {name} (free an effect of the bench file's "
                                    "[effects]: " + (", ".join(self.effects) or "it has none") + ")")
            if name not in KNOWN:
                raise SettingsError(f"--free {name}: expected known values among {', '.join(KNOWN)}, or an effect "
                                    "of the bench file's [effects]")
        from .model.structure import StructureError, parse_structure

        try:
            parse_structure(self.structure)  # its canonical form reads as a [structure] table
        except StructureError as exc:
            raise SettingsError(f"structure: {exc}") from None
        for key, value in self.effects.items():  # as a bench file's [effects] entries are checked
            try:
                parse_effect(key, value)
            except BenchEffectError as exc:
                raise SettingsError(f"effects: {exc}") from None
        torques = [k for k in self.effects if is_torque(k)]
        if torques and self.refine == "off":
            raise SettingsError(f"--refine off with the bench file's {', '.join(torques)}: only the output-error "
                                "refinement carries torque effects (DREM's regression is eq. (1)'s); drop --refine off")
        if self.free and self.refine == "off":
            raise SettingsError("--free needs the refinement (it estimates the freed values); drop --refine off")
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
