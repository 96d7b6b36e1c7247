"""Guards held at their edge: each threshold that decides a verdict has a case just inside and just outside it,
so a threshold loosened (or tightened) in a copy of the project makes this file fail."""
import math

import numpy as np
import pytest

from trms_ident import design as planner
from trms_ident import joint
from trms_ident import known_values
from trms_ident.params import ESTIMATED, defaults


def verdict_of(name: str, j1: float, sd: float) -> joint.LogVerdict:
    """A log that determines J1 alone [kg m^2], with standard deviation ``sd``."""
    cov = np.full((4, 4), np.nan)
    cov[0, 0] = sd ** 2
    estimates = {k: (j1 if k == "J1" else None) for k in ESTIMATED}
    return joint.LogVerdict(name, None, estimates, {k: (math.nan, math.nan) for k in ESTIMATED}, cov)


@pytest.mark.parametrize("z, consistent", [(2.0, True), (3.0, False)])
def test_the_joint_consistency_test_rejects_a_run_three_standard_deviations_off_and_keeps_one_two_off(z, consistent):
    """Three logs of J1, each with a 0.5 % standard deviation; the third is ``z`` standard deviations of the
    difference off the other two (1.2 % and 1.8 %: beyond PRACTICAL_REL both, so only the level decides).  At
    joint.LEVEL = 0.05, Bonferroni over three logs (0.0167 each), 2 sd (p = 0.046) agrees and 3 sd (p = 0.0027)
    does not; a level of 1e-12 would pass both, a level of 0.2 would reject both."""
    j1, sd = 0.068, 0.068 * 0.005
    off = z * sd * math.sqrt(1.5)  # the difference's sd: its own and the other two's mean, sd^2 (1 + 1/2)
    assert off / j1 >= joint.PRACTICAL_REL
    logs = [verdict_of("a", j1, sd), verdict_of("b", j1, sd), verdict_of("c", j1 + off, sd)]
    test = joint._test(logs, [0, 1, 2], fit=None)
    assert logs[2].z["J1"] == pytest.approx(z, rel=1e-9)
    assert test["level"] == 0.05 and test["consistent"] is consistent


@pytest.mark.parametrize("peak_rad, share, refused", [(0.165, (0.02, 0.05), False), (0.185, (0.06, 0.12), True)])
def test_design_refuses_a_run_at_the_voltage_limit_8_percent_of_the_time_and_keeps_one_at_3(peak_rad, share, refused):
    """A square pair (pitch ``peak_rad``, yaw twice that, 2 s period, 20 s at 100 Hz) with 2 mrad angle noise on
    Table 1's bench: at 0.165 rad a voltage is at its limit about 3 % of the time (kept, within the 5 % limit), at
    0.185 rad about 8 % (refused, with the share said)."""
    from sim.simulate import DEFAULT_PID

    t = np.arange(2001) / 100.0
    a = planner.square(t, planner.Square(peak_rad, 2.0))
    b = planner.square(t, planner.Square(2 * peak_rad, 2.0), 0.25)
    r = planner.simulate_run(t, a, b, 100.0, defaults(), "quadratic", {"alpha": 2e-3, "beta": 2e-3}, DEFAULT_PID,
                             2.5, planner.Limits())
    measured = r.envelope["saturated_share"]
    assert share[0] < measured < share[1]
    assert planner.Limits().saturated_share == 0.05
    said = [v for v in r.violations if "at its 2.5 V limit" in v]
    assert bool(said) is refused
    if refused:
        assert f"{100 * measured:.3g} % of the time with the angles' noise (limit 5 %)" in said[0]


@pytest.mark.parametrize("factor, plausible", [(5.0, True), (0.2, True), (20.0, False), (0.05, False), (-1.0, False)])
def test_a_known_value_refitted_20_times_off_the_table_is_not_a_finding(factor, plausible):
    """A refitted known value within 10x of the value given (either way) is plausible; 20x, 1/20 or the other
    sign is a fit run off to a number no bench has, never reported as the bench's value."""
    for given in (defaults()["Mg"], defaults()["kc"]):
        assert known_values.plausible_value(factor * given, given) is plausible
    assert known_values.plausible_value(math.nan, 0.32) is False


