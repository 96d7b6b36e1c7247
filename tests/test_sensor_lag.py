"""The acquisition chain's lag of the logged angles (issue #32, item 3): the simulator's filter, the diagnosis'
own (effects.angle_lag) and its inverse (model.observed_log), the output-error fit scored through the lag, and
diagnose telling the lag apart from an input delay."""
import math

import numpy as np
import pytest

from sim import SimSettings, simulate
from trms_ident.diagnosis import held_out, oe
from trms_ident.diagnosis.model import Model, observed_log
from trms_ident.diagnosis.run import diagnose
from trms_ident.model.effects import SENSOR_LAG, angle_lag
from trms_ident.params import defaults

from .conftest import as_log

Q12 = 2 * math.pi / 4096
JB = ("J1", "B1", "J2", "B2")


def _lagged(lag, ref="multisine", rate=200.0, seed=12, q=Q12, duration=60.0, effect="sensor_lag"):
    return simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=duration, seed=seed, quantization_rad=q,
                                effects=[{"effect": effect, "axis": "both", "value": lag}]))


def test_the_diagnosis_lag_is_the_simulators_filter_and_observed_log_inverts_it():
    r = _lagged(0.05, q=0.0, duration=20.0)
    true = r.true_state[:, [0, 2]]
    logged = np.column_stack([r.alpha_rad, r.beta_rad])
    np.testing.assert_allclose(angle_lag(true, 0.05, 1 / 200.0), logged, rtol=0, atol=1e-13)
    # mid-run: the filter's state at the first sample is the first logged angle
    np.testing.assert_allclose(angle_lag(true[500:], 0.05, 1 / 200.0, first=logged[500]), logged[500:], atol=1e-13)
    back = observed_log(as_log(r), 0.05)
    inner = slice(200, -200)  # the zero-phase smoothing's ends
    err = np.column_stack([back.alpha_rad, back.beta_rad])[inner] - true[inner]
    lagerr = logged[inner] - true[inner]
    assert np.max(np.abs(err)) < 0.01 * np.max(np.abs(lagerr))  # the lag's error, inverted to 1 %


def test_the_output_error_fit_through_the_lag_reaches_the_floor_with_the_true_values():
    r = _lagged(0.1, ref="steps", rate=100.0, seed=14)
    log = as_log(r)
    truth = {k: r.truth["estimated"][k] for k in JB}
    f = oe.Fitter(log, defaults(), "quadratic")
    seed_model = f._fit(Model(), {}, truth, None)
    lag = f._fit(Model().with_mod(SENSOR_LAG, 0.1), {SENSOR_LAG: 0.1}, truth, None)
    for a in ("alpha", "beta"):  # scored against the logged angles, at the log's floors
        assert lag.rms_rad[a] <= 1.1 * f.noise[a] < seed_model.rms_rad[a] / 10
    for k in JB:
        assert lag.estimate[k] == pytest.approx(truth[k], rel=2e-3)


@pytest.mark.parametrize("effect, value, ref, rate, seed", [("sensor_lag", 0.05, "square", 500.0, 13),
                                                            ("input_delay", 0.03, "multisine", 200.0, 15)])
def test_diagnose_tells_an_acquisition_lag_from_an_input_delay(effect, value, ref, rate, seed):
    d = diagnose(as_log(_lagged(value, ref=ref, rate=rate, seed=seed, effect=effect)))
    assert d.verdict == "explained"
    assert [(f.effect, f.axis) for f in d.findings] == [(effect, "both")]
    f = d.findings[0]
    assert f.parameter["value"] == pytest.approx(value, rel=0.05)
    other = "input_delay:both" if effect == "sensor_lag" else "sensor_lag:both"
    assert other not in f.alternatives and f"told it apart from {other}" in f.evidence
    assert d.held_out["after"]["yaw"] > d.held_out["before"]["yaw"]


def test_the_gate_does_not_judge_a_findings_model_whose_fit_on_a_half_ran_off():
    h = {"before": {"pitch": 85.0, "yaw": 96.0}, "after": {"pitch": 61.6, "yaw": 85.8},
         "converged": {"before": False, "after": False}}
    assert held_out.lowered(h, converged_only=True) == [] and held_out.lowering([], h) == []
    assert held_out.caution(h).startswith(" Caution: fitted on one half")  # said, not used to refuse
    assert "the findings' model's fit on a half did not converge: the after figure is no measure" in \
        held_out.sentence(h, True)
    assert "did not converge" not in held_out.sentence({**h, "converged": {"before": False, "after": True}}, True)
    assert held_out.lowered({**h, "converged": {"before": False, "after": True}}, converged_only=True) == \
        ["pitch", "yaw"]


def test_on_a_long_log_the_lag_is_tested_on_the_head_first(monkeypatch):
    # logs longer than GRID_SPAN_S search their grids on the head; the lag's regression of the whole log is only
    # built once the head passes it (memory): the finding and its value are the same
    from trms_ident.diagnosis import trials

    monkeypatch.setattr(trials, "GRID_SPAN_S", 30.0)
    d = diagnose(as_log(_lagged(0.05, ref="square", rate=500.0, seed=13)))
    assert [(f.effect, f.axis) for f in d.findings] == [("sensor_lag", "both")]
    assert d.findings[0].parameter["value"] == pytest.approx(0.05, rel=0.02)
