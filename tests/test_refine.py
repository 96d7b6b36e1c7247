"""Prediction-error refinement after DREM: sensitivities, convergence, intervals, and when it is not used."""
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

import trms_ident.identify as identify_mod
from trms_ident.cli import app
from trms_ident.identify import Settings, identify
from trms_ident.model import plant as P
from trms_ident.numerics import refine as R
from trms_ident.numerics.filters import discretize
from trms_ident.numerics.hold import motor_states_on_grid
from trms_ident.numerics.kernel_args import readonly
from trms_ident.params import defaults

from sim import SimSettings, simulate

from .conftest import as_log, sim_cached

NAMES = ("J1", "B1", "J2", "B2")


def test_held_motor_states_match_scipy_zero_order_hold_and_a_fine_integration():
    p = defaults()
    rng = np.random.default_rng(0)
    for dt in (1e-3, 1e-2):
        u1, u2 = rng.uniform(-2, 2, 3000), rng.uniform(-2, 2, 3000)
        t = np.arange(3000) * dt
        m = motor_states_on_grid(t, u1, u2, t, p)
        ref = np.column_stack([
            discretize([p["k1"]], [p["T11"], p["T10"]], dt, "zoh").apply(u1),
            discretize([p["k2"]], [p["T21"], p["T20"]], dt, "zoh").apply(u2),
            discretize([p["k1"]], np.polymul([p["Tp"], 1.0], [p["T11"], p["T10"]]), dt, "zoh").apply(u1)])
        np.testing.assert_allclose(m, ref, atol=1e-10)
    # jittered stamps, grid times between them: against Euler steps of 1 us with every switch at its stamp
    t = np.concatenate([[0.0], np.cumsum(1e-2 * rng.uniform(0.75, 1.25, 299))])
    u1, u2 = rng.uniform(-2, 2, 300), rng.uniform(-2, 2, 300)
    grid = np.linspace(0.0, t[-1], 217)
    m = motor_states_on_grid(t, u1, u2, grid, p)
    fine = np.arange(0.0, t[-1] + 5e-7, 1e-6)
    held = np.searchsorted(t, fine, side="right") - 1
    x = np.array([p["k1"] / p["T10"] * u1[0], p["k2"] / p["T20"] * u2[0], p["k1"] / p["T10"] * u1[0]])
    out = np.empty((fine.size, 3))
    for i, k in enumerate(held):
        out[i] = x
        x = x + 1e-6 * np.array([(p["k1"] * u1[k] - p["T10"] * x[0]) / p["T11"],
                                 (p["k2"] * u2[k] - p["T20"] * x[1]) / p["T21"], (x[0] - x[2]) / p["Tp"]])
    ref = np.column_stack([np.interp(grid, fine, out[:, j]) for j in range(3)])
    np.testing.assert_allclose(m, ref, atol=2e-5)  # Euler's own error; a switch 25 % off moves tau by ~1e-3


def _pass(r, pv, starts, m0, h, out):
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    n = r.t_s.size
    return R.gauss_newton_pass(r.u1_v, r.u2_v, y, np.ones(2), starts, m0, pv, False, h, np.zeros((n, 2)),
                               R.MAX_SUBSTEP_S, n, 1000, out, np.zeros((n, 2, 0)))


@pytest.mark.parametrize("jitter, effects", [
    (0.0, {}), (0.2, {}),
    # the effects the output-error fit carries change the Jacobian (friction's slope, the cable's beta term,
    # the reversed rotors' thrust): the sensitivities must stay exact with them in
    (0.1, {"coulomb_friction:pitch": 2e-3, "quadratic_drag:yaw": 0.02, "cable_stiffness:yaw": 0.005,
           "thrust_asymmetry:pitch": -0.2, "thrust_asymmetry:yaw": 0.3, "coulomb_friction:yaw": 3e-3,
           "quadratic_drag:pitch": 0.01, "com_offset:pitch": 0.04, "yaw_inertia_pitch:yaw": 0.004,
           "sensor_offset:pitch": 0.02})])