@pytest.mark.parametrize("over_noise, verdict", [(1.2, "explained"), (3.0, "partly_explained")])
def test_findings_whose_predictions_stay_3x_the_noise_are_not_called_explained(over_noise, verdict):
    """diagnose's verdict when the output-error simulation cannot carry the findings: their 2 s predictions within
    EXPLAINED_RMS_OVER_NOISE (1.5x) of the noise floor explain the log, 3x does not.  The angles have a standard
    deviation 100x the floor, so a prediction fit of 100 - r % is r times the floor."""
    from trms_ident.diagnosis.verdict import EXPLAINED_RMS_OVER_NOISE, verdict_of
    from trms_ident.log import validated

    assert EXPLAINED_RMS_OVER_NOISE == 1.5
    t = np.arange(2000) * 0.01
    wave = 0.1 * math.sqrt(2.0) * np.sin(2 * np.pi * 0.5 * t)  # standard deviation 0.1 rad
    log = validated(t, 0 * t, 0 * t, wave, wave, source="x")
    seed = {"adequate": False, "axes": {a: {"noise_floor_rad": 1e-3} for a in ("pitch", "yaw")}}
    fit = {"pitch": 100.0 - over_noise, "yaw": 100.0 - 1.0}
    got, sentence = verdict_of(log, seed, ["a finding"], fit, {}, None)
    assert got == verdict
    if verdict == "partly_explained":
        assert "the pitch prediction error is still 3x its noise level" in sentence


@pytest.mark.parametrize("over_noise, verdict", [(1.1, "explained"), (1.4, "partly_explained")])
def test_findings_whose_simulation_stays_above_1_2x_the_noise_are_not_called_explained(over_noise, verdict):
    """With the output-error simulation of the findings' model (estimate's adequacy threshold, 1.2x)."""
    from trms_ident.diagnosis.verdict import EXPLAINED_OE_OVER_NOISE, verdict_of
    from trms_ident.log import validated

    assert EXPLAINED_OE_OVER_NOISE == 1.2
    t = np.arange(2000) * 0.01
    log = validated(t, 0 * t, 0 * t, 0.1 * np.sin(t), 0.1 * np.cos(t), source="x")
    seed = {"adequate": False, "axes": {}}
    got, _ = verdict_of(log, seed, ["a finding"], {}, {}, {"alpha": over_noise, "beta": 1.0}, {"alpha": "noise"})
    assert got == verdict


def _standardised(k: int) -> np.ndarray:
    """k evenly spread numbers with mean 0 and sample standard deviation 1 exactly (per-block values)."""
    z = np.linspace(-1.0, 1.0, k)
    return (z - z.mean()) / z.std(ddof=1)


def _held_out_test(p_target: float, spread: float = 0.1, k: int = 16, n_tests: int = 20):
    """select.compare on a candidate whose per-block log-ratios of held-out RSS (current over candidate) have a
    t statistic giving one-sided p = ``p_target`` over ``k`` blocks, their spread ``spread``."""
    from types import SimpleNamespace

    from scipy.special import stdtrit

    from trms_ident.diagnosis.select import Score, compare

    t = float(stdtrit(k - 1, 1.0 - p_target))
    d = t * spread / math.sqrt(k) + spread * _standardised(k)
    base = Score({"pitch": np.ones(k)}, {}, {})
    new = Score({"pitch": np.exp(-d)}, {}, {})
    return compare(base, new, SimpleNamespace(g={"pitch": np.ones(100)}), ("pitch",), n_tests)


@pytest.mark.parametrize("p_value, passes", [(0.001, True), (0.01, False)])
def test_the_equation_errors_family_wise_level_passes_p_0_001_and_refuses_p_0_01_among_20(p_value, passes):
    """diagnose's held-out test over the library's 20 candidates: family-wise 5 % (Bonferroni, 0.0025 each) passes
    a candidate at p = 0.001 and refuses one at p = 0.01, both above the 5 % practical size (5.9 %, 8.5 %).  A family level of
    0.9 (0.045 each) would pass both; one of 0.01 (0.0005 each) would refuse both."""
    from trms_ident.diagnosis.select import FAMILY_ALPHA, MIN_REL_GAIN

    test = _held_out_test(p_value)
    assert test.p == pytest.approx(p_value, rel=1e-6) and test.gain > 1.15 * MIN_REL_GAIN
    assert test.passed is passes
    assert FAMILY_ALPHA == 0.05


