"""What a finding's fitted term looks like: the effect as a curve over the range the log visits.

Pure numerics for the report's per-finding figures: each effect of the library (model/effects.py) drawn as the
quantity it changes (a torque [N m], the voltage the motor sees [V], an inertia [kg m^2], ...) against its
regime variable, beside what the seed model (paper eq. 1 with Table 1) assumes there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.effects import Candidate, angle_lag, with_unit
from ..model.plant import thrust_law
from .model import delayed


@dataclass(frozen=True)
class Shape:
    x_label: str
    x: np.ndarray
    y_label: str
    fitted: np.ndarray  # with the finding's value
    seed: np.ndarray  # what the seed model assumes (0 where it has no such term)
    title: str


def _span(v: np.ndarray, symmetric: bool = True) -> np.ndarray:
    """300 points over the range of v (symmetric about 0 when asked), never empty."""
    v = v[np.isfinite(v)]
    hi = float(np.max(np.abs(v))) if v.size else 1.0
    hi = hi if hi > 0 else 1.0
    lo = -hi if symmetric or not v.size else float(np.min(v))
    return np.linspace(lo, hi if symmetric or not v.size else float(np.max(v)), 300)


#: a torque effect declared by its torque alone is drawn as its mean torque in this many bins of its regime
BINS = 60


def declared_shape(c: Candidate, value: float, regime_label: str, regime: np.ndarray, torque_nm: np.ndarray
                   ) -> Shape:
    """A torque effect the model room declares by its torque alone (model/effects.py): its torque over the log
    (``torque_nm`` [N m] per sample at the finding's value) as the mean in BINS bins of its regime variable."""
    ok = np.isfinite(regime) & np.isfinite(torque_nm)
    x, t = regime[ok], torque_nm[ok]
    if x.size == 0 or float(np.ptp(x)) == 0.0:
        x, t = np.zeros(1), np.array([float(np.mean(t))]) if t.size else np.zeros(1)
    else:
        edges = np.linspace(float(x.min()), float(x.max()), BINS + 1)
        idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, BINS - 1)
        count = np.bincount(idx, minlength=BINS)
        keep = count > 0
        x = (0.5 * (edges[:-1] + edges[1:]))[keep]
        t = (np.bincount(idx, weights=t, minlength=BINS) / np.maximum(count, 1))[keep]
    return Shape(regime_label, x, "torque [N m], mean per bin of the log", t, np.zeros_like(t),
                 f"{c.effect.replace('_', ' ')} on {c.axis}: {c.parameter} = {with_unit(value, c.unit)}")