def test_forward_sensitivities_match_finite_differences(jitter, effects):
    # every unknown: J1, B1, J2, B2, the start states tau1(0), tau2(0), zeta(0), the window's start angles/rates
    r = simulate(SimSettings(ref="square", duration_s=10.0, jitter=jitter, seed=2))
    n = r.t_s.size
    h = np.diff(r.t_s)
    base = P.model_vector(defaults(), effects=effects)
    starts, m0 = np.array([[0.01, 0.2, 0.02, 0.3]]), np.array([0.3, -0.2, 0.1, 0.0, 0.0])  # no further lags
    out = np.empty((n, 2))
    _, a, b, _ = _pass(r, base, starts, m0, h, out)
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    jac = np.empty((n, 2, R.NU))
    for i in range(R.NU):
        pv, st, m = base.copy(), starts.copy(), m0.copy()
        step = 1e-6 * pv[i] if i < 4 else 1e-6
        if i < 4:
            pv[i] += step
        elif i < R.NG:
            m[i - 4] += step
        else:
            st[0, i - R.NG] += step
        pert = np.empty((n, 2))
        _pass(r, pv, st, m, h, pert)
        jac[:, :, i] = (pert - out) / step
    np.testing.assert_allclose(np.diag(a[0]), np.einsum("kci,kci->i", jac, jac), rtol=1e-4)
    np.testing.assert_allclose(b[0], np.einsum("kci,kc->i", jac, y - out), rtol=1e-3, atol=1e-9 * np.abs(b[0]).max())


def test_refinement_converges_to_the_truth_from_a_poor_start_and_finds_the_start_states():
    # a log cut from the middle of a run: the motors and M_R's lag are far from the first voltage's steady state
    r = simulate(SimSettings(ref="multisine", sample_rate_hz=200.0, duration_s=60.0, start_s=33.0, seed=4))
    truth = r.truth["estimated"]
    start = {k: v * f for (k, v), f in zip(truth.items(), (1.05, 0.7, 0.95, 1.1))}
    res = R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / 200.0, defaults(), "quadratic", start,
                   {"alpha": 1e-6, "beta": 1e-6})
    assert res.converged
    for k in NAMES:
        assert res.estimate[k] == pytest.approx(truth[k], rel=1e-8)
        lo, hi = res.ci95[k]
        assert lo <= truth[k] <= hi  # the integrator's own error is inside the interval
    assert res.start_states["beta_dot_0_rad_s"] == pytest.approx(r.true_state[0, 3], abs=1e-8)
    assert res.prediction.shape == (r.t_s.size, 2)


def test_refined_estimate_is_the_headline_and_its_intervals_cover_on_noisy_logs():
    # 95 % intervals over 8 noise seeds x 4 parameters; the errors scaled by the intervals' standard
    # errors must look like N(0, 1), not wider (the motors' unknown start once made B2's 2.5x too wide)
    covered, z = 0, []
    for seed in range(8):
        r = sim_cached("sine", 200.0, 60.0, 1e-3, 0.0, 10 + seed)
        res = identify(as_log(r))
        assert res.headline == "refined" and res.refined is not None and res.refined.converged
        for k, v in r.truth["estimated"].items():
            ci = res.intervals[k]
            assert res.estimates[k] == res.refined.estimate[k]
            covered += ci.low <= v <= ci.high
            z.append((res.estimates[k] - v) / ((ci.high - ci.low) / 2 / 1.97))
    assert covered >= 28, covered
    assert float(np.sqrt(np.mean(np.square(z)))) < 1.4, np.round(z, 2)


def test_refinement_not_used_when_the_model_misses_something():
    # a yaw cable the seed model lacks: the refined angles cannot reach the noise level
    r = sim_cached("multisine", 200.0, 90.0, 0.0, 2 * np.pi / 4096, 7,
                   ((("axis", "yaw"), ("effect", "cable_stiffness"), ("value", 0.004)),))
    res = identify(as_log(r))
    assert res.headline == "offline"
    assert "NOT used" in res.refine_note
    assert res.estimates["J1"] == res.offline["J1"]