@pytest.mark.parametrize("spread, passes", [(0.0262, False), (0.03, True)])
def test_a_significant_candidate_must_also_lower_the_held_out_error_by_5_percent(spread, passes):
    """The practical size: at p = 1e-6 a candidate whose held-out RSS falls by 4.7 % is refused, by 5.4 % passed
    (select.MIN_REL_GAIN = 5 %)."""
    test = _held_out_test(1e-6, spread=spread)
    assert test.p == pytest.approx(1e-6, rel=1e-6)
    assert (0.045 < test.gain < 0.05) if not passes else (0.05 < test.gain < 0.055)
    assert test.passed is passes


def _oe_fit(**changes):
    """An output-error candidate fit that passes every part of the output-error test (oe.shortfall), with
    ``changes`` applied."""
    from dataclasses import replace

    from trms_ident.diagnosis.oe import OEFit

    fit = OEFit(key="cable_stiffness:yaw", value=0.004, se=1e-5, t=12.0, p=1e-9, cost_drop=0.3, explained=0.2,
                excess_share=0.9, torque_share=0.05, estimates={}, samples=1000)
    return replace(fit, **changes)


@pytest.mark.parametrize("changes, refused", [
    ({"p": 0.002}, False), ({"p": 0.003}, True),  # family-wise 5 % over 20 candidates: 0.0025 each
    ({"cost_drop": 0.012}, False), ({"cost_drop": 0.008}, True),  # oe.MIN_COST_DROP = 1 % of the angle error
    ({"torque_share": 0.006}, False), ({"torque_share": 0.004}, True),  # oe.MIN_TORQUE_SHARE = 0.5 %
    ({"torque_share": 0.0012, "profiled": True}, False),  # oe.MIN_MODIFICATION_SHARE = 0.1 % for a modification
    ({"torque_share": 0.0008, "profiled": True}, True),
])
def test_the_output_error_test_refuses_just_past_each_of_its_edges(changes, refused):
    """oe.shortfall, the output-error test that decides a candidate: each of its guards passes a fit just inside
    its edge and refuses one just outside it (a guard loosened or tightened past these makes this fail)."""
    from trms_ident.diagnosis.oe import MIN_COST_DROP, MIN_MODIFICATION_SHARE, MIN_TORQUE_SHARE, shortfall
    from trms_ident.diagnosis.select import FAMILY_ALPHA

    assert not shortfall(_oe_fit(), 20, FAMILY_ALPHA)  # the fit as built passes
    why = shortfall(_oe_fit(**changes), 20, FAMILY_ALPHA)
    assert bool(why) is refused, why
    assert (MIN_COST_DROP, MIN_TORQUE_SHARE, MIN_MODIFICATION_SHARE) == (0.01, 0.005, 0.001)


@pytest.mark.parametrize("other_gain, separable", [(0.192, False), (0.188, True)])
def test_two_look_alikes_are_told_apart_only_when_the_better_explains_5_percent_more(other_gain, separable):
    """trials.separable: the better of two candidates whose fits look alike is told apart (not flagged as a
    look-alike) only when it is better block by block (one-sided 5 %) and its held-out gain exceeds the other's by
    SEPARATION_MARGIN (5 %) of its own: 0.2 against 0.192 (4 %) stays a look-alike, against 0.188 (6 %) is told
    apart, on the same clearly better blocks."""
    from types import SimpleNamespace

    from trms_ident.diagnosis.select import Score, Test
    from trms_ident.diagnosis.trials import SEPARATION_MARGIN, separable as told_apart
    from trms_ident.model.effects import by_key

    k = 16
    d = 0.05 + 0.01 * _standardised(k)  # the better one's blocks: t = 20 over the other's
    reg = SimpleNamespace(g={"yaw": np.ones(100)})
    c = by_key("cable_stiffness:yaw")
    other = {"c": c, "score": Score({"yaw": np.ones(k)}, {}, {}), "reg": reg, "test": Test(other_gain, 5.0, 1e-5,
                                                                                         0.1, True)}
    best = {"c": c, "score": Score({"yaw": np.exp(-d)}, {}, {}), "reg": reg, "test": Test(0.2, 6.0, 1e-6, 0.1, True)}
    assert told_apart(best, other) is separable
    assert SEPARATION_MARGIN == 0.05