def term_shape(c: Candidate, value: float, p: dict, law: str, velocity: np.ndarray, angle: np.ndarray,
               pitch_rad: np.ndarray, u_v: np.ndarray, dt_s: float) -> Shape:
    """The finding's term over the log's range: ``velocity`` [rad/s] and ``angle`` [rad] of the finding's axis,
    ``pitch_rad`` the pitch angle, ``u_v`` the axis' voltage (u1 for effects on both axes), ``dt_s`` the step.
    (A torque effect declared by its torque alone: declared_shape.)"""
    e, ax = c.effect, c.axis
    name = {"pitch": "pitch", "yaw": "yaw", "both": "motor"}[ax]
    if e == "coulomb_friction":
        w = _span(velocity)
        return Shape(f"{name} velocity [rad/s]", w, "friction torque [N m]", -value * np.sign(w), 0 * w,
                     f"Coulomb friction: -Fc sign(omega), Fc = {value:.3g} N m")
    if e == "quadratic_drag":
        w = _span(velocity)
        return Shape(f"{name} velocity [rad/s]", w, "drag torque [N m]", -value * w * np.abs(w), 0 * w,
                     f"quadratic drag: -c omega |omega|, c = {value:.3g} N m s^2/rad^2")
    if e == "cable_stiffness":
        b = _span(angle)
        return Shape("yaw angle beta [rad]", b, "cable torque [N m]", -value * b, 0 * b,
                     f"cable: -k beta, k = {value:.3g} N m/rad")
    if e in ("com_offset", "sensor_offset"):
        a = _span(angle, symmetric=False)
        # com: gravity acts as Mg sin(a + d); encoder: the true angle is the logged a - d
        true = a + value if e == "com_offset" else a - value
        return Shape("logged pitch angle alpha [rad]", a, "gravity torque [N m]", -p["Mg"] * np.sin(true),
                     -p["Mg"] * np.sin(a), f"{e.replace('_', ' ')}: delta = {value:.3g} rad")
    if e == "thrust_asymmetry":
        k, t1, t0, qa, qb = ((p["k1"], p["T11"], p["T10"], p["a1"], p["b1"]) if ax == "pitch" else
                             (p["k2"], p["T21"], p["T20"], p["a2"], p["b2"]))
        tau = _span(k / t0 * u_v)  # the motor state's steady range
        table = thrust_law(tau, qa, qb, law)  # eq. (1) thrust law
        return Shape(f"{'main' if ax == 'pitch' else 'tail'} motor state tau", tau, "thrust torque [N m]",
                     np.where(tau < 0, (1.0 + value) * table, table), table,
                     f"thrust asymmetry: (1 + s) M(tau) for tau < 0, s = {value:+.3g}")
    if e == "yaw_inertia_pitch":
        a = _span(pitch_rad, symmetric=False)
        return Shape("pitch angle alpha [rad]", a, "yaw inertia [kg m^2]", p["J2"] - value * np.sin(a) ** 2,
                     np.full_like(a, p["J2"]), f"yaw inertia J2 - dJ sin^2(alpha), dJ = {value:.3g} kg m^2 "
                     "(J2 of the table as the level)")
    if e == "motor_second_lag":  # the motor's step response, first order (the table) and with the further lag
        t11, t10 = (p["T11"], p["T10"]) if ax == "pitch" else (p["T21"], p["T20"])
        tm = t11 / t10
        t = np.linspace(0.0, 5.0 * (tm + value), 300)
        first = 1.0 - np.exp(-t / tm)
        if not value > 0:  # no further lag: the table's first-order motor
            second = first
        elif abs(tm - value) > 1e-9:
            second = 1.0 - (tm * np.exp(-t / tm) - value * np.exp(-t / value)) / (tm - value)
        else:
            second = 1.0 - (1.0 + t / tm) * np.exp(-t / tm)
        return Shape("t after a voltage step [s]", t, "motor state / steady state", second, first,
                     f"second-order motor: a further lag of {value:.3g} s after the given {tm:.3g} s")
    if e == "sensor_lag":  # a step of the true angle as the acquisition chain logs it, and as the seed model does
        t = np.arange(0.0, 5.0 * value + 2.0 * dt_s, dt_s)
        true = np.ones_like(t)
        return Shape("t after a step of the true angle [s]", t, "logged angle / step", angle_lag(true * (t > 0), value,
                     dt_s), (t > 0).astype(float), f"acquisition lag: 1/(T s + 1), T = {1e3 * value:.3g} ms")
    if c.modify is not None:  # a voltage transform declared in the model room (model/effects.py)
        u = _span(u_v)
        return Shape(f"logged {'u1' if ax != 'yaw' else 'u2'} [V]", u, "voltage the motor sees [V]",
                     c.modify(u, value), u, f"{e.replace('_', ' ')}: {value:.3g} {c.unit}")
    if e == "input_delay":
        k = int(np.argmax(np.abs(np.diff(u_v)))) if u_v.size > 1 else 0  # the largest step in the log
        half = max(int(round(max(3 * value, 0.2) / dt_s)), 2)
        sl = slice(max(k - half, 0), min(k + half, u_v.size))
        t = np.arange(u_v.size)[sl] * dt_s
        u_d = delayed(u_v, value / dt_s)[sl]  # as the prediction model delays it
        return Shape("t [s]", t, "u1 [V]", u_d, u_v[sl], f"input delay: d = {1e3 * value:.3g} ms (around "
                     "the log's largest voltage step)")
    if e == "motor_lag":
        t11, t10 = (p["T11"], p["T10"]) if ax == "pitch" else (p["T21"], p["T20"])
        t = np.linspace(0.0, 5.0 * max(value, t11) / t10, 300)
        return Shape("t after a voltage step [s]", t, "motor state / steady state",
                     1.0 - np.exp(-t * t10 / value), 1.0 - np.exp(-t * t10 / t11),
                     f"motor lag: time constant {value:.3g} s (table {t11:.3g} s)")
    raise ValueError(f"no shape for {c.key}")


def thin(n: int, points: int = 4000) -> slice:
    """Every k-th sample so that at most about ``points`` are drawn."""
    return slice(None, None, max(1, int(math.ceil(n / points))))