def test_refinement_modes_and_the_automatic_length_limit(monkeypatch):
    log = as_log(sim_cached("square", 1000.0, 20.0))
    off = identify(log, Settings(refine="off"))
    assert off.refined is None and off.headline == "offline" and "off" in off.refine_note
    monkeypatch.setattr(identify_mod, "REFINE_AUTO_MAX_STEPS", 1000)
    auto = identify(log)
    assert auto.refined is None and auto.headline == "offline" and "skipped" in auto.refine_note
    forced = identify(log, Settings(refine="on"))
    assert forced.headline == "refined"
    drem = identify(log, Settings(headline="drem"))
    assert drem.headline == "drem" and drem.estimates["J1"] == drem.drem_final["J1"]


def test_cli_reports_the_refinement(tmp_path, square_csv):
    res = CliRunner().invoke(app, ["estimate", str(square_csv), "-o", str(tmp_path / "o"), "--no-report",
                                   "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["headline"] == "refined" and doc["refined"]["used"] is True
    assert set(doc["refined"]["estimates"]) == set(NAMES)
    assert "prediction-error refinement" in res.stderr
    res = CliRunner().invoke(app, ["estimate", str(square_csv), "-o", str(tmp_path / "p"), "--no-report",
                                   "--refine", "sometimes"])
    assert res.exit_code == 2 and "refine must be one of" in res.output


@pytest.mark.parametrize("signed", [False, True])
def test_freed_values_sensitivities_are_exact(signed):
    # every model value the kernel differentiates itself (known values but the motors', the effects, an exogenous
    # torque's parameter) against a central difference of the pass; the effects are in, so that each term acts
    r = simulate(SimSettings(ref="multisine", duration_s=10.0, jitter=0.1, seed=4))
    n = r.t_s.size
    h = np.diff(r.t_s)
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    effects = {"coulomb_friction:pitch": 2e-3, "coulomb_friction:yaw": 3e-3, "quadratic_drag:pitch": 0.01,
               "quadratic_drag:yaw": 0.02, "cable_stiffness:yaw": 0.005, "thrust_asymmetry:pitch": -0.2,
               "thrust_asymmetry:yaw": 0.3, "com_offset:pitch": 0.04, "yaw_inertia_pitch:yaw": 0.004,
               "sensor_offset:pitch": 0.02}
    pv0 = P.model_vector(defaults(), effects=effects, exogenous=("gain",))
    pv0[P.N_SLOTS] = 0.5
    tq = np.ascontiguousarray(np.stack([np.sin(r.beta_rad), np.cos(3 * r.alpha_rad)], axis=1)[:, :, None])
    starts, m0 = np.array([[0.01, 0.2, 0.02, 0.3]]), np.array([0.3, -0.2, 0.1, 0.0, 0.0])  # no further lags
    slots = sorted(R.DIRECT_SLOTS) + [P.N_SLOTS]
    assert set(slots) >= set(P.EFFECT_SLOTS.values())
    assert {P.PARAM_ORDER.index(k) for k in ("Mg", "Kg", "a1", "kc")} <= set(slots)

    def run(pv, fs=()):
        out = np.empty((n, 2))
        res = R.gauss_newton_pass(r.u1_v, r.u2_v, y, np.ones(2), starts, m0, pv, signed, h, np.zeros((n, 2)),
                                  R.MAX_SUBSTEP_S, n, 1000, out, np.zeros((n, 2, 0)), ext=tq @ pv[P.N_SLOTS:],
                                  fs=np.array(fs, dtype=np.int64), tq=tq)
        return res, out

    (_, a, b, _), out = run(pv0, slots)
    assert a.shape[1] == R.NU + len(slots)
    # the fixed columns are unchanged by the freed ones
    (_, a0, b0, _), _ = run(pv0)
    np.testing.assert_array_equal(a[0, :R.NU, :R.NU], a0[0])
    def central(i, step):
        hi, lo = pv0.copy(), pv0.copy()
        hi[i] += step
        lo[i] -= step
        return (run(hi)[1] - run(lo)[1]) / (2 * step)

    jac_j1 = central(0, 1e-6 * pv0[0])
    for c, i in enumerate(slots):
        jac = central(i, 1e-6 * max(abs(pv0[i]), 1e-2))
        j = R.NU + c
        assert np.sum(jac ** 2) > 0, P.PARAM_ORDER[i] if i < len(P.PARAM_ORDER) else i
        np.testing.assert_allclose(a[0, j, j], np.sum(jac ** 2), rtol=1e-4, err_msg=str(i))
        np.testing.assert_allclose(b[0, j], np.sum(jac * (y - out)), rtol=1e-3, err_msg=str(i))
        # and its cross term with J1's column
        np.testing.assert_allclose(a[0, 0, j], np.sum(jac_j1 * jac), rtol=1e-3, atol=1e-6 * np.sqrt(a[0, 0, 0] * a[0, j, j]),
                                   err_msg=str(i))


def test_windows_give_the_same_pass_in_one_thread_or_several(monkeypatch):
    # the windows start from the motor states of motor_starts, so any split over threads gives the same bits;
    # and motor_starts from zero start states plus its sensitivity columns is motor_starts from any start
    r = simulate(SimSettings(ref="multisine", sample_rate_hz=1000.0, duration_s=12.0, jitter=0.2, seed=6))
    n = r.t_s.size
    h = np.diff(r.t_s)
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    # both motors second order: the further lags' starts (lag1(0), lag2(0)) are linear in the motors too
    pv = P.model_vector(defaults(), effects={"motor_second_lag:pitch": 0.2, "motor_second_lag:yaw": 0.3})
    win, nw = 2000, n // 2000
    starts = np.column_stack([r.alpha_rad[::win][:nw], np.zeros(nw), r.beta_rad[::win][:nw], np.zeros(nw)])
    m0 = np.array([0.3, -0.2, 0.1, 1.5, -0.7])
    dsw = np.zeros((n, 2))
    u1, u2 = readonly(r.u1_v), readonly(r.u2_v)  # the type gauss_newton_pass passes (one compiled kernel)
    free = R.motor_starts(u1, u2, pv, h, dsw, R.MAX_SUBSTEP_S, win, nw, np.zeros(5))
    direct = R.motor_starts(u1, u2, pv, h, dsw, R.MAX_SUBSTEP_S, win, nw, m0)
    np.testing.assert_allclose(R.motor_response(free, m0), direct, rtol=1e-12, atol=1e-15)

    def run(threads):
        monkeypatch.setattr(R, "THREAD_MIN_SAMPLES", 0)
        monkeypatch.setattr(R.parallel, "cores", lambda: threads)
        out = np.empty((n, 2))
        res = R.gauss_newton_pass(r.u1_v, r.u2_v, y, np.ones(2), starts, m0, pv, False, h, dsw, R.MAX_SUBSTEP_S,
                                  win, 1000, out, np.zeros((n, 2, 0)))
        return res, out

    (c1, a1, b1, s1), o1 = run(1)
    for threads in (2, 4):
        (c, a, b, s), o = run(threads)
        assert c == c1
        for x, x1 in ((a, a1), (b, b1), (s, s1), (o, o1)):
            np.testing.assert_array_equal(x, x1)
    # the predictions-only pass (sens=False: line-search trials, forward-difference columns) integrates the
    # states by the same arithmetic: the same predictions and cost to the bit, no normal equations
    out = np.empty((n, 2))
    c0, a0, b0, s0 = R.gauss_newton_pass(r.u1_v, r.u2_v, y, np.ones(2), starts, m0, pv, False, h, dsw,
                                         R.MAX_SUBSTEP_S, win, 1000, out, np.zeros((n, 2, 0)), sens=False)
    assert c0 == c1
    np.testing.assert_array_equal(out, o1)
    assert not np.any(a0) and not np.any(b0) and not np.any(s0)
    # the windows after the first still see the start states through the motors: tau1(0)'s column there
    # against a finite difference over the whole log
    step = 1e-6
    out = np.empty((n, 2))
    R.gauss_newton_pass(r.u1_v, r.u2_v, y, np.ones(2), starts, m0 + [step, 0, 0, 0, 0], pv, False, h, dsw,
                        R.MAX_SUBSTEP_S, win, 1000, out, np.zeros((n, 2, 0)))
    jac = (out - o1) / step
    w = 1  # the second window: its diagonal entry for tau1(0) is the sum of squared sensitivities
    sl = slice(w * win, (w + 1) * win)
    np.testing.assert_allclose(a1[w, 4, 4], np.sum(jac[sl] ** 2), rtol=1e-4)


@pytest.mark.parametrize("lags", [(0.2, 0.0), (0.15, 0.3)])
def test_the_further_lags_start_states_have_exact_sensitivities(lags):
    # a second-order motor's further lag state at the first sample (LAG_START_SLOTS, -3 and -4) is an unknown
    # whose angle sensitivities the kernel integrates: against a central difference of the pass in m0[3], m0[4]
    r = simulate(SimSettings(ref="square", duration_s=8.0, jitter=0.1, seed=3))
    n = r.t_s.size
    h = np.diff(r.t_s)
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    pv = P.model_vector(defaults(), effects={"motor_second_lag:pitch": lags[0], "motor_second_lag:yaw": lags[1]})
    starts, m0 = np.array([[0.01, 0.2, 0.02, 0.3]]), np.array([0.3, -0.2, 0.1, 1.2, -0.8])
    slots = [s for s, t2 in zip((-3, -4), lags) if t2 > 0]

    def run(m, fs=()):
        out = np.empty((n, 2))
        res = R.gauss_newton_pass(r.u1_v, r.u2_v, y, np.ones(2), starts, m, pv, False, h, np.zeros((n, 2)),
                                  R.MAX_SUBSTEP_S, n, 1000, out, np.zeros((n, 2, 0)), fs=np.array(fs, dtype=np.int64))
        return res, out

    (_, a, b, _), out = run(m0, slots)
    for c, i in enumerate(slots):
        hi, lo = m0.copy(), m0.copy()
        hi[-i] += 1e-5
        lo[-i] -= 1e-5
        jac = (run(hi)[1] - run(lo)[1]) / 2e-5
        j = R.NU + c
        assert np.sum(jac ** 2) > 1e-3  # it acts: a lag of a volt off moves the angles
        np.testing.assert_allclose(a[0, j, j], np.sum(jac ** 2), rtol=1e-5)
        np.testing.assert_allclose(b[0, j], np.sum(jac * (y - out)), rtol=1e-4)


def test_a_second_order_motors_lag_start_is_estimated_on_a_log_cut_mid_run():
    # a square wave with the main motor second order, cut mid-run where the lag is far from the first voltage's
    # steady state: refine estimates it (start_states' lag1_0) and J/B come out exact; without a second-order
    # motor there is no such unknown
    from trms_ident.model.plant import steady_motor_states

    t2 = 0.25
    r = simulate(SimSettings(ref="square", sample_rate_hz=200.0, duration_s=30.0, start_s=17.3, seed=5,
                             effects=[{"effect": "motor_second_lag", "axis": "pitch", "value": t2}]))
    truth = r.truth["estimated"]
    res = R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / 200.0, defaults(), "quadratic", truth,
                   {"alpha": 1e-6, "beta": 1e-6}, effects={"motor_second_lag:pitch": t2})
    assert res.converged
    # the simulator's further lag at the first sample: the held voltages of the whole run from rest through it
    i0 = round(17.3 * 200)
    run = simulate(SimSettings(ref="square", sample_rate_hz=200.0, duration_s=47.3, seed=5,
                               effects=[{"effect": "motor_second_lag", "axis": "pitch", "value": t2}]))
    np.testing.assert_array_equal(run.u1_v[i0:i0 + 100], r.u1_v[:100])
    c = math.exp(-1 / 200.0 / t2)
    lag = 0.0
    for u in run.u1_v[:i0]:
        lag = c * lag + (1.0 - c) * u
    assert abs(lag - r.u1_v[0]) > 0.1, "the lag must be off the first voltage's steady state for this test"
    assert res.start_states["lag1_0"] == pytest.approx(lag, abs=1e-6)
    assert "lag2_0" not in res.start_states
    for k in NAMES:
        assert res.estimate[k] == pytest.approx(truth[k], rel=1e-7)
    assert max(res.rms_rad.values()) < 1e-7
    plain = R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / 200.0, defaults(), "quadratic", truth,
                     {"alpha": 1e-6, "beta": 1e-6})
    assert "lag1_0" not in plain.start_states and len(steady_motor_states(0, 0, defaults())) == 3


