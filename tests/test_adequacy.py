"""The adequacy verdict's floors (numerics/adequacy.py)."""
import math

import numpy as np
import pytest


def test_a_noise_free_log_is_judged_against_the_integrators_precision_not_its_unmeasurable_floor():
    """A fit to 3e-8 rad of angles whose 'noise' is 1e-10 rad (a simulation stored in doubles) fits: no model is
    integrated finer than NUMERICAL_FLOOR_RAD (1e-7 rad); 3e-7 rad above it does not fit (against the black box
    its smoothness allows: here a sine it simulates better)."""
    from trms_ident.numerics.adequacy import NUMERICAL_FLOOR_RAD, model_check

    t = np.arange(4000) * 0.01
    y = np.column_stack([np.sin(0.3 * t), np.cos(0.2 * t)])
    u = np.column_stack([np.sin(0.3 * t), np.cos(0.2 * t)])
    wobble = np.sin(7.0 * t)[:, None] * np.array([1.0, 1.0])
    noise = {"alpha": 1e-10, "beta": 1e-10}
    ok = model_check(y, y + 3e-8 * wobble, u, noise, 0.01, "test")
    assert ok["adequate"] is True and "integrator's precision" in ok["sentence"]
    assert ok["axes"]["pitch"]["rms_over_noise"] == pytest.approx(3e-8 / math.sqrt(2) / NUMERICAL_FLOOR_RAD, rel=1e-2)
    off = model_check(y, y + 3e-6 * wobble, u, noise, 0.01, "test")
    assert off["adequate"] is not True
