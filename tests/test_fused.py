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
