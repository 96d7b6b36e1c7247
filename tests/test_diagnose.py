"""Diagnose: the right physics named on concealed effects, clean logs left alone, the JSON contract."""
import dataclasses
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.diagnosis import oe
from trms_ident.diagnosis.model import delayed
from trms_ident.diagnosis.predict import N_FX, predict, predict_fitted_start
from trms_ident.diagnosis.run import diagnose
from trms_ident.diagnosis.select import Score, compare
from trms_ident.io.csv_log import write_csv_log

from .conftest import as_log, sim_cached

runner = CliRunner()
Q12 = 2 * math.pi / 4096


def _diag(ref, rate, duration, effects=(), noise=0.0, q=Q12, seed=3):
    r = sim_cached(ref, rate, duration, noise, q, seed, tuple(tuple(sorted(e.items())) for e in effects))
    return diagnose(as_log(r)), r


@pytest.mark.parametrize("effect, axis, value, ref", [
    ("coulomb_friction", "pitch", 1e-3, "multisine"),
    ("cable_stiffness", "yaw", 0.005, "steps"),
    ("input_delay", "both", 0.02, "multisine"),
    ("dead_zone", "yaw", 0.1, "multisine"),
    ("motor_lag", "pitch", 1.32, "steps"),
    ("thrust_asymmetry", "yaw", 0.3, "square"),
    ("thrust_asymmetry", "pitch", -0.2, "multisine"),
    ("yaw_inertia_pitch", "yaw", 0.005, "multisine"),
])
def test_concealed_effect_is_named_fitted_and_improves_the_fit(effect, axis, value, ref):
    d, r = _diag(ref, 100.0, 90.0, [dict(effect=effect, axis=axis, value=value)])
    assert d.mismatch
    f = d.findings[0]
    assert (f.effect, f.axis) == (effect, axis), [(x.effect, x.axis) for x in d.findings]
    assert f.parameter["value"] == pytest.approx(value, rel=0.3)
    if math.isnan(f.fit_before):  # the seed model's least-squares J or B is not physical: nothing to predict with
        assert min(d.nominal[k] for k in (("J1", "B1") if axis == "pitch" else ("J2", "B2"))) <= 0
    else:
        assert f.fit_after > f.fit_before
    # on samples it was not fitted on, the model with the finding simulates its axes better than the seed model
    for ax in (("pitch", "yaw") if axis == "both" else (axis,)):
        assert d.held_out["after"][ax] > d.held_out["before"][ax], d.held_out
    truth = r.truth["estimated"]
    for k in ("J1", "J2"):  # the augmented model recovers J where the nominal one was pulled away
        assert abs(d.augmented[k] / truth[k] - 1) <= abs(d.nominal[k] / truth[k] - 1) + 1e-3
    if effect == "dead_zone":  # its interval: the steps of its staircase cost no worse than its own, edges at |u2|
        lo, hi = f.parameter["ci95"]
        u = np.abs(r.u2_v)
        assert lo <= value <= hi and np.min(np.abs(u - lo)) < 1e-12 and np.min(np.abs(u - hi)) < 1e-12, (lo, hi)
    if effect == "yaw_inertia_pitch":  # the output-error kernel carries the inertia too: its test decides
        assert oe.carries("yaw_inertia_pitch:yaw") and "output-error test that decides passed it" in f.evidence, \
            f.evidence


def test_two_effects_are_both_named():
    d, _ = _diag("multisine", 100.0, 90.0, [dict(effect="cable_stiffness", axis="yaw", value=0.005),
                                            dict(effect="coulomb_friction", axis="pitch", value=2e-3)])
    named = {(f.effect, f.axis) for f in d.findings}
    assert {("cable_stiffness", "yaw"), ("coulomb_friction", "pitch")} <= named
    # each finding carries its own step: the fits chain from the seed model's to the final one, each step
    # raises the fit of the axes it acts on, and its term's shape is the fitted law
    assert [s["key"] for s in d.steps] == [f"{f.effect}:{f.axis}" for f in d.findings]
    last = dict(d.fit_before)
    for f, step in zip(d.findings, d.steps):
        for axis, a in step["axes"].items():
            assert a["fit_before"] == pytest.approx(last[axis]) and a["fit_after"] > a["fit_before"]
            last[axis] = a["fit_after"]
            assert a["measured"].shape == a["before"].shape == a["residual_after"].shape == a["regime"].shape
        assert f.fit_after == pytest.approx(min(a["fit_after"] for a in step["axes"].values()))
        sh = step["shape"]
        if f.effect == "coulomb_friction":
            assert np.allclose(np.abs(sh.fitted[sh.x != 0]), f.parameter["value"]) and not sh.seed.any()
            assert np.all(sh.fitted[sh.x > 0] < 0)  # opposes the motion
        if f.effect == "cable_stiffness":
            assert np.allclose(sh.fitted, -f.parameter["value"] * sh.x)
    for axis in d.fit_after:
        assert last[axis] == pytest.approx(d.fit_after[axis])


@pytest.mark.parametrize("ref, rate, noise, q", [("square", 200.0, 0.0, 0.0), ("sine", 200.0, 0.0, Q12),
                                                  ("multisine", 100.0, 1e-3, 0.0), ("steps", 100.0, 0.0, Q12)])
def test_clean_logs_report_no_mismatch(ref, rate, noise, q):
    d, _ = _diag(ref, rate, 90.0, (), noise, q)
    assert not d.mismatch, [(f.effect, f.axis, f.evidence) for f in d.findings]
    assert d.fit_before["pitch"] > 80 and d.fit_before["yaw"] > 80  # noisy restarts cost some fit


def test_indistinguishable_candidates_are_said_so():
    # a centre-of-mass offset and an encoder zero offset have the same gravity signature
    d, _ = _diag("multisine", 100.0, 90.0, [dict(effect="com_offset", axis="pitch", value=0.01)])
    f = d.findings[0]
    names = {f"{f.effect}:{f.axis}", *f.alternatives}
    assert "com_offset:pitch" in names
    if f.effect != "com_offset":
        assert "cannot be told apart" in f.evidence


@pytest.mark.parametrize("effect, value, ref, seed", [("sensor_offset", 0.01, "sine", 119), ("com_offset", 0.03, "steps", 117)])
def test_output_error_fit_tells_the_two_offsets_apart(effect, value, ref, seed):
    # the equation error alone once named the other offset first on these logs (benchmark logs 17 and 19); the
    # output-error fit tells them apart when it does not (with the start states modelled, the equation error
    # now separates the com offset of the steps log by itself)
    d, _ = _diag(ref, 1000.0, DURATION_OFFSETS_S, [dict(effect=effect, axis="pitch", value=value)], 1e-3, 0.0, seed)
    f = d.findings[0]
    assert f.effect == effect and not f.alternatives, (f.effect, f.evidence)
    assert f.parameter["value"] == pytest.approx(value, rel=0.05)
    if effect == "sensor_offset":
        assert "told apart" in f.evidence
    # the output-error kernel carries either offset with its parameter free: its test judged the finding; with it
    # the model reaches the noise floor, so the search stops there (no round after it, no candidate tested on top)
    judged = [t for t in d.oe_tested if (t["effect"], t["axis"]) == (effect, "pitch") and not t["after"]]
    assert judged and judged[0]["passed"] and judged[0]["parameter"] == pytest.approx(value, rel=0.05)
    assert d.settings["search_stopped_after_round"] == 1
    assert max(d.settings["output_error_check"]["rms_over_noise"].values()) <= 1.2
    assert not any(t["after"] for t in d.oe_tested)


DURATION_OFFSETS_S = 90.0


def test_block_test_keeps_false_positives_rare():
    # a candidate that explains nothing: per-block log-ratios centred on zero -> rarely "passes"
    rng = np.random.default_rng(0)
    passes = 0
    for _ in range(200):
        base = rng.chisquare(20, 24)
        new = base * np.exp(rng.normal(0, 0.05, 24))
        g = {"pitch": np.ones(10)}
        passes += compare(Score({"pitch": base}, {}, {}), Score({"pitch": new}, {}, {}),
                          type("R", (), {"g": g})(), ("pitch",), 14).passed
    assert passes <= 2  # family level 1 %, divided over 14 candidates


