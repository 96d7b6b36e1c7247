"""Physics outside the library, as a term: a torque c x (a product of the model's signals) on one axis.

A bench whose physics is not eq. (1) plus the library's effects (model/effects.py) can still be written down:
its axis' torque lacks a term such as c * M1 * sin(alpha) (the main rotor's thrust grows with the pitch angle).
A term is written as its axis and a product of one to three factors from FACTORS, the model's own signals:

    [terms]
    "pitch: M1 * sin(alpha)" = { c = 0.31, from = "diagnose of run.csv (sha256 1f2e...)" }
    "yaw: beta' * |beta'|" = -0.004

Its parameter c carries the unit that makes c x product a torque [N m] (coefficient_unit).  Inside the tool a
term is one more torque effect of the model room, declared by its torque alone (effects.Candidate.torque): its
key is ``term(<product>):<axis>`` (term_key), and the output-error refinement carries it as an exogenous torque
computed from the measured angles, their smoothed rates and the motor states the logged voltages drive
(diagnosis.model.state_signals), held at its value or freed beside J/B.  The simulator (sim/) integrates the
same product from its own true states.  Pure: no files.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

#: factor as written -> (the state_signals entry it reads, its unit as exponents of the base units, meaning)
#: base units: torque [N m], angle [rad], time [s], voltage [V]; motor states tau1, tau2 are in the table's units
#: of eq. (1) (k1 u / T10 at the steady state: V-like, written "tau")
FACTORS: dict[str, tuple[str, dict, str]] = {
    "1": ("one", {}, "a constant"),
    "alpha": ("alpha", {"rad": 1}, "the pitch angle"),
    "beta": ("beta", {"rad": 1}, "the yaw angle"),
    "sin(alpha)": ("sin_alpha", {}, "the sine of the pitch angle"),
    "cos(alpha)": ("cos_alpha", {}, "the cosine of the pitch angle"),
    "alpha'": ("dalpha", {"rad": 1, "s": -1}, "the pitch rate"),
    "beta'": ("dbeta", {"rad": 1, "s": -1}, "the yaw rate"),
    "|alpha'|": ("abs_dalpha", {"rad": 1, "s": -1}, "the pitch rate's magnitude"),
    "|beta'|": ("abs_dbeta", {"rad": 1, "s": -1}, "the yaw rate's magnitude"),
    "sign(alpha')": ("sign_dalpha", {}, "the pitch rate's sign"),
    "sign(beta')": ("sign_dbeta", {}, "the yaw rate's sign"),
    "tau1": ("tau1", {"tau": 1}, "the main motor's state"),
    "tau2": ("tau2", {"tau": 1}, "the tail motor's state"),
    "M1": ("M1", {"N m": 1}, "the main rotor's thrust torque"),
    "M2": ("M2", {"N m": 1}, "the tail rotor's thrust torque"),
    "MR": ("MR", {"N m": 1}, "the main rotor's reaction torque on yaw"),
    "u1": ("u1", {"V": 1}, "the main motor's voltage"),
    "u2": ("u2", {"V": 1}, "the tail motor's voltage"),
}
MAX_FACTORS = 3
AXES = ("pitch", "yaw")
#: a term's parameter: its name in a bench file's entry
PARAMETER = "c"
_KEY = re.compile(r"^term\((?P<product>[^()]*(?:\([^()]*\)[^()]*)*)\):(?P<axis>\w+)$")


class TermError(ValueError):
    """A term that cannot be read: the message names it and what was expected (``reason``: the latter alone)."""

    def __init__(self, text: str, reason: str):
        super().__init__(f"{text!r}: {reason}")
        self.reason = reason


@dataclass(frozen=True)
class Term:
    axis: str  # "pitch" or "yaw": the equation of eq. (1) the torque is added to
    factors: tuple[str, ...]  # names of FACTORS, in the written order

    @property
    def product(self) -> str:
        """'M1*sin(alpha)'."""
        return "*".join(self.factors)

    @property
    def key(self) -> str:
        """The model room's key: 'term(M1*sin(alpha)):pitch'."""
        return term_key(self.product, self.axis)

    @property
    def unit(self) -> str:
        return coefficient_unit(self.factors)

    def torque(self, sig: dict) -> np.ndarray:
        """The torque per unit c [N m / unit] from the signals (diagnosis.model.state_signals; term_signals adds
        the ones a product reads)."""
        s = term_signals(sig)
        out = np.ones_like(np.asarray(sig["alpha"], dtype=float))
        for f in self.factors:
            out = out * s[FACTORS[f][0]]
        return out

    def sentence(self, value: float | None = None) -> str:
        """'the pitch torque has a term c * M1 * sin(alpha) (c = 0.31): the main rotor's thrust torque times the
        sine of the pitch angle'."""
        c = "c" if value is None else f"c = {value:.4g}" + ("" if self.unit == "1" else f" {self.unit}")
        return (f"the {self.axis} torque has a term c * {' * '.join(self.factors)} ({c}): "
                + " times ".join(FACTORS[f][2] for f in self.factors))