def test_integration_error_is_estimated_with_a_really_halved_sub_step():
    # at 1 kHz the sub-step is the 1 ms sample interval: the Richardson pass must halve that (halving the 2.5 ms
    # ceiling instead left one sub-step per sample, the same pass, and an integration error of exactly 0)
    r = sim_cached("square", 1000.0, 20.0)
    res = identify(as_log(r), Settings(refine="on"))
    err = res.refined.integration_error
    assert res.refined.converged and max(err.values()) > 0.0
    for k, v in r.truth["estimated"].items():
        lo, hi = res.refined.ci95[k]
        assert lo <= v <= hi
        assert err[k] < 1e-9 * v  # RK4 at 1 ms: far below any noisy log's interval


def test_every_known_value_can_be_freed():
    # Settings checks --free against the table's known values without loading the compiled refinement
    from trms_ident.params import KNOWN

    assert R.FREEABLE == KNOWN


def test_backtracking_goes_to_the_parabolas_minimum_within_its_safeguards():
    # cost(lam) = 10 - 4 lam + q lam^2 along the step: a failed trial at lam = 1 gives the parabola exactly
    for q, expected in ((5.0, 0.4), (20.0, 0.1), (4.5, 0.4444444444444444)):
        trial = 10.0 - 4.0 + q
        assert trial > 10.0
        assert R.backtrack(1.0, 10.0, -4.0, trial) == pytest.approx(min(max(expected, 0.1), 0.5))
    assert R.backtrack(1.0, 10.0, -4.0, 10.0 - 4.0 * 0.5 + 2.5 * 0.25) == pytest.approx(0.5)  # clipped: halving
    assert R.backtrack(0.5, 10.0, -4.0, float("nan")) == pytest.approx(0.05)  # no cost there: a tenth
    assert R.backtrack(0.5, 10.0, 0.0, 12.0) == pytest.approx(0.25)  # no descent known: halving
    # every step length shrinks at least two-fold, ten-fold when the cost soars: a search that never descends
    # ends within 5 trials (halving took 14 to reach 1e-4)
    lam, n = 1.0, 0
    while lam >= 1e-4:
        lam, n = R.backtrack(lam, 10.0, -4.0, 1e6), n + 1
    assert n <= 5


