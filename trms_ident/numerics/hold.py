"""Exact motor and reaction-lag states for voltages held over jittered sample intervals (paper eq. 1).

A logger on a busy PC stamps samples with jitter; the controller holds each voltage from its own
stamp to the next.  The motor lags tau_i = k_i/(T_i1 s + T_i0) u_i and the lag state zeta of
M_R = kc (T0 s + 1)/(Tp s + 1) tau1 are linear, so their states at any time follow in closed form
from the last stamp before it: this module evaluates them on a uniform grid (the grid DREM's
filters run on) with every switch at its real time.  Tested against a fine-step integration.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .coefficients import zoh_motor_lag_states


@njit(cache=True, nogil=True, inline="always")
def _advance(tau, zeta, u, h, k, t1, t0, tp):
    """tau, zeta after h [s] with u held: the exact transition of (tau, zeta) (coefficients.zoh_motor_lag_states)."""
    e1, e2, phi21, g1, g2 = zoh_motor_lag_states(k, tp, t1, t0, h)
    return e1 * tau + g1 * u, phi21 * tau + e2 * zeta + g2 * u


@njit(cache=True, nogil=True, inline="always")
def _advance1(tau, zeta, u, h, k, t1, t0, tp, rv):
    """_advance, or (rv: the bench's structure drives M_R's lag by the voltage itself) the motor and a lag of u."""
    if not rv:
        return _advance(tau, zeta, u, h, k, t1, t0, tp)
    e = math.exp(-h / tp)
    return _advance(tau, 0.0, u, h, k, t1, t0, 1.0)[0], e * zeta + (1.0 - e) * u


@njit(cache=True, nogil=True)
def _on_grid(t, u1, u2, grid, p, rv, out):
    k1, t11, t10, k2, t21, t20, tp = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    # steady state of the first held voltages, as the uniform path's filters start
    tau1, tau2 = k1 / t10 * u1[0], k2 / t20 * u2[0]
    zeta = u1[0] if rv else tau1
    j = 0  # stamp interval holding the current time
    now = t[0]
    for g in range(grid.size):
        while j < t.size - 1 and t[j + 1] <= grid[g]:
            tau1, zeta = _advance1(tau1, zeta, u1[j], t[j + 1] - now, k1, t11, t10, tp, rv)
            tau2, _ = _advance(tau2, 0.0, u2[j], t[j + 1] - now, k2, t21, t20, 1.0)
            now = t[j + 1]
            j += 1
        h = grid[g] - now
        if h > 0.0:
            tau1, zeta = _advance1(tau1, zeta, u1[j], h, k1, t11, t10, tp, rv)
            tau2, _ = _advance(tau2, 0.0, u2[j], h, k2, t21, t20, 1.0)
            now = grid[g]
        out[g, 0], out[g, 1], out[g, 2] = tau1, tau2, zeta


def motor_states_on_grid(t_s: np.ndarray, u1_v: np.ndarray, u2_v: np.ndarray, grid_s: np.ndarray,
                         params: dict, t2_s: np.ndarray | None = None, reaction_voltage: bool = False) -> np.ndarray:
    """(len(grid), 3): tau1, tau2, zeta at the grid times [s], u_k held over [t_k, t_k+1) (eq. 1).

    ``t2_s``: the times u2 switches at, when they differ from u1's (``t_s``).  ``reaction_voltage``: zeta is the
    lag of u1 itself (the bench's structure, model/structure.py), not of tau1."""
    p = np.array([params[k] for k in ("k1", "T11", "T10", "k2", "T21", "T20", "Tp")], dtype=float)
    grid = np.ascontiguousarray(grid_s, dtype=float)
    u1 = np.ascontiguousarray(u1_v, dtype=float)
    u2 = np.ascontiguousarray(u2_v, dtype=float)
    out = np.empty((grid.size, 3))
    _on_grid(np.ascontiguousarray(t_s, dtype=float), u1, u2, grid, p, reaction_voltage, out)
    if t2_s is not None:
        second = np.empty_like(out)
        _on_grid(np.ascontiguousarray(t2_s, dtype=float), u1, u2, grid, p, reaction_voltage, second)
        out[:, 1] = second[:, 1]
    return out


def reaction_moment(tau1: np.ndarray, zeta: np.ndarray, params: dict) -> np.ndarray:
    """M_R = kc (T0/Tp tau1 + (1 - T0/Tp) zeta) [N m], the state form of kc (T0 s + 1)/(Tp s + 1) tau1 (eq. 1); under
    a voltage-driven reaction the caller passes u1 for tau1."""
    r = params["T0"] / params["Tp"]
    return params["kc"] * (r * tau1 + (1.0 - r) * zeta)
