"""Linear regressions g = m^T q of the plant (paper eqs. 1 and 3), q = [J; B] per axis.

Pitch (eq. 1):  J1 a'' + B1 a' = M1 - Mg sin a - Kg M1 b' cos a        =: y_p
Yaw   (eq. 1):  J2 b'' + B2 b' = M2 - M_R                              =: y_y
Filtering both sides with F(s) = c_F/(s + a)^2 (eq. 3) removes the unmeasured
derivatives:  F[y] = J F[s^2 x] + B F[s x]  with x the axis angle.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.plant import pitch_torque, thrust_law, yaw_torque
from .filters import discretize, second_order_lowpass


@dataclass(frozen=True)
class PlantSignals:
    """Torques reconstructed from the logged voltages and angles (all at the sample times)."""

    tau1: np.ndarray  # main rotor motor state [-]
    tau2: np.ndarray  # tail rotor motor state [-]
    M1_nm: np.ndarray  # main rotor thrust moment [N m]
    M2_nm: np.ndarray  # tail rotor thrust moment [N m]
    MR_nm: np.ndarray  # reaction moment of the main rotor on yaw [N m]
    dbeta_rad_s: np.ndarray  # causal estimate of beta' [rad/s]
    y_pitch_nm: np.ndarray  # right-hand side of the pitch equation [N m]
    y_yaw_nm: np.ndarray  # right-hand side of the yaw equation [N m]


def plant_signals(u1_v, u2_v, alpha_rad, beta_rad, dt_s: float, p: dict, law: str,
                  gravity_offset_rad: float = 0.0, structure: dict | None = None) -> PlantSignals:
    """Motor states, moments and the right-hand sides y_p, y_y of eq. (1).

    The motor voltages are held by the bench's controller between samples, so the
    motor lags and the reaction moment are discretized with zero-order hold and are
    exact.  beta' inside the gyroscopic term is not measured: it is the central
    difference (beta[k+1] - beta[k-1]) / (2 dt), second order accurate, so the pitch
    regression at t_k is available at t_k+1 (one sample of latency).  A causal
    derivative filter w^2 s/(s+w)^2 was measured to bias B1 by -0.2 % at 1 kHz and -2 %
    at 100 Hz through its lag; the central difference left < 0.05 % at 100 Hz.  ``structure``: the bench's
    (model/structure.py): the gyroscope and M_R driven by the voltage u1 where it says so.
    """
    from ..model.structure import gyroscope_voltage, of_bench, reaction_voltage

    structure = structure if structure is not None else of_bench(p)  # diagnose's bench holds it (model.structure)
    # eq. (1): tau_i = k_i / (T_i1 s + T_i0) u_i
    tau1 = discretize([p["k1"]], [p["T11"], p["T10"]], dt_s, "zoh").apply(u1_v)
    tau2 = discretize([p["k2"]], [p["T21"], p["T20"]], dt_s, "zoh").apply(u2_v)
    # eq. (1): M_R = kc (T0 s + 1)/(Tp s + 1) tau1, realised from u1 in one ZOH step
    mr = discretize(p["kc"] * p["k1"] * np.array([p["T0"], 1.0]),
                    np.polymul([p["Tp"], 1.0], [p["T11"], p["T10"]]), dt_s, "zoh").apply(u1_v)
    if reaction_voltage(structure):  # M_R = kc (T0 s + 1)/(Tp s + 1) u1, the lead-lag on the held voltage itself
        mr = discretize(p["kc"] * np.array([p["T0"], 1.0]), [p["Tp"], 1.0], dt_s, "zoh").apply(u1_v)
    dbeta = np.gradient(beta_rad, dt_s, edge_order=2) if beta_rad.size > 2 else np.zeros_like(beta_rad)
    m1 = thrust_law(tau1, p["a1"], p["b1"], law)
    m2 = thrust_law(tau2, p["a2"], p["b2"], law)
    # gravity_offset_rad: a centre-of-mass offset, Mg sin(alpha + delta) (diagnose's extended model)
    gd = np.asarray(u1_v, dtype=float) if gyroscope_voltage(structure) else m1
    y_p = pitch_torque.py_func(m1, gd, np.sin(alpha_rad + gravity_offset_rad), np.cos(alpha_rad), dbeta, p["Mg"],
                               p["Kg"])
    y_y = yaw_torque.py_func(m2, mr)
    return PlantSignals(tau1, tau2, m1, m2, mr, dbeta, y_p, y_y)


def filtered_regression(y: np.ndarray, x_rad: np.ndarray, dt_s: float, a_rad_s: float,
                        gain: float) -> tuple[np.ndarray, np.ndarray]:
    """eq. (3): g = F[y], m = [F s^2 x, F s x] with F = gain/(s + a)^2, bilinear."""
    num, den = second_order_lowpass(a_rad_s, gain)
    g = discretize(num, den, dt_s, "bilinear").apply(y)
    m = np.empty((x_rad.size, 2))
    m[:, 0] = discretize(np.array([gain, 0.0, 0.0]), den, dt_s, "bilinear").apply(x_rad)
    m[:, 1] = discretize(np.array([gain, 0.0]), den, dt_s, "bilinear").apply(x_rad)
    return g, m