def test_a_profile_over_an_offset_is_smooth_once_each_fit_has_converged():
    # power benchmark log 5074: a bench off Table 1, a 12-bit square wave at 1 kHz cut 30 s into the run, a 0.08 rad
    # centre-of-mass offset.  The stopping rule counted only what the global unknowns could still gain, so fits
    # stopped while the windows' starts had ~20 to gain: the cost profile over the offset jumped by 24 between
    # neighbouring values.  Converged fits give a parabola, whose second difference is the offset's curvature.
    from trms_ident.numerics.design import angle_noise_rad

    known = {"Mg": 0.35937742192749184, "a1": 0.010918889646463582, "b2": 0.07746372169176753,
             "kc": -0.23427544669613243}
    bench = {"J1": 0.10452220666112509, "B1": 0.005808182552502405, "J2": 0.02188675641021779,
             "B2": 0.07931861814785898}
    r = simulate(SimSettings(ref="square", sample_rate_hz=1000.0, duration_s=90.0, quantization_rad=2 * np.pi / 4096,
                             seed=5074, start_s=30.0, overrides={**bench, **known},
                             effects=[dict(effect="com_offset", axis="pitch", value=0.08)]))
    theta0 = {"J1": 0.10445822290638598, "B1": 0.005866570877466441, "J2": 0.021886771234148332,
              "B2": 0.0793180594706843}  # the equation error's estimate, where diagnose starts the fit
    noise = {"alpha": angle_noise_rad(r.alpha_rad), "beta": angle_noise_rad(r.beta_rad)}
    fits = [R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1e-3, {**defaults(), **known}, "quadratic", theta0,
                     noise, gravity_offset_rad=d) for d in (0.0800015, 0.0800025, 0.0800035)]
    assert all(f.converged for f in fits)
    c = [f.cost for f in fits]
    assert abs(c[0] - 2.0 * c[1] + c[2]) < 5.0, c  # was -29 (176.45, 200.19, 194.95 above 180 000)


