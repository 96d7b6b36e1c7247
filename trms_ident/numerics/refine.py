"""Prediction-error refinement of J1, B1, J2, B2, started from the DREM estimate (offline stage).

DREM's offline optimum (eq. 7) is consistent but not efficient: the filters weight the data
by their design, not by the noise, and angle noise reaches the regressor F s^2[x] (errors in
variables).  The prediction-error estimate minimises the angle errors themselves, which for
white angle noise is the maximum-likelihood estimate.  It is a nonlinear least-squares
problem; from DREM's estimate Gauss-Newton converges in a few steps, so DREM supplies what an
output-error fit lacks on its own: a start inside the basin.  A model that does not fit the log
leaves angle errors above the noise level; the caller (identify) then keeps DREM's estimate.

Model: paper eq. (1), both axes together (the pitch equation takes beta' from the model, not
differentiated from the log), state [alpha, alpha', beta, beta', tau1, tau2, zeta] with zeta
the lag state of M_R = kc (T0 s + 1)/(Tp s + 1) tau1.  The logged voltages are held over each
sample interval (the bench's controller holds them); classical RK4 in sub-steps of at most
MAX_SUBSTEP_S advances the state together with its sensitivities to the parameters and to
the window's start (forward sensitivity equations: one pass gives the Gauss-Newton system).

The log is cut into windows of WINDOW_S seconds.  Each window starts from its own angles and
velocities (four nuisance parameters per window, fitted with J and B and eliminated by a Schur
complement; motor states from the exact zero-order-hold reconstruction at the window's first
sample), so a model error cannot accumulate over the whole log (yaw has no restoring force)
and no differentiated start enters the fit.  The angle errors are weighted by each angle's
noise level.  Interval: batch means over BLOCK_S blocks of the scores of the parameters with
the windows' starts projected out (valid for correlated errors, e.g. quantization).
The first BURN_IN_TIME_CONSTANTS x the slowest motor or M_R lag (10 s with the table's values,
at most a quarter of the log) are left out: the motors' states when the log begins are not
known, and a wrong guess (off by only the first command's steady state) made B2's errors about
2.5 times wider than its interval over noise seeds of a 60 s log.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.special import stdtrit

from .coefficients import zoh_first_order, zoh_motor_lag_states

#: window length [s]: long against the pitch damping time J1/B1 (~11 s) is best for B1 and J1 (over 10
#: noise seeds of a 120 s multisine at 200 Hz, 1 mrad: J1 rms error 0.023 % with 10 s windows, 0.018 % with
#: 20 s, 0.012 % with 40 s or one window), and windows stop model errors piling up over a whole log
WINDOW_S = 40.0
#: RK4 sub-step: the integrator's error on noise-free logs is ~1e-10 relative at 2.5 ms (measured)
MAX_SUBSTEP_S = 2.5e-3
MAX_ITERATIONS = 8
#: Gauss-Newton stops when the next step would move every parameter by less than this fraction of its
#: value, or by less than STEP_OVER_SE of its standard error
TOLERANCE = 1e-11
STEP_OVER_SE = 1e-2
BLOCK_S = 1.0
BURN_IN_TIME_CONSTANTS = 5.0
#: intervals narrower than this fraction of the estimate get the integrator's error added
RICHARDSON_BELOW = 1e-6
NAMES = ("J1", "B1", "J2", "B2")
# the model vector handed to the compiled kernel
_P = ("J1", "B1", "J2", "B2", "a1", "b1", "a2", "b2", "Mg", "Kg", "k1", "k2", "T11", "T10", "T21", "T20", "kc",
      "T0", "Tp")
_NS = 27  # 7 states, 14 pitch sensitivities, 6 yaw sensitivities


@dataclass(frozen=True)
class Refined:
    estimate: dict  # J1, B1, J2, B2
    ci95: dict  # name -> (low, high)
    converged: bool
    iterations: int
    rms_rad: dict  # angle error RMS after refinement, per angle [rad]
    cost: float  # sum of squared noise-weighted angle errors at the estimate (2 angles x samples used)
    window_s: float
    skipped_s: float  # left out at the log's start (unknown motor states)
    windows: int
    substeps: int
    blocks: int
    integration_error: dict  # estimated parameter error of the RK4 integration (0 when not needed)


@njit(cache=True, nogil=True, inline="always")
def _thrust(tau, a, b, signed):
    return a * tau * (abs(tau) if signed else tau) + b * tau


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"})
def _rhs(x, u1, u2, p, signed, d):
    """Paper eq. (1) with the motor lags and M_R's lag state, and the forward sensitivities.

    Pitch sensitivities (x[7:14] of alpha, x[14:21] of alpha') to J1, B1, J2, B2, alpha0, alpha'0,
    beta'0; yaw sensitivities (x[21:24] of beta, x[24:27] of beta') to J2, B2, beta'0."""
    j1, b1, j2, b2 = p[0], p[1], p[2], p[3]
    m1 = _thrust(x[4], p[4], p[5], signed)
    m2 = _thrust(x[5], p[6], p[7], signed)
    mr = p[16] * (p[17] / p[18] * x[4] + (1.0 - p[17] / p[18]) * x[6])
    sa, ca = math.sin(x[0]), math.cos(x[0])
    # gravity Mg sin(alpha + delta): p[19] = delta, a centre-of-mass offset (0 in the seed model)
    sg, cg = (sa, ca) if p[19] == 0.0 else (math.sin(x[0] + p[19]), math.cos(x[0] + p[19]))
    f1 = (m1 - b1 * x[1] - p[8] * sg - p[9] * m1 * x[3] * ca) / j1
    f3 = (m2 - b2 * x[3] - mr) / j2
    d[0] = x[1]
    d[1] = f1
    d[2] = x[3]
    d[3] = f3
    d[4] = (p[10] * u1 - p[13] * x[4]) / p[12]
    d[5] = (p[11] * u2 - p[15] * x[5]) / p[14]
    d[6] = (x[4] - x[6]) / p[18]
    # yaw: d/dt S_beta' = -B2/J2 S_beta' + d f3 / d theta
    for j in range(3):
        d[21 + j] = x[24 + j]
        d[24 + j] = -b2 / j2 * x[24 + j]
    d[24] -= f3 / j2
    d[25] -= x[3] / j2
    # pitch: d/dt S_alpha' = A10 S_alpha + A11 S_alpha' + A13 S_beta' + d f1 / d theta
    a10 = (-p[8] * cg + p[9] * m1 * x[3] * sa) / j1
    a11 = -b1 / j1
    a13 = -p[9] * m1 * ca / j1
    for c in range(7):
        d[7 + c] = x[14 + c]
        d[14 + c] = a10 * x[7 + c] + a11 * x[14 + c]
    d[14 + 2] += a13 * x[24]  # J2
    d[14 + 3] += a13 * x[25]  # B2
    d[14 + 6] += a13 * x[26]  # beta'0
    d[14] -= f1 / j1
    d[15] -= x[1] / j1


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "arcp"})
def gauss_newton_pass(u1, u2, motor, y, inv_sig, starts, p, signed, dt, nsub, win, block, out):
    """One pass over the log: predictions (out), weighted cost, per-window normal equations in the
    8 unknowns (J1, B1, J2, B2, alpha0, alpha'0, beta0, beta'0) and per-block scores."""
    n = u1.size
    nw = starts.shape[0]
    nb = max(n // block, 1)
    h = dt / nsub
    a_mat = np.zeros((nw, 8, 8))
    b_vec = np.zeros((nw, 8))
    scores = np.zeros((nb, 8))
    x = np.empty(_NS)
    xt = np.empty(_NS)
    k1 = np.empty(_NS)
    k2 = np.empty(_NS)
    k3 = np.empty(_NS)
    k4 = np.empty(_NS)
    ja = np.empty(8)
    jb = np.empty(8)
    cost = 0.0
    for w in range(nw):
        s = w * win
        e = n if w == nw - 1 else s + win
        x[:] = 0.0
        x[0], x[1], x[2], x[3] = starts[w, 0], starts[w, 1], starts[w, 2], starts[w, 3]
        x[4], x[5], x[6] = motor[s, 0], motor[s, 1], motor[s, 2]
        x[7 + 4] = 1.0  # d alpha / d alpha0
        x[14 + 5] = 1.0  # d alpha' / d alpha'0
        x[24 + 2] = 1.0  # d beta' / d beta'0
        for k in range(s, e):
            out[k, 0] = x[0]
            out[k, 1] = x[2]
            ra = (y[k, 0] - x[0]) * inv_sig[0]
            rb = (y[k, 1] - x[2]) * inv_sig[1]
            cost += ra * ra + rb * rb
            for i in range(4):
                ja[i] = x[7 + i] * inv_sig[0]
            ja[4], ja[5], ja[6], ja[7] = x[11] * inv_sig[0], x[12] * inv_sig[0], 0.0, x[13] * inv_sig[0]
            jb[0], jb[1], jb[2], jb[3] = 0.0, 0.0, x[21] * inv_sig[1], x[22] * inv_sig[1]
            jb[4], jb[5], jb[6], jb[7] = 0.0, 0.0, inv_sig[1], x[23] * inv_sig[1]
            q = min(k // block, nb - 1)
            for i in range(8):
                g = ja[i] * ra + jb[i] * rb
                b_vec[w, i] += g
                scores[q, i] += g
                for j in range(i, 8):
                    a_mat[w, i, j] += ja[i] * ja[j] + jb[i] * jb[j]
            if k == e - 1:
                break
            for _ in range(nsub):
                _rhs(x, u1[k], u2[k], p, signed, k1)
                for i in range(_NS):
                    xt[i] = x[i] + 0.5 * h * k1[i]
                _rhs(xt, u1[k], u2[k], p, signed, k2)
                for i in range(_NS):
                    xt[i] = x[i] + 0.5 * h * k2[i]
                _rhs(xt, u1[k], u2[k], p, signed, k3)
                for i in range(_NS):
                    xt[i] = x[i] + h * k3[i]
                _rhs(xt, u1[k], u2[k], p, signed, k4)
                for i in range(_NS):
                    x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        for i in range(8):
            for j in range(i):
                a_mat[w, i, j] = a_mat[w, j, i]
    return cost, a_mat, b_vec, scores


@njit(cache=True, nogil=True)
def _motor_kernel(u1, u2, c, out):
    e1, e2, phi21, g1, g2, e3, g3 = c[0], c[1], c[2], c[3], c[4], c[5], c[6]
    # steady state of the first held voltages, as the filters of the DREM path start
    t1 = g1 / (1.0 - e1) * u1[0]
    out[0, 0], out[0, 1], out[0, 2] = t1, g3 / (1.0 - e3) * u2[0], t1
    for k in range(u1.size - 1):
        out[k + 1, 0] = e1 * out[k, 0] + g1 * u1[k]
        out[k + 1, 1] = e3 * out[k, 1] + g3 * u2[k]
        out[k + 1, 2] = phi21 * out[k, 0] + e2 * out[k, 2] + g2 * u1[k]


def warm_up() -> None:
    """Load the compiled kernels from numba's cache on a tiny input (commands call this in a thread)."""
    from ..params import defaults

    n = 8
    u, out = np.zeros(n), np.empty((n, 2))
    gauss_newton_pass(u, u, np.zeros((n, 3)), np.zeros((n, 2)), np.ones(2), np.zeros((1, 4)),
                      model_vector(defaults()), False, 1e-3, 1, n, n, out)
    motor_states(u, u, 1e-3, defaults())


def model_vector(params: dict, gravity_offset_rad: float = 0.0) -> np.ndarray:
    """The compiled kernel's parameter vector: the table's values in _P order, then the gravity offset."""
    return np.array([params[k] for k in _P] + [gravity_offset_rad], dtype=float)


def motor_states(u1, u2, dt, p) -> np.ndarray:
    """tau1, tau2 and zeta at the samples (n, 3), exact for held voltages (zero-order hold), paper eq. (1)."""
    e1, e2, phi21, g1, g2 = zoh_motor_lag_states(p["k1"], p["Tp"], p["T11"], p["T10"], dt)
    b3, a3 = zoh_first_order(p["k2"], p["T21"], p["T20"], dt)
    out = np.empty((u1.size, 3))
    _motor_kernel(np.ascontiguousarray(u1, dtype=float), np.ascontiguousarray(u2, dtype=float),
                  np.array([e1, e2, phi21, g1, g2, -a3[1], b3[1]]), out)
    return out


def _start_velocity(x: np.ndarray, s: int, dt: float) -> float:
    """Slope [rad/s] of a quadratic fitted to the first 50 ms (at least 5 samples) of a window."""
    m = min(max(5, int(round(0.05 / dt))), x.size - s)
    if m < 3:
        return 0.0
    return float(np.polyfit(np.arange(m) * dt, x[s:s + m], 2)[1])


def substeps(dt: float) -> int:
    """RK4 sub-steps per sample interval of dt [s], each at most MAX_SUBSTEP_S."""
    return max(1, int(math.ceil(dt / MAX_SUBSTEP_S - 1e-9)))


def _schur(a, b):
    """Eliminate each window's start: the parameters' normal matrix and right-hand side, and per window
    (L'L)^-1 [L'G, L'r], from which the starts' step and the projected scores follow."""
    s_mat, s_rhs, per_window = np.zeros((4, 4)), np.zeros(4), []
    for w in range(a.shape[0]):
        lg = a[w, 4:, :4]
        k_mat = np.linalg.lstsq(a[w, 4:, 4:], np.column_stack([lg, b[w, 4:]]), rcond=1e-13)[0]
        s_mat += a[w, :4, :4] - lg.T @ k_mat[:, :4]
        s_rhs += b[w, :4] - lg.T @ k_mat[:, 4]
        per_window.append(k_mat)
    return s_mat, s_rhs, per_window


def _covariance(s_mat, per_window, scores, win, block):
    """Batch-means covariance of the parameters: per-block scores with the windows' starts projected out."""
    nb = scores.shape[0]
    w_of_block = np.minimum(np.arange(nb) * block // win, len(per_window) - 1)
    proj = np.stack([k[:, :4] for k in per_window])[w_of_block]  # (nb, 4, 4)
    sc = scores[:, :4] - np.einsum("bij,bi->bj", proj, scores[:, 4:])
    sc = sc - sc.mean(axis=0)
    meat = nb / max(nb - 1, 1) * sc.T @ sc
    inv = np.linalg.inv(s_mat)
    return inv @ meat @ inv


def refine(u1, u2, alpha, beta, dt: float, params: dict, law: str, theta0: dict, noise_rad: dict,
           window_s: float = WINDOW_S, gravity_offset_rad: float = 0.0) -> Refined:
    """Gauss-Newton on the noise-weighted angle errors, from theta0 (DREM's estimate).

    ``gravity_offset_rad``: a centre-of-mass offset, gravity Mg sin(alpha + delta) (diagnose's
    extended model; an encoder offset is handled by the caller, shifting the logged angle)."""
    # the motors' states when the log begins are unknown (their reconstruction assumes steady state):
    # start after BURN_IN_TIME_CONSTANTS of the slowest motor or reaction lag, when that no longer matters
    slowest_s = max(params["T11"] / params["T10"], params["T21"] / params["T20"], abs(params["Tp"]))
    k0 = min(int(round(BURN_IN_TIME_CONSTANTS * slowest_s / dt)), alpha.size // 4)
    motor = motor_states(u1, u2, dt, params)[k0:]
    u1, u2, alpha, beta = u1[k0:], u2[k0:], alpha[k0:], beta[k0:]
    n = alpha.size
    block = max(int(round(BLOCK_S / dt)), 1)
    win = max(int(round(window_s / dt)) // block, 1) * block  # windows hold whole blocks
    nw = max(n // win, 1)
    nsub = substeps(dt)
    signed = law == "signed"
    y = np.ascontiguousarray(np.column_stack([alpha, beta]))
    sig = np.array([max(noise_rad.get("alpha", 0.0), 1e-12), max(noise_rad.get("beta", 0.0), 1e-12)])
    inv_sig = 1.0 / sig
    starts = np.array([[alpha[s], _start_velocity(alpha, s, dt), beta[s], _start_velocity(beta, s, dt)]
                       for s in range(0, nw * win, win)])
    theta = np.array([theta0[k] for k in NAMES], dtype=float)
    base = model_vector(params, gravity_offset_rad)
    out = np.empty((n, 2))

    def evaluate(th, st):
        pv = base.copy()
        pv[:4] = th
        return gauss_newton_pass(u1, u2, motor, y, inv_sig, st, pv, signed, dt, nsub, win, block, out)

    cost, a, b, scores = evaluate(theta, starts)
    converged, it = False, 0
    for it in range(1, MAX_ITERATIONS + 1):
        s_mat, s_rhs, per_window = _schur(a, b)
        d = np.sqrt(np.diag(s_mat))
        step = np.linalg.solve(s_mat / np.outer(d, d), s_rhs / d) / d
        step_starts = np.array([k[:, 4] - k[:, :4] @ step for k in per_window])
        se = np.sqrt(np.maximum(np.diag(_covariance(s_mat, per_window, scores, win, block)), 0.0))
        if it > 1 and np.all((np.abs(step) <= TOLERANCE * theta) | (np.abs(step) <= STEP_OVER_SE * se)):
            converged = True  # the next step would not move anything that matters: stop here, where the
            break  # normal equations (and so the interval) were evaluated
        lam, accepted = 1.0, None
        while lam >= 1e-4:  # step halving keeps every iteration downhill
            th_new = theta + lam * step
            if np.all(th_new > 0):
                res = evaluate(th_new, starts + lam * step_starts)
                if res[0] <= cost:
                    accepted = th_new, starts + lam * step_starts, res
                    break
            lam *= 0.5
        if accepted is None:  # no downhill step: at the minimum to working precision
            converged = bool(np.all(np.abs(step) <= np.maximum(1e-6 * theta, 0.1 * se)))
            evaluate(theta, starts)  # leave the predictions of the accepted parameters in ``out``
            break
        theta, starts, (cost, a, b, scores) = accepted[0], accepted[1], accepted[2]
    s_mat, s_rhs, per_window = _schur(a, b)
    cov = _covariance(s_mat, per_window, scores, win, block)
    nb = scores.shape[0]
    half = float(stdtrit(max(nb - 1, 1), 0.975)) * np.sqrt(np.maximum(np.diag(cov), 0.0))
    rms = _rms(y, out)
    integration = np.zeros(4)
    if np.any(half < RICHARDSON_BELOW * theta):
        # intervals this narrow (noise-free logs) meet the integrator's own error: estimate it from the
        # parameter shift that halving the sub-step causes (RK4: the error falls 16-fold) and add twice that
        pv = base.copy()
        pv[:4] = theta
        fine = gauss_newton_pass(u1, u2, motor, y, inv_sig, starts, pv, signed, dt, 2 * nsub, win, block,
                                 np.empty((n, 2)))
        _, rhs_fine, _ = _schur(fine[1], fine[2])
        integration = np.abs(np.linalg.solve(s_mat, rhs_fine - s_rhs)) * 16.0 / 15.0
        half = half + 2.0 * integration
    half = np.maximum(half, 10.0 * TOLERANCE * theta)  # no claim finer than the convergence test
    return Refined(dict(zip(NAMES, map(float, theta))),
                   {k: (float(theta[i] - half[i]), float(theta[i] + half[i])) for i, k in enumerate(NAMES)},
                   converged, it, rms, float(cost), win * dt, k0 * dt, nw, nsub, nb,
                   {k: float(integration[i]) for i, k in enumerate(NAMES)})


def _rms(y, pred) -> dict:
    e = y - pred
    return {"alpha": float(np.sqrt(np.mean(e[:, 0] ** 2))), "beta": float(np.sqrt(np.mean(e[:, 1] ** 2)))}