@pytest.mark.parametrize("corr, alike", [(0.96, True), (0.94, False)])
def test_two_candidates_whose_residuals_correlate_0_96_are_look_alikes_and_0_94_are_not(corr, alike):
    """trials.aliased: two fitted candidates change the residual alike when their equation errors correlate at
    least ALIAS_CORRELATION (0.95) on every axis: 0.96 on both axes is alike, 0.94 on one is not."""
    from types import SimpleNamespace

    from trms_ident.diagnosis.trials import aliased

    n = 400
    t = np.arange(n)
    e1 = np.sin(2 * np.pi * 3 * t / n)  # orthogonal, zero mean: their mix correlates exactly corr with e1
    e2 = np.sin(2 * np.pi * 7 * t / n)

    def fitted(g_pitch, g_yaw):  # a regression with no columns: its residual is g itself
        reg = SimpleNamespace(g={"pitch": g_pitch, "yaw": g_yaw},
                              x={"pitch": np.zeros((n, 0)), "yaw": np.zeros((n, 0))})
        return {"reg": reg, "score": SimpleNamespace(theta={"pitch": np.zeros(0), "yaw": np.zeros(0)})}

    mixed = corr * e1 + math.sqrt(1.0 - corr * corr) * e2
    a, b = fitted(e1, e1), fitted(mixed, 0.99 * e1 + math.sqrt(1 - 0.99 ** 2) * e2)
    assert np.corrcoef(e1, mixed)[0, 1] == pytest.approx(corr, abs=1e-9)
    assert aliased(a, b) is alike


@pytest.mark.parametrize("after, said", [(89.95, []), (89.8, ["pitch"])])
def test_a_held_out_fit_lowered_by_0_2_points_is_said_and_by_0_05_is_not(after, said):
    """held_out.lowered: the findings lower an axis' held-out fit when it falls by more than LOWERED_BY_PERCENT
    (0.1 percentage points): 90 % -> 89.8 % is said (and gates the findings on that axis), 90 % -> 89.95 % is not."""
    from trms_ident.diagnosis.held_out import lowered

    h = {"before": {"pitch": 90.0, "yaw": 95.0}, "after": {"pitch": after, "yaw": 95.5}}
    assert lowered(h) == said


def _kv_fit(name: str, worst: float, cost: float = 10.0) -> dict:
    """A known value's refit alone as the seed check records it: 10 % off its table value, the worst angle
    ``worst`` times its floor."""
    table = defaults()[name]
    return {"name": name, "value": 0.9 * table, "table": table, "cost": cost,
            "over_noise": {"alpha": worst, "beta": 1.0}}


@pytest.mark.parametrize("worst, seed_worst, led", [(9.0, 100.0, True), (11.0, 100.0, False), (9.0, 17.0, False)])
def test_a_known_value_leads_the_search_only_within_10x_its_floor_and_half_the_seed_models_misfit(worst, seed_worst,
                                                                                                 led):
    """compound.leads: a known value's refit alone leads the effect search (value_first) when it left the worst
    angle within VALUE_FIRST_OVER_NOISE (10x) of its floor and within half the seed model's worst."""
    from trms_ident.diagnosis.compound import leads

    got = leads({"fits": [_kv_fit("T21", worst)]}, seed_worst)
    assert [f["name"] for f in got] == (["T21"] if led else [])


