"""The simulator: integrator convergence, the paper's references, reproducibility, truth."""
import numpy as np
import pytest

from sim import SimSettings, simulate
from sim.references import reference


def test_halving_the_step_changes_the_log_by_less_than_1e_9_rad():
    # RK4 error ~ h^4: from 0.5 ms to 0.25 ms the logged angles move by far less than 1 nrad
    base = dict(ref="square", duration_s=10.0, sample_rate_hz=50.0)
    a = simulate(SimSettings(**base, max_step_s=5e-4))
    b = simulate(SimSettings(**base, max_step_s=2.5e-4))
    assert np.max(np.abs(a.alpha_rad - b.alpha_rad)) < 1e-9
    assert np.max(np.abs(a.beta_rad - b.beta_rad)) < 1e-9
    # and one RK4 step per 20 ms sample is visibly different: the test can fail
    c = simulate(SimSettings(**base, max_step_s=2e-2))
    assert np.max(np.abs(c.beta_rad - a.beta_rad)) > 1e-9


def test_paper_references():
    t = np.array([0.0, 0.5, 1.5, 2.5])
    a, b = reference("square", t)
    np.testing.assert_allclose(a, [0, 0.5, -0.5, 0.5])
    np.testing.assert_allclose(b, [0, 0.3, -0.3, 0.3])
    a, b = reference("sine", t)
    np.testing.assert_allclose(a, 0.5 * np.sin(0.5 * t))
    np.testing.assert_allclose(b, 0.2 * np.sin(0.3 * t))
    with pytest.raises(ValueError, match="unknown reference 'ramp'"):
        reference("ramp", t)


def test_same_seed_same_log_other_seed_other_noise():
    s = dict(ref="steps", duration_s=5.0, noise_std_rad=1e-3)
    a, b = simulate(SimSettings(**s, seed=3)), simulate(SimSettings(**s, seed=3))
    c = simulate(SimSettings(**s, seed=4))
    np.testing.assert_array_equal(a.alpha_rad, b.alpha_rad)
    assert not np.array_equal(a.alpha_rad, c.alpha_rad)


def test_controller_limit_and_quantization():
    q = 2 * np.pi / 4096
    r = simulate(SimSettings(ref="square", duration_s=10.0, quantization_rad=q, u_limit_v=2.0))
    assert np.max(np.abs(r.u1_v)) <= 2.0 and np.max(np.abs(r.u2_v)) <= 2.0
    np.testing.assert_allclose(r.alpha_rad / q, np.round(r.alpha_rad / q), atol=1e-9)


def test_truth_records_parameters_and_settings():
    r = simulate(SimSettings(ref="sine", duration_s=2.0, overrides={"J1": 0.07}, seed=11))
    assert r.truth["estimated"]["J1"] == 0.07
    assert r.truth["settings"]["seed"] == 11 and r.truth["settings"]["ref"] == "sine"
    assert r.truth["parameters"]["Mg"] == 0.32


@pytest.mark.parametrize("bad, message", [
    (dict(ref="nope"), "unknown reference"),
    (dict(sample_rate_hz=0.0), "sample_rate_hz must be > 0"),
    (dict(noise_std_rad=-1.0), "noise_std_rad must be >= 0"),
    (dict(thrust_law="cubic"), "unknown thrust law"),
    (dict(effects=[{"effect": "magic", "value": 1.0}]), "unknown effect"),
])
def test_bad_settings_are_refused(bad, message):
    with pytest.raises(ValueError, match=message):
        simulate(SimSettings(**{"duration_s": 1.0, **bad}))


def test_an_acquisition_lag_filters_the_logged_angles_by_its_difference_equation():
    # sensor_lag: each logged angle is the previous one moved (1 - c) of the way to the true angle, c = e^(-dt/T),
    # from the true angle at the first sample; the controller reads the lagged angles, so the run changes too
    lag = 0.05
    r = simulate(SimSettings(ref="square", sample_rate_hz=200.0, duration_s=10.0, seed=2,
                             effects=[{"effect": "sensor_lag", "axis": "both", "value": lag}]))
    c = np.exp(-(1 / 200.0) / lag)
    for col, logged in ((0, r.alpha_rad), (2, r.beta_rad)):
        true = r.true_state[:, col]
        assert logged[0] == true[0]
        np.testing.assert_allclose(logged[1:], c * logged[:-1] + (1 - c) * true[1:], rtol=0, atol=1e-15)
    plain = simulate(SimSettings(ref="square", sample_rate_hz=200.0, duration_s=10.0, seed=2))
    assert np.max(np.abs(plain.alpha_rad - plain.true_state[:, 0])) == 0.0
    assert np.max(np.abs(r.alpha_rad - plain.alpha_rad)) > 1e-3  # a 50 ms lag shows, and the loop reacts to it
    with pytest.raises(ValueError, match="sensor_lag must be > 0 s"):
        simulate(SimSettings(ref="square", effects=[{"effect": "sensor_lag", "axis": "both", "value": 0.0}]))


@pytest.mark.parametrize("axis", ["pitch", "yaw"])
def test_the_shifted_dead_zone_is_the_plain_plant_driven_by_the_blocks_output(axis):
    """simulate's shifted_dead_zone (Simulink's Dead Zone block: 0 inside [-w, w], u - w sign(u) outside) acts as
    the same voltages shifted by hand and fed to the plant without it, to round-off; it differs from the cut-off
    form (dead_zone), which passes a voltage above the width unchanged."""
    from sim.effects import pack
    from sim.plant import PARAM_ORDER, open_loop
    from trms_ident.params import defaults

    p = defaults()
    vec = np.array([p[k] for k in PARAM_ORDER])
    dt, w = 0.005, 0.3
    t = np.arange(int(6.0 / dt)) * dt
    u1 = 0.9 * np.sin(2 * np.pi * 0.4 * t)
    u2 = 0.8 * np.sin(2 * np.pi * 0.3 * t + 1.0)
    shifted = lambda u: np.sign(u) * np.maximum(np.abs(u) - w, 0.0)  # noqa: E731
    fx = np.array(pack([{"effect": "shifted_dead_zone", "axis": axis, "value": w}]), dtype=float)
    cut = np.array(pack([{"effect": "dead_zone", "axis": axis, "value": w}]), dtype=float)
    plain = np.array(pack([]), dtype=float)
    a = open_loop(dt, u1, u2, vec, 0, fx, 5e-4, np.zeros(9))
    b = open_loop(dt, shifted(u1) if axis == "pitch" else u1, shifted(u2) if axis == "yaw" else u2, vec, 0, plain,
                  5e-4, np.zeros(9))
    c = open_loop(dt, u1, u2, vec, 0, cut, 5e-4, np.zeros(9))
    assert np.max(np.abs(a - b)) < 1e-12
    assert np.max(np.abs(a - c)) > 1e-2  # rad: the two forms are different benches