def test_a_freed_saturation_level_is_estimated_with_j_b_and_its_interval_covers():
    """A tail-motor saturation acting on much of the log, freed: the refinement clips the voltages itself and
    estimates the level with J/B by Gauss-Newton (refine.SATURATION_SLOTS), from a start 2 % off; the level and
    J/B land within their intervals of the truth and the model fits.  (A profile over the level, a few
    Gauss-Newton steps per trial, stopped 0.05 % off a saturation acting on 85 % of a log: 5x the yaw's floor.)"""
    level = 1.5
    r = sim_cached("multisine", 200.0, 60.0, 5e-4, 0.0, 3,
                   effects=((("axis", "yaw"), ("effect", "input_saturation"), ("value", level)),))
    acting = float(np.mean(np.abs(r.u2_v) > level))
    assert acting > 0.1, acting  # the level is reached: the test means something
    key = "input_saturation:yaw"
    res = identify(as_log(r), Settings(effects={key: 1.02 * level}, free=(key,)))
    assert res.model_check["adequate"] is True, res.model_check["sentence"]
    f = res.refined.freed[key]
    assert f["ci95"][0] <= level <= f["ci95"][1], f
    assert f["estimate"] == pytest.approx(level, rel=1e-3)
    for k, v in r.truth["estimated"].items():
        lo, hi = res.refined.ci95[k]
        assert lo <= v <= hi, (k, v, lo, hi)
    # held, the same saturation is applied to the voltages before the fit: the same model, the same cost there
    # (to Gauss-Newton's stopping rule)
    held = identify(as_log(r), Settings(effects={key: f["estimate"]}))
    assert held.refined.cost == pytest.approx(res.refined.cost, abs=2 * R.MIN_COST_DECREASE)


