"""The library of candidate effects the seed model leaves out (shared notes, model.md).

Kept apart from the simulator's own effect code (sim/effects.py): the diagnosis must find
what the simulator injected without sharing its implementation.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Candidate:
    effect: str
    axis: str  # "pitch", "yaw" or "both"
    parameter: str
    unit: str
    kind: str  # "linear": an extra regressor; "grid": fitted by search over its parameter
    grid: tuple[float, ...] = ()
    sentence: str = ""  # one-sentence explanation, formatted with {value} and {unit}
    #: the variable the effect's residual shows against: "velocity" or "angle" of its axis, "pitch_angle", or
    #: "input" (the axis' voltage)
    regime: str = "input"

    @property
    def key(self) -> str:
        return f"{self.effect}:{self.axis}"


def _geom(lo: float, hi: float, n: int) -> tuple[float, ...]:
    r = (hi / lo) ** (1 / (n - 1))
    return tuple(lo * r ** i for i in range(n))


CANDIDATES: tuple[Candidate, ...] = (
    Candidate("coulomb_friction", "pitch", "Fc", "N m", "linear",
              sentence="a constant friction torque of {value:.3g} {unit} opposes the pitch motion and flips sign "
                       "when the velocity reverses", regime="velocity"),
    Candidate("coulomb_friction", "yaw", "Fc", "N m", "linear",
              sentence="a constant friction torque of {value:.3g} {unit} opposes the yaw motion and flips sign when "
                       "the velocity reverses", regime="velocity"),
    Candidate("quadratic_drag", "pitch", "c", "N m s^2/rad^2", "linear",
              sentence="aerodynamic drag c*omega*|omega| with c = {value:.3g} {unit} brakes fast pitch motion",
              regime="velocity"),
    Candidate("quadratic_drag", "yaw", "c", "N m s^2/rad^2", "linear",
              sentence="aerodynamic drag c*omega*|omega| with c = {value:.3g} {unit} brakes fast yaw motion",
              regime="velocity"),
    Candidate("cable_stiffness", "yaw", "k", "N m/rad", "linear",
              sentence="the cable pulls the beam back towards beta = 0 with {value:.3g} {unit}", regime="angle"),
    Candidate("com_offset", "pitch", "delta", "rad", "linear",
              sentence="the centre of mass sits {value:.3g} {unit} off the beam axis, so gravity acts as "
                       "Mg sin(alpha + delta)", regime="angle"),
    Candidate("sensor_offset", "pitch", "delta", "rad", "linear",
              sentence="the pitch encoder reads {value:.3g} {unit} more than the true angle (zero offset)",
              regime="angle"),
    Candidate("thrust_asymmetry", "pitch", "s", "1", "linear",
              sentence="the main rotor turning backwards (tau1 < 0) pushes {value:+.2%} relative to the table's "
                       "thrust law (thrust asymmetry of a reversed rotor)"),
    Candidate("thrust_asymmetry", "yaw", "s", "1", "linear",
              sentence="the tail rotor turning backwards (tau2 < 0) pushes {value:+.2%} relative to the table's "
                       "thrust law (thrust asymmetry of a reversed rotor)"),
    Candidate("yaw_inertia_pitch", "yaw", "dJ", "kg m^2", "linear",
              sentence="the yaw inertia depends on the pitch angle: J2 - {value:.3g} {unit} x sin^2(alpha) (the "
                       "beam's inertia about the vertical falls as it tilts)", regime="pitch_angle"),
    Candidate("dead_zone", "pitch", "w", "V", "grid", _geom(0.02, 0.6, 16),
              sentence="main-motor voltages below {value:.3g} {unit} in magnitude move nothing (dead zone)"),
    Candidate("dead_zone", "yaw", "w", "V", "grid", _geom(0.02, 0.6, 16),
              sentence="tail-motor voltages below {value:.3g} {unit} in magnitude move nothing (dead zone)"),
    Candidate("input_saturation", "pitch", "U", "V", "grid", tuple(2.45 - 0.1 * i for i in range(16)),
              sentence="the main motor saturates at {value:.3g} {unit}, below the logged command"),
    Candidate("input_saturation", "yaw", "U", "V", "grid", tuple(2.45 - 0.1 * i for i in range(16)),
              sentence="the tail motor saturates at {value:.3g} {unit}, below the logged command"),
    Candidate("input_delay", "both", "d", "s", "grid", (),
              sentence="the motors act on the logged voltages {value:.3g} {unit} late (transport delay)"),
    Candidate("motor_lag", "pitch", "T", "s", "grid", (),
              sentence="the main motor's time constant is {value:.3g} {unit}, not the table's value"),
    Candidate("motor_lag", "yaw", "T", "s", "grid", (),
              sentence="the tail motor's time constant is {value:.3g} {unit}, not the table's value"),
)

#: sensor_offset on yaw: the yaw equation has no term in beta itself, so an encoder zero offset
#: leaves no trace in it (unless a cable is also present); it is not a candidate.
UNOBSERVABLE = {"sensor_offset:yaw": "the yaw equation contains no term in beta, so a yaw encoder offset "
                                     "changes nothing the model can see"}

BY_KEY = {c.key: c for c in CANDIDATES}