def test_prediction_windows_start_from_the_state_that_fits_them():
    # yaw: J beta'' + B beta' = tau-driven torque - M_R; a trajectory from known window starts, then
    # starts guessed 0.3 rad/s off: the fitted starts recover the trajectory, the guessed ones do not
    dt, n, horizon = 0.01, 2000, 200
    t = np.arange(n) * dt
    tau, other = 0.5 + 0.3 * np.sin(t), 0.02 * np.cos(0.5 * t)
    th = np.array([0.02, 0.1, 0.02, 0.09, 0.0, 0.0, 0.0])
    fx = np.zeros(N_FX)
    zero = np.zeros(n)
    rng = np.random.default_rng(1)
    x_true_start = np.repeat(rng.normal(0, 1, n // horizon), horizon)
    v_true_start = np.repeat(rng.normal(0, 1, n // horizon), horizon)
    y = predict(False, x_true_start, v_true_start, tau, other, zero, zero, zero, dt, horizon, th, fx)
    guess = v_true_start + 0.3
    fitted = predict_fitted_start(False, y, guess, tau, other, zero, zero, zero, dt, horizon, th, fx)
    np.testing.assert_allclose(fitted, y, atol=1e-8)
    assert np.max(np.abs(predict(False, y, guess, tau, other, zero, zero, zero, dt, horizon, th, fx) - y)) > 0.01


def test_fractional_delay_of_a_held_signal():
    u = np.array([0.0, 0, 1, 1, 1, 0, 0])
    np.testing.assert_allclose(delayed(u, 1.0), [0, 0, 0, 1, 1, 1, 0])
    np.testing.assert_allclose(delayed(u, 0.5), [0, 0, 0.5, 1, 1, 0.5, 0])


def test_cli_json_contract_and_report(tmp_path):
    r = sim_cached("multisine", 100.0, 90.0, 0.0, Q12, 3, ((("axis", "yaw"), ("effect", "coulomb_friction"),
                                                          ("value", 5e-3)),))
    log = tmp_path / "bench.csv"
    write_csv_log(log, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    res = runner.invoke(app, ["diagnose", str(log), "--json", "-", "--report", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["mismatch"] is True
    f = doc["findings"][0]
    assert f["effect"] == "coulomb_friction" and f["axis"] == "yaw"
    assert set(f["parameter"]) == {"name", "value", "unit"} and f["parameter"]["unit"] == "N m"
    assert isinstance(f["fit_before"], float) and f["fit_after"] > f["fit_before"] and f["evidence"]
    for key in ("nominal", "augmented"):
        assert set(doc["estimates"][key]) == {"J1", "B1", "J2", "B2"}
    # the output-error fit's J/B once that fit of the findings' model reaches the noise level and predicts no worse
    assert doc["settings"]["estimates_augmented_from"] == "output_error_check"
    for k in ("J1", "B1", "J2", "B2"):
        assert doc["estimates"]["augmented"][k] == pytest.approx(r.truth["estimated"][k], rel=0.01)
    assert "1. coulomb_friction on yaw: Fc = " in res.stderr
    # the finding raises the held-out simulation fit (fitted on one half, simulated on the other), said and drawn
    held = doc["held_out_fit"]
    assert held["after"]["yaw"] > held["before"]["yaw"] and held["samples"] == len(r.t_s)
    assert ("Held-out simulation fit (fitted on one half, simulated on the other), before -> after the findings: "
            f"pitch {held['before']['pitch']:.1f} % -> {held['after']['pitch']:.1f} %") in res.stderr
    html = (tmp_path / "rep" / "report.html").read_text()
    # residual, regime, overlay, held-out simulation; one set for the finding
    assert html.count("data:image/png;base64,") == 5
    assert "<h2>Held-out simulation</h2>" in html and "Held-out simulation fit (fitted on one half" in html
    assert "Finding 1: coulomb_friction on yaw" in html
    # the page says the verdict as the terminal's first line does: the findings in plain words, then why
    from trms_ident.report.terminal import headline
    leads = bool(doc["estimates"]["not_credible"]["augmented"])
    assert f"</span> {headline(doc['verdict'], doc['findings'], leads)}</b>." in html
    assert "Coulomb friction on yaw (Fc = " in html
    import html as html_mod
    assert f"Why: {html_mod.escape(doc['verdict_sentence'])}" in html
    assert json.loads((tmp_path / "rep" / "diagnosis.json").read_text())["mismatch"] is True


def test_cli_clean_log_says_no_mismatch(square_csv):
    res = runner.invoke(app, ["diagnose", str(square_csv)])
    assert res.exit_code == 0 and "CONSISTENT: the model fits this log as it is" in res.output
    assert "why: the seed model already fits the log" in res.output


@pytest.mark.parametrize("grid, vertex, log_space", [
    ([2.0, 1.5, 1.2, 0.9], 1.3, False),  # descending and uneven (saturation levels, negative offsets)
    ([0.85, 0.95, 1.0, 1.05, 1.15], 0.93, False),  # the offset refinement grid
    ([0.5, 1, 1.5, 2, 3, 4], 1.7, True),  # the delay grid, uneven even in log space
])
def test_grid_refinement_finds_the_parabola_vertex(grid, vertex, log_space):
    from trms_ident.diagnosis.trials import _refine

    to = np.log if log_space else (lambda v: v)
    gains = [-(to(g) - to(vertex)) ** 2 for g in grid]
    assert _refine(grid, gains, int(np.argmax(gains)), log_space) == pytest.approx(vertex, rel=1e-9)


def test_progress_is_reported_in_order_and_quiet_when_piped(square_csv):
    r = sim_cached("multisine", 100.0, 90.0, 0.0, Q12, 3, ())
    seen = []
    diagnose(as_log(r), progress=lambda stage, done: seen.append((stage, done)))
    fractions = [f for _, f in seen]
    assert fractions == sorted(fractions) and fractions[0] == 0.0 and fractions[-1] >= 0.85
    assert any(stage.startswith("testing coulomb_friction:pitch") for stage, _ in seen)
    res = runner.invoke(app, ["diagnose", str(square_csv), "--json", "-"])  # stderr is not a terminal here
    assert res.exit_code == 0 and "━" not in res.stderr and "\r" not in res.stderr


@pytest.mark.parametrize("ref, rate, noise, q, effect, axis, value", [
    ("square", 1000.0, 0.0, Q12, "coulomb_friction", "yaw", 0.004),
    ("steps", 250.0, 1e-3, 0.0, "input_delay", "both", 0.02),
])
def test_log_that_begins_mid_run(ref, rate, noise, q, effect, axis, value):
    """The motors' states when the log begins come from the seed check's estimate, and the filters' start
    transients are regressors of the model: a log cut 30 s into the run is diagnosed like one from rest."""
    from sim import SimSettings, simulate

    r = simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=90.0, noise_std_rad=noise, quantization_rad=q,
                             seed=77, start_s=30.0, effects=[dict(effect=effect, axis=axis, value=value)]))
    d = diagnose(as_log(r))
    f = d.findings[0]
    assert (f.effect, f.axis) == (effect, axis)
    assert f.parameter["value"] == pytest.approx(value, rel=0.3)
    assert d.seed_check["start_states"] is not None
    clean = simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=90.0, noise_std_rad=noise,
                                 quantization_rad=q, seed=78, start_s=30.0))
    assert diagnose(as_log(clean)).verdict == "consistent"


def test_every_candidate_has_a_term_shape_that_is_the_seed_model_at_its_neutral_value():
    from trms_ident.model.effects import CANDIDATES
    from trms_ident.diagnosis.shapes import term_shape
    from trms_ident.params import defaults

    p = defaults()
    rng = np.random.default_rng(1)
    w, x, a, u = (rng.normal(0, s, 500) for s in (1.0, 0.5, 0.3, 1.5))
    neutral = {"input_saturation": 10.0, "motor_lag": None}
    for c in CANDIDATES:
        if c.torque is not None:  # declared by its torque alone (a term): its shape is declared_shape's
            continue             # (tests/test_model_room.py)
        v = neutral.get(c.effect, 0.0)
        if c.effect == "motor_lag":
            v = p["T11"] if c.axis == "pitch" else p["T21"]
        sh = term_shape(c, v, p, "quadratic", w, x, a, u, 1e-2)
        assert sh.x.shape == sh.fitted.shape == sh.seed.shape and np.all(np.isfinite(sh.fitted)), c.key
        np.testing.assert_allclose(sh.fitted, sh.seed, atol=1e-12, err_msg=c.key)
        moved = term_shape(c, 1.0 if c.effect == "input_saturation" else (v or 0.0) + 0.1, p, "quadratic",
                           w, x, a, u, 1e-2)
        assert not np.allclose(moved.fitted, moved.seed), c.key  # and a non-neutral value shows


def test_output_error_fit_finds_small_friction_the_equation_error_misses():
    # 0.002 N m of pitch Coulomb friction, square wave, a log cut 30 s into the run: the filtered equation error
    # loses it in the noise F s^2 amplifies (held-out RSS -4 %, under the 5 % practical size), and the seed
    # model's angles even fit at the noise level; simulated with the effect's parameter free, thousands of
    # samples agree on it
    from sim import SimSettings, simulate

    r = simulate(SimSettings(ref="square", sample_rate_hz=200.0, duration_s=90.0, quantization_rad=Q12, seed=3,
                             start_s=30.0, effects=[dict(effect="coulomb_friction", axis="pitch", value=2e-3)]))
    d = diagnose(as_log(r))
    assert [(f.effect, f.axis) for f in d.findings] == [("coulomb_friction", "pitch")]
    f = d.findings[0]
    assert f.parameter["value"] == pytest.approx(2e-3, rel=0.05)
    assert f.evidence.startswith("output-error fit")
    assert d.verdict == "explained"
    judged = [x for x in d.oe_tested if x["effect"] == "coulomb_friction" and x["axis"] == "pitch"]
    assert judged and judged[0]["passed"] and judged[0]["t"] > 10
    assert not any(x["passed"] for x in d.oe_tested if x["after"])  # nothing more once it is in


def test_fit_change_shows_the_change():
    from trms_ident.diagnosis.predict import fit_change

    assert fit_change(99.688, 99.694) == "99.688 % -> 99.694 %"  # 2 decimals would read 99.69 -> 99.69
    assert fit_change(96.64, 99.09) == "96.64 % -> 99.09 %"
    assert fit_change(float("nan"), 97.5).startswith("n/a (J or B not physical")


def test_json_output_is_strict_json():
    # Python's json writes NaN and Infinity, which jq and JavaScript's JSON.parse refuse
    from trms_ident.report.summary import to_json

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    doc = json.loads(to_json({"fit": {"pitch": float("nan"), "yaw": 97.5}, "r": [float("inf"), -float("inf"), 1],
                              "t": (0.5, float("nan")), "s": "nan", "ok": True}), parse_constant=refuse)
    assert doc == {"fit": {"pitch": None, "yaw": 97.5}, "r": [None, None, 1], "t": [0.5, None], "s": "nan",
                   "ok": True}


@pytest.mark.parametrize("mid_run", [False, True])
def test_start_basis_from_the_leading_samples_equals_the_full_length_one(mid_run):
    """The start columns are built over the leading samples only (start_head): the same basis, to the bit, as
    built over the whole log, on a log longer than the head (from rest, and cut mid-run)."""
    from dataclasses import fields

    from trms_ident.diagnosis import model as M
    from trms_ident.numerics.filters import discretize, second_order_lowpass
    from trms_ident.numerics.fused import plant_signals
    from trms_ident.params import defaults

    r = sim_cached("multisine", 100.0, 200.0, 0.0, Q12)
    log = as_log(r)
    if mid_run:
        k = 3000
        from trms_ident.log import validated
        log = validated(r.t_s[k:], r.u1_v[k:], r.u2_v[k:], r.alpha_rad[k:], r.beta_rad[k:])
    p, dt = defaults(), log.sample_time_s
    ps = plant_signals(log.u1_v, log.u2_v, log.alpha_rad, log.beta_rad, dt, p, "quadratic")
    for a in (0.7, 3.0):
        assert M.start_head(p, a, dt, len(log)) < len(log)  # the case under test
        f = discretize(*second_order_lowpass(a, a * a), dt, "bilinear")
        for axis in ("pitch", "yaw"):
            q0, n0 = M._leading_basis(M.start_columns(axis, p, "quadratic", ps, log.alpha_rad, a, dt, f))
            q1, n1 = M.start_basis(axis, p, "quadratic",
                                   lambda m: M.PlantSignals(*(getattr(ps, x.name)[:m] for x in fields(ps))),
                                   log.alpha_rad, a, dt, f)
            assert n1 == n0 and 0 < n0 < len(log)
            np.testing.assert_array_equal(q1, q0)


def test_segments_locate_a_burst_of_equation_error_in_time():
    """A residual ten times larger over 40-55 s of a 120 s log: one segment, covering the burst to within the
    rolling window, with its RMS ratio against the median window (analytically 10)."""
    from trms_ident.diagnosis.locate import segments

    dt = 0.01
    t = np.arange(12000) * dt
    r = np.where((t >= 40.0) & (t < 55.0), 10.0, 1.0) * np.where(np.arange(t.size) % 2, 1.0, -1.0)
    ctx = {"velocity": np.ones_like(t), "input": np.zeros_like(t), "angle": np.zeros_like(t), "input_limit": 1.0,
           "angle_max": 1.0}
    seg = segments(t, r, 2.0, ctx)
    assert len(seg) == 1
    assert 38.0 <= seg[0]["start_s"] <= 40.0 and 55.0 <= seg[0]["end_s"] <= 57.0
    assert seg[0]["rms_ratio"] == pytest.approx(10.0)
    assert segments(t, np.ones_like(t), 2.0, ctx) == []


@pytest.mark.parametrize("effect, axis, value, ref, start", [
    ("dead_zone", "yaw", 0.1, "chirp", 0.0),
    ("input_saturation", "pitch", 1.6, "steps", 30.0),
    ("input_delay", "both", 0.03, "square", 30.0),
    ("motor_lag", "yaw", 1.3, "multisine", 0.0),
])
def test_output_error_profile_fits_an_input_modification_and_leaves_a_clean_log_alone(effect, axis, value, ref,
                                                                                       start):
    # an input modification has no sensitivity to follow (a dead zone's cost is piecewise constant in its
    # width): fitted by output error over its value, started 20 % off, it lands on the injected value, its
    # held-out test passes with room and the simulation fit rises; the same profile on the log without the
    # effect does not pass
    from sim import SimSettings, simulate
    from trms_ident.diagnosis import oe
    from trms_ident.model.effects import BY_KEY
    from trms_ident.diagnosis.model import Model
    from trms_ident.diagnosis.select import FAMILY_ALPHA
    from trms_ident.diagnosis.trials import value_grid
    from trms_ident.params import defaults

    p = defaults()
    theta0 = {k: p[k] for k in ("J1", "B1", "J2", "B2")}
    key = f"{effect}:{axis}"
    fits = {}
    for effects in ([dict(effect=effect, axis=axis, value=value)], []):
        log = as_log(simulate(SimSettings(ref=ref, sample_rate_hz=200.0, duration_s=60.0, quantization_rad=Q12,
                                          seed=7, start_s=start, effects=effects)))
        fits[bool(effects)] = oe.Fitter(log, p, "quadratic").profile(Model(), {}, theta0, key,
                                                                     value_grid(BY_KEY[key], log, p), 0.8 * value)
    f = fits[True]
    assert f.profiled and f.value == pytest.approx(value, rel=0.03)
    assert oe.passes(f, 24, FAMILY_ALPHA) and f.t > 10 and f.cost_drop > 0.3
    own = "pitch" if axis == "both" else axis
    assert f.fits[own][1] > f.fits[own][0]
    assert "held-out drop in angle error" in oe.evidence(f, 0.005)
    g = fits[False]
    assert g is None or not oe.passes(g, 24, FAMILY_ALPHA)


def test_each_model_predicts_from_its_own_motor_start_states():
    # a square-wave log cut 30 s into the run with a 0.02 s input delay: the seed model's least-squares B1 is not
    # physical, and the motors' start states chosen for it (and estimated without the delay) had left the yaw
    # prediction of the findings' model at 80 % for its first seconds and the verdict "partly explained"
    from sim import SimSettings, simulate

    r = simulate(SimSettings(ref="square", sample_rate_hz=1000.0, duration_s=90.0, quantization_rad=Q12, seed=91,
                             start_s=30.0, effects=[dict(effect="input_delay", axis="both", value=0.02)]))
    d = diagnose(as_log(r))
    assert [(f.effect, f.axis) for f in d.findings] == [("input_delay", "both")]
    assert d.findings[0].parameter["value"] == pytest.approx(0.02, rel=0.05)
    assert d.verdict == "explained", d.verdict_sentence
    assert min(d.fit_after.values()) > 99.0
    assert d.settings["start_states_after"] is not None  # estimated (not the steady state of the first volts)


@pytest.mark.xfail(strict=True, reason=(
    "known defect (7 Dec 2026; bisected: passes at 6e7a582^, fails since 6e7a582 added the shifted dead zone to "
    "the library, and at ca539d2, f8d2ec3 and, its diagnose, 1d0f784): a 0.065 V shifted yaw dead zone is "
    "named beside the friction (0.0033 N m) in place of the cable, 'partly explained'; the rounds take one "
    "candidate at a time and nothing swaps a finding for its rival once a later one is in (issue #75's search)"))
def test_output_error_fit_decides_between_close_rivals():
    # yaw Coulomb friction and a yaw cable, square wave cut mid-run: the equation error ranks a yaw motor time
    # constant 2 % off its table value (gain 0.62) just above the cable (0.60); fitted by output error, the
    # cable leaves a third of the misfit the time constant leaves, and both injected effects are named
    from sim import SimSettings, simulate

    r = simulate(SimSettings(ref="square", sample_rate_hz=1000.0, duration_s=90.0, quantization_rad=Q12, seed=92,
                             start_s=30.0, effects=[dict(effect="coulomb_friction", axis="yaw", value=0.004),
                                                    dict(effect="cable_stiffness", axis="yaw", value=0.01)]))
    d = diagnose(as_log(r))
    named = {(f.effect, f.axis): f for f in d.findings}
    assert set(named) == {("cable_stiffness", "yaw"), ("coulomb_friction", "yaw")}, list(named)
    assert named["cable_stiffness", "yaw"].parameter["value"] == pytest.approx(0.01, rel=0.1)
    assert named["coulomb_friction", "yaw"].parameter["value"] == pytest.approx(0.004, rel=0.1)
    assert "the output-error fit told it apart from motor_lag:yaw" in named["cable_stiffness", "yaw"].evidence
    assert d.verdict == "explained", d.verdict_sentence


@pytest.mark.parametrize("first, value, second, kept", [
    ("dead_zone:yaw", 0.15, None, ["input_delay:both"]),
    ("coulomb_friction:yaw", None, dict(effect="coulomb_friction", axis="yaw", value=5e-3),
     ["coulomb_friction:yaw", "input_delay:both"])])
def test_an_earlier_finding_is_judged_again_given_the_later_ones(first, value, second, kept):
    # findings come one per round; one that no longer helps once a later one is in (here a yaw dead zone the log
    # does not have, put first by hand) must go, a real one (a yaw friction beside the delay) must stay
    from trms_ident.diagnosis import oe
    from trms_ident.model.effects import BY_KEY
    from trms_ident.diagnosis.model import Model, regression
    from trms_ident.diagnosis.fits import prediction_fits
    from trms_ident.diagnosis.search import _backward, block_ids, block_length, score
    from trms_ident.diagnosis.trials import at_value, effect_values, jb_estimates, try_candidate
    from trms_ident.numerics.design import design_filters
    from trms_ident.params import defaults

    effects = [dict(effect="input_delay", axis="both", value=0.03)] + ([second] if second else [])
    r = sim_cached("multisine", 100.0, 90.0, 0.0, Q12, 11, tuple(tuple(sorted(e.items())) for e in effects))
    log = as_log(r)
    p, law, n = defaults(), "quadratic", 17
    a = design_filters(log.alpha_rad, log.beta_rad, log.sample_time_s).a_rad_s
    ids = block_ids(len(log), block_length(len(log), log.sample_time_s, 1.0 / a))
    cache = {("start_states",): None}
    reg0 = regression(log, p, law, a, Model(), cache)
    sc0 = score(reg0, ids, ("pitch", "yaw"))
    c = BY_KEY[first]
    res = (try_candidate(c, log, p, law, a, Model(), cache, ids, sc0, n) if value is None else
           at_value(c, value, log, p, law, a, Model(), cache, ids, sc0, n))
    res["before"] = (Model(), reg0, sc0)
    last = at_value(BY_KEY["input_delay:both"], 0.03, log, p, law, a, res["model"], cache, ids, res["score"], n)
    last["before"] = (res["model"], res["reg"], res["score"])
    findings = [(res, []), (last, [])]
    current, augmented = last["model"], jb_estimates(last["score"], last["reg"])
    values = effect_values(current, last["score"], last["reg"])
    fit_after, _ = prediction_fits(log, p, law, current, values, augmented)
    dropped = _backward(findings, current, augmented, values, fit_after, log, p, law, a, cache, ids, n,
                        oe.Fitter(log, p, law), [], {}, None)
    assert [f[0]["c"].key for f in findings] == kept
    if second is None:
        assert [(x["effect"], x["axis"]) for x in dropped] == [("dead_zone", "yaw")]
        assert dropped[0]["reason"].startswith("given the other findings, it does not raise the yaw prediction fit")
    else:
        assert dropped == []


def test_a_rugged_dead_zone_profile_is_scanned_and_a_wrong_width_is_never_called_explained(monkeypatch):
    # a 0.4 V yaw dead zone on a square-wave log whose yaw input sits at its limit most of the time: the
    # profile over the width is rugged (a basin a few % wide, local minima elsewhere).  From 0.15 V the coarse
    # steps stop in a local minimum; the scan over the whole range finds the width.  diagnose sets the width
    # by that profile; left at the equation error's grid value the findings' model does not fit, and the verdict
    # must say so rather than "explained"
    from sim import SimSettings, simulate
    from trms_ident.diagnosis import oe, search, trials
    from trms_ident.model import effects
    from trms_ident.model.effects import BY_KEY
    from trms_ident.diagnosis.model import Model
    from trms_ident.params import defaults

    log = as_log(simulate(SimSettings(ref="square", sample_rate_hz=1000.0, duration_s=60.0, quantization_rad=Q12,
                                      seed=94, start_s=30.0,
                                      effects=[dict(effect="dead_zone", axis="yaw", value=0.4)])))
    p = defaults()
    theta0 = {k: p[k] for k in ("J1", "B1", "J2", "B2")}
    key = "dead_zone:yaw"

    def profiled():
        fitter = oe.Fitter(log, p, "quadratic")
        f = fitter.profile(Model(), {}, theta0, key, trials.value_grid(BY_KEY[key], log, p), 0.15)
        return f, fitter.check(Model().with_mod(key, f.value), {}, theta0)

    f, check = profiled()
    assert f.value == pytest.approx(0.4, rel=0.01) and check["beta"] < 1.2
    assert f.se > 1e-5  # no finer than the gap between the logged voltages either side of the width
    d = diagnose(log)
    assert [(x.effect, x.axis) for x in d.findings] == [("dead_zone", "yaw")] and d.verdict == "explained"
    assert d.findings[0].parameter["value"] == pytest.approx(0.4, rel=0.01)
    assert d.settings["output_error_check"]["rms_over_noise"]["beta"] < 1.2

    monkeypatch.setattr(oe, "PROFILE_SCAN_OVER_FLOOR", math.inf)
    f, check = profiled()
    assert abs(f.value / 0.4 - 1) > 0.3 and check["beta"] > 1.5
    # the dead zone as a modification whose value the equation error's grid sets (not a step one)
    monkeypatch.setattr(effects, "CANDIDATES", tuple(dataclasses.replace(c, step=False) if c.effect == "dead_zone"
                                                     else c for c in effects.CANDIDATES))
    monkeypatch.setattr(search, "_polish", lambda findings, current, *args: current)
    d = diagnose(log)
    assert d.settings["output_error_check"]["rms_over_noise"]["beta"] > 1.5
    # the width the grid leaves (0.0546 V, measured) simulates the yaw worse than no dead zone (2.9x its floor
    # against 2.5x) and acts on little of the thrust: refused (run._without_inert, measured), and with nothing left
    # the verdict is "unexplained", never "explained", nor "partly explained" without a finding
    assert d.findings == [] and d.verdict == "unexplained"
    wrong = [r for r in d.refused if (r["effect"], r["axis"]) == ("dead_zone", "yaw")]
    assert abs(wrong[-1]["parameter"] / 0.4 - 1) > 0.02 and "the model without it fits the log as well" in \
        wrong[-1]["reason"]


@pytest.mark.xfail(strict=True, reason=(
    "known defect (measured 5 Dec 2026; bisected: failing since 6e7a582 added the shifted dead zone to the library): "
    "a 0.008 V shifted pitch dead zone is named beside the lag and the drag, which reach both floors without it "
    "(1.05x and 1.06x, measured); a backward step refusing it by the floors alone also dropped a true 0.111 V yaw "
    "dead zone (compound.py bench 1003) and was not kept"))
def test_an_input_modification_is_fitted_again_given_the_later_findings():
    # a 1.32 s pitch motor lag and a 0.005 yaw drag: the lag, found first, is profiled while the drag is still
    # missing (both axes share the output-error cost) and lands near 1.24 s, and a pitch thrust asymmetry
    # stands in for the rest.  Profiled again with the drag in, the lag comes back to its value, and the
    # asymmetry, now negligible, is refused.  The drag, decided by output error beside the lag at 1.246 s (0.00386),
    # is fitted again with the lag at its value
    from sim import SimSettings, simulate

    log = as_log(simulate(SimSettings(ref="square", sample_rate_hz=1000.0, duration_s=90.0, noise_std_rad=1e-3,
                                      seed=95, effects=[dict(effect="quadratic_drag", axis="yaw", value=0.005),
                                                        dict(effect="motor_lag", axis="pitch", value=1.32)])))
    d = diagnose(log)
    got = {(f.effect, f.axis): f for f in d.findings}
    assert set(got) == {("motor_lag", "pitch"), ("quadratic_drag", "yaw")}
    lag = got[("motor_lag", "pitch")]
    assert lag.parameter["value"] == pytest.approx(1.32, rel=0.03)
    assert "fitted again by output error with the other findings in" in lag.evidence
    drag = got[("quadratic_drag", "yaw")]
    assert drag.parameter["value"] == pytest.approx(0.005, rel=0.03)
    assert "fitted again by output error with the other findings in: 0.00499" in drag.evidence
    assert "(was 0.00386" in drag.evidence
    assert any(r["effect"] == "thrust_asymmetry" and "negligible" in r["reason"] for r in d.refused)
    assert d.verdict == "explained"


def test_a_pitch_offset_of_no_practical_size_is_not_a_finding():
    """The equation error passes any consistent residual on a clean log; a pitch offset must also move the
    gravity torque by oe.MIN_TORQUE_SHARE of the thrust torque, as the output-error fit asks of its candidates."""
    from trms_ident.diagnosis import oe
    from trms_ident.model.effects import CANDIDATES
    from trms_ident.diagnosis.trials import practical
    from trms_ident.params import defaults

    r = sim_cached("square", 100.0, 90.0, 0.0, 0.0, 7, ())
    log, p = as_log(r), defaults()
    by_key = {c.key: c for c in CANDIDATES}
    for key in ("sensor_offset:pitch", "com_offset:pitch"):
        c = by_key[key]
        share = oe.torque_share(key, 0.005, log, p, "quadratic")
        per_n_m = oe.torque_share("coulomb_friction:pitch", 1.0, log, p, "quadratic")  # 1 / RMS thrust torque
        assert share == pytest.approx(0.005 * p["Mg"] * np.sqrt(np.mean(np.cos(r.alpha_rad) ** 2)) * per_n_m,
                                      rel=1e-9)
        assert practical(c, 0.005, log, p, "quadratic") and practical(c, -0.04, log, p, "quadratic")
        assert not practical(c, 2.6e-5, log, p, "quadratic") and not practical(c, -2.6e-5, log, p, "quadratic")
    # the floor is the offsets' only: other equation-error findings keep the tests that passed them
    assert practical(by_key["quadratic_drag:pitch"], 1e-6, log, p, "quadratic")


def test_a_friction_the_equation_error_cannot_fit_physically_is_judged_by_output_error():
    # a 0.008 N m pitch friction on a bench with little viscous friction (B1 = 0.0095, known values off Table 1):
    # the equation error's refit with the friction makes B1 = -0.023 (friction and B1 omega alike over this
    # excitation) and the finding was refused, leaving "unexplained"; the output-error fit, J/B free, passes its
    # held-out test with J/B physical and right, and those are the model's J/B
    from sim import SimSettings, simulate

    bench = {"J1": 0.1, "B1": 0.0095, "J2": 0.0171, "B2": 0.105}
    known = {"Mg": 0.318, "a1": 0.01355, "b2": 0.0941, "kc": -0.1758}
    r = simulate(SimSettings(ref="multisine", sample_rate_hz=200.0, duration_s=90.0, quantization_rad=Q12, seed=97,
                             overrides={**bench, **known},
                             effects=[dict(effect="coulomb_friction", axis="pitch", value=0.008)]))
    d = diagnose(as_log(r), known)
    assert [(f.effect, f.axis) for f in d.findings] == [("coulomb_friction", "pitch")]
    assert d.findings[0].parameter["value"] == pytest.approx(0.008, rel=0.05)
    assert any(t["effect"] == "coulomb_friction" and t["axis"] == "pitch" and t["passed"] for t in d.oe_tested)
    for k, v in bench.items():
        assert d.augmented[k] == pytest.approx(v, rel=0.05), k
    assert d.settings["estimates_augmented_from"] == "output_error"
    assert d.verdict == "explained", d.verdict_sentence
    from trms_ident.report.diagnosis import render, to_doc

    page = render(to_doc(d, as_log(r)), d, as_log(r))
    assert "with findings (output-error fit: the equation error's were not physical)" in page


def test_an_output_error_question_asked_twice_is_fitted_once(monkeypatch):
    # diagnose judges a step modification in its round and again when the prediction fit refuses it: the same
    # profile (a 100 s CE150 recording spent half its time in the second one); a repeat is answered from memory
    from trms_ident.diagnosis import oe
    from trms_ident.diagnosis.model import Model
    from trms_ident.params import defaults

    r = sim_cached("multisine", 100.0, 30.0, 0.0, Q12, 3, ((("axis", "yaw"), ("effect", "dead_zone"),
                                                             ("value", 0.1)),))
    p = defaults()
    fitter = oe.Fitter(as_log(r), p, "quadratic")
    theta0 = {k: p[k] for k in ("J1", "B1", "J2", "B2")}
    grid = tuple(0.02 * 1.25 ** i for i in range(16))
    first = fitter.profile(Model(), {}, theta0, "dead_zone:yaw", grid, 0.08)
    assert first is not None and first.value == pytest.approx(0.1, rel=0.3)
    calls = []
    monkeypatch.setattr(oe.Fitter, "_fit", lambda *a, **k: calls.append(a) or pytest.fail("fitted again"))
    assert fitter.profile(Model(), {}, dict(theta0), "dead_zone:yaw", list(grid), 0.08) is first
    assert not calls
    # a different question is not answered from memory
    with pytest.raises(pytest.fail.Exception, match="fitted again"):
        fitter.profile(Model(), {}, theta0, "dead_zone:yaw", grid, 0.12)


def test_the_findings_model_is_checked_at_its_converged_fit(monkeypatch):
    # the verdict's output-error check of the findings' model read the error of a fit that had run out of
    # iterations (a crawl from the table's B1 towards 0.0095 on a power-benchmark bench): a 0.008 N m pitch
    # friction found at 0.00799 N m was called partly explained.  A model's fit that stopped short goes on from
    # there (oe.Fitter.base, which the check and every profile's drop read)
    from trms_ident.diagnosis import oe
    from trms_ident.diagnosis.model import Model
    from trms_ident.diagnosis.verdict import EXPLAINED_OE_OVER_NOISE
    from trms_ident.params import defaults

    r = sim_cached("multisine", 100.0, 30.0, 0.0, Q12, 3, ((("axis", "pitch"), ("effect", "coulomb_friction"),
                                                             ("value", 0.008)),))
    p = defaults()
    model, values = Model().with_linear("coulomb_friction:pitch"), {"coulomb_friction:pitch": 0.008}
    theta0 = {k: p[k] * 1.5 for k in ("J1", "B1", "J2", "B2")}
    full = oe.Fitter(as_log(r), p, "quadratic").check(model, values, theta0)
    assert full is not None and max(full.values()) < EXPLAINED_OE_OVER_NOISE
    fit = oe.Fitter._fit
    short = []

    def one_iteration_first(self, *a, **k):  # the base fit stops after one iteration, as out of iterations
        if not short:
            k["max_iterations"] = 1
        out = fit(self, *a, **k)
        short.append(out.converged)
        return out

    monkeypatch.setattr(oe.Fitter, "_fit", one_iteration_first)
    stopped = oe.Fitter(as_log(r), p, "quadratic")
    checked = stopped.check(model, values, theta0)
    assert short[0] is False and short[1] is True  # the short fit, then one that went on from it
    assert checked == pytest.approx(full, rel=0.02)
    base = stopped.base(model, values, theta0)  # the base is that fit: a profile's drop is not the crawl's end
    assert max(base.rms_rad[a] / stopped.noise_floor[a] for a in stopped.noise) < EXPLAINED_OE_OVER_NOISE


def test_a_screens_point_is_one_fit_and_a_shooting_start_above_the_models_fit_is_not_gone_on_with(monkeypatch):
    """Two economies of the model's own fit (oe.Fitter.base), each measured to cost seconds a log (diagnose_speed
    seed 69508, a saturation log 2.1x slower): a screen's point (judge.py's pair screens the other motor's level
    over its grid) is the model's fit as one fit leaves it (first_fit), cached, and the model's own fit goes on from
    that fit instead of fitting it again; a multiple-shooting start whose first fit is not below the model's fit is
    not gone on with (_from_shooting), however far from converged that first fit is."""
    from trms_ident.diagnosis import oe
    from trms_ident.diagnosis.model import Model
    from trms_ident.params import defaults

    r = sim_cached("multisine", 100.0, 30.0, 0.0, Q12, 3, ())
    p = defaults()
    theta0 = {k: p[k] * 1.5 for k in ("J1", "B1", "J2", "B2")}
    fit, calls = oe.Fitter._fit, []

    def counted(self, *a, **k):
        calls.append(dict(k))
        return fit(self, *a, **k)

    monkeypatch.setattr(oe.Fitter, "_fit", counted)
    fitter = oe.Fitter(as_log(r), p, "quadratic")
    first = fitter.first_fit(Model(), {}, theta0)
    assert len(calls) == 1 and fitter.first_fit(Model(), {}, theta0) is first and len(calls) == 1
    base = fitter.base(Model(), {}, theta0)
    assert base.cost <= first.cost
    assert all(k.get("start") is not None or k.get("window_s") for k in calls[1:])  # never the first fit again

    def short_after_shooting(self, *a, **k):  # every fit from a shooting start stops after one iteration
        if k.get("start") is not None and not k.get("window_s"):
            k["max_iterations"] = 1
        calls.append(dict(k))
        return fit(self, *a, **k)

    monkeypatch.setattr(oe.Fitter, "_fit", short_after_shooting)
    calls.clear()
    assert fitter._from_shooting(Model(), {}, theta0, base) is base  # the converged fit at the floor stays
    assert len(calls) == 2  # the shooting fit and one fit from it, nothing more
    assert fitter._from_shooting(Model(), {}, theta0, base) is base and len(calls) == 2  # made once (the check's)


def test_the_equation_error_orders_and_the_output_error_test_decides(monkeypatch):
    # a clean log, with the equation-error test made to pass a yaw cable that is not there: the output-error fit
    # carries a cable, so its held-out test decides, and it does not pass it (the equation error used to decide)
    from trms_ident.diagnosis import search
    from trms_ident.diagnosis.select import Test

    real = search.try_candidate

    def forced(c, *args):
        res = real(c, *args)
        if res is not None and c.key == "cable_stiffness:yaw":
            res = {**res, "test": Test(gain=0.5, t=20.0, p=1e-12, share=0.1, passed=True), "value": 0.005}
        return res

    monkeypatch.setattr(search, "try_candidate", forced)
    d, _ = _diag("multisine", 200.0, 60.0, noise=5e-4, seed=41)
    assert not d.findings and d.verdict == "consistent"
    (refused,) = [r for r in d.refused if r["effect"] == "cable_stiffness"]
    assert refused["reason"].startswith("in round 1, the equation-error test passed it, the output-error test that "
                                        "decides does not: ")
    assert any(t["effect"] == "cable_stiffness" and not t["passed"] for t in d.oe_tested)
    # and a real yaw drag: the equation error passes it, the output-error test decides it, the evidence says so
    monkeypatch.undo()
    d, _ = _diag("multisine", 100.0, 90.0, [dict(effect="quadratic_drag", axis="yaw", value=0.02)])
    (f,) = d.findings
    assert (f.effect, f.axis) == ("quadratic_drag", "yaw") and f.parameter["value"] == pytest.approx(0.02, rel=0.05)
    assert "the output-error test that decides passed it: output-error fit with the effect's parameter free" in f.evidence
    assert any(t["effect"] == "quadratic_drag" and t["passed"] for t in d.oe_tested)


def test_findings_whose_refitted_j_b_are_not_credible_never_explain_the_log():
    from trms_ident.diagnosis.verdict import credible
    good = {"J1": 0.07, "B1": 0.005, "J2": 0.021, "B2": 0.09}
    assert credible("explained", "s.", good) == ("explained", "s.")
    verdict, sentence = credible("explained", "s.", {**good, "J1": 1.3e15})
    assert verdict == "partly_explained"
    assert "(J1 = 1.3e+15: not positive, or more than 100x from Table 1)" in sentence and "leads" in sentence
    assert credible("partly_explained", "s.", {**good, "B2": -1.0})[0] == "partly_explained"


@pytest.mark.parametrize("rho, within", [(0.0, 0.1), (0.95, 0.3)])
def test_a_profiled_values_standard_error_holds_when_the_errors_are_correlated(rho, within):
    # y = v g + e, fitted by profiling v: the profile's per-block costs at three values around the minimum give
    # the standard error.  Against the spread of the estimate over 200 draws: with white e it is the curvature's
    # 1/sqrt(g'g); with e correlated over ~20 samples (a model that misses something) batch means keep it
    # honest where the curvature claims six times too little
    from scipy.signal import lfilter

    from trms_ident.diagnosis.oe import profile_se

    rng = np.random.default_rng(7)
    n, per_block = 4000, 100
    g = np.sin(np.arange(n) * 0.01) + 0.5
    estimates, ses = [], []
    for _ in range(200):
        e = lfilter([math.sqrt(1.0 - rho * rho)], [1.0, -rho], rng.standard_normal(n))
        y = g + e
        v = float(g @ y / (g @ g))
        x = v + np.array([-0.05, 0.0, 0.05])
        costs = np.array([np.sum(((y - xi * g) ** 2).reshape(-1, per_block), axis=1) for xi in x])
        estimates.append(v)
        ses.append(profile_se(x, costs, v))
    spread = float(np.std(estimates))
    assert float(np.median(ses)) == pytest.approx(spread, rel=within)
    if rho:
        assert float(np.median(ses)) > 3.0 / math.sqrt(g @ g)  # the curvature's white-noise answer


def test_an_axis_the_findings_model_cannot_predict_is_never_explained():
    # a prediction fit that is not a number (J or B not physical) had made the error ratio NaN, which compares
    # false with every threshold: such a model could be called explained; a real CE150 sweep printed "nanx"
    from types import SimpleNamespace

    from trms_ident.diagnosis.verdict import verdict_of

    log = SimpleNamespace(alpha_rad=np.linspace(0, 0.3, 100), beta_rad=np.linspace(0, 0.2, 100))
    seed = {"adequate": False, "axes": {"pitch": {"noise_floor_rad": 1e-3}, "yaw": {"noise_floor_rad": 1e-3}}}
    verdict, sentence = verdict_of(log, seed, ["a finding"], {"pitch": math.nan, "yaw": 99.99}, {}, None)
    assert verdict == "partly_explained"
    assert "(the pitch prediction error cannot be told: the findings' model has no prediction of it)" in sentence
    assert "nan" not in sentence


def test_a_seed_model_as_good_as_the_black_box_on_a_smoothed_log_is_consistent_when_nothing_is_found():
    # estimate says "not decided" (no noise floor to judge by, and the seed model simulates the angles as well as a
    # flexible black box): diagnose, finding nothing, must not call that physics outside the library (measured
    # on a real CE150 azimuth sweep: "unexplained" beside estimate's "not decided")
    from types import SimpleNamespace

    from trms_ident.diagnosis.verdict import verdict_of

    log = SimpleNamespace(alpha_rad=np.linspace(0, 0.3, 100), beta_rad=np.linspace(0, 0.2, 100))
    undecided = {"adequate": None, "floor_used": "black_box"}
    seed = {"adequate": None, "sentence": "Not decided: ...", "axes": {"pitch": dict(undecided), "yaw": dict(undecided)}}
    verdict, sentence = verdict_of(log, seed, [], {"pitch": 99.0, "yaw": 99.0}, {}, None)
    assert verdict == "consistent" and sentence.startswith("the seed model simulates this log as well as a flexible")
    assert sentence.endswith("Not decided: ...")
    # an axis the black box beats does not fit; a fit that did not converge decides nothing: both stay unexplained
    for axis in ({"adequate": False, "floor_used": "black_box"}, {"adequate": None, "floor_used": "noise"}):
        seed["axes"]["yaw"] = axis
        seed["adequate"] = axis["adequate"]
        verdict, sentence = verdict_of(log, seed, [], {"pitch": 99.0, "yaw": 99.0}, {}, None)
        assert verdict == "unexplained"
        # nothing found alone does not tell physics outside the library from several differences at once
        assert sentence.startswith("no effect in the library improves the fit alone: the mismatch is physics "
                                   "outside the library, or more than one difference at once")


def test_the_output_error_check_decides_the_verdict_when_it_can_carry_the_findings():
    """Explained rests on the findings' model simulated by output error, the test estimate applies to the seed
    model (within 1.2x the noise level), not on the 2 s predictions, which restart from measured angles and use
    the equation error's J/B; a ratio that is not a number never passes."""
    from types import SimpleNamespace

    from trms_ident.diagnosis.verdict import verdict_of

    log = SimpleNamespace(alpha_rad=np.linspace(0, 0.3, 100), beta_rad=np.linspace(0, 0.2, 100))
    seed = {"adequate": False, "axes": {"pitch": {"noise_floor_rad": 1e-3}, "yaw": {"noise_floor_rad": 1e-3}}}
    poor_predictions = {"pitch": 50.0, "yaw": 50.0}
    assert verdict_of(log, seed, ["f"], poor_predictions, {}, {"alpha": 1.0, "beta": 1.1})[0] == "explained"
    verdict, sentence = verdict_of(log, seed, ["f"], {"pitch": 99.99, "yaw": 99.99}, {}, {"alpha": 1.0, "beta": 1.3})
    assert verdict == "partly_explained" and "yaw angle's error is still 1.3x" in sentence
    assert verdict_of(log, seed, ["f"], {"pitch": 99.99, "yaw": 99.99}, {}, {"alpha": math.nan, "beta": 1.0})[0] \
        == "partly_explained"


def test_the_rescue_fits_candidates_on_an_axis_left_above_its_floor_first():
    # power benchmark log 134 (0.1 V yaw dead zone, square wave at 1 kHz, mid-run): the pitch fitted at 1.00x its
    # floor, the yaw at 1.89x; two pitch motor lags led the equation error's gains (0.16-0.18, at p = 1) and took
    # two of the rescue's three places, and the dead zone (gain 0.0036) was never fitted by output error
    from trms_ident.diagnosis import judge
    from trms_ident.diagnosis.select import Test
    from trms_ident.model.effects import by_key

    def res(key, gain, t):
        return {"c": by_key(key), "test": Test(gain=gain, t=t, p=0.5, share=0.0, passed=False)}

    results = [res("motor_second_lag:pitch", 0.18, -262.0), res("motor_lag:pitch", 0.16, -38.0),
               res("cable_stiffness:yaw", 0.01, 3.0), res("thrust_asymmetry:pitch", 0.005, 3.7),
               res("dead_zone:yaw", 0.0036, 2.7), res("input_delay:both", 0.002, 5.2)]
    keys = [r["c"].key for r in judge._rescue_order(results, {"yaw"})]
    assert keys == ["cable_stiffness:yaw", "dead_zone:yaw", "input_delay:both"]
    # power log 149: a pitch saturation left the pitch at its floor and the yaw at 3.7x (u1 drives the yaw through
    # the reaction torque): it acts on the yaw and leads
    sat = res("input_saturation:pitch", 0.90, 2.5)
    keys = [r["c"].key for r in judge._rescue_order(results + [sat], {"yaw"})]
    assert keys == ["input_saturation:pitch", "cable_stiffness:yaw", "dead_zone:yaw"]
    # both axes off (the sparse-correction tests' bench, Kg and kc off): by gain alone, as before
    keys = [r["c"].key for r in judge._rescue_order(results, {"pitch", "yaw"})]
    assert keys == ["motor_second_lag:pitch", "motor_lag:pitch", "cable_stiffness:yaw"]
    # a motor's time constant among them whose output-error fit lowers the cost brings that motor of second order
    # after them, however low the equation error ranked it (independent.py seed 3307 bench 14: the lag tested at the
    # table's T11 fell below the first eight; T11 alone dropped the cost 13 %); one whose fit raised the cost does
    # not (diagnose_speed.py seed 5813 bench 20: the main motor's form passed on a dead zone and k2 off)
    lags = [res("motor_lag:pitch", 0.61, 4.1), res("cable_stiffness:yaw", 0.23, 1.4), res("motor_lag:yaw", 0.15, 1.6),
            res("input_delay:both", 0.14, -3.9), res("motor_second_lag:pitch", 0.001, -1.0),
            res("motor_second_lag:yaw", 0.001, -1.0)]
    keys = [r["c"].key for r in judge._rescue_order(lags, {"pitch", "yaw"})]
    assert keys == ["motor_lag:pitch", "cable_stiffness:yaw", "motor_lag:yaw"]
    drops = {"motor_lag:pitch": 0.13, "cable_stiffness:yaw": 0.2, "motor_lag:yaw": -0.09}
    assert [r["c"].key for r in judge._second_order_forms(lags, drops)] == ["motor_second_lag:pitch"]
    assert [r["c"].key for r in judge._second_order_forms(lags, {**drops, "motor_lag:pitch": -4.4})] == []
    assert judge._second_order_forms(lags, {**drops, "motor_second_lag:pitch": 0.3}) == []  # fitted already

    class Checked:  # the current model's output-error check: angle -> error over its floor
        def __init__(self, ratio):
            self.ratio = ratio

        def check(self, model, values, theta0):
            return self.ratio

    assert judge._misfit_axes(Checked({"alpha": 1.0, "beta": 1.89}), None, {}, {}) == {"yaw"}
    assert judge._misfit_axes(Checked({"alpha": 1.3, "beta": 1.1}), None, {}, {}) == {"pitch"}
    assert judge._misfit_axes(Checked({"alpha": math.nan, "beta": 1.0}), None, {}, {}) == {"pitch"}
    assert judge._misfit_axes(Checked(None), None, {}, {}) == {"pitch", "yaw"}  # the fit cannot say


def test_a_profile_on_a_log_cut_mid_run_starts_where_the_current_models_fit_did():
    # the profile's fits go on from the current model's J/B and its start states: restarted at the motors'
    # steady state, the fits of a steps log cut 30 s in stayed at ~1e6x the noise floor at every delay but one
    # and the 0.08 s delay's profile ran off to 0.176 s (power benchmark, seed 5093)
    from sim import SimSettings, simulate
    from trms_ident.diagnosis.model import Model
    from trms_ident.diagnosis.trials import value_grid
    from trms_ident.model.effects import BY_KEY
    from trms_ident.params import defaults

    p = defaults()
    theta0 = {k: p[k] for k in ("J1", "B1", "J2", "B2")}
    key = "input_delay:both"
    log = as_log(simulate(SimSettings(ref="steps", sample_rate_hz=250.0, duration_s=90.0, noise_std_rad=1e-3,
                                      seed=5093, start_s=30.0,
                                      effects=[dict(effect="input_delay", axis="both", value=0.08)])))
    fitter = oe.Fitter(log, p, "quadratic")
    f = fitter.profile(Model(), {}, theta0, key, value_grid(BY_KEY[key], log, p), 0.06)
    assert f.value == pytest.approx(0.08, rel=0.02)
    assert oe.passes(f, 24, 0.05) and f.excess_share > 0.99
    base = fitter.base(Model(), {}, theta0)
    at_truth = fitter._fit(Model(), {}, base.estimate, None, {key: 0.08}, start=base.start_states)
    assert at_truth.cost < 1.1 * 2 * fitter.n  # the true delay fits to the noise floor from there


def test_a_refusal_says_a_fit_that_is_not_a_number_in_words():
    """A finding refused while the model has no physical J/B to predict with (the CE150 elevation ramp, measured)
    says so in words; 'nan %' reached the user once (CI, Data100_ea_a0)."""
    from trms_ident.diagnosis.search import _refusal
    from trms_ident.model.effects import Candidate
    c = Candidate("com_offset", "pitch", "delta", "rad", "linear")
    ok = {"J1": 0.07, "B1": 0.006, "J2": 0.02, "B2": 0.1}
    why = _refusal(c, ok, ok, {"pitch": math.nan, "yaw": math.nan}, {"pitch": math.nan, "yaw": math.nan})
    assert why == ("it does not raise the pitch prediction fit (n/a (J or B not physical: no prediction) -> "
                   "n/a (J or B not physical: no prediction))")
    assert _refusal(c, ok, ok, {"pitch": 90.0}, {"pitch": 95.0}) is None
    assert "(95.00 % -> 90.00 %)" in _refusal(c, ok, ok, {"pitch": 95.0}, {"pitch": 90.0})


def test_a_modification_finding_that_acts_on_no_sample_that_matters_is_refused_and_the_verdict_stands():
    """Whichever step placed it, an input-modification finding that changes its motor's thrust by less than the
    practical size (oe.MIN_MODIFICATION_SHARE) is not a finding (measured: a 6.3e-7 V dead zone named beside a
    right saturation); the fit without it is the same, so the verdict stands."""
    from dataclasses import replace

    from trms_ident.diagnosis.run import _without_inert
    from trms_ident.log import validated
    from trms_ident.params import merge

    from .plants import textbook
    from .test_compound import _diagnosis, _finding

    t, u1, u2, a, b = textbook.simulate_log(10.0, 100.0, seed=3)
    log = validated(t, u1, u2, a, b, source="textbook", angle_unit="rad")
    tiny, real = _finding("shifted_dead_zone", "pitch", "w", 6.3e-7), _finding("input_saturation", "pitch", "U", 0.9)
    d = replace(_diagnosis([tiny, real]), verdict="explained",
                steps=[{"key": "shifted_dead_zone:pitch"}, {"key": "input_saturation:pitch"}])
    out = _without_inert(d, log, merge({}), "quadratic")
    assert out.findings == [real] and out.verdict == "explained" and out.steps == [{"key": "input_saturation:pitch"}]
    assert out.refused[-1]["effect"] == "shifted_dead_zone" and "below the practical size" in out.refused[-1]["reason"]
    alone = _without_inert(replace(_diagnosis([tiny]), verdict="explained"), log, merge({}), "quadratic")
    assert alone.findings == [] and alone.verdict == "consistent"
    kept = _without_inert(replace(_diagnosis([_finding("shifted_dead_zone", "pitch", "w", 0.1)]),
                                  verdict="explained"), log, merge({}), "quadratic")
    assert len(kept.findings) == 1  # a 0.1 V dead zone acts


def test_a_small_modification_the_fit_needs_is_kept_and_a_log_it_explains_is_never_called_consistent(monkeypatch):
    """The share of the thrust a modification changes is no measure of its need where thrust and reaction hold an
    axis nearly balanced (measured: a 0.42 s second lag of the CE150's tail motor on its elevation ramp, 0.00099 of
    the thrust's RMS, brings the yaw from 25 000x its floor to it; refused on its share, the verdict had become
    "consistent" with the seed model's yaw fit at 10 %).  _without_inert refuses a small one only when the model
    without it fits as well, measured: here every modification counts as small (the practical size raised), and a
    log's own 0.25 V dead zone is kept, the verdict explained; the same finding on a clean log is refused."""
    from dataclasses import replace

    from trms_ident.diagnosis import oe
    from trms_ident.diagnosis.result import VERDICTS
    from trms_ident.diagnosis.run import _without_inert
    from trms_ident.log import validated
    from trms_ident.params import merge

    from .plants import textbook
    from .test_compound import _diagnosis, _finding

    monkeypatch.setattr(oe, "MIN_MODIFICATION_SHARE", math.inf)
    zone = _finding("shifted_dead_zone", "yaw", "w", 0.25)
    for dead_zone_v, kept in (((0.0, 0.25), True), (None, False)):
        t, u1, u2, a, b = textbook.simulate_log(20.0, 100.0, seed=3, dead_zone_v=dead_zone_v)
        log = validated(t, u1, u2, a, b, source="textbook", angle_unit="rad")
        for verdict in ("explained", "partly_explained"):
            said = VERDICTS[verdict] + ". What the rule said."
            out = _without_inert(replace(_diagnosis([zone]), verdict=verdict, verdict_sentence=said), log, merge({}),
                                 "quadratic")
            # refused, the verdict is the model's without it: the clean log's seed model reaches its floors, and
            # nothing of the findings' words stays
            assert (out.findings == [zone] and out.verdict == verdict and out.verdict_sentence == said) if kept else \
                (out.findings == [] and out.verdict == "consistent" and
                 out.verdict_sentence == VERDICTS["consistent"] + "."), (dead_zone_v, verdict)
    # a finding that changes nothing on a log the model without it leaves above its floors (its yaw dead zone not
    # found): unexplained, what the rule said after the verdict kept
    t, u1, u2, a, b = textbook.simulate_log(20.0, 100.0, seed=3, dead_zone_v=(0.0, 0.25))
    log = validated(t, u1, u2, a, b, source="textbook", angle_unit="rad")
    tiny = _finding("shifted_dead_zone", "pitch", "w", 1e-6)
    said = VERDICTS["partly_explained"] + ". Refitted alone, every known value ran off."
    out = _without_inert(replace(_diagnosis([tiny]), verdict="partly_explained", verdict_sentence=said), log,
                         merge({}), "quadratic")
    assert out.findings == [] and out.verdict == "unexplained"
    assert out.verdict_sentence == VERDICTS["unexplained"] + ". Refitted alone, every known value ran off."


def test_a_dead_zone_form_that_leaves_the_log_unexplained_is_searched_again_without_it(monkeypatch):
    """The search picks a dead zone's form before a second difference is in the model (run._other_forms): where the
    log stays unexplained beside it and its other form passed its output-error test too, the search runs again
    without the form found, and that diagnosis is kept when it explains the log, the first form said as refused;
    kept as it was when it does not, and never tried when the first diagnosis explains the log or the other form
    did not pass."""
    from dataclasses import replace

    from trms_ident.diagnosis import run
    from trms_ident.log import validated

    from .plants import textbook
    from .test_compound import _diagnosis, _finding

    t, u1, u2, a, b = textbook.simulate_log(10.0, 100.0, seed=3)
    log = validated(t, u1, u2, a, b, source="textbook", angle_unit="rad")
    rival = {"effect": "shifted_dead_zone", "axis": "pitch", "after": [], "parameter": 0.23, "passed": True}
    cut = replace(_diagnosis([_finding("dead_zone", "pitch", "w", 0.43)]), verdict="partly_explained",
                  verdict_sentence="partly.", oe_tested=[rival])
    both = replace(_diagnosis([_finding("shifted_dead_zone", "pitch", "w", 0.17),
                               _finding("shifted_dead_zone", "yaw", "w", 0.19)]), verdict="explained",
                   verdict_sentence="explained.")
    calls = []

    def searched(answers):
        def fake(log, overrides, p, law, a_rad_s, progress, seed, gated, shared=None):
            calls.append([g["key"] for g in gated])
            return answers[len(calls) - 1], list(gated), None
        return fake

    monkeypatch.setattr(run, "_stops_seen", lambda *args: [])
    monkeypatch.setattr(run, "_searched", searched([cut, both]))
    d = run.diagnose(log, seed=object())
    assert calls == [[], ["dead_zone:pitch"]]
    assert d.verdict == "explained" and [f.effect for f in d.findings] == ["shifted_dead_zone"] * 2
    assert d.refused[-1]["effect"] == "dead_zone" and d.refused[-1]["reason"].startswith(run.OTHER_FORM)
    assert "simulated it worse" not in d.verdict_sentence  # not said as the held-out gate's refusal

    calls.clear()
    monkeypatch.setattr(run, "_searched", searched([cut, replace(cut, verdict="unexplained")]))
    d = run.diagnose(log, seed=object())
    assert calls == [[], ["dead_zone:pitch"]] and d.verdict == "partly_explained" and d.refused == []

    calls.clear()
    monkeypatch.setattr(run, "_searched", searched([replace(cut, verdict="explained")]))
    assert run.diagnose(log, seed=object()).verdict == "explained" and calls == [[]]

    calls.clear()  # the other form never passed its test: the rerun could not name it first, not tried
    monkeypatch.setattr(run, "_searched", searched([replace(cut, oe_tested=[{**rival, "passed": False}]), both]))
    assert run.diagnose(log, seed=object()).verdict == "partly_explained" and calls == [[]]


def test_fitters_sharing_answers_fit_a_question_once():
    """diagnose's reruns of the search (held-out gate, a dead zone's other form) share the output-error answers
    (oe.Fitter.share_answers): a candidate one fitter fitted is answered to the next from there, the same answer,
    without a fit; a question not asked before is fitted."""
    from trms_ident.diagnosis import oe
    from trms_ident.diagnosis.model import Model
    from trms_ident.log import validated
    from trms_ident.params import defaults

    from .plants import textbook

    t, u1, u2, a, b = textbook.simulate_log(20.0, 100.0, seed=3)
    log = validated(t, u1, u2, a, b, source="textbook", angle_unit="rad")
    p = defaults()
    theta0 = {k: p[k] for k in ("J1", "B1", "J2", "B2")}
    shared: dict = {}
    first = oe.Fitter(log, p, "quadratic")
    first.share_answers(shared)
    got = first.candidate(Model(), {}, theta0, "coulomb_friction:pitch")
    assert got is not None
    second = oe.Fitter(log, p, "quadratic")
    second.share_answers(shared)
    fits = []
    real = second._fit
    second._fit = lambda *args, **kw: fits.append(args) or real(*args, **kw)
    assert second.candidate(Model(), {}, theta0, "coulomb_friction:pitch") is got and fits == []
    second.candidate(Model(), {}, theta0, "cable_stiffness:yaw")
    assert fits  # a new question is fitted
