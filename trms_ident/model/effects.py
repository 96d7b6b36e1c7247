"""The library of candidate effects the seed model leaves out (shared notes, model.md): the model room.

Kept apart from the simulator's own effect code (sim/effects.py): the diagnosis must find
what the simulator injected without sharing its implementation.

A new torque effect is one entry here: a Candidate of kind "linear" with ``torque``, its torque per unit
parameter as a function of the measured and reconstructed signals (diagnosis.model.state_signals: angles, smoothed
rates, the motor states and thrust torques of eq. 1).  From that one function every stage derives it: the
equation-error regressor (diagnosis.model.phi, eq. 3), the output-error fit and its held-out test (the torque enters the
simulation of eq. 1 as an input computed from the measured states: numerics.refine's exogenous torques), the
prediction fit, its torque share (the practical-size floor), the report's shape of the term, and the
plausible range (``bounds``).

A new input modification on one axis is one entry too: a Candidate of kind "grid" with ``modify``, the
voltages its axis' motor sees as a function of the logged ones and the parameter, and the ``grid`` the equation
error searches; the equation error, the output-error profile over its value with its held-out test, the
prediction fit, its share of the thrust torque and its figure derive from it (the dead zone and the saturation
are written so).

The torque effects written before this interface carry hand-written code in those stages instead (compiled
into the output-error kernel with the simulated states, model.plant.EFFECT_SLOTS): faster, and exact in the
states; tests check that the two paths agree (tests/test_model_room.py).  The transport delay and a motor's
time constant act on both axes or on the motor's dynamics and keep their own code in diagnosis.model.modified_inputs.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

INF = math.inf


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
    #: the parameter's plausible values, an open interval (a friction torque is positive, ...)
    bounds: tuple[float, float] = (-INF, INF)
    #: a torque effect declared by its torque alone (module docstring): signals dict -> torque [N m] per unit
    #: parameter, added to the right-hand side of its axis' eq. (1); None for the hand-written effects
    torque: Callable | None = None
    #: an input modification declared by its voltage transform: (logged voltages of its axis [V], parameter) ->
    #: the voltages its motor sees [V]; None for the others
    modify: Callable | None = None
    #: the modification's cost is piecewise constant in its value (it changes only where the value passes a
    #: logged voltage) and rugged away from it: its value is resolved only to the gap between those voltages, and
    #: the equation error's 16-point grid places it coarsely (a 0.4 V yaw dead zone measured at 0.386 V, leaving
    #: 1.9x the yaw noise level), so a finding of one takes its value from the output-error profile
    #: (oe.Fitter.profile) when the current model is one that fit carries
    step: bool = False
    #: ``modify`` takes the sample time too: (voltages [V], parameter, dt [s]) -> voltages (a filter)
    needs_dt: bool = False

    @property
    def key(self) -> str:
        return f"{self.effect}:{self.axis}"

    def plausible(self, value: float) -> bool:
        return math.isfinite(value) and self.bounds[0] < value < self.bounds[1]

    def said(self, value: float) -> str:
        """Its sentence at ``value`` (the effect's name where it has none)."""
        return self.sentence.format(value=value, unit=self.unit) if self.sentence else self.effect


#: positive parameters (a torque's size, a width, a delay)
POSITIVE = (0.0, INF)
#: a bench's plausible values of the parameters that stand in for anything when the model lacks something (issue:
#: "no finding a physicist would laugh at"): beyond them a fitted value describes no bench, it absorbs a misfit
#: - an angle offset (encoder zero, centre of mass): a few degrees; 10 deg is far beyond a mounted encoder's or a
#:   balanced beam's (measured: -0.86 rad, 49 deg, fitted on the CE150's published model, which has none)
ANGLE_OFFSET = (-math.radians(10.0), math.radians(10.0))
#: - a transport delay of the voltages: a digital loop's milliseconds to tens of milliseconds; 0.15 s is 15
#:   steps of a 100 Hz loop (benchmarks draw 0.01-0.08 s; measured: 0.28 s fitted beside a 49 deg offset)
TRANSPORT_DELAY = (0.0, 0.15)
#: - an acquisition chain's lag of the angles: an encoder has none, a filtered potentiometer tens of ms; 0.2 s
#:   is past every chain we know (benchmarks/sensor_lag.py draws 0.01-0.15 s)
ACQUISITION_LAG = (0.0, 0.2)
#: - a motor's time constant: the TRMS's are about 1 s (Table 1), the CE150's 0.25-0.3 s: 0.05-5 s; a motor's
#:   second lag below 1.5 s (measured: 6.06 s fitted on a log whose angles do not follow their inputs)
MOTOR_TIME_CONSTANT = (0.05, 5.0)
MOTOR_SECOND_LAG = (0.0, 1.5)
#: - a reversed rotor's thrust against the table's law: between none (-100 %) and twice (+100 %); real props
#:   are weaker in reverse (measured: +616 % fitted on Rotondo's published plant, which has no such term)
REVERSED_THRUST = (-1.0, 1.0)
#: - a motor's dead zone: below 1 V (40 % of the TRMS's 2.5 V range, the CE150's whole range in machine units)
DEAD_ZONE_WIDTH = (0.0, 1.0)


def _geom(lo: float, hi: float, n: int) -> tuple[float, ...]:
    r = (hi / lo) ** (1 / (n - 1))
    return tuple(lo * r ** i for i in range(n))


def _dead_zone(u: np.ndarray, w: float) -> np.ndarray:
    return np.where(np.abs(u) < w, 0.0, u)  # |u| < w applies no voltage, a larger one passes unchanged


def _shifted_dead_zone(u: np.ndarray, w: float) -> np.ndarray:
    """The dead zone of Simulink's and Simscape's Dead Zone blocks, Modelica's Blocks.Nonlinear.DeadZone and
    PLECS's, and of a motor whose static friction must be overcome: zero inside [-w, w], u - w sign(u) outside
    (the characteristic shifted by the width, continuous in u and in w)."""
    return np.sign(u) * np.maximum(np.abs(u) - w, 0.0)


def _saturation(u: np.ndarray, limit: float) -> np.ndarray:
    return np.clip(u, -limit, limit)


def second_lag(u: np.ndarray, t2_s: float, dt_s: float) -> np.ndarray:
    """The held voltages u [V] through a further first-order lag 1/(T2 s + 1), as the mean over each sample
    interval of the lag's exact response (a second-order motor: two linear lags in cascade act the same in
    either order, so the motor's first-order state following this drive is the second-order motor's).  The
    lag starts in its steady state for the first voltage, as the motors do."""
    from scipy.signal import lfilter

    if not t2_s > 0 or u.size == 0:
        return np.asarray(u, dtype=float)
    a = math.exp(-dt_s / t2_s)
    u = np.asarray(u, dtype=float)
    y = lfilter([0.0, 1.0 - a], [1.0, -a], u, zi=[u[0]])[0]  # the lag's state at each sample
    return u + (y - u) * (t2_s / dt_s) * (1.0 - a)  # its mean over the interval that follows


def angle_lag(y: np.ndarray, t_s: float, dt_s: float | np.ndarray, first=None) -> np.ndarray:
    """The angles y [rad] (n, or n x k) as an acquisition chain with a first-order lag 1/(T s + 1) logs them,
    discretized at the sample rate: y_log[k] = c y_log[k-1] + (1 - c) y[k], c = e^(-dt/T).  ``first``: the
    logged angle(s) at the first sample, the filter's state there (default y[0]: at rest on the first sample; a
    log that begins mid-run gives its own first sample).  ``dt_s``: the step [s], or the n - 1 steps of jittered
    stamps."""
    from scipy.signal import lfilter

    y = np.asarray(y, dtype=float)
    y0 = y[0] if first is None else np.asarray(first, dtype=float)
    if not t_s > 0 or y.shape[0] < 2:
        return y.copy()
    if np.ndim(dt_s) == 0:
        c = math.exp(-float(dt_s) / t_s)
        out = np.empty_like(y)
        out[0] = y0
        zi = (c * y0)[None] if y.ndim > 1 else [c * y0]
        out[1:] = lfilter([1.0 - c], [1.0, -c], y[1:], axis=0, zi=zi)[0]
        return out
    c = np.exp(-np.asarray(dt_s, dtype=float) / t_s)
    out = np.empty_like(y)
    out[0] = y0
    for k in range(1, y.shape[0]):  # jittered stamps: each step its own c
        out[k] = c[k - 1] * out[k - 1] + (1.0 - c[k - 1]) * y[k]
    return out


#: the acquisition chain's lag of the logged angles: an output modification (diagnosis.model.observed_log); the
#: equation error and the output-error fit see the angles de-lagged, the output-error score lags the simulation
SENSOR_LAG = "sensor_lag:both"


CANDIDATES: tuple[Candidate, ...] = (
    Candidate("coulomb_friction", "pitch", "Fc", "N m", "linear",
              sentence="a constant friction torque of {value:.3g} {unit} opposes the pitch motion and flips sign "
                       "when the velocity reverses", regime="velocity", bounds=POSITIVE),
    Candidate("coulomb_friction", "yaw", "Fc", "N m", "linear",
              sentence="a constant friction torque of {value:.3g} {unit} opposes the yaw motion and flips sign when "
                       "the velocity reverses", regime="velocity", bounds=POSITIVE),
    Candidate("quadratic_drag", "pitch", "c", "N m s^2/rad^2", "linear",
              sentence="aerodynamic drag c*omega*|omega| with c = {value:.3g} {unit} brakes fast pitch motion",
              regime="velocity", bounds=POSITIVE),
    Candidate("quadratic_drag", "yaw", "c", "N m s^2/rad^2", "linear",
              sentence="aerodynamic drag c*omega*|omega| with c = {value:.3g} {unit} brakes fast yaw motion",
              regime="velocity", bounds=POSITIVE),
    Candidate("cable_stiffness", "yaw", "k", "N m/rad", "linear",
              sentence="the cable pulls the beam back towards beta = 0 with {value:.3g} {unit}", regime="angle",
              bounds=POSITIVE),
    Candidate("com_offset", "pitch", "delta", "rad", "linear",
              sentence="the centre of mass sits {value:.3g} {unit} off the beam axis, so gravity acts as "
                       "Mg sin(alpha + delta)", regime="angle", bounds=ANGLE_OFFSET),
    Candidate("sensor_offset", "pitch", "delta", "rad", "linear",
              sentence="the pitch encoder reads {value:.3g} {unit} more than the true angle (zero offset)",
              regime="angle", bounds=ANGLE_OFFSET),
    Candidate("thrust_asymmetry", "pitch", "s", "1", "linear",
              sentence="the main rotor turning backwards (tau1 < 0) pushes {value:+.2%} relative to the table's "
                       "thrust law (thrust asymmetry of a reversed rotor)",
              bounds=REVERSED_THRUST),
    Candidate("thrust_asymmetry", "yaw", "s", "1", "linear",
              sentence="the tail rotor turning backwards (tau2 < 0) pushes {value:+.2%} relative to the table's "
                       "thrust law (thrust asymmetry of a reversed rotor)", bounds=REVERSED_THRUST),
    Candidate("yaw_inertia_pitch", "yaw", "dJ", "kg m^2", "linear",
              sentence="the yaw inertia depends on the pitch angle: J2 - {value:.3g} {unit} x sin^2(alpha) (the "
                       "beam's inertia about the vertical falls as it tilts)", regime="pitch_angle",
              bounds=POSITIVE),  # a tilted beam's inertia about the vertical can only fall
    Candidate("sensor_lag", "both", "T", "s", "grid", _geom(0.005, 0.25, 16),
              sentence="the logged angles lag the true ones: the acquisition chain filters both through a "
                       "first-order lag of {value:.3g} {unit}", regime="velocity", bounds=ACQUISITION_LAG),
    Candidate("dead_zone", "pitch", "w", "V", "grid", _geom(0.02, 0.6, 16),
              sentence="main-motor voltages below {value:.3g} {unit} in magnitude move nothing, larger ones pass "
                       "unchanged (a cut-off dead zone)",
              bounds=DEAD_ZONE_WIDTH, modify=_dead_zone, step=True),
    Candidate("dead_zone", "yaw", "w", "V", "grid", _geom(0.02, 0.6, 16),
              sentence="tail-motor voltages below {value:.3g} {unit} in magnitude move nothing, larger ones pass "
                       "unchanged (a cut-off dead zone)",
              bounds=DEAD_ZONE_WIDTH, modify=_dead_zone, step=True),
    # the textbook form (_shifted_dead_zone): its cost is continuous in w, so it is profiled like any declared
    # modification, not resolved to the gap between logged voltages as the cut-off form above is
    Candidate("shifted_dead_zone", "pitch", "w", "V", "grid", _geom(0.02, 0.6, 16),
              sentence="the main motor sees nothing of voltages below {value:.3g} {unit} in magnitude and "
                       "{value:.3g} {unit} less of larger ones (a dead zone as Simulink's block draws it)",
              bounds=DEAD_ZONE_WIDTH, modify=_shifted_dead_zone),
    Candidate("shifted_dead_zone", "yaw", "w", "V", "grid", _geom(0.02, 0.6, 16),
              sentence="the tail motor sees nothing of voltages below {value:.3g} {unit} in magnitude and "
                       "{value:.3g} {unit} less of larger ones (a dead zone as Simulink's block draws it)",
              bounds=DEAD_ZONE_WIDTH, modify=_shifted_dead_zone),
    Candidate("input_saturation", "pitch", "U", "V", "grid", tuple(2.45 - 0.1 * i for i in range(16)),
              sentence="the main motor saturates at {value:.3g} {unit}, below the logged command",
              modify=_saturation, step=True),
    Candidate("input_saturation", "yaw", "U", "V", "grid", tuple(2.45 - 0.1 * i for i in range(16)),
              sentence="the tail motor saturates at {value:.3g} {unit}, below the logged command",
              modify=_saturation, step=True),
    Candidate("input_delay", "both", "d", "s", "grid", (),
              sentence="the motors act on the logged voltages {value:.3g} {unit} late (transport delay)",
              bounds=TRANSPORT_DELAY),
    Candidate("motor_lag", "pitch", "T", "s", "grid", (),
              sentence="the main motor's time constant is {value:.3g} {unit}, not the table's value",
              bounds=MOTOR_TIME_CONSTANT),
    Candidate("motor_lag", "yaw", "T", "s", "grid", (),
              sentence="the tail motor's time constant is {value:.3g} {unit}, not the table's value",
              bounds=MOTOR_TIME_CONSTANT),
    Candidate("motor_second_lag", "pitch", "T2", "s", "grid", _geom(0.02, 1.0, 16),
              sentence="the main motor is second order: its drive follows the voltage through a further lag of "
                       "{value:.3g} {unit}", bounds=MOTOR_SECOND_LAG, modify=second_lag, needs_dt=True),
    Candidate("motor_second_lag", "yaw", "T2", "s", "grid", _geom(0.02, 1.0, 16),
              sentence="the tail motor is second order: its drive follows the voltage through a further lag of "
                       "{value:.3g} {unit}", bounds=MOTOR_SECOND_LAG, modify=second_lag, needs_dt=True),
)

def _searched_terms() -> tuple[Candidate, ...]:
    """The terms the search tries beside the library's effects (model/terms.py, SEARCHED): physics outside the
    library, each a product of two of the model's signals on one axis, declared by its torque alone."""
    from . import terms

    return tuple(terms.candidate(k) for k in terms.searched_keys())


CANDIDATES = CANDIDATES + _searched_terms()

#: input nonlinearities of a motor's drive: the same kind of drive runs both motors, so one found on a motor is
#: tried on the other after the rounds (it must pass the output-error test like any candidate)
SIBLING_EFFECTS = ("dead_zone", "shifted_dead_zone", "input_saturation")
#: forms of one effect: a motor has one dead zone, cut off or shifted, never both; the data choose the form
FORMS = {"dead_zone": "shifted_dead_zone", "shifted_dead_zone": "dead_zone"}


def other_form_key(c: Candidate) -> str | None:
    """The same effect on the same axis in its other form: dead_zone:pitch -> "shifted_dead_zone:pitch"."""
    return f"{FORMS[c.effect]}:{c.axis}" if c.effect in FORMS else None

#: sensor_offset on yaw: the yaw equation has no term in beta itself, so an encoder zero offset
#: leaves no trace in it (unless a cable is also present); it is not a candidate.
UNOBSERVABLE = {"sensor_offset:yaw": "the yaw equation contains no term in beta, so a yaw encoder offset "
                                     "changes nothing the model can see"}

BY_KEY = {c.key: c for c in CANDIDATES}


def with_unit(value: float, unit: str) -> str:
    """'0.002 N m'; a dimensionless parameter (unit "1") without its unit."""
    return f"{value:.4g}" + ("" if unit == "1" else f" {unit}")


def by_key(key: str) -> Candidate | None:
    """The entry of CANDIDATES with this key, read when called (BY_KEY is the library as imported); a term's key
    (model/terms.py: 'term(M1*sin(alpha)):pitch') gives its entry, declared by its torque."""
    from . import terms

    if terms.is_term_key(key):
        try:
            return _term_candidate(key)
        except terms.TermError:
            return None
    return next((c for c in CANDIDATES if c.key == key), None)


@functools.lru_cache(maxsize=256)
def _term_candidate(key: str) -> Candidate:
    from . import terms

    return terms.candidate(key)


def other_motor_key(c: Candidate) -> str:
    """The same effect on the other motor's axis: dead_zone:pitch -> "dead_zone:yaw"."""
    return f"{c.effect}:{'yaw' if c.axis == 'pitch' else 'pitch'}"


def declared_modification(key: str) -> bool:
    """Is ``key`` an input modification declared by its voltage transform (Candidate.modify)?"""
    c = by_key(key)
    return c is not None and c.modify is not None


def generic(key: str) -> bool:
    """Is ``key`` a torque effect declared by its torque alone (the module docstring's one-entry effects)?"""
    c = by_key(key)
    return c is not None and c.torque is not None
