"""Held-out simulation fits (diagnosis/held_out.py) and the floors a smoothed log is judged against
(adequacy.judging_floors): a model fitted on one half of a log is simulated on the other with its values held."""
import math

import numpy as np
import pytest

from trms_ident.diagnosis import held_out, oe
from trms_ident.diagnosis.model import Model
from trms_ident.diagnosis.run import diagnose
from trms_ident.numerics.adequacy import judging_floors
from trms_ident.numerics.refine import refine
from trms_ident.params import defaults

from .conftest import as_log, sim_cached

Q12 = 2 * math.pi / 4096
JB = ("J1", "B1", "J2", "B2")
CABLE = ((("axis", "yaw"), ("effect", "cable_stiffness"), ("value", 0.005)),)


def test_a_held_fit_keeps_its_values_and_fits_only_the_start_states():
    r = sim_cached("multisine", 200.0, 60.0, 0.0, Q12, 4)
    log = as_log(r)
    truth = {k: r.truth["estimated"][k] for k in JB}
    noise = {"alpha": Q12 / math.sqrt(12), "beta": Q12 / math.sqrt(12)}
    args = (log.u1_v, log.u2_v, log.alpha_rad, log.beta_rad, log.sample_time_s, defaults(), "quadratic")
    off = {k: v * 1.3 for k, v in truth.items()}
    held = refine(*args, off, noise, hold=True)
    assert held.estimate == off  # held: exactly the values given
    right = refine(*args, truth, noise, hold=True)
    assert right.estimate == truth
    for ang in ("alpha", "beta"):  # the true values simulate to the encoder's rounding once the starts are fitted
        assert right.rms_rad[ang] <= 1.2 * noise[ang]
    assert max(held.rms_rad[a] / noise[a] for a in noise) > 3.0  # 30 % off J/B shows on data they were not fitted on
    free = refine(*args, off, noise)  # not held: J/B move back to the truth
    assert free.estimate["J2"] == pytest.approx(truth["J2"], rel=1e-3)


def test_the_missing_effect_raises_the_held_out_fit_and_a_clean_model_keeps_it():
    r = sim_cached("multisine", 200.0, 120.0, 0.0, Q12, 3, CABLE)
    log = as_log(r)
    truth = {k: r.truth["estimated"][k] for k in JB}
    f = oe.Fitter(log, defaults(), "quadratic")
    before = f.held_out(Model(), {}, truth)
    after = f.held_out(Model().with_linear("cable_stiffness:yaw"), {"cable_stiffness:yaw": 0.0}, truth)
    assert after["fit_percent"]["yaw"] > 99.9 > before["fit_percent"]["yaw"] + 20.0
    assert after["rms_rad"]["beta"] <= 1.2 * f.noise["beta"]  # the true model: noise left on the held-out halves
    for fold in after["folds"]:  # each half alone gives the cable back
        assert fold["values"]["cable_stiffness:yaw"] == pytest.approx(0.005, rel=0.02)
    assert [fold["fitted_on"] for fold in after["folds"]] == [[0, 12000], [12000, 24001]]


def test_judging_floors_take_the_black_box_where_the_log_measures_no_noise():
    noise = {"alpha": 1e-9, "beta": 4e-4}
    check = {"axes": {"pitch": {"floor_used": "black_box", "black_box": {"rms_rad": 2e-4}},
                      "yaw": {"floor_used": "noise"}}}
    floors, used = judging_floors(check, noise)
    assert floors == {"alpha": 2e-4, "beta": 4e-4} and used == {"alpha": "black_box", "beta": "noise"}
    check["axes"]["pitch"]["floor_used"] = "none"  # the black box does not simulate it: the bound is kept
    assert judging_floors(check, noise) == ({"alpha": 1e-9, "beta": 4e-4}, {"alpha": "none", "beta": "noise"})
    assert judging_floors(None, noise)[0] == noise


def test_a_smoothed_log_is_judged_against_the_black_box_and_its_findings_raise_the_held_out_fit():
    # noise-free angles (as the CE150's smoothed ones: no measurable noise floor) with a yaw cable the seed model
    # lacks: the verdict rests on the black-box floor the seed check measured, never on a 1e-12 rad "floor", and
    # the cable raises the held-out simulation fit
    r = sim_cached("multisine", 200.0, 90.0, 0.0, 0.0, 3, CABLE)
    d = diagnose(as_log(r))
    assert [(f.effect, f.axis) for f in d.findings] == [("cable_stiffness", "yaw")]
    assert d.settings["floors"]["yaw"]["used"] == "black_box"
    assert d.settings["floors"]["yaw"]["rad"] == pytest.approx(
        d.seed_check["axes"]["yaw"]["black_box"]["rms_rad"])
    assert d.verdict == "explained" and "black-box model leaves on held-out data" in d.verdict_sentence
    h = d.held_out
    assert h["after"]["yaw"] > h["before"]["yaw"] + 20.0 and h["after"]["yaw"] > 99.9
    assert held_out.lowered(h) == [] and "Caution: fitted on one half" not in d.verdict_sentence
    assert np.all(np.isfinite(h["prediction"]["after"]))


def test_findings_that_simulate_an_axis_worse_on_held_out_samples_are_said():
    h = {"before": {"pitch": 99.5, "yaw": 97.0}, "after": {"pitch": 99.45, "yaw": 90.0}}
    assert held_out.lowered(h) == ["yaw"]  # 0.05 points on pitch is within LOWERED_BY_PERCENT
    assert held_out.caution(h) == (" Caution: fitted on one half of the log and simulated on the other, the model with "
                                   "the findings does worse than the seed model (yaw 97.0 % -> 90.0 %): the findings "
                                   "may describe this recording rather than the bench.")
    assert held_out.caution({**h, "after": None}) == "" and held_out.caution(None) == ""
    assert held_out.sentence({**h, "after": None}, True).endswith(
        "pitch 99.5 %, yaw 97.0 % for the seed model; the findings' model could not be fitted by output error on the "
        "halves.")
