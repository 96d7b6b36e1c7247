"""What diagnose returns: the diagnosis, its findings and the verdicts' words (search.py builds them, weigh.py
applies the rule to them, report/diagnosis.py writes them out)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class Finding:
    effect: str
    axis: str
    parameter: dict
    fit_before: float
    fit_after: float
    evidence: str
    explanation: str
    gain: float
    t: float
    p: float
    alternatives: list = field(default_factory=list)
    shift: dict = field(default_factory=dict)


def known_value_finding(name: str, value: float, table: float, unit: str, ci95, fit_before: dict, fit_after: float,
                        evidence: str, gain: float = math.nan, alternatives=(), shift: dict | None = None) -> Finding:
    """The finding that a known value of eq. (1) is ``value``, not the ``table`` it was given (weigh.py's rule and
    compound.py's): on its axis (known_values.AXIS), its t and p against the value given from its 95 % interval
    ``ci95``, ``fit_before`` the axes' fits before (axis -> %)."""
    from ..known_values import AXIS, against_given

    lo, hi = ci95
    axis = AXIS[name]
    return Finding("known_value", axis, {"name": name, "value": value, "table": table, "unit": unit,
                                         "ci95": [lo, hi]},
                   fit_before.get(axis, math.nan), fit_after, evidence,
                   f"the bench's {name} is {value:.4g}, not the {table:.4g} it was given", gain,
                   *against_given(value, table, (lo, hi)), list(alternatives), dict(shift or {}))


@dataclass
class Diagnosis:
    mismatch: bool
    findings: list[Finding]
    nominal: dict
    augmented: dict
    fit_before: dict  # axis -> NRMSE %
    fit_after: dict
    segments: dict
    regimes: dict
    lag: dict
    tested: list[dict]
    settings: dict
    residual: dict  # axis -> (t, residual before, residual after)
    overlay: dict  # axis -> (t, measured, predicted before, predicted after)
    velocity: dict  # axis -> smoothed velocity [rad/s] used for the regressors and the regimes
    verdict: str = "consistent"  # consistent | explained | partly_explained | unexplained (VERDICTS)
    verdict_sentence: str = ""
    refused: list = field(default_factory=list)  # findings the equation error chose but the checks refused
    seed_check: dict = field(default_factory=dict)  # identify's model_check of the seed model
    corrections: list = field(default_factory=list)  # sparse.Correction per axis left above its noise level
    steps: list = field(default_factory=list)  # per finding, thinned for its figures (_finding_steps)
    oe_tested: list = field(default_factory=list)  # candidates judged by output error (oe.py), in order
    #: several known values refitted together (known_values.joint), when no single one nor the effect search
    #: explains the log (weigh.py); None when that search did not run or found no set
    known_values_joint: dict | None = None
    #: the seed model's and the findings' model's held-out simulation fits (held_out.py); None when not run
    held_out: dict | None = None
    #: J/B with 95 % intervals, identifiability and the adequacy verdict under the findings' model, estimated as
    #: `estimate --params` does under the bench file `export` writes (api.under_findings); None without findings
    with_findings: dict | None = None


VERDICTS = {
    "consistent": "the seed model already fits the log to its noise level",
    "explained": "the accepted findings bring the model's fit to the noise level",
    "partly_explained": "the accepted findings raise the fit, but not to the noise level: something else is missing",
    # the search tries one difference at a time: finding nothing does not tell physics outside the library from
    # several differences at once (measured: a2 24 % high beside a 0.29 V yaw dead zone of the library's, each
    # refit and each effect alone short of the floor, nothing found)
    "unexplained": ("no effect in the library improves the fit alone: the mismatch is physics outside the library, "
                    "or more than one difference at once (known values off their table, or an effect beside one)"),
}
