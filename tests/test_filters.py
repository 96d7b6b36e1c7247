"""Discretized filters against analytic continuous-time responses."""
import numpy as np
import pytest

from trms_ident.numerics.filters import discretize, second_order_lowpass


def test_zoh_first_order_is_exact_for_held_input():
    # k/(T1 s + T0) driven by a unit step held by ZOH: y(t) = k/T0 (1 - exp(-T0 t / T1))
    k, T1, T0, dt = 1.1, 1.1, 1.0, 0.01
    t = np.arange(500) * dt
    u = np.ones_like(t)
    u[0] = 0.0  # the step is applied at t = 0 and held; the filter starts from rest
    y = discretize([k], [T1, T0], dt, "zoh").apply(u)
    expected = np.where(t > 0, k / T0 * (1 - np.exp(-T0 * (t - dt) / T1)), 0.0)
    np.testing.assert_allclose(y, expected, atol=1e-13)


@pytest.mark.parametrize("a", [1.0, 10.0])
def test_bilinear_lowpass_sine_response_matches_frequency_response(a):
    # steady-state response of a^2/(s+a)^2 to sin(w t): |F(jw)| sin(w t + arg F(jw))
    dt, w = 1e-3, 0.7
    t = np.arange(int(60 / dt)) * dt
    num, den = second_order_lowpass(a, a * a)
    y = discretize(num, den, dt, "bilinear").apply(np.sin(w * t))
    F = a * a / (1j * w + a) ** 2
    expected = np.abs(F) * np.sin(w * t + np.angle(F))
    tail = t > 30  # transients have decayed
    np.testing.assert_allclose(y[tail], expected[tail], atol=2e-6)


def test_derivative_filters_of_a_ramp():
    # F s[x] for x = c t tends to c (DC gain of F is 1); F s^2[x] tends to 0
    a, dt, c = 2.0, 1e-3, 0.3
    t = np.arange(20000) * dt
    num, den = second_order_lowpass(a, a * a)
    fs = discretize([a * a, 0.0], den, dt, "bilinear").apply(c * t)
    fs2 = discretize([a * a, 0.0, 0.0], den, dt, "bilinear").apply(c * t)
    assert fs[-1] == pytest.approx(c, rel=1e-9)
    assert abs(fs2[-1]) < 1e-9


def test_steady_state_start_for_constant_input():
    num, den = second_order_lowpass(3.0, 9.0)
    y = discretize(num, den, 1e-3, "bilinear").apply(np.full(1000, 0.42))
    np.testing.assert_allclose(y, 0.42, rtol=1e-10)  # coefficient round-off only


def test_unknown_method_is_refused():
    with pytest.raises(ValueError, match="method must be one of"):
        discretize([1.0], [1.0, 1.0], 0.01, "euler")
