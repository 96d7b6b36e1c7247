"""Unmodelled physics the simulator can inject (never written to the log, only to the truth file).

Each effect has an axis and one physical parameter with a unit (see shared notes, model.md).
The simulator packs them into a flat float array for its compiled kernel.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Effect:
    name: str
    axes: tuple[str, ...]
    parameter: str
    unit: str
    meaning: str


EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect("coulomb_friction", ("pitch", "yaw"), "Fc", "N m", "torque -Fc*sign(omega)"),
        Effect("quadratic_drag", ("pitch", "yaw"), "c", "N m s^2/rad^2", "torque -c*omega*|omega|"),
        Effect("cable_stiffness", ("yaw",), "k", "N m/rad", "yaw restoring torque -k*beta"),
        Effect("com_offset", ("pitch",), "delta", "rad", "gravity moment Mg*sin(alpha + delta)"),
        Effect("sensor_offset", ("pitch", "yaw"), "delta", "rad", "logged angle = angle + delta"),
        Effect("dead_zone", ("pitch", "yaw"), "w", "V", "|u| < w applies no voltage, a larger u passes unchanged"),
        Effect("shifted_dead_zone", ("pitch", "yaw"), "w", "V",
               "the Dead Zone block of Simulink, Simscape, Modelica and PLECS: 0 inside [-w, w], u - w sign(u) "
               "outside"),
        Effect("input_saturation", ("pitch", "yaw"), "U", "V", "plant sees clip(u, -U, U)"),
        Effect("input_delay", ("both",), "d", "s", "plant sees u(t - d)"),
        Effect("motor_lag", ("pitch", "yaw"), "T", "s", "true motor time constant T11 or T21"),
        Effect("thrust_asymmetry", ("pitch", "yaw"), "s", "1",
               "a reversed rotor (tau < 0) gives (1 + s) times the table's thrust law"),
        Effect("motor_second_lag", ("pitch", "yaw"), "T2", "s",
               "a second-order motor: the motor's drive follows the voltage through a further lag 1/(T2 s + 1) "
               "(the cascade of two first-order lags; the CE150's motors are second order)"),
        Effect("sensor_lag", ("both",), "T", "s",
               "the acquisition chain's filter: both logged angles (which the controller reads too) follow the true "
               "ones through a first-order lag 1/(T s + 1), discretized at the sample rate (a digital filter)"),
        Effect("yaw_inertia_pitch", ("yaw",), "dJ", "kg m^2",
               "yaw inertia J2 - dJ sin^2(alpha): the beam's inertia about the vertical falls as it tilts "
               "(with its centrifugal and Coriolis terms)"),
    )
}

# Layout of the kernel's effect vector.
I_COULOMB = (0, 1)
I_DRAG = (2, 3)
I_CABLE = 4
I_COM = 5
I_SENSOR = (6, 7)
I_DEADZONE = (8, 9)
I_SAT = (10, 11)
I_DELAY = 12
I_ASYM = (13, 14)
I_YAW_INERTIA = 15
I_LAG2 = (16, 17)
I_SENSOR_LAG = 18
I_SHIFTED_DEADZONE = (19, 20)
N_EFFECT_SLOTS = 21
AXIS_INDEX = {"pitch": 0, "yaw": 1}
#: a term (physics outside the library: c x a product of the plant's signals on one axis, trms_ident/model/terms.py's
#: grammar) follows the effect slots: the count at N_EFFECT_SLOTS, then per term its axis (0 pitch, 1 yaw), c, and
#: TERM_FACTORS codes of its factors (0: none), evaluated by the kernel from its own true states (plant._factor)
TERM_FACTORS = {"1": 0, "alpha": 1, "beta": 2, "sin(alpha)": 3, "cos(alpha)": 4, "alpha'": 5, "beta'": 6, "|alpha'|": 7,
                "|beta'|": 8, "sign(alpha')": 9, "sign(beta')": 10, "tau1": 11, "tau2": 12, "M1": 13, "M2": 14,
                "MR": 15, "u1": 16, "u2": 17}
TERM_SLOTS = 5  # axis, c, three factor codes


def pack(effects: list[dict]) -> list[float]:
    """Turn ``[{"effect": name, "axis": "pitch", "value": x}, ...]`` into the kernel vector.

    ``motor_lag`` is not packed: it changes T11/T21 of the plant instead (see simulate).
    """
    vec = [0.0] * N_EFFECT_SLOTS
    vec[I_SAT[0]] = vec[I_SAT[1]] = float("inf")
    terms = [spec for spec in effects if spec.get("effect") == "term"]
    for spec in effects:
        name, value = spec["effect"], float(spec["value"])
        if name == "term":
            continue
        if name not in EFFECTS:
            raise ValueError(f"unknown effect {name!r}; expected one of {', '.join(EFFECTS)}")
        axis = spec.get("axis", EFFECTS[name].axes[0])
        if axis not in EFFECTS[name].axes:
            raise ValueError(f"effect {name} acts on {'/'.join(EFFECTS[name].axes)}, not {axis!r}")
        if name == "motor_lag":
            continue
        slot = {
            "coulomb_friction": I_COULOMB,
            "quadratic_drag": I_DRAG,
            "sensor_offset": I_SENSOR,
            "dead_zone": I_DEADZONE,
            "shifted_dead_zone": I_SHIFTED_DEADZONE,
            "input_saturation": I_SAT,
            "thrust_asymmetry": I_ASYM,
            "motor_second_lag": I_LAG2,
        }.get(name)
        if name == "motor_second_lag" and not value > 0:
            raise ValueError("motor_second_lag must be > 0 s")
        if slot is not None:
            vec[slot[AXIS_INDEX[axis]]] = value
        elif name == "cable_stiffness":
            vec[I_CABLE] = value
        elif name == "com_offset":
            vec[I_COM] = value
        elif name == "yaw_inertia_pitch":
            vec[I_YAW_INERTIA] = value
        elif name == "sensor_lag":
            if not value > 0:
                raise ValueError("sensor_lag must be > 0 s")
            vec[I_SENSOR_LAG] = value
        elif name == "input_delay":
            if value < 0:
                raise ValueError("input_delay must be >= 0 s")
            vec[I_DELAY] = value
    if terms:
        vec.append(float(len(terms)))
        for spec in terms:
            vec += _term_slots(spec)
    return vec


def _term_slots(spec: dict) -> list[float]:
    """A term {"effect": "term", "axis", "product": 'M1*sin(alpha)', "value": c} as its kernel slots."""
    from trms_ident.model.terms import TermError, parse_product

    axis = spec.get("axis")
    if axis not in AXIS_INDEX:
        raise ValueError(f"a term acts on pitch or yaw, not {axis!r}")
    try:
        factors = parse_product(spec.get("product", ""))
    except TermError as exc:
        raise ValueError(f"term: {exc}") from None
    codes = [float(TERM_FACTORS[f]) for f in factors] + [0.0] * (TERM_SLOTS - 2 - len(factors))
    return [float(AXIS_INDEX[axis]), float(spec["value"])] + codes
