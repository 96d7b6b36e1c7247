"""The model room (trms_ident/model/effects.py): a new torque effect or input modification is one entry there,
and every stage of the diagnosis derives it from that entry's torque or voltage transform; the output-error fit's
exogenous-torque path agrees with the compiled one."""
import dataclasses
import json
import math
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from sim import SimSettings, simulate
from trms_ident.cli import app
from trms_ident.diagnosis import oe
from trms_ident.model import effects
from trms_ident.diagnosis.model import Model
from trms_ident.diagnosis.run import diagnose
from trms_ident.diagnosis.select import FAMILY_ALPHA
from trms_ident.diagnosis.shapes import declared_shape
from trms_ident.io.csv_log import write_csv_log
from trms_ident.params import defaults

from .conftest import as_log

Q12 = 2 * math.pi / 4096
runner = CliRunner()

#: the one entry a developer writes: a gyroscopic coupling stronger than the table's Kg, torque -dKg M1 beta'
#: cos(alpha) on pitch (eq. 1's gyroscopic term once more).  The library has no such effect (tests/
#: test_sparse_correction.py finds this log's mismatch outside the library).
GYRO = effects.Candidate("gyroscopic_gain", "pitch", "dKg", "1", "linear",
                         sentence="the gyroscopic coupling is {value:.3g} stronger than the table's Kg",
                         regime="pitch_angle", bounds=effects.POSITIVE,
                         torque=lambda s: -s["M1"] * s["dbeta"] * np.cos(s["alpha"]))


def _kg_log():
    # the plant's gyroscopic coupling is 0.1, the table's (and diagnose's) 0.05
    return simulate(SimSettings(ref="multisine", duration_s=120.0, sample_rate_hz=200.0, quantization_rad=Q12,
                                seed=21, overrides={"Kg": 0.1}))


