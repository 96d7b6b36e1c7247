"""What diagnose returns: the diagnosis, its findings and the verdicts' words (run.py builds them, weigh.py
applies the rule to them, report/diagnosis.py writes them out)."""
from __future__ import annotations

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
    "unexplained": "no effect in the library improves the fit: the mismatch is physics outside the library",
}
