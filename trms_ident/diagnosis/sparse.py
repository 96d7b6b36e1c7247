"""Physics outside the library: a sparse, data-driven correction of an axis' residual torque.

When the named effects leave an axis above its noise level, its remaining equation error

    r = F[y] - J F[s^2 x] - B F[s x] - sum_j theta_j F[phi_j]            (eq. 3 with the accepted effects)

is explained by a few terms of a small library of candidate torques phi_k(angles, rates, motor states),
filtered alike: a SINDy-style sparse regression (Brunton, Proctor & Kutz 2016), with
``pysindy.optimizers.STLSQ`` (sequentially thresholded least squares) choosing the terms.  J, B and the
accepted effects are refitted with them and never thresholded: the library columns are first made
orthogonal to them (Frisch-Waugh-Lovell), so STLSQ's coefficients are those of the joint fit.  The library
leaves out the forward thrust: with it, the terms could rebuild the whole right-hand side of eq. (1) and
"explain" everything with J = B = 0; the forward thrust is the yardstick the other terms are measured by
(a thrust scale common to both directions is J and B scaled alike, which no log can tell apart).

Each distinct set of terms STLSQ picks over a range of thresholds is then scored like a candidate
effect: cross-fitted on even/odd blocks (select.score) and kept only when its held-out residual drops
beyond chance at the family level (select.compare, Bonferroni over the candidates and the term sets
tried).  The kept terms are said in words ("the yaw torque is short by about 40 % when the tail rotor runs
backwards (u2 < 0)") and the axis' prediction fit is shown with the correction added as a torque.  A
correction describes what the log shows; it is not a named physical effect, so it never makes the
verdict "explained".
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..numerics import safe
from .model import Regression, deflate, state_signals
from .select import FAMILY_ALPHA, compare, score

#: STLSQ thresholds tried, on columns and target scaled to unit norm (a term must carry about this share
#: of the residual to stay)
THRESHOLDS = (0.01, 0.02, 0.05, 0.1, 0.2, 0.4)
MAX_TERMS = 4
#: a term stays only if leaving it out would cost at least this share of the held-out gain (collinear terms,
#: e.g. a constant and cos(alpha) near alpha = 0, otherwise come in cancelling pairs)
PRUNE_GAIN = 0.01


@dataclass(frozen=True)
class Term:
    name: str
    axis: str
    unit: str  # of the coefficient
    torque: Callable  # (signals dict) -> torque [N m] per unit coefficient, added to the axis' right-hand side
    words: Callable  # (coefficient, context dict) -> one sentence
    #: the same torque as a bench file holds it: a term's product (model/terms.py: 'M1*beta'*cos(alpha)'), or the
    #: library effect whose parameter it is ('thrust_asymmetry:pitch'); tests/test_sparse_correction.py checks that
    #: the torques agree
    carried: str = ""


def _pct(x: float) -> str:
    """A relative size in words: whole percent, two digits below 1 % (a real CE150 sweep read "about 0 %
    stronger")."""
    return f"{abs(x):.0%}" if abs(x) >= 0.01 else f"{100 * abs(x):.2g}%"


def _thrust_words(rotor: str, sign: str, axis: str, direction: str):
    def words(c, ctx):
        return (f"the {axis} torque is {'short' if c < 0 else 'larger'} by about {_pct(c)} when the {rotor} rotor "
                f"runs {direction} ({sign})")
    return words


def _product(axis: str, product: str, meaning: str) -> Term:
    """A term the search tries (model/terms.py, SEARCHED) as one of this library's: its torque and unit from the
    bench file's grammar, its sentence the term and what it means physically."""
    from ..model.terms import parse_entry

    t = parse_entry(f"{axis}: {product}")
    return Term(t.product, axis, t.unit, t.torque,
                lambda c, ctx: f"the {axis} torque lacks a term c * {' * '.join(t.factors)} (c = {c:.3g}"
                               + ("" if t.unit == "1" else f" {t.unit}") + f"): {meaning}",
                carried=t.product)


def _products() -> tuple[Term, ...]:
    from ..model.terms import SEARCHED

    return tuple(_product(axis, product, meaning) for axis, product, meaning, _ in SEARCHED)


#: products of two of the model's signals for physics the library has no entry for: the terms the search tries
#: (model/terms.py, SEARCHED); here they may describe what the search's findings leave
PRODUCTS: tuple[Term, ...] = _products()


LIBRARY: tuple[Term, ...] = (
    Term("constant", "pitch", "N m", lambda s: np.ones_like(s["alpha"]),
         lambda c, ctx: f"a constant pitch torque of {c:+.3g} N m",
         carried='1'),
    Term("sin_alpha", "pitch", "N m", lambda s: np.sin(s["alpha"]),
         lambda c, ctx: f"the gravity moment is about {_pct(c / ctx['Mg'])} {'weaker' if c > 0 else 'stronger'} "
                        "than the table's Mg sin(alpha)",
         carried='sin(alpha)'),
    Term("cos_alpha", "pitch", "N m", lambda s: np.cos(s["alpha"]),
         lambda c, ctx: f"a pitch torque of {c:+.3g} N m x cos(alpha), as a centre-of-mass offset of "
                        f"{-c / ctx['Mg']:+.3g} rad would give",
         carried='cos(alpha)'),
    Term("rate", "pitch", "N m s/rad", lambda s: s["dalpha"],
         lambda c, ctx: f"the pitch damping is {_pct(c / ctx['B1'])} {'lower' if c > 0 else 'higher'} than B1 "
                        f"({-c:+.3g} N m s/rad)",
         carried="alpha'"),
    Term("drag", "pitch", "N m s^2/rad^2", lambda s: s["dalpha"] * np.abs(s["dalpha"]),
         lambda c, ctx: f"a pitch torque of {c:+.3g} N m s^2/rad^2 x alpha'|alpha'| (drag if negative)",
         carried="alpha'*|alpha'|"),
    Term("sign", "pitch", "N m", lambda s: np.tanh(s["dalpha"] / s["scale_alpha"]),
         lambda c, ctx: f"a torque of {abs(c):.3g} N m {'against' if c < 0 else 'along'} the pitch motion that "
                        "flips with its direction",
         carried="sign(alpha')"),
    Term("thrust_reverse", "pitch", "1", lambda s: np.where(s["tau1"] < 0, s["M1"], 0.0) * s["gyro_factor"],
         _thrust_words("main", "u1 < 0", "pitch", "backwards"),
         carried='thrust_asymmetry:pitch'),
    Term("gyroscopic", "pitch", "1", lambda s: s["M1"] * s["dbeta"] * np.cos(s["alpha"]),
         lambda c, ctx: f"the gyroscopic coupling is about {_pct(c / ctx['Kg'])} {'weaker' if c > 0 else 'stronger'}"
                        " than the table's Kg",
         carried="M1*beta'*cos(alpha)"),
    Term("constant", "yaw", "N m", lambda s: np.ones_like(s["beta"]),
         lambda c, ctx: f"a constant yaw torque of {c:+.3g} N m",
         carried='1'),
    Term("angle", "yaw", "N m/rad", lambda s: s["beta"],
         lambda c, ctx: f"a yaw torque of {c:+.3g} N m/rad x beta ({'a spring pulling back to beta = 0' if c < 0 else 'pushing away from beta = 0'})",
         carried='beta'),
    Term("pitch_angle", "yaw", "N m/rad", lambda s: s["alpha"],
         lambda c, ctx: f"a yaw torque of {c:+.3g} N m/rad x alpha (the pitch angle pushes the yaw axis)",
         carried='alpha'),
    Term("rate", "yaw", "N m s/rad", lambda s: s["dbeta"],
         lambda c, ctx: f"the yaw damping is {_pct(c / ctx['B2'])} {'lower' if c > 0 else 'higher'} than B2 "
                        f"({-c:+.3g} N m s/rad)",
         carried="beta'"),
    Term("drag", "yaw", "N m s^2/rad^2", lambda s: s["dbeta"] * np.abs(s["dbeta"]),
         lambda c, ctx: f"a yaw torque of {c:+.3g} N m s^2/rad^2 x beta'|beta'| (drag if negative)",
         carried="beta'*|beta'|"),
    Term("sign", "yaw", "N m", lambda s: np.tanh(s["dbeta"] / s["scale_beta"]),
         lambda c, ctx: f"a torque of {abs(c):.3g} N m {'against' if c < 0 else 'along'} the yaw motion that "
                        "flips with its direction",
         carried="sign(beta')"),
    Term("thrust_reverse", "yaw", "1", lambda s: np.where(s["tau2"] < 0, s["M2"], 0.0),
         _thrust_words("tail", "u2 < 0", "yaw", "backwards"),
         carried='thrust_asymmetry:yaw'),
    Term("reaction", "yaw", "1", lambda s: s["MR"],
         lambda c, ctx: f"the main rotor's reaction torque on yaw is about {_pct(c)} "
                        f"{'weaker' if c > 0 else 'stronger'} than the table's M_R",
         carried='MR'),
) + PRODUCTS


@dataclass
class Correction:
    axis: str
    terms: list[dict]  # name, coefficient, unit, sentence
    sentence: str
    held_out_gain: float  # held-out equation-error RSS reduction (fraction)
    t: float
    p: float
    fit_before: float  # prediction fit [%] without and with the correction
    fit_after: float
    estimates: dict  # J, B of the axis refitted with the terms
    torque_nm: np.ndarray  # the correction as a torque per sample [N m]
    prediction: np.ndarray  # the axis' multi-step predictions with the correction [rad]
    #: its terms fitted by output error in the findings' model (held_out.correction_fits), or None
    output_error: dict | None = None


#: the measured and reconstructed signals the library is made of (the model room's, shared with the named effects)
signals = state_signals


def fit_correction(axis: str, reg: Regression, base_score, ids: np.ndarray, sig: dict, filt, n_tests: int,
                   basis=None) -> tuple[list[Term], np.ndarray, object, object, object] | None:
    """The sparse set of library terms that best lowers the held-out residual of ``axis`` beyond chance, or
    None.  Returns (terms, coefficients, score, test, regression with the terms)."""
    from pysindy.optimizers import STLSQ

    terms = [t for t in LIBRARY if t.axis == axis]
    # eq. (3): -F[phi], as model.py, with the start-state regressors' span removed as from every other column
    cols = np.column_stack([deflate(-filt.apply(t.torque(sig)), basis) for t in terms])
    x = reg.x[axis]
    theta = base_score.theta[axis]
    r = reg.g[axis] - x @ theta
    # Frisch-Waugh-Lovell: the library's part not explained by J, B and the accepted effects
    try:
        proj = safe.lstsq(x, cols)
    except np.linalg.LinAlgError:  # a regression that overflowed: no correction to describe
        return None
    lib = cols - x @ proj
    norms = np.linalg.norm(lib, axis=0)
    usable = norms > 1e-12 * max(float(norms.max()), 1e-300)
    rn = float(np.linalg.norm(r))
    if rn == 0 or not usable.any():
        return None
    supports = []
    for thr in THRESHOLDS:
        opt = STLSQ(threshold=thr, alpha=1e-8, normalize_columns=False, max_iter=50)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "eliminated all coefficients" at a high threshold: an empty set
            opt.fit(lib[:, usable] / norms[usable], r / rn)
        coef = np.zeros(len(terms))
        coef[usable] = np.ravel(opt.coef_)
        s = tuple(int(i) for i in np.flatnonzero(coef))
        if s and len(s) <= MAX_TERMS and s not in supports:
            supports.append(s)
    if not supports:
        return None
    level = FAMILY_ALPHA / (n_tests + len(supports))

    def scored(s):
        xs = np.column_stack([x, cols[:, list(s)]])
        rs = Regression({**reg.g}, {**reg.x, axis: xs}, {})
        sc = score(rs, ids, (axis,))
        return sc, compare(base_score, sc, rs, (axis,), n_tests, alpha=level), rs

    best = None
    for s in supports:
        sc, test, rs = scored(s)
        while len(s) > 1:  # backward pruning: a term whose removal costs < PRUNE_GAIN of the held-out gain goes
            trials = [(scored(tuple(i for i in s if i != j)), j) for j in s]
            (sc2, test2, rs2), j = max(trials, key=lambda tr: tr[0][1].gain)
            if test2.gain < test.gain - PRUNE_GAIN * abs(test.gain):
                break
            s, sc, test, rs = tuple(i for i in s if i != j), sc2, test2, rs2
        if not _keeps_physics(sc.theta[axis][:2], theta[:2]):
            continue  # e.g. terms that rebuild the right-hand side itself, leaving 0 = 0 with J = B = 0
        if test.passed and (best is None or test.gain > best[3].gain):
            best = ([terms[i] for i in s], sc.theta[axis][x.shape[1]:], sc, test, rs)
    return best


#: a correction may move J or B by at most this fraction of their values with the named effects
MAX_JB_CHANGE = 0.5


def _keeps_physics(jb: np.ndarray, jb_before: np.ndarray) -> bool:
    """J and B stay positive and near their values without the correction: a correction describes a torque the
    model misses, it does not replace the model's inertia and damping."""
    if not np.all(jb > 0):
        return False
    if not np.all(jb_before > 0):  # the model without it was not physical: any physical J, B is a repair
        return True
    return bool(np.all(np.abs(jb / jb_before - 1.0) <= MAX_JB_CHANGE))


def describe(terms: list[Term], coef: np.ndarray, context: dict) -> list[dict]:
    """Each term's name, coefficient, unit, sentence, and ``key``: the bench file's entry that carries it (a term of
    model/terms.py, or a library effect: Term.carried) at the coefficient's value."""
    return [{"term": t.name, "coefficient": float(c), "unit": t.unit, "sentence": t.words(float(c), context),
             "key": carried_key(t)} for t, c in zip(terms, coef)]


def carried_key(t: Term) -> str:
    """The model room's key of the bench file's entry that carries ``t``: 'term(M1*beta'*cos(alpha)):pitch', or a
    library effect's key ('thrust_asymmetry:pitch')."""
    from ..model.terms import term_key

    return t.carried if ":" in t.carried else term_key(t.carried, t.axis)


def torque(terms: list[Term], coef: np.ndarray, sig: dict) -> np.ndarray:
    """The correction as a torque per sample [N m] (unfiltered), for the prediction fit."""
    out = np.zeros_like(sig["alpha"])
    for t, c in zip(terms, coef):
        out = out + float(c) * t.torque(sig)
    return out

