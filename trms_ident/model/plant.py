"""The plant of paper eq. (1), written once: its terms, the parameter vector the kernels read, the start states.

    J1 alpha'' = M1 - B1 alpha' - Mg sin(alpha + delta) - Kg M1 beta' cos(alpha) + [effects]   (pitch)
    J2 beta''  = M2 - B2 beta' - M_R + [effects]                                             (yaw)
    M_i = a_i tau_i^2 + b_i tau_i  (or a_i tau_i |tau_i| + b_i tau_i: law "signed")
    T_i1 tau_i' = k_i u_i - T_i0 tau_i;   M_R = kc (T0 s + 1)/(Tp s + 1) tau1 = kc (T0/Tp tau1 + (1 - T0/Tp) zeta),
    Tp zeta' = tau1 - zeta

Every stage of the tool that evaluates eq. (1) takes its terms from here: the output-error simulation and its
exact sensitivities (numerics/refine.py), the DREM regressions (numerics/fused.py, and its scipy reference path
numerics/regressors.py through the terms' array forms, ``term.py_func``), the diagnosis' per-axis prediction fit
(diagnosis/predict.py).  The simulator (sim/) does not: it is the independent truth plant the tests compare with.

The terms are compiled functions inlined into the kernels that call them (numba ``inline="always"``): the
kernels run as fast as with the formulas written out in place.  numba's cache checks only the calling file's
time stamp: after editing this file, delete the ``__pycache__`` folders (or touch the callers) before timing or
testing, or a kernel compiled with the old term is loaded.

The model vector (``model_vector``) is what the compiled output-error kernel reads: the parameter table's values
in PARAM_ORDER, the centre-of-mass offset delta, then one slot per effect the kernel carries (EFFECT_SLOTS;
0 = absent), the motors' further lags (LAG_SLOTS), then the parameters of exogenous torques (effects declared
by their torque in model/effects.py, computed from the measured states by the caller).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

#: the parameter table's values in the order of the model vector (J/B first: the unknowns)
PARAM_ORDER = ("J1", "B1", "J2", "B2", "a1", "b1", "a2", "b2", "Mg", "Kg", "k1", "k2", "T11", "T10", "T21", "T20",
               "kc", "T0", "Tp")
#: the model vector's slot of the centre-of-mass offset delta [rad] in Mg sin(alpha + delta) (0 in the seed model)
GRAVITY_OFFSET_SLOT = len(PARAM_ORDER)
#: the slots after it: the effects the output-error kernel carries (0 = absent): Coulomb friction Fc [N m]
#: (smoothed sign), quadratic drag c [N m s^2/rad^2], yaw cable stiffness k [N m/rad], thrust asymmetry s of a
#: reversed rotor ((1 + s) times the thrust law for tau < 0), a yaw inertia that falls as the beam tilts,
#: J2 - dJ sin^2(alpha) [kg m^2] (with its Lagrange terms: yaw_inertia, centrifugal_pitch, coriolis_yaw), and a
#: pitch encoder's zero offset [rad] (the logged angle is the true one plus it: an output term, no torque)
EFFECT_SLOTS = {"com_offset:pitch": GRAVITY_OFFSET_SLOT, "coulomb_friction:pitch": 20, "coulomb_friction:yaw": 21,
                "quadratic_drag:pitch": 22, "quadratic_drag:yaw": 23, "cable_stiffness:yaw": 24,
                "thrust_asymmetry:pitch": 25, "thrust_asymmetry:yaw": 26, "yaw_inertia_pitch:yaw": 27,
                "sensor_offset:pitch": 28}
YAW_INERTIA_SLOT = EFFECT_SLOTS["yaw_inertia_pitch:yaw"]
SENSOR_OFFSET_SLOT = EFFECT_SLOTS["sensor_offset:pitch"]
#: then a second-order motor's further lag T2 [s] on each motor (0 = first order, eq. 1): the voltage drives
#: the motor through 1/(T2 s + 1), integrated as a state of the kernel (exact within each sample interval,
#: where a held drive is not: model/effects.second_lag).  Held at its value, never freed in the kernel (an
#: input modification's value is profiled: model_profile.py)
LAG_SLOTS = {"motor_second_lag:pitch": max(EFFECT_SLOTS.values()) + 1,
             "motor_second_lag:yaw": max(EFFECT_SLOTS.values()) + 2}
LAG1_SLOT, LAG2_SLOT = LAG_SLOTS["motor_second_lag:pitch"], LAG_SLOTS["motor_second_lag:yaw"]
#: then the bench's structure where it is not eq. (1)'s (model/structure.py; 0 = eq. 1): the gyroscopic torque
#: driven by the voltage u1 instead of the thrust M1 (1), M_R's lead-lag driven by u1 instead of tau1 (1), and the
#: end stops of each angle [rad] (low, high; active when low < high: 0, 0 is none)
STRUCTURE_SLOTS = {"structure:gyroscope_voltage": LAG2_SLOT + 1, "structure:reaction_voltage": LAG2_SLOT + 2,
                   "structure:pitch_stop_low": LAG2_SLOT + 3, "structure:pitch_stop_high": LAG2_SLOT + 4,
                   "structure:yaw_stop_low": LAG2_SLOT + 5, "structure:yaw_stop_high": LAG2_SLOT + 6}
GYRO_VOLTAGE_SLOT = STRUCTURE_SLOTS["structure:gyroscope_voltage"]
REACTION_VOLTAGE_SLOT = STRUCTURE_SLOTS["structure:reaction_voltage"]
STOP_SLOT = STRUCTURE_SLOTS["structure:pitch_stop_low"]  # pitch low, high, yaw low, high from here
#: the model vector's length without exogenous torques (their parameters follow from here on)
N_SLOTS = STOP_SLOT + 4
#: Coulomb friction's sign is smoothed as tanh(omega / FRICTION_SMOOTH_RAD_S) [rad/s] (RK4 needs a smooth right
#: side; the diagnosis' prediction model uses the same)
FRICTION_SMOOTH_RAD_S = 1e-3

_TERM = {"cache": True, "nogil": True, "inline": "always"}


@njit(**_TERM)
def thrust(tau, a, b, signed):
    """Rotor thrust moment [N m] of the motor state tau (eq. 1): a tau^2 + b tau, or a tau|tau| + b tau (signed)."""
    return a * tau * (abs(tau) if signed else tau) + b * tau


@njit(**_TERM)
def thrust_slope(tau, a, b, signed):
    """d thrust / d tau (eq. 1)."""
    return 2.0 * a * (abs(tau) if signed else tau) + b


@njit(**_TERM)
def reversed_gain(tau, s):
    """Thrust asymmetry of a reversed rotor: the thrust law's factor, 1 + s for tau < 0, else 1 (s = 0: eq. 1)."""
    return 1.0 + s if tau < 0.0 else 1.0