def test_a_torque_effect_declared_in_one_entry_is_found_fitted_and_reported(monkeypatch, tmp_path):
    # without the entry the same log is explained by the known value Kg alone; this entry is Kg's gyroscopic
    # term once more, so the two are the same physics: both explain the log with one parameter and are
    # reported as look-alikes, never one dropped (diagnosis/weigh.py)
    monkeypatch.setattr(effects, "CANDIDATES", effects.CANDIDATES + (GYRO,))
    r = _kg_log()
    d = diagnose(as_log(r))
    assert sorted((f.effect, f.axis) for f in d.findings) == [("gyroscopic_gain", "pitch"), ("known_value", "pitch")]
    f = next(f for f in d.findings if f.effect == "gyroscopic_gain")
    kv = next(f for f in d.findings if f.effect == "known_value")
    assert kv.parameter["name"] == "Kg" and kv.parameter["value"] == pytest.approx(0.1, rel=0.02)
    assert {"gyroscopic_gain:pitch", "known_value:Kg"} & set(d.findings[0].alternatives)
    assert f.parameter["value"] == pytest.approx(0.05, rel=0.05)
    assert d.verdict == "explained" and not d.corrections
    truth = r.truth["estimated"]
    for k in ("J1", "B1"):  # the axis refitted with the effect (or the value) recovers the plant's J and B
        assert d.augmented[k] == pytest.approx(truth[k], rel=0.02)
    assert f.fit_after > f.fit_before
    shape = next(s for s in d.steps if s["key"].startswith("gyroscopic_gain"))["shape"]  # the term's figure
    assert shape.x_label == "alpha [rad]" and re.search(r"dKg = 0\.0(5|49)", shape.title) and np.all(np.isfinite(shape.fitted))
    # the same log through the command line: the sentence, the JSON and the report's figure of the term
    path = tmp_path / "kg.csv"
    write_csv_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    res = runner.invoke(app, ["diagnose", str(path), "-o", str(tmp_path / "out"), "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    found = next(x for x in doc["findings"] if x["effect"] == "gyroscopic_gain")
    assert "stronger than the table's Kg" in found["explanation"]
    assert re.search(r"gyroscopic_gain on pitch: dKg = 0\.0[45]\d*\n", res.stderr)  # dimensionless: no unit "1"
    html = (tmp_path / "out" / "report.html").read_text()
    assert re.search(r"Finding [12]: gyroscopic_gain on pitch", html)


@pytest.mark.parametrize("effect, axis, value, ref, torque", [
    ("cable_stiffness", "yaw", 0.005, "steps", lambda s: -s["beta"]),
    ("coulomb_friction", "pitch", 0.002, "square", lambda s: -np.tanh(s["dalpha"] / s["scale_alpha"])),
])
def test_the_exogenous_torque_path_agrees_with_the_compiled_effect(monkeypatch, effect, axis, value, ref, torque):
    # the same physics twice: compiled into the output-error kernel (simulated states) and declared by its torque
    # from the measured states; both pass the test at the size the issue asks, with the same parameter
    key, copy = f"{effect}:{axis}", f"{effect}_declared:{axis}"
    c = effects.by_key(key)
    monkeypatch.setattr(effects, "CANDIDATES",
                        effects.CANDIDATES + (dataclasses.replace(c, effect=f"{effect}_declared", torque=torque),))
    log = as_log(simulate(SimSettings(ref=ref, sample_rate_hz=200.0, duration_s=60.0, quantization_rad=Q12, seed=7,
                                      effects=[dict(effect=effect, axis=axis, value=value)])))
    p = defaults()
    theta0 = {k: p[k] for k in ("J1", "B1", "J2", "B2")}
    fitter = oe.Fitter(log, p, "quadratic")
    compiled, declared = (fitter.candidate(Model(), {}, theta0, k) for k in (key, copy))
    assert oe.passes(compiled, 24, FAMILY_ALPHA) and oe.passes(declared, 24, FAMILY_ALPHA)
    assert declared.value == pytest.approx(compiled.value, rel=0.03)
    assert declared.value == pytest.approx(value, rel=0.05)
    assert declared.torque_share == pytest.approx(compiled.torque_share, rel=0.2)
    for k in ("J1", "B1", "J2", "B2"):
        assert declared.estimates[k] == pytest.approx(compiled.estimates[k], rel=0.01)


def test_an_input_modification_declared_in_one_entry_replaces_the_saturation(monkeypatch):
    # the library without its saturation, plus one entry: a driver that clips the main motor's voltage, declared
    # by its voltage transform; the equation error, the output-error profile, the verdict and the figure follow
    clip = effects.Candidate("voltage_clip", "pitch", "U", "V", "grid", tuple(2.45 - 0.1 * i for i in range(16)),
                             sentence="the main motor's driver clips at {value:.3g} {unit}", bounds=effects.POSITIVE,
                             modify=lambda u, limit: np.clip(u, -limit, limit), step=True)
    monkeypatch.setattr(effects, "CANDIDATES",
                        tuple(c for c in effects.CANDIDATES if c.effect != "input_saturation") + (clip,))
    log = as_log(simulate(SimSettings(ref="steps", sample_rate_hz=200.0, duration_s=60.0, quantization_rad=Q12, seed=7,
                                      start_s=30.0, effects=[dict(effect="input_saturation", axis="pitch",
                                                                  value=1.6)])))
    d = diagnose(log)
    assert [(f.effect, f.axis) for f in d.findings] == [("voltage_clip", "pitch")]
    f = d.findings[0]
    assert f.parameter["value"] == pytest.approx(1.6, rel=0.01)
    assert f.evidence.startswith("output-error fits over the modification's value")
    assert d.verdict == "explained" and "clips at 1.6 V" in f.explanation
    shape = d.steps[0]["shape"]
    assert shape.title == "voltage clip: 1.6 V"
    np.testing.assert_allclose(shape.fitted, np.clip(shape.x, -1.6, 1.6), atol=1e-4)


def test_a_declared_term_is_drawn_as_its_mean_torque_over_its_regime():
    x = np.linspace(-1.0, 1.0, 6001)
    sh = declared_shape(GYRO, 0.05, "alpha [rad]", x, 0.05 * np.sin(x))
    assert sh.x.size == 60 and np.all(np.diff(sh.x) > 0)
    np.testing.assert_allclose(sh.fitted, 0.05 * np.sin(sh.x), atol=0.05 * (2 / 60))  # within half a bin's slope
    assert np.all(sh.seed == 0) and "dKg = 0.05" in sh.title
    flat = declared_shape(GYRO, 0.05, "alpha [rad]", np.zeros(10), np.ones(10))
    assert flat.x.size == 1 and flat.fitted[0] == 1.0


def test_plausible_ranges_come_from_the_entry():
    assert effects.by_key("coulomb_friction:pitch").plausible(0.01)
    assert not effects.by_key("coulomb_friction:pitch").plausible(-0.01)
    assert not effects.by_key("thrust_asymmetry:yaw").plausible(-1.5)
    assert effects.by_key("com_offset:pitch").plausible(-0.02)
    assert not effects.by_key("com_offset:pitch").plausible(math.nan)
