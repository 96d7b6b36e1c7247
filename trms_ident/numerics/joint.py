"""One bench, several logs: J1, B1, J2, B2 fitted by output error over all logs together (pure).

Each log keeps its own unknowns (the motor and reaction-lag start states, a second-order motor's further lag
start, each window's starting angles and rates), its own noise weights, windows and sample rate; only J/B are
shared. Gauss-Newton on the summed noise-weighted angle errors, with the unknowns eliminated level by level: per
log the windows' starts (as refine does), then that log's start states, leaving one 4 x 4 system in J/B summed
over the logs (the normal equations of the pooled cost, eq. (1) simulated exactly as numerics/refine.py does).

Each log's cost counts with a weight (Run.weight: the caller's; joint.py gives 1 / noise_inflation), so that the
output-error fit leans on each log by the information it really carries. From its optimum the pool then takes one
efficient step (_efficient_step): the logs' score equations weighted by the inverse of their variances M_log, so
that the pooled J/B is the precision-weighted mean of the logs' own estimates and its covariance
(sum over logs of S_log M_log^-1 S_log)^-1; Student's t on the total number of blocks. M_log is S_log C_log S_log
when the log's own estimate gave a covariance C_log of all four (Run.cov_jb: batch means, widened by the rounding's
spread on an encoder's grid; joint.py hands its diagonal, the variances, so the weights are per parameter), so
that a pool of one log reports that log's own interval and no pool is wider than any of its logs; else the
batch-means variance of its scores at the pooled fit (its own nuisance unknowns projected out). A fit that did
not converge keeps the sandwich S^-1 (sum of M_log) S^-1 of its last iterate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import stdtrit

from . import safe
from .refine import (JB_STEP_OVER_SE, MAX_ITERATIONS, MIN_COST_DECREASE, NAMES, NL, START_NAMES, STEP_OVER_SE,
                     TOLERANCE, WINDOW_S, angle_rms, backtrack, scaled_inverse, schur, setup)


@dataclass(frozen=True)
class Run:
    """One log of the joint fit: its samples [V, rad], median step [s], noise floor [rad], stamps and voltage
    switch delays when not uniform, and where its start states begin (a single-log fit's, or None)."""
    u1: np.ndarray
    u2: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    dt: float
    noise_rad: dict
    t_s: np.ndarray | None = None
    switch_delay_s: np.ndarray | None = None
    start_states0: dict | None = None
    weight: float = 1.0  # the log's share of the pooled cost: 1 / its noise inflation (see noise_inflation)
    cov_jb: np.ndarray | None = None  # (4, 4) the log's own J/B covariance, as its estimate reports it (or None)
    torques: dict | None = None  # the bench's terms on this log: key -> (n, 2) torque per unit c (refine's torques)


@dataclass(frozen=True)
class JointFit:
    estimate: dict  # J1, B1, J2, B2: the efficient step's from the output-error fit (see _efficient_step)
    ci95: dict  # name -> (low, high)
    cov: np.ndarray  # (4, 4) covariance of J/B
    converged: bool
    iterations: int
    cost: float  # the pooled noise-weighted squared angle error (each log's own, unweighted by its share)
    blocks: int  # independent blocks over all logs
    runs: list  # per log: {"prediction", "rms_rad", "cost", "start_states", "blocks", "weight"}
    output_error: dict  # J/B of the weighted output-error fit, where each log's prediction is simulated


def refine_joint(runs: list[Run], params: dict, law: str, theta0: dict, window_s: float = WINDOW_S,
                 max_iterations: int = MAX_ITERATIONS, effects: dict | None = None) -> JointFit:
    """Gauss-Newton over all ``runs`` at once from ``theta0`` (J/B); see the module docstring.  ``effects``: the
    bench's torque effects at their values (refine's), shared by every run (a term's torque is each run's own:
    Run.torques)."""
    setups = [setup(r.u1, r.u2, r.alpha, r.beta, r.dt, params, law, theta0, r.noise_rad, window_s, t_s=r.t_s,
                    switch_delay_s=r.switch_delay_s, start_states0=r.start_states0, effects=effects,
                    torques=r.torques)
              for r in runs]
    jb = np.array([theta0[k] for k in NAMES], dtype=float)
    motors = [su.theta[4:].copy() for su in setups]  # each log's start states (no freed values here)
    starts = [su.starts.copy() for su in setups]
    outs = [np.empty((su.n, 2)) for su in setups]
    weights = [r.weight for r in runs]
    state = [_weighted(su.prob.evaluate(np.r_[jb, m], st, out), w)
             for su, m, st, out, w in zip(setups, motors, starts, outs, weights)]
    converged, it = False, 0
    for it in range(1, max_iterations + 1):
        system = [_eliminate(a, b, su.theta.size) for (_, a, b, _), su in zip(state, setups)]
        s_mat = sum(e.s_gg for e in system)
        s_rhs = sum(e.r_gg for e in system)
        step = scaled_inverse(s_mat) @ s_rhs
        steps = [e.local_steps(step) for e in system]
        se = np.sqrt(np.maximum(np.diag(_sandwich(s_mat, system, state, setups)), 0.0))
        # the decrease the full step predicts: the shared unknowns' plus each log's own (start states, windows)
        pending = float(step @ s_rhs) + sum(e.local_gain for e in system)
        small = (np.abs(step) <= STEP_OVER_SE * se) | (np.abs(step) <= TOLERANCE * np.abs(jb))
        if it > 1 and (np.all(small) or (pending < MIN_COST_DECREASE and bool(np.all(
                small | (np.abs(step) <= JB_STEP_OVER_SE * se))))):
            converged = True
            break
        cost = sum(c for c, _, _, _ in state)
        slope = -2.0 * pending  # the cost's derivative along the full step
        lam, accepted = 1.0, None
        while lam >= 1e-4:  # backtracking keeps every iteration downhill (as refine's)
            jb_new = jb + lam * step
            trial_cost, trial = math.nan, None
            if np.all(jb_new > 0):
                trial = [(m + lam * dm, st + lam * dst) for m, st, (dm, dst) in zip(motors, starts, steps)]
                if all(np.all(np.isfinite(m)) and np.all(np.isfinite(st)) for m, st in trial):
                    trial_outs = [np.empty((su.n, 2)) for su in setups]
                    with np.errstate(all="ignore"):  # no freed values: the cost-only pass is the full pass
                        results = [_weighted(su.prob.evaluate(np.r_[jb_new, m], st, out, cost_only=True), w)
                                   for su, (m, st), out, w in zip(setups, trial, trial_outs, weights)]
                    trial_cost = float(sum(res[0] for res in results))
                    if trial_cost <= cost:
                        accepted = jb_new, trial, results, trial_outs
                        break
                    trial_cost = trial_cost if math.isfinite(trial_cost) else math.nan
            lam = backtrack(lam, cost, slope, trial_cost)
        if accepted is None:  # no downhill step: at the minimum to working precision
            converged = bool(np.all(np.abs(step) <= np.maximum(1e-6 * jb, 0.1 * se)))
            break
        jb, trial, state, outs = accepted
        motors = [m for m, _ in trial]
        starts = [st for _, st in trial]
    system = [_eliminate(a, b, su.theta.size) for (_, a, b, _), su in zip(state, setups)]
    s_mat = sum(e.s_gg for e in system)
    meats = [_meat(e, st, su) if r.cov_jb is None else e.s_gg @ r.cov_jb @ e.s_gg  # (e.s_gg carries w: w^2 S C S)
             for e, st, su, r in zip(system, state, setups, runs)]
    jb_oe = jb
    if converged:
        jb, cov = _efficient_step(jb, system, meats)
    else:
        inv = scaled_inverse(s_mat)
        cov = inv @ sum(meats) @ inv  # the sandwich
    blocks = sum(sc.shape[0] for _, _, _, sc in state)
    half = float(stdtrit(max(blocks - 1, 1), 0.975)) * np.sqrt(np.maximum(np.diag(cov), 0.0))
    per_run = [{"prediction": out, "rms_rad": angle_rms(su.y, out), "cost": float(c / w), "weight": w,
                "blocks": int(sc.shape[0]),
                "start_states": {**dict(zip(START_NAMES + su.lags, map(float, m))),
                                 "alpha_dot_0_rad_s": float(st[0, 1]),
                                 "beta_dot_0_rad_s": float(st[0, 3])}}
               for su, out, m, st, (c, _, _, sc), w in zip(setups, outs, motors, starts, state, weights)]
    return JointFit(dict(zip(NAMES, map(float, jb))),
                    {k: (float(jb[i] - half[i]), float(jb[i] + half[i])) for i, k in enumerate(NAMES)},
                    cov, converged, it, float(sum(r["cost"] for r in per_run)), blocks, per_run,
                    dict(zip(NAMES, map(float, jb_oe))))


def _weighted(res: tuple, w: float) -> tuple:
    """A log's cost, normal equations and scores with its weight in the pooled cost."""
    cost, a, b, scores = res
    return cost * w, a * w, b * w, scores * w


def noise_inflation(fit) -> float:
    """How much more a log's J/B vary than its white-noise weights say: the median over J/B of the batch-means
    variance over the Gauss-Newton (Fisher) variance, at the log's own optimum (numerics/refine.Refined).  About 1
    for white angle noise; above 1 where the errors are coloured (a 12-bit encoder on slow motion at 1 kHz).
    Pooling with weights 1 / inflation makes each log count by the information it really carries: with white-noise
    weights a quantised 1 kHz log outweighed logs that determine B1 better, and the pooled B1 interval came out
    twice the best single log's."""
    if fit is None or fit.fit is None or fit.cov_jb is None:
        return 1.0
    f = fit.fit
    e = _eliminate(f.a, f.b, f.a.shape[1] - NL)
    fisher = np.diag(scaled_inverse(e.s_gg))
    batch = np.diag(fit.cov_jb)
    ok = (fisher > 0) & np.isfinite(batch) & (batch > 0)
    return float(np.median(batch[ok] / fisher[ok])) if ok.any() else 1.0


@dataclass
class _Eliminated:
    """One log's normal equations with its own unknowns eliminated: the J/B part (s_gg, r_gg) and what recovers
    the rest from a J/B step."""
    s_gg: np.ndarray
    r_gg: np.ndarray
    k_m: np.ndarray  # (ng - 4, 5): A_mm^-1 [A_mg, r_m] for the start states (and any other unknown of the log's)
    per_window: list  # refine's per-window (L'L)^-1 [L'G, L'r]
    b: np.ndarray
    local_gain: float  # the decrease the log's own unknowns still bring with J/B held

    def local_steps(self, step_jb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The log's start-state step and its windows' start steps for a J/B step."""
        dm = self.k_m[:, 4] - self.k_m[:, :4] @ step_jb
        full = np.r_[step_jb, dm]
        ng = full.size
        return dm, np.array([k[:, ng] - k[:, :ng] @ full for k in self.per_window])


def _eliminate(a: np.ndarray, b: np.ndarray, ng: int) -> _Eliminated:
    """A log's normal equations with ``ng`` global unknowns (J/B first, then its own start states): the windows'
    starts and then its start states eliminated."""
    s_mat, s_rhs, per_window = schur(a, b, ng)  # the windows' starts out, as refine does
    a_gm, a_mm = s_mat[:4, 4:], s_mat[4:, 4:]
    k_m = safe.lstsq(a_mm, np.column_stack([s_mat[4:, :4], s_rhs[4:]]), rcond=1e-13)
    gain = float(s_rhs[4:] @ k_m[:, 4]) + sum(float(b[w, ng:] @ k[:, ng]) for w, k in enumerate(per_window))
    return _Eliminated(s_mat[:4, :4] - a_gm @ k_m[:, :4], s_rhs[:4] - a_gm @ k_m[:, 4], k_m, per_window, b, gain)


def _meat(e: _Eliminated, state: tuple, su) -> np.ndarray:
    """One log's batch-means variance of its J/B scores, its own unknowns projected out."""
    scores = state[3]
    nb = scores.shape[0]
    w_of_block = np.minimum(np.arange(nb) * su.block // su.win, len(e.per_window) - 1)
    ng = e.k_m.shape[0] + 4
    proj = np.stack([k[:, :ng] for k in e.per_window])[w_of_block]
    sc = scores[:, :ng] - np.einsum("bij,bi->bj", proj, scores[:, ng:ng + 4])  # windows' starts out
    sc = sc[:, :4] - sc[:, 4:] @ e.k_m[:, :4]  # the log's start states out
    sc = sc - sc.mean(axis=0)
    return nb / max(nb - 1, 1) * sc.T @ sc


def _sandwich(s_mat, system, state, setups) -> np.ndarray:
    """S^-1 (sum of each log's batch-means meat of its J/B scores, its own unknowns projected out) S^-1."""
    meat = sum(_meat(e, st, su) for e, st, su in zip(system, state, setups))
    inv = scaled_inverse(s_mat)
    return inv @ meat @ inv


def _efficient_step(jb: np.ndarray, system: list, meats: list) -> tuple[np.ndarray, np.ndarray]:
    """The efficient combination of the logs from the converged output-error fit at ``jb``: one Gauss-Newton step
    of the stacked score equations weighted by the inverse of their variances (efficient GMM),

        theta = jb + F^-1 sum_log S M^-1 r,    cov = F^-1,    F = sum_log S M^-1 S,

    with S, r a log's J/B normal matrix and right-hand side (its own unknowns eliminated) and M its score variance.
    Where M = S C S (the log's own covariance C), S M^-1 S = C^-1 and S^-1 r is the step to that log's own optimum,
    so theta is the precision-weighted mean of the logs' own estimates, weights C^-1, and its covariance
    (sum C^-1)^-1 is no wider than any log's own in any direction (joint.py hands a diagonal C, the log's
    variances: its batch means' correlations are too noisy to weight by, joint._own_cov). A scalar weight per log
    cannot do that when the logs' noise is coloured differently (one log's J1 is best, another's B1): with the best
    scalar weights the pooled J1 and B1 of one benchmark bench were both 1.25x the best single log's. The step is
    the estimate only if it stays positive; else the output-error fit with its sandwich covariance is kept."""
    infos, rhs = [], []
    for e, meat in zip(system, meats):
        s_m = e.s_gg @ scaled_inverse(meat)  # the weights w cancel: (w S)(w^2 M)^-1 (w S) = S M^-1 S
        infos.append(s_m @ e.s_gg)
        rhs.append(s_m @ e.r_gg)
    cov = scaled_inverse(sum(infos))
    step = cov @ sum(rhs)
    if np.all(np.isfinite(step)) and np.all(jb + step > 0):
        return jb + step, cov
    inv = scaled_inverse(sum(e.s_gg for e in system))
    return jb, inv @ sum(meats) @ inv