def term_key(product: str, axis: str) -> str:
    return f"term({product}):{axis}"


def is_term_key(key: str) -> bool:
    return isinstance(key, str) and key.startswith("term(")


def parse_product(text: str) -> tuple[str, ...]:
    """'M1 * sin(alpha)' -> ('M1', 'sin(alpha)'); raises TermError naming what was expected."""
    text = str(text).strip()
    parts = [p.strip() for p in text.split("*")]
    if not text or any(not p for p in parts):
        raise TermError(text, "expected a product of factors joined by '*', such as 'M1 * sin(alpha)'")
    unknown = [p for p in parts if p not in FACTORS]
    if unknown:
        raise TermError(text, f"unknown factor {unknown[0]!r}; expected among {', '.join(FACTORS)}")
    if len(parts) > MAX_FACTORS:
        raise TermError(text, f"{len(parts)} factors; a term is a product of at most {MAX_FACTORS}")
    return tuple(parts)


def parse_entry(name: str) -> Term:
    """A bench file's ``[terms]`` entry name, 'pitch: M1 * sin(alpha)', as a Term."""
    axis, sep, product = str(name).partition(":")
    axis = axis.strip()
    if not sep or axis not in AXES:
        raise TermError(name, "expected \"AXIS: PRODUCT\" with AXIS pitch or yaw, such as \"pitch: M1 * sin(alpha)\"")
    return Term(axis, parse_product(product))


def from_key(key: str) -> Term:
    """The model room's key 'term(M1*sin(alpha)):pitch' as a Term."""
    m = _KEY.match(key or "")
    if not m or m["axis"] not in AXES:
        raise TermError(key, "expected term(PRODUCT):pitch or term(PRODUCT):yaw")
    return Term(m["axis"], parse_product(m["product"]))


def coefficient_unit(factors: tuple[str, ...]) -> str:
    """The unit of c that makes c x the product a torque [N m]: 'N m s/rad' for alpha', '1' for M1 * sin(alpha)."""
    dims = {"N m": 1}
    for f in factors:
        for u, e in FACTORS[f][1].items():
            dims[u] = dims.get(u, 0) - e
    up = [u + (f"^{e}" if e > 1 else "") for u, e in dims.items() if e > 0]
    down = [u + (f"^{-e}" if e < -1 else "") for u, e in dims.items() if e < 0]
    return (" ".join(up) or "1") + "".join(f"/{d}" for d in down)


def term_signals(sig: dict) -> dict:
    """The signals a product reads (FACTORS' first entries), from diagnosis.model.state_signals' dict: the sign of
    a rate smoothed as the library's Coulomb friction is (tanh of the rate over the scale its noise sets)."""
    s = dict(sig)
    s.setdefault("one", np.ones_like(np.asarray(sig["alpha"], dtype=float)))
    s.setdefault("sin_alpha", np.sin(sig["alpha"]))
    s.setdefault("cos_alpha", np.cos(sig["alpha"]))
    for rate, scale in (("dalpha", "scale_alpha"), ("dbeta", "scale_beta")):
        s.setdefault("abs_" + rate, np.abs(sig[rate]))
        s.setdefault("sign_" + rate, np.tanh(sig[rate] / sig.get(scale, 1e-3)))
    return s