@pytest.mark.parametrize("factor, moved", [(1.011, True), (0.989, True), (1.009, False), (0.991, False)])
def test_a_known_value_that_moves_less_than_1_percent_from_its_table_value_has_not_moved(factor, moved):
    """known_values.practical_change: a refit that moves a value by less than PRACTICAL_CHANGE (1 %) of the
    value given does not name it (a value 0.06 % off its table once stood in for a dead zone)."""
    for given in (defaults()["Mg"], defaults()["T21"]):
        assert known_values.practical_change(factor * given, given) is moved
    assert known_values.practical_change(1e-3, 0.0) and not known_values.practical_change(0.0, 0.0)


@pytest.mark.parametrize("new_cost, earns", [(79.0, True), (81.0, False)])
def test_a_further_known_value_earns_its_place_only_by_a_quarter_of_the_excess(new_cost, earns):
    """known_values.earns_place: the joint search frees a further value when it removes at least JOINT_MIN_SHARE
    (25 %) of the cost above the noise level's (here 100 over a floor of 20: 21 removed earns it, 19 does not);
    a set already at the floor frees nothing."""
    assert known_values.earns_place(100.0, new_cost, 20.0) is earns
    assert not known_values.earns_place(19.0, 0.0, 20.0)


@pytest.mark.parametrize("gap, told", [(11.0, True), (9.0, False)])
def test_the_two_pitch_offsets_are_told_apart_by_a_cost_gap_of_11_and_not_of_9(gap, told, monkeypatch):
    """discriminate.tell_offsets_apart: both offsets' output-error fits reach the noise level; the one with the
    lower noise-weighted squared angle error wins when the gap is at least MIN_COST_GAP (10: a likelihood ratio
    of e^5), else the log cannot tell them apart."""
    from types import SimpleNamespace

    from trms_ident.diagnosis import discriminate
    from trms_ident.log import validated

    cost = {"com_offset:pitch": 100.0, "sensor_offset:pitch": 100.0 + gap}

    def refine(*args, free, effects, **kw):  # the fits, as numerics.refine would report them
        return SimpleNamespace(freed={free[0]: {"estimate": 0.02}}, converged=True, cost=cost[free[0]],
                               rms_rad={"alpha": 1e-4, "beta": 1e-4})

    monkeypatch.setattr(discriminate, "refine", refine)
    rng = np.random.default_rng(0)
    t = np.arange(1000) * 0.01
    log = validated(t, 0 * t, 0 * t, 0.1 * np.sin(t) + 1e-3 * rng.standard_normal(t.size),
                    0.1 * np.cos(t) + 1e-3 * rng.standard_normal(t.size), source="x")
    v = discriminate.tell_offsets_apart(log, log.u1_v, log.u2_v, defaults(), "quadratic", {},
                                        {k: 0.02 for k in discriminate.PAIR})
    assert v.gap == pytest.approx(gap)
    assert v.winner == ("com_offset:pitch" if told else None)


@pytest.mark.parametrize("worst, stops", [(1.05, True), (1.15, False)])
def test_the_search_stops_when_its_findings_bring_both_angles_within_1_1x_their_floors(worst, stops, monkeypatch):
    """search._reaches_floor: the rounds stop once the findings' output-error check leaves both angles within
    STOP_OE_OVER_NOISE (1.1x) of their floors with J/B physical; at 1.15x they go on (a further effect the 1.2x
    verdict tolerance hides can still be found)."""
    from types import SimpleNamespace

    from trms_ident.diagnosis import search
    from trms_ident.diagnosis.model import Model

    monkeypatch.setattr(search, "effect_values", lambda *a, **k: {})
    monkeypatch.setattr(search, "oe_start", lambda *a, **k: {})
    jb = {k: defaults()[k] for k in ESTIMATED}
    fitter = SimpleNamespace(check_fit=lambda model, values, theta0: ({"alpha": worst, "beta": 1.0}, jb))
    assert search._reaches_floor(fitter, Model(), None, None, {}, defaults()) is stops
    unphysical = SimpleNamespace(check_fit=lambda model, values, theta0: ({"alpha": 1.0, "beta": 1.0},
                                                                          {**jb, "B2": -1e-3}))
    assert search._reaches_floor(unphysical, Model(), None, None, {}, defaults()) is False


