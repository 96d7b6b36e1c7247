"""Several logs of one bench: each log's own estimate, the pooled estimate, and whether they agree (pure).

    logs --identify (each alone)--> per-log estimates, covariances, start states
         --numerics/joint.refine_joint--> pooled J1, B1, J2, B2 over all logs (output error, eq. (1))
         --consistency test--> logs that disagree are named and left out of the pool, which is fitted again
         --model_check per log--> does the pooled model fit each log?

The consistency test: for each log and the parameters it and the others determine on their own,
d = theta_log - theta_others, theta_others the precision-weighted combination of the other logs' own estimates,
with covariance C_log + C_others; Q_log = d' (C_log + C_others)^-1 d is chi-square with as many degrees of
freedom as parameters, tested at 0.05 / (number of logs) (Bonferroni over the logs); a log differs when that test rejects
and a parameter beyond 2 standard deviations differs by at least PRACTICAL_REL (1 %). (Against the pool itself,
which contains the log, the difference's covariance C_log - C_pool is nearly singular when one log dominates:
four z-scores below 1 made a chi-square of 14.) Overall: Cochran's Q, the information-weighted spread of the
logs' estimates about their combination. With three logs or more, the log that disagrees most is left out and the rest tested again, until
they agree or two remain; two logs that disagree cannot say which of them is the odd one, and the result says so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import chdtrc, stdtrit

from .errors import IdentificationError
from .identify import MOTORS_AT_REST, Result, identify, model_kw, model_name, noise_floors, timing, under_model
from .log import Log
from .numerics.adequacy import model_check
from .numerics.joint import JointFit, Run, noise_inflation, refine_joint
from .numerics.stats import IDENTIFIABLE_REL_HALF_WIDTH
from .params import ESTIMATED, merge
from .settings import Settings

#: family-wise level of the consistency test over the logs (Bonferroni)
LEVEL = 0.05
#: a log differs only by at least this relative amount in a parameter that differs beyond 2 standard deviations:
#: noise-free logs have intervals at round-off (1e-10 of the value), where 1e-9 read as 29 standard deviations
PRACTICAL_REL = 0.01


@dataclass
class LogVerdict:
    """One log in the joint estimate: its own estimate, and how it sits against the pool."""
    name: str
    result: Result  # its estimate alone
    estimates: dict  # J/B alone (None: not determined by this log)
    ci95: dict
    cov: np.ndarray | None  # (4, 4) covariance of its J/B alone (NaN rows where not determined)
    in_pool: bool = True
    q: float | None = None  # its consistency statistic against the pool
    df: int = 0
    p: float | None = None
    z: dict = field(default_factory=dict)  # per parameter: (theta_log - theta_pool) / sd of the difference
    model_check: dict | None = None  # the pooled model on this log
    rel: dict = field(default_factory=dict)  # per parameter: theta_log / theta_others - 1

    def mask(self) -> np.ndarray:
        """The parameters this log determines alone."""
        return np.array([self.estimates[k] is not None and np.isfinite(self.cov[j, j]) and self.cov[j, j] > 0
                         for j, k in enumerate(ESTIMATED)])

    def theta(self) -> np.ndarray:
        return np.array([self.estimates[k] if self.estimates[k] is not None else np.nan for k in ESTIMATED])

    def info(self) -> np.ndarray:
        """The information (inverse covariance) of its determined parameters, zero elsewhere."""
        m = self.mask()
        out = np.zeros((4, 4))
        if m.any():
            out[np.ix_(m, m)] = np.linalg.pinv(self.cov[np.ix_(m, m)])
        return out


@dataclass
class JointResult:
    estimates: dict  # pooled J/B (None where not identifiable from the pool)
    ci95: dict
    identifiability: dict
    fit: JointFit
    logs: list  # LogVerdict, in the order given
    consistent: bool | None  # None: fewer than two logs determine a common parameter
    outliers: list  # names of the logs left out of the pool
    sentence: str
    test: dict
    params: dict
    settings: Settings
    adequate: bool | None


def identify_joint(logs: list[Log], settings: Settings | None = None, names: list[str] | None = None) -> JointResult:
    """The joint estimate of ``logs`` (one bench); ``names`` label them in sentences (default: their sources)."""
    settings = settings or Settings()
    settings.validate()
    if settings.free:
        raise IdentificationError("--free with --joint: known values are estimated per log only; run estimate on "
                                  "each log with --free, or leave --free out of the joint estimate")
    names = names or [log.source for log in logs]
    params = merge(settings.overrides, source="parameter overrides")
    verdicts = [_alone(log, name, settings) for log, name in zip(logs, names)]
    # the pooled fit and its checks see the logs as the bench file's model does (identify does so per log)
    seen = [under_model(log, params, settings.effects, kernel=True) for log in logs]
    logs, params = [v[0] for v in seen], (seen[0][1] if seen else params)
    pool = list(range(len(logs)))
    fit = _pooled(logs, verdicts, pool, params, settings)
    test = _test(verdicts, pool, fit)
    outliers = []
    while test["consistent"] is False and len(pool) > 2:
        level = test["level_per_log"]
        worst = max((i for i in pool if _differs(verdicts[i], level)),
                    key=lambda i: (verdicts[i].q or 0.0) / max(verdicts[i].df, 1))
        pool.remove(worst)
        outliers.append(verdicts[worst].name)
        verdicts[worst].in_pool = False
        fit = _pooled(logs, verdicts, pool, params, settings)
        test = _test(verdicts, pool, fit, leave_out=test)
    _test_left_out(verdicts, pool, fit)
    for i, v in enumerate(verdicts):
        v.model_check = _check_log(logs[i], fit, pool.index(i), model_name(settings)) if i in pool else None
    estimates, ci95, why = {}, {}, {}
    for j, k in enumerate(ESTIMATED):
        est, (lo, hi) = fit.estimate[k], fit.ci95[k]
        rel = (hi - lo) / 2 / est if est > 0 else math.inf
        ok = est > 0 and rel <= IDENTIFIABLE_REL_HALF_WIDTH and fit.converged
        estimates[k], ci95[k] = (est if ok else None), (lo, hi)
        why[k] = (f"95 % interval ±{100 * rel:.2g} %" if ok else
                  f"no pooled estimate: the pooled fit did not converge in {fit.iterations} Gauss-Newton iterations"
                  if not fit.converged else
                  f"not identifiable from these logs together: 95 % interval ±{100 * rel:.3g} %" if est > 0 else
                  f"estimate {est:.3g} is not positive: these logs do not determine it")
    checks = [v.model_check["adequate"] for v in verdicts if v.model_check]
    adequate = False if False in checks else (None if None in checks else True)
    sentence = _sentence(verdicts, test, outliers, fit)
    if not fit.converged:
        sentence += (f" The pooled fit did not converge ({fit.iterations} Gauss-Newton iterations): no pooled number "
                     "is an estimate.")
    misfits = [v.name for v in verdicts if v.result.model_check["adequate"] is False]
    if misfits:
        sentence += (f" The model does not fit {len(misfits)} of the {len(verdicts)} logs on their own, so their "
                     "estimates, and any disagreement between them, are those of a model that misses something "
                     "(run `trms-ident diagnose` on them): read the pool with care.")
    return JointResult(estimates, ci95, why, fit, verdicts, test["consistent"], outliers, sentence, test, params,
                       settings, adequate)


def _alone(log: Log, name: str, settings: Settings) -> LogVerdict:
    res = identify(log, settings)
    cov = np.full((4, 4), np.nan)
    if res.headline == "refined" and res.refined is not None and res.refined.cov_jb is not None:
        cov = res.refined.cov_jb.copy()
    else:  # DREM's intervals: the diagonal only (its four scalar regressions are estimated apart)
        cov = np.zeros((4, 4))
        for j, k in enumerate(ESTIMATED):
            iv = res.intervals[k]
            if iv.identifiable and math.isfinite(iv.low):
                cov[j, j] = ((iv.high - iv.low) / 2 / float(stdtrit(max(iv.blocks - 1, 1), 0.975))) ** 2
    known = [k for k in ESTIMATED if res.estimates[k] is not None]
    mask = np.array([k in known for k in ESTIMATED])
    cov[~mask, :], cov[:, ~mask] = np.nan, np.nan
    return LogVerdict(name, res, dict(res.estimates), {k: (res.intervals[k].low, res.intervals[k].high)
                                                       for k in ESTIMATED}, cov)


def _pooled(logs: list[Log], verdicts: list[LogVerdict], pool: list[int], params: dict, settings: Settings
            ) -> JointFit:
    """The pooled fit over the logs in ``pool``, started where the logs' own fits agree best: output error weighted
    by each log's noise inflation, then the efficient combination of the logs' score equations
    (numerics/joint._efficient_step)."""
    start = {}
    for j, k in enumerate(ESTIMATED):  # the precision-weighted mean of the logs that determine it, else the table
        pairs = [(verdicts[i].estimates[k], verdicts[i].cov[j, j]) for i in pool
                 if verdicts[i].estimates[k] is not None and verdicts[i].cov[j, j] > 0]
        start[k] = (sum(e / v for e, v in pairs) / sum(1 / v for _, v in pairs)) if pairs else params[k]
    runs = []
    for i in pool:
        log, res = logs[i], verdicts[i].result
        r = res.refined
        starts0 = r.start_states if (r is not None and r.converged) else MOTORS_AT_REST
        tm = timing(log, len(log))
        runs.append(Run(log.u1_v, log.u2_v, log.alpha_rad, log.beta_rad, log.sample_time_s, noise_floors(log, len(log)),
                        tm["t_s"], tm["switch_delay_s"], starts0,
                        1.0 / max(noise_inflation(r if res.headline == "refined" else None), 1e-6),
                        _own_cov(verdicts[i], res),
                        model_kw(settings, log=log, params=params,
                                 start=starts0 if r is not None and r.converged else None).get("torques")))
    effects = model_kw(settings).get("effects")
    failed = None
    # from where the logs agree, then from the table's J/B: a start among far-apart logs' estimates (the CE150's
    # recordings under eq. (1): J2 0.0018-0.07) can overflow the pooled simulation before its first step
    for theta0 in (start, {k: params[k] for k in ESTIMATED}):
        try:
            with np.errstate(all="ignore"):  # an overflow is a failed start, said below, not a warning
                return refine_joint(runs, params, settings.thrust_law, theta0, effects=effects)
        except (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError) as exc:
            failed = exc
    raise IdentificationError(f"the pooled fit of {', '.join(verdicts[i].name for i in pool)} failed from the logs' "
                              f"own estimates and from the table's J/B ({failed}): the model cannot be simulated on "
                              "these logs together; estimate them one by one")


def _own_cov(v: LogVerdict, res: Result) -> np.ndarray | None:
    """The log's own J/B variances for the pooled sandwich, as a diagonal covariance: its refined estimate's, when
    that determines all four (a DREM-only or partly determined log's scores are weighed at the pooled fit instead).
    The diagonal makes the pool the precision-weighted mean of the logs' own estimates parameter by parameter: the
    correlations between J and B a log's batch means estimate come from few blocks, and a pool weighted by them
    leaned on their noise (benchmarks/lab_files.py: the parts of one log split at its gaps covered the truth 66/80
    at 95 % with the full matrices, 73/80 with the diagonal, the whole logs 78/80; benchmarks/joint.py: the same
    figures either way)."""
    if res.headline != "refined" or v.cov is None or not np.all(np.isfinite(v.cov)):
        return None
    return np.diag(np.diag(v.cov))


def _test(verdicts: list[LogVerdict], pool: list[int], fit: JointFit, leave_out: dict | None = None) -> dict:
    """The consistency test of the logs in ``pool`` (see the module docstring): each log against the others'
    combination, and Cochran's Q over them all."""
    for i in pool:
        _against(verdicts[i], [verdicts[m] for m in pool if m != i])
    tested = [verdicts[i] for i in pool if verdicts[i].df]
    theta, _, determined = _combine([verdicts[i] for i in pool])
    q = sum(float((v.theta() - theta)[v.mask()] @ v.info()[np.ix_(v.mask(), v.mask())] @ (v.theta() - theta)[v.mask()])
            for v in (verdicts[i] for i in pool) if v.mask().any())
    df = sum(int(verdicts[i].mask().sum()) for i in pool) - int(determined.sum())
    level = LEVEL / max(len(tested), 1)
    consistent = None if len(tested) < 2 else not any(_differs(v, level) for v in tested)
    out = {"method": "each log's own estimate against the precision-weighted combination of the others' (chi-square, "
                     "covariance C_log + C_others), Bonferroni over the logs; overall Cochran's Q",
           "level": LEVEL, "level_per_log": level, "q": q, "df": df,
           "p": float(chdtrc(df, q)) if df > 0 else None, "logs_tested": len(tested), "consistent": consistent}
    if leave_out is not None:
        out["before_leaving_out"] = {k: leave_out[k] for k in ("q", "df", "p", "consistent")}
    return out


def _differs(v: LogVerdict, level: float) -> bool:
    """Significant at ``level`` and large enough to matter (PRACTICAL_REL in a parameter beyond 2 sd)."""
    return v.p is not None and v.p < level and any(abs(v.rel[k]) >= PRACTICAL_REL and abs(v.z[k]) >= 2.0
                                                      for k in v.z)


def _combine(verdicts: list[LogVerdict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The precision-weighted combination of the logs' own estimates: theta, its covariance, and which
    parameters any of them determines."""
    info = sum((v.info() for v in verdicts), np.zeros((4, 4)))
    rhs = sum((v.info() @ np.where(v.mask(), v.theta(), 0.0) for v in verdicts), np.zeros(4))
    determined = np.diag(info) > 0
    cov = np.full((4, 4), np.nan)
    theta = np.full(4, np.nan)
    if determined.any():
        sub = np.linalg.pinv(info[np.ix_(determined, determined)])
        cov[np.ix_(determined, determined)] = sub
        theta[determined] = sub @ rhs[determined]
    return theta, cov, determined


def _against(v: LogVerdict, others: list[LogVerdict]) -> None:
    """v's own estimate against the others' combination, on the parameters both determine."""
    v.z, v.q, v.df, v.p = {}, None, 0, None
    theta, cov, determined = _combine(others)
    idx = [j for j in range(4) if v.mask()[j] and determined[j]]
    if not idx:
        return
    d = v.theta()[idx] - theta[idx]
    c = v.cov[np.ix_(idx, idx)] + cov[np.ix_(idx, idx)]
    sd = np.sqrt(np.maximum(np.diag(c), 1e-300))
    v.z = {ESTIMATED[j]: float(d[n] / sd[n]) for n, j in enumerate(idx)}
    v.rel = {ESTIMATED[j]: float(v.theta()[j] / theta[j] - 1.0) for j in idx}
    v.q = float(d @ np.linalg.pinv(c) @ d)
    v.df = len(idx)
    v.p = float(chdtrc(v.df, v.q))


def _test_left_out(verdicts: list[LogVerdict], pool: list[int], fit: JointFit) -> None:
    """A log left out is compared with the combination of the logs in the pool."""
    for i, v in enumerate(verdicts):
        if i not in pool:
            _against(v, [verdicts[m] for m in pool])


def _check_log(log: Log, fit: JointFit, k: int, model: str = "eq. (1)") -> dict:
    run = fit.runs[k]
    n = len(log)
    y = np.column_stack([log.alpha_rad, log.beta_rad])
    u = np.column_stack([log.u1_v, log.u2_v])
    scope = (f"output-error simulation of {model} at the pooled J/B, this log's own start states, in 40 s windows "
             "from fitted starts")
    return model_check(y, run["prediction"], u, noise_floors(log, n), log.sample_time_s, scope)


def _sentence(verdicts: list[LogVerdict], test: dict, outliers: list, fit: JointFit) -> str:
    n = len(verdicts)
    if test["consistent"] is None:
        return (f"{n} log(s): fewer than two determine a common parameter on their own, so whether they come from "
                "one bench cannot be tested; the pooled estimate assumes they do.")
    if test["consistent"] and not outliers:
        spread = (f"Cochran's chi-square {test['q']:.3g} on {test['df']} degrees of freedom, p = {test['p']:.3g}")
        if test["p"] is not None and test["p"] < LEVEL:
            return (f"The {n} logs agree to within {100 * PRACTICAL_REL:g} %: their differences are beyond chance "
                    f"({spread}) but no log differs from the others by {100 * PRACTICAL_REL:g} % or more; one bench, "
                    "pooled.")
        return f"The {n} logs agree ({spread}): one bench, pooled."
    if not test["consistent"]:
        worst = max(verdicts, key=lambda v: (v.q or 0.0) / max(v.df, 1))
        return (f"The logs disagree (chi-square {test['q']:.3g} on {test['df']} degrees of freedom, p = "
                f"{test['p']:.3g}) and two logs cannot say which is the odd one: "
                + _difference(worst, fit) + ". The pooled estimate holds both; read it with care.")
    parts = []
    for name in outliers:
        v = next(x for x in verdicts if x.name == name)
        parts.append(_difference(v, fit))
    return ("Left out of the pool: " + "; ".join(parts) + ": a different bench, a changed rotor, or physics only "
            f"that log excites. The other {n - len(outliers)} logs agree" +
            (f" to within {100 * PRACTICAL_REL:g} % (Cochran's p = {test['p']:.3g})" if test["p"] is not None and
             test["p"] < LEVEL else f" (Cochran's p = {test['p']:.3g})") + " and are pooled.")


def _difference(v: LogVerdict, fit: JointFit) -> str:
    k = max(v.z, key=lambda name: abs(v.z[name])) if v.z else None
    if k is None:
        return f"{v.name} disagrees"
    rel = v.rel[k]
    return (f"{k} in {v.name} is {abs(100 * rel):.3g} % {'above' if rel > 0 else 'below'} the others "
            f"({v.z[k]:+.1f} standard deviations)")
