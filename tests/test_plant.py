"""The model room (trms_ident/model/plant.py): eq. (1) written once, and every kernel that uses it agrees with the
simulator's independent implementation (sim/plant.py) at random states, with and without the effects."""
import ast
import math
from pathlib import Path

import numpy as np
import pytest

from sim import effects as sim_effects
from sim import plant as sim_plant
from trms_ident.diagnosis import predict
from trms_ident.model import plant as P
from trms_ident.numerics import refine as R
from trms_ident.params import defaults

PACKAGE = Path(__file__).resolve().parent.parent / "trms_ident"

#: the effects the output-error kernel carries, with the simulator's names and sizes larger than any bench's
EFFECTS = {"coulomb_friction:pitch": 3e-3, "coulomb_friction:yaw": 2e-2, "quadratic_drag:pitch": 0.02,
           "quadratic_drag:yaw": 0.03, "cable_stiffness:yaw": 0.01, "com_offset:pitch": 0.05,
           "thrust_asymmetry:pitch": -0.3, "thrust_asymmetry:yaw": 0.4, "yaw_inertia_pitch:yaw": 0.004}


def _sim_vector(effects: dict) -> np.ndarray:
    return np.array(sim_effects.pack([{"effect": k.split(":")[0], "axis": k.split(":")[1], "value": v}
                                      for k, v in effects.items()]), dtype=float)


def _states(rng, n=200):
    """Random states [alpha, alpha', beta, beta', tau1, tau2, zeta] and voltages, both rotor directions."""
    x = np.column_stack([rng.uniform(-1.2, 1.2, n), rng.uniform(-3, 3, n), rng.uniform(-3, 3, n),
                         rng.uniform(-3, 3, n), rng.uniform(-2.5, 2.5, n), rng.uniform(-2, 2, n),
                         rng.uniform(-2.5, 2.5, n)])
    x[:5, 1] = x[:5, 3] = 0.0  # at rest: Coulomb friction's smoothed sign at 0
    return x, rng.uniform(-2.5, 2.5, (n, 2))


