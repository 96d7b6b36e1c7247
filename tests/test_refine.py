"""Prediction-error refinement after DREM: sensitivities, convergence, intervals, and when it is not used."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

import trms_ident.identify as identify_mod
from trms_ident.cli import app
from trms_ident.identify import Settings, identify
from trms_ident.io.csv_log import write_csv_log
from trms_ident.numerics import refine as R
from trms_ident.numerics.filters import discretize
from trms_ident.params import defaults

from .conftest import as_log, sim_cached

NAMES = ("J1", "B1", "J2", "B2")


def test_motor_states_match_scipy_zero_order_hold():
    p = defaults()
    rng = np.random.default_rng(0)
    for dt in (1e-3, 1e-2):
        u1, u2 = rng.uniform(-2, 2, 3000), rng.uniform(-2, 2, 3000)
        m = R.motor_states(u1, u2, dt, p)
        ref = np.column_stack([
            discretize([p["k1"]], [p["T11"], p["T10"]], dt, "zoh").apply(u1),
            discretize([p["k2"]], [p["T21"], p["T20"]], dt, "zoh").apply(u2),
            discretize([p["k1"]], np.polymul([p["Tp"], 1.0], [p["T11"], p["T10"]]), dt, "zoh").apply(u1)])
        np.testing.assert_allclose(m, ref, atol=1e-10)


def test_forward_sensitivities_match_finite_differences():
    r = sim_cached("square", 1000.0, 10.0)
    p = defaults()
    dt, n = 1e-3, r.t_s.size
    motor = R.motor_states(r.u1_v, r.u2_v, dt, p)
    y = np.column_stack([r.alpha_rad, r.beta_rad])
    base = R.model_vector(p)
    starts = np.array([[0.01, 0.2, 0.02, 0.3]])

    def pred(pv, st):
        out = np.empty((n, 2))
        R.gauss_newton_pass(r.u1_v, r.u2_v, motor, y, np.ones(2), st, pv, False, dt, 1, n, 1000, out)
        return out

    out = np.empty((n, 2))
    _, a, b, _ = R.gauss_newton_pass(r.u1_v, r.u2_v, motor, y, np.ones(2), starts, base, False, dt, 1, n, 1000, out)
    jac = np.empty((n, 2, 8))
    for i in range(8):
        pv, st = base.copy(), starts.copy()
        h = 1e-6 * pv[i] if i < 4 else 1e-6
        if i < 4:
            pv[i] += h
        else:
            st[0, i - 4] += h
        jac[:, :, i] = (pred(pv, st) - out) / h
    np.testing.assert_allclose(np.diag(a[0]), np.einsum("kci,kci->i", jac, jac), rtol=1e-4)
    np.testing.assert_allclose(b[0], np.einsum("kci,kc->i", jac, y - out), rtol=1e-3)


def test_refinement_converges_to_the_truth_from_a_poor_start():
    r = sim_cached("multisine", 200.0, 60.0)
    truth = r.truth["estimated"]
    start = {k: v * f for (k, v), f in zip(truth.items(), (1.05, 0.7, 0.95, 1.1))}
    res = R.refine(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 1 / 200.0, defaults(), "quadratic", start,
                   {"alpha": 1e-6, "beta": 1e-6})
    assert res.converged
    for k in NAMES:
        assert res.estimate[k] == pytest.approx(truth[k], rel=1e-8)
        lo, hi = res.ci95[k]
        assert lo <= truth[k] <= hi  # the integrator's own error is inside the interval
    assert res.skipped_s == pytest.approx(10.0)  # five motor / M_R lags: the motors' start is unknown


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
