"""Baselines the tool is compared with in benchmarks/accuracy.py (not part of the package).

* paper: the paper's literal configuration, F = 10/(s+10)^2, H = 100/(s+100)^2 as printed,
  gamma = 100 (square) or 1000 (other references), final value of the DREM trace.
* rls: recursive least squares with exponential forgetting (memory 20 s) on the unmixed
  regression (4) g = m^T q, with the paper's F (a = 10 rad/s, unit DC gain).
* oe: output-error grey-box fit, scipy.optimize.least_squares on the angle error of an
  open-loop simulation driven by the logged voltages, started from 0.5x the truth; from rest, or with
  the initial state estimated too (accuracy_seeds.py).
"""
from __future__ import annotations

import math
import time

import numpy as np
from numba import njit
from scipy.optimize import least_squares

from sim.effects import N_EFFECT_SLOTS
from sim.plant import PARAM_ORDER, open_loop
from trms_ident.identify import Settings, identify
from trms_ident.numerics.regressors import filtered_regression, plant_signals
from trms_ident.params import defaults

NAMES = ("J1", "B1", "J2", "B2")


def paper_literal(log, ref: str) -> dict:
    gamma = 100.0 if ref == "square" else 1000.0
    res = identify(log, Settings(filter_a_rad_s=10.0, filter_b_rad_s=100.0, gain_convention="paper",
                                 gamma={k: gamma for k in NAMES}, headline="drem", refine="off"))
    return dict(res.drem_final)


@njit(cache=True)
def _rls(g, m, lam, delta):
    q = np.zeros(2)
    P = np.eye(2) * delta
    for k in range(g.size):
        phi = m[k]
        Pphi = P @ phi
        gain = Pphi / (lam + phi @ Pphi)
        q = q + gain * (g[k] - phi @ q)
        P = (P - np.outer(gain, Pphi)) / lam
    return q


def rls(log, memory_s: float = 20.0) -> dict:
    p = defaults()
    dt = log.sample_time_s
    ps = plant_signals(log.u1_v, log.u2_v, log.alpha_rad, log.beta_rad, dt, p, "quadratic")
    out = {}
    for y, x, names in ((ps.y_pitch_nm, log.alpha_rad, ("J1", "B1")), (ps.y_yaw_nm, log.beta_rad, ("J2", "B2"))):
        g, m = filtered_regression(y, x, dt, 10.0, 100.0)  # eq. (4) with the paper's F (unit DC gain)
        q = _rls(g, np.ascontiguousarray(m), math.exp(-dt / memory_s), 1e6)
        out.update(dict(zip(names, q)))
    return out


def output_error(log, truth: dict, decimate_to_hz: float = 50.0, initial_state: str = "rest") -> dict:
    """scipy least squares on the angle errors of an open-loop simulation (the simulator's own integrator),
    decimated to ``decimate_to_hz``, started from 0.5x the truth.  ``initial_state``: "rest" (angles from the
    first sample, everything else 0) or "estimate" (alpha'(0), beta'(0), tau1(0), tau2(0), zeta(0) fitted too,
    as greyest's InitialState='estimate': fair for logs that do not start at rest)."""
    p = defaults()
    dt = log.sample_time_s
    step = max(1, int(round(1.0 / (decimate_to_hz * dt))))
    fx = np.zeros(N_EFFECT_SLOTS)  # every slot the kernel reads (13 here had left the thrust-asymmetry and
    fx[10] = fx[11] = np.inf       # yaw-inertia slots reading past the array's end)
    meas = np.column_stack([log.alpha_rad, log.beta_rad])[::step]
    free_x0 = initial_state == "estimate"

    def residual(theta):
        pp = dict(p, J1=theta[0], B1=theta[1], J2=theta[2], B2=theta[3])
        vec = np.array([pp[k] for k in PARAM_ORDER])
        x0 = np.zeros(9)
        x0[0], x0[2] = log.alpha_rad[0], log.beta_rad[0]
        if free_x0:
            x0[1], x0[3], x0[4], x0[5], x0[6] = theta[4:9]
        sim = open_loop(dt, log.u1_v, log.u2_v, vec, 0, fx, 5e-4, x0)[::step]
        return (sim - meas).ravel()

    start = [0.5 * truth[k] for k in NAMES]
    scale, lo = list(start), [1e-6] * 4
    if free_x0:
        d0 = np.gradient(np.column_stack([log.alpha_rad, log.beta_rad])[:50], dt, axis=0)[0]
        t1 = p["k1"] / p["T10"] * log.u1_v[0]
        start += [d0[0], d0[1], t1, p["k2"] / p["T20"] * log.u2_v[0], t1]
        scale += [1.0] * 5
        lo += [-np.inf] * 5
    sol = least_squares(residual, np.array(start), x_scale=np.array(scale), bounds=(np.array(lo), np.inf),
                        max_nfev=300 if free_x0 else 200)
    return dict(zip(NAMES, sol.x[:4]))


def timed(fn, *args) -> tuple[dict, float, float]:
    """(result, wall time [s], CPU time of this process [s], all threads: the work, less sensitive than
    the wall time to what else the shared machine runs)."""
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn(*args)
    return out, time.perf_counter() - t0, time.process_time() - c0