@pytest.mark.parametrize("law", ["quadratic", "signed"])
@pytest.mark.parametrize("effects", [{}, EFFECTS])
def test_the_output_error_kernel_and_the_simulator_agree_on_eq_1(law, effects):
    # refine's right-hand side (states 0..6) against sim's: two codes, one equation
    p = {**defaults(), "J1": 0.05, "B1": 0.009, "J2": 0.03, "B2": 0.07, "Mg": 0.28, "Kg": 0.07, "kc": -0.25}
    pv = P.model_vector(p, effects={k: v for k, v in effects.items() if k != "com_offset:pitch"},
                        gravity_offset_rad=effects.get("com_offset:pitch", 0.0))
    sim_p = np.array([p[k] for k in sim_plant.PARAM_ORDER])
    fx = _sim_vector(effects)
    x, u = _states(np.random.default_rng(7))
    ours, theirs = np.empty(R._NS), np.empty(9)  # the simulator's 9 states (its second-order motors' drives)
    for xi, ui in zip(x, u):
        full = np.zeros(R._NS)
        full[:7] = xi
        R._rhs(full, ui[0], ui[1], 0.0, 0.0, pv, law == "signed", ours, np.zeros(0, dtype=np.int64),
               np.zeros((0, 2)))
        sim_plant._deriv(np.r_[xi, 0.0, 0.0], ui[0], ui[1], sim_p, 1 if law == "signed" else 0, fx, theirs)
        np.testing.assert_allclose(ours[:7], theirs[:7], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("law", ["quadratic", "signed"])
def test_the_prediction_model_and_the_simulator_agree_on_eq_1(law):
    # diagnose's per-axis prediction (measured beta' into pitch, M_R into yaw) against sim's right-hand side,
    # with every effect the prediction model carries
    p = defaults()
    effects = EFFECTS
    fx_sim = _sim_vector(effects)
    x, u = _states(np.random.default_rng(8))
    dx = np.empty(9)  # the simulator's 9 states: a 7-element array was written past its end
    signed = 1.0 if law == "signed" else 0.0
    # predict's effect vector: Fc, c, k_cable, com delta, sensor delta, thrust asymmetry s, yaw dJ
    fx_p = np.array([effects["coulomb_friction:pitch"], effects["quadratic_drag:pitch"], 0.0,
                     effects["com_offset:pitch"], 0.0, effects["thrust_asymmetry:pitch"], 0.004])
    fx_y = np.array([effects["coulomb_friction:yaw"], effects["quadratic_drag:yaw"], effects["cable_stiffness:yaw"],
                     0.0, 0.0, effects["thrust_asymmetry:yaw"], 0.004])
    th_p = np.array([p["J1"], p["B1"], p["a1"], p["b1"], p["Mg"], p["Kg"], signed])
    th_y = np.array([p["J2"], p["B2"], p["a2"], p["b2"], p["Mg"], p["Kg"], signed])
    sim_p = np.array([p[k] for k in sim_plant.PARAM_ORDER])
    for xi, ui in zip(x, u):
        sim_plant._deriv(np.r_[xi, 0.0, 0.0], ui[0], ui[1], sim_p, int(signed), fx_sim, dx)
        al, dal, be, dbe, tau1, tau2, zeta = xi
        mr = P.reaction_moment.py_func(tau1, zeta, p["kc"], p["T0"], p["Tp"])
        s2, scw = math.sin(al) ** 2, math.sin(al) * math.cos(al) * dal
        pitch = predict._rhs(True, al, dal, tau1, dbe, s2, scw, 0.0, th_p, fx_p)
        yaw = predict._rhs(False, be, dbe, tau2, mr, s2, scw, 0.0, th_y, fx_y)
        np.testing.assert_allclose([pitch, yaw], [dx[1], dx[3]], rtol=1e-12, atol=1e-12)


def test_the_terms_array_forms_are_the_compiled_terms():
    # the scipy reference path (numerics/regressors.py) calls the terms' Python forms on arrays: same numbers
    rng = np.random.default_rng(9)
    tau, s = rng.uniform(-2, 2, 50), rng.uniform(-1, 1, 50)
    for signed in (False, True):
        arr = P.thrust.py_func(tau, 0.0135, 0.0924, signed)
        assert np.array_equal(arr, [P.thrust(t, 0.0135, 0.0924, signed) for t in tau])
    np.testing.assert_array_equal(P.thrust_law(tau, 0.02, 0.09, "signed"), 0.02 * tau * np.abs(tau) + 0.09 * tau)
    np.testing.assert_array_equal(P.thrust_law(tau, 0.02, 0.09, "quadratic"), 0.02 * tau * tau + 0.09 * tau)
    arr = P.pitch_torque.py_func(tau, tau, np.sin(s), np.cos(s), s, 0.32, 0.05)
    np.testing.assert_array_equal(arr, [P.pitch_torque(a, a, math.sin(b), math.cos(b), b, 0.32, 0.05)
                                        for a, b in zip(tau, s)])
    # thrust_slope is the thrust's derivative
    h = 1e-6
    for signed in (False, True):
        up, down = (P.thrust.py_func(tau + d, 0.0135, 0.0924, signed) for d in (h, -h))
        fd = (up - down) / (2 * h)
        np.testing.assert_allclose([P.thrust_slope(t, 0.0135, 0.0924, signed) for t in tau], fd, rtol=1e-7)


def test_model_vector_layout():
    p = defaults()
    pv = P.model_vector(p, 0.03, {"cable_stiffness:yaw": 0.01}, exogenous=("gain",))
    assert pv.size == P.N_SLOTS + 1
    assert [pv[P.slot(k)] for k in P.PARAM_ORDER] == [p[k] for k in P.PARAM_ORDER]
    assert pv[P.GRAVITY_OFFSET_SLOT] == 0.03 and pv[P.slot("cable_stiffness:yaw")] == 0.01
    assert P.slot("gain", ("gain",)) == P.N_SLOTS and pv[P.N_SLOTS] == 0.0
    assert sorted([*P.EFFECT_SLOTS.values(), *P.LAG_SLOTS.values(), *P.STRUCTURE_SLOTS.values()]) == \
        list(range(P.GRAVITY_OFFSET_SLOT, P.N_SLOTS))
    assert all(pv[i] == 0.0 for i in P.STRUCTURE_SLOTS.values())  # eq. (1)'s structure: no stop, no voltage drive
    with pytest.raises(ValueError, match="nosuch"):
        P.slot("nosuch")


def test_the_model_room_imports_nothing_above_it():
    # arrows point one way: model/ is used by numerics/ and diagnosis/, never the reverse
    for path in (PACKAGE / "model").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                assert node.level == 1, f"{path.name} imports {'.' * node.level}{node.module}"
            if isinstance(node, ast.ImportFrom) and not node.level:
                assert not (node.module or "").startswith(("trms_ident", "sim")), f"{path.name}: {node.module}"