def test_each_kernel_is_compiled_for_one_array_type_whatever_the_voltages_flags():
    """Read-only and writable voltages (the log's views, a clipped copy) reach the same compiled kernel: numba
    compiles once per argument type, and each extra type of windows_pass cost ~5 s of a first run's compilation
    (numerics.kernel_args)."""
    from trms_ident.numerics import fused

    r = sim_cached("steps", 200.0, 4.0)
    n = r.t_s.size
    pv = P.model_vector(defaults())
    starts = np.array([[r.alpha_rad[0], 0.0, r.beta_rad[0], 0.0]])
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    kernels = (R.windows_pass, R.motor_starts, fused._plant_signals)
    before = [len(k.signatures) for k in kernels]  # what this worker's earlier tests compiled (at most one each)
    frozen = r.u1_v.view(), r.u2_v.view()
    for v in frozen:
        v.flags.writeable = False
    for u1, u2 in ((r.u1_v.copy(), r.u2_v.copy()), frozen, (r.u1_v[::1].copy(), np.asfortranarray(r.u2_v))):
        R.gauss_newton_pass(u1, u2, y, np.ones(2), starts, np.zeros(5), pv, False, np.diff(r.t_s),
                            np.zeros((n, 2)), R.MAX_SUBSTEP_S, n, 100, np.empty((n, 2)), np.zeros((n, 2, 0)))
        fused.plant_signals(u1, u2, r.alpha_rad.copy(), r.beta_rad, 1 / 200.0, defaults(), "signed")
    for kernel, b in zip(kernels, before):
        assert len(kernel.signatures) == max(b, 1), (kernel.py_func.__name__, kernel.signatures)


def test_fan_out_runs_each_item_in_the_callers_context():
    """A caller's np.errstate (numpy keeps it in a context variable) holds in fan_out's worker threads: diagnose
    silences the overflows of a fit that runs off, and a worker's overflow had reached the terminal as a
    RuntimeWarning."""
    import contextvars
    import warnings

    from trms_ident.numerics import parallel

    mark = contextvars.ContextVar("mark", default="unset")

    def work(x):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a RuntimeWarning would raise here
            big = np.array([1e308]) * (x + 10.0)  # overflows to inf
        return mark.get(), bool(np.isinf(big[0]))

    token = mark.set("caller's")
    try:
        with np.errstate(all="ignore"):
            out = parallel.fan_out(work, range(4))
    finally:
        mark.reset(token)
    assert out == [("caller's", True)] * 4