@pytest.mark.parametrize("value, refused", [(0.995, True), (1.012, False)])
def test_a_motor_time_constant_the_output_error_fits_within_1_percent_of_the_table_is_refused(value, refused):
    """judge.oe_fit: a yaw motor time constant (the motor_lag candidate, T21 under another name) whose
    output-error value lands within MOTOR_LAG_NEUTRAL (1 %) of the table's 1.0 s changes nothing and is refused,
    whatever its drop in angle error; 1.2 % off passes."""
    from types import SimpleNamespace

    from trms_ident.diagnosis.judge import oe_fit
    from trms_ident.model.effects import by_key

    c = by_key("motor_lag:yaw")
    fit = _oe_fit(key=c.key, value=value, profiled=True)
    fitter = SimpleNamespace(profile=lambda *a, **k: fit)
    log = SimpleNamespace(u1_v=np.zeros(10), u2_v=np.zeros(10), sample_time_s=0.01)
    from trms_ident.diagnosis.model import Model

    got, why = oe_fit(c, 1.05, fitter, Model(), {}, {}, log, defaults(), 20, [])
    assert got is fit
    assert bool(why) is refused, why
    if refused:
        assert why == ["its fitted time constant 0.995 s is within 1 % of the table's: it changes nothing"]


@pytest.mark.parametrize("factor, verdict", [(90.0, "explained"), (110.0, "partly_explained"),
                                             (1 / 110, "partly_explained")])
def test_findings_whose_refitted_j_is_over_100x_off_the_table_are_leads_not_an_explanation(factor, verdict):
    """verdict.credible: J/B refitted with the findings more than PLAUSIBLE_FACTOR (100x) from Table 1 (a J
    either way) say the findings' model is far from the bench: "explained" becomes "partly_explained" and the
    sentence says the values are leads to check; 90x stays explained."""
    from trms_ident.diagnosis.verdict import credible

    jb = {k: defaults()[k] for k in ESTIMATED}
    got, sentence = credible("explained", "s.", {**jb, "J2": factor * jb["J2"]})
    assert got == verdict
    assert ("read the findings and their values as leads to check" in sentence) is (verdict != "explained")


@pytest.mark.parametrize("before, after, as_well", [
    (3.0, 3.03, True), (3.0, 3.031, False),  # far from the floor: within 1 % of the findings' model (INERT_FIT_RATIO)
    (1.1, 1.199, True), (1.1, 1.201, False),  # at the floor: within the verdict's threshold (RMS_OVER_NOISE 1.2)
    (1.3, 1.19, True), (1.3, 1.32, False)])
def test_a_model_with_fewer_findings_fits_as_well_within_1_percent_or_within_the_verdicts_threshold(before, after,
                                                                                                    as_well):
    """diagnose drops a finding (an input modification of no practical size, a library effect a term makes
    unnecessary) only where the model without it fits the log as well: each angle's error RMS over its floor within
    1 % of the findings' model's, or under 1.2x where that model was."""
    from trms_ident.diagnosis.run import fits_as_well

    assert fits_as_well({"alpha": 1.0, "beta": before}, {"alpha": 1.0, "beta": after}) is as_well


@pytest.mark.parametrize("over_noise, judged", [(1.19, True), (1.21, False)])
def test_a_candidate_beside_a_current_model_that_did_not_converge_is_judged_only_at_1_2x_the_floor(over_noise,
                                                                                                  judged):
    """When the current model's output-error fit does not converge (far from the log), a candidate's fit is judged
    only when it brings both angles within 1.2x their floors (oe.UNCONVERGED_BASE_OVER_NOISE): else its drop from
    an unconverged cost means nothing."""
    from trms_ident.diagnosis.oe import judged_beside_unconverged

    floors = {"alpha": 4e-4, "beta": 5e-4}
    assert judged_beside_unconverged({"alpha": 4e-4, "beta": over_noise * 5e-4}, floors) is judged
    assert judged_beside_unconverged({"alpha": over_noise * 4e-4, "beta": 5e-4}, floors) is judged