#: a thrust scaled by a factor: c is the change of that thrust per unit of the factor, within -100 % and +100 %
THRUST_SHARE = (-1.0, 1.0)

#: the terms diagnose's search tries beside the library's effects (model/effects.py adds them to CANDIDATES;
#: diagnosis/sparse.py's correction has them too): products of two of the model's signals for physics the library
#: has no entry for (issue #76: a thrust that depends on the pitch angle or on the yaw rate, a torque in the yaw
#: rate squared, a friction whose level depends on the pitch angle, a coupling of the two rates), each with what
#: it means and the range of c a bench may have.  The forward thrusts' own products with cos(alpha) are left out, as
#: the thrusts themselves: near alpha = 0 they are J and B scaled alike (sparse.py's yardstick).  A pitch friction
#: c sign(alpha') sin(alpha) was tried and taken out: its level changes sign with the angle (no friction does), and
#: it stood in for what it is not (a 0.0014 N m one named for a gyroscopic coupling twice the table's,
#: tests/test_sparse_correction.py; for a thrust changing with the pitch rate, outside.py --terms benches 16, 18, 19)
SEARCHED: tuple[tuple[str, str, str, tuple[float, float]], ...] = (
    ("pitch", "M1*sin(alpha)", "the main rotor's thrust changes with the pitch angle", THRUST_SHARE),
    ("pitch", "beta'*beta'", "a pitch torque in the yaw rate squared", (-math.inf, math.inf)),
    ("yaw", "M2*sin(alpha)", "the tail rotor's yaw torque changes with the pitch angle", THRUST_SHARE),
    ("yaw", "M2*beta'", "the tail rotor's thrust changes with the yaw rate", (-math.inf, math.inf)),
    ("yaw", "sign(beta')*cos(alpha)", "a friction on yaw whose level changes with the pitch angle",
     (-math.inf, math.inf)),
    ("yaw", "alpha'*beta'", "a yaw torque in the product of the two rates (a Coriolis-like coupling)",
     (-math.inf, math.inf)),
)


def meaning(key: str) -> str:
    """What a searched term means physically ('the main rotor's thrust changes with the pitch angle'); for any
    other term, its factors in words."""
    t = from_key(key)
    for axis, product, words, _ in SEARCHED:
        if (axis, product) == (t.axis, t.product):
            return words
    return " times ".join(FACTORS[f][2] for f in t.factors)


def candidate(key: str):
    """The model room's entry (effects.Candidate, declared by its torque) of a term's key: its sentence says the
    term and what it means, its bounds are SEARCHED's for a searched term (else any finite c)."""
    from .effects import Candidate

    t = from_key(key)
    bounds = next((b for axis, product, _, b in SEARCHED if (axis, product) == (t.axis, t.product)),
                  (-math.inf, math.inf))
    c = "(c = {value:.4g})" if t.unit == "1" else "(c = {value:.4g} {unit})"
    return Candidate(f"term({t.product})", t.axis, PARAMETER, t.unit, "linear",
                     sentence=f"the {t.axis} torque has a term c * {' * '.join(t.factors)} {c}: {meaning(key)}",
                     regime=_regime(t), bounds=bounds, torque=t.torque)


def _regime(t: Term) -> str:
    """What a term's shape is drawn against (effects.Candidate.regime): its own axis' rate when a factor is one,
    else the pitch angle when a factor is made of it, else the axis' voltage."""
    own = {"pitch": ("alpha'", "|alpha'|", "sign(alpha')"), "yaw": ("beta'", "|beta'|", "sign(beta')")}[t.axis]
    if set(t.factors) & set(own):
        return "velocity"
    if set(t.factors) & {"alpha", "sin(alpha)", "cos(alpha)"}:
        return "pitch_angle"
    return "input"


def searched_keys() -> tuple[str, ...]:
    return tuple(term_key(product, axis) for axis, product, _, _ in SEARCHED)