def test_fan_out_keeps_order_and_does_not_nest():
    """parallel.fan_out: results in the items' order, work inside a worker runs serially there (a nested pool
    would wait for ever on work queued behind it), and a fit's windows stay in its thread inside a worker."""
    import threading

    from trms_ident.numerics import parallel

    def inner(x):
        return (x, parallel.in_worker(), threading.current_thread().name)

    def outer(x):
        return parallel.fan_out(inner, range(x, x + 3))

    out = parallel.fan_out(outer, range(0, 12, 3))
    assert [[v for v, _, _ in row] for row in out] == [[x, x + 1, x + 2] for x in range(0, 12, 3)]
    if parallel.cores() > 1:
        for row in out:
            assert all(busy for _, busy, _ in row)
            assert len({name for _, _, name in row}) == 1  # the inner items ran in their outer item's thread
    assert not parallel.in_worker()


@pytest.mark.parametrize("freed", [(), ("input_saturation:yaw",)])
def test_a_trial_fit_without_its_interval_has_the_same_values_cost_and_predictions(freed):
    """refine's ``interval`` False (a profile's or a screen's trial fit) integrates no sensitivity on its last
    step: the same estimates, start states, cost and predictions bit for bit as the fit with its interval, which
    it does not report (NaN); with J/B alone and with a freed level (a differenced column)."""
    r = sim_cached("multisine", 200.0, 30.0, 5e-4, 0.0, 3,
                   effects=((("axis", "yaw"), ("effect", "input_saturation"), ("value", 1.5)),))
    start = {k: v * f for (k, v), f in zip(r.truth["estimated"].items(), (1.05, 0.7, 0.95, 1.1))}
    kw = dict(free=freed, effects={"input_saturation:yaw": 1.53}, max_iterations=3)
    fits = [R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / 200.0, defaults(), "quadratic", start,
                     {"alpha": 5e-4, "beta": 5e-4}, interval=i, **kw) for i in (True, False)]
    full, trial = fits
    assert trial.iterations == full.iterations == 3  # the last step was taken: the case that skips a pass
    assert trial.estimate == full.estimate and trial.start_states == full.start_states
    assert trial.cost == full.cost and np.array_equal(trial.prediction, full.prediction)
    assert {k: v["estimate"] for k, v in trial.freed.items()} == {k: v["estimate"] for k, v in full.freed.items()}
    assert all(math.isnan(lo) and math.isnan(hi) for lo, hi in trial.ci95.values())
    assert all(math.isfinite(lo) and math.isfinite(hi) for lo, hi in full.ci95.values())


def test_a_trial_fits_longer_sub_steps_move_the_angles_far_below_any_noise_floor():
    """TRIAL_SUBSTEP_S (one RK4 step a sample at 100 Hz, where MAX_SUBSTEP_S takes four): the predictions of a
    100 Hz log, with a 0.05 s second-order motor (the fastest dynamics the library adds without a friction), stay
    within 1e-7 rad of the fine sub-step's, and the cost within 1e-6 of it; with a Coulomb friction the trial
    keeps COULOMB_SUBSTEP_S (the same numbers as without ``substep_s``); a log with hardly any noise keeps the
    fine sub-step (trial_substep)."""
    r = sim_cached("multisine", 100.0, 30.0, 5e-4, 0.0, 3)
    truth = r.truth["estimated"]

    def fit(effects, **kw):
        return R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / 100.0, defaults(), "quadratic", truth,
                        {"alpha": 5e-4, "beta": 5e-4}, effects=effects, max_iterations=0, **kw)

    lag = {"motor_second_lag:pitch": 0.05}
    fine, coarse = fit(lag), fit(lag, substep_s=R.TRIAL_SUBSTEP_S)
    assert coarse.substeps == 1 and fine.substeps == 4
    err = float(np.max(np.abs(coarse.prediction - fine.prediction)))
    assert 0.0 < err < 1e-7, err
    assert coarse.cost == pytest.approx(fine.cost, rel=1e-6)
    friction = {"coulomb_friction:yaw": 0.002}
    a, b = fit(friction), fit(friction, substep_s=R.TRIAL_SUBSTEP_S)
    assert a.substeps == b.substeps > 4 and np.array_equal(a.prediction, b.prediction)
    assert R.trial_substep({"alpha": 5e-4, "beta": 2e-5}) == R.TRIAL_SUBSTEP_S
    assert R.trial_substep({"alpha": 5e-4, "beta": 5e-6}) is None