@njit(**_TERM)
def motor_rate(u, tau, k, t1, t0):
    """tau' of a DC motor tau = k / (T1 s + T0) u (eq. 1) at voltage u [V]."""
    return (k * u - t0 * tau) / t1


@njit(**_TERM)
def lag_rate(tau1, zeta, tp):
    """zeta' of M_R's lag state, Tp zeta' = tau1 - zeta (eq. 1)."""
    return (tau1 - zeta) / tp


@njit(**_TERM)
def reaction_moment(tau1, zeta, kc, t0, tp):
    """M_R = kc (T0 s + 1)/(Tp s + 1) tau1 [N m] (eq. 1) from tau1 and the lag state zeta."""
    return kc * (t0 / tp * tau1 + (1.0 - t0 / tp) * zeta)


@njit(**_TERM)
def pitch_torque(m1, gd, sin_g, cos_a, dbeta, mg, kg):
    """Pitch torques of eq. (1) but J1 alpha'' + B1 alpha' [N m]: M1 - Mg sin(alpha + delta) - Kg gd beta' cos alpha,
    with gd the gyroscope's drive: M1 in eq. (1), the voltage u1 where the bench's structure says so (the CE150's
    K_gyro u1 phi' cos psi: model/structure.py).  sin_g = sin(alpha + delta), cos_a = cos(alpha)."""
    return m1 - mg * sin_g - kg * gd * dbeta * cos_a


