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
