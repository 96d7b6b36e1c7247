"""The compiled plant signals the diagnosis rebuilds for every candidate equal the scipy reference path."""
import numpy as np
import pytest

from .conftest import sim_cached


@pytest.mark.parametrize("law", ["quadratic", "signed"])
def test_compiled_plant_signals_equal_the_reference(law):
    from trms_ident.numerics import fused, regressors
    from trms_ident.params import defaults

    r = sim_cached("multisine", 200.0, 30.0)
    p = defaults()
    ref = regressors.plant_signals(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 0.005, p, law, 0.01)
    fast = fused.plant_signals(r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 0.005, p, law, 0.01)
    for name in ref.__dataclass_fields__:
        a, b = getattr(ref, name), getattr(fast, name)
        assert np.max(np.abs(a - b)) <= 1e-10 * max(np.max(np.abs(a)), 1e-12), name


def test_plant_signals_from_given_motor_states():
    """Started from the steady state of the first voltage, the explicit-state path equals the filter path; from
    other states (a log that begins mid-run) the motors relax to the same signals."""
    from trms_ident.numerics import fused
    from trms_ident.params import defaults

    r = sim_cached("multisine", 200.0, 30.0)
    p = defaults()
    args = (r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, 0.005, p, "quadratic")
    ref = fused.plant_signals(*args)
    t1, t2 = p["k1"] / p["T10"] * r.u1_v[0], p["k2"] / p["T20"] * r.u2_v[0]
    same = fused.plant_signals(*args, start=dict(tau1_0=t1, tau2_0=t2, zeta_0=t1))
    other = fused.plant_signals(*args, start=dict(tau1_0=t1 + 0.3, tau2_0=t2 - 0.2, zeta_0=t1))
    for name in ("tau1", "tau2", "MR_nm", "y_pitch_nm", "y_yaw_nm"):
        a = getattr(ref, name)
        assert np.max(np.abs(getattr(same, name) - a)) <= 1e-9 * np.max(np.abs(a)), name
    assert other.tau1[0] == pytest.approx(t1 + 0.3) and abs(other.tau1[0] - ref.tau1[0]) > 0.29
    assert abs(other.tau1[-1] - ref.tau1[-1]) < 1e-9  # 30 s later the start is forgotten (T11 = 1.1 s)


def test_the_free_responses_span_every_zero_input_response_of_the_filter():
    """start_unknowns' columns: a filter's response to a start state off the steady state, with no input, is a
    combination of _free_responses of its denominator (F's double pole, a motor lag's single one)."""
    from scipy.signal import lfilter

    from trms_ident.numerics import fused
    from trms_ident.numerics.coefficients import bilinear_second_order, zoh_first_order

    rng = np.random.default_rng(4)
    for b, a in (bilinear_second_order(2.0, 1.0, 1, 0.01), zoh_first_order(1.1, 1.1, 1.0, 0.01)):
        cols = np.column_stack(fused._free_responses(a, 3000))
        assert cols.shape[1] == (2 if a[2] != 0.0 else 1)
        for _ in range(3):
            zi = rng.normal(size=2)
            if a[2] == 0.0 and b[2] == 0.0:
                zi[1] = 0.0  # the second state of a first-order section is 0 whatever its history
            y, _ = lfilter(b, a, np.zeros(3000), zi=zi)
            coef, *_ = np.linalg.lstsq(cols, y, rcond=None)
            assert np.max(np.abs(cols @ coef - y)) <= 1e-12 * np.max(np.abs(y))
    lam = 0.97  # first order: the geometric decay itself
    assert np.allclose(fused._free_responses(np.array([1.0, -lam, 0.0]), 50)[0], lam ** np.arange(50))