@njit(**_TERM)
def yaw_torque(m2, mr):
    """Yaw torques of eq. (1) but J2 beta'' + B2 beta' [N m]: M2 - M_R."""
    return m2 - mr


@njit(**_TERM)
def coulomb_sign(omega):
    """The smoothed sign of a rate omega [rad/s] that Coulomb friction opposes."""
    return math.tanh(omega / FRICTION_SMOOTH_RAD_S)


@njit(**_TERM)
def friction(sign, omega, fc, c):
    """Friction beyond B omega [N m]: Coulomb -Fc sign(omega) (``sign``: coulomb_sign) and drag -c omega|omega|."""
    return -fc * sign - c * omega * abs(omega)


@njit(**_TERM)
def yaw_inertia(j2, dj, sin_a):
    """The yaw inertia of a beam tilted by alpha [kg m^2]: J2 - dJ sin^2(alpha) (J2 itself in eq. 1, dJ = 0)."""
    return j2 - dj * sin_a * sin_a


@njit(**_TERM)
def centrifugal_pitch(dj, sin_a, cos_a, dbeta):
    """Pitch torque of a pitch-dependent yaw inertia [N m] (Lagrange: J'(alpha) beta'^2 / 2 = -dJ sin cos beta'^2)."""
    return -dj * sin_a * cos_a * dbeta * dbeta


@njit(**_TERM)
def coriolis_yaw(dj, sin_a, cos_a, dalpha, dbeta):
    """Yaw torque of a pitch-dependent yaw inertia [N m]: d/dt(J(alpha) beta') = J beta'' + J'(alpha) alpha' beta',
    moved to the right-hand side, +2 dJ sin cos alpha' beta'."""
    return 2.0 * dj * sin_a * cos_a * dalpha * dbeta


def thrust_law(tau: np.ndarray, a: float, b: float, law: str) -> np.ndarray:
    """``thrust`` of arrays, with the law by name ("quadratic" or "signed")."""
    return thrust.py_func(tau, a, b, law == "signed")


def model_vector(params: dict, gravity_offset_rad: float = 0.0, effects: dict | None = None,
                 exogenous: tuple[str, ...] = ()) -> np.ndarray:
    """The compiled kernel's parameter vector: the table's values in PARAM_ORDER, the gravity offset, the effects'
    slots (EFFECT_SLOTS; ``effects``: key -> value, absent ones 0), then the exogenous torques' parameters in
    the order of ``exogenous`` (the kernel reads none of these: the caller turns them into torques)."""
    pv = np.zeros(N_SLOTS + len(exogenous))
    pv[:len(PARAM_ORDER)] = [params[k] for k in PARAM_ORDER]
    pv[GRAVITY_OFFSET_SLOT] = gravity_offset_rad
    for key, v in (effects or {}).items():
        pv[slot(key, exogenous)] = v
    return pv


def slot(name: str, exogenous: tuple[str, ...] = ()) -> int:
    """Position in the model vector of a known value (PARAM_ORDER), an effect (EFFECT_SLOTS) or an exogenous
    torque's parameter (after them, in the order of ``exogenous``)."""
    if name in EFFECT_SLOTS:
        return EFFECT_SLOTS[name]
    if name in LAG_SLOTS:
        return LAG_SLOTS[name]
    if name in STRUCTURE_SLOTS:
        return STRUCTURE_SLOTS[name]
    if name in exogenous:
        return N_SLOTS + exogenous.index(name)
    if name in PARAM_ORDER:
        return PARAM_ORDER.index(name)
    raise ValueError(f"{name!r} is not in the model: expected a parameter of the table "
                     f"({', '.join(PARAM_ORDER)}), an effect ({', '.join(EFFECT_SLOTS)}) or an exogenous torque")


def steady_motor_states(u1_0: float, u2_0: float, params: dict, reaction_voltage: bool = False) -> np.ndarray:
    """tau1, tau2, zeta at the steady state of held voltages u1_0, u2_0 [V] (eq. 1; zeta follows u1 itself under a
    voltage-driven reaction): a first guess of the start states, never assumed (the refinement estimates them)."""
    t1 = params["k1"] / params["T10"] * u1_0
    return np.array([t1, params["k2"] / params["T20"] * u2_0, u1_0 if reaction_voltage else t1])
