"""No finding a physicist would laugh at: every parameter a misfit can push anywhere has a bench's plausible range
in the model room, each tested at its edge; a value outside it is said as a stand-in for missing physics, never
reported as a finding (diagnosis.verdict.stand_in, diagnosis.run's final guard)."""
import math

import numpy as np
import pytest

from trms_ident.diagnosis.result import Diagnosis, Finding
from trms_ident.diagnosis.run import _without_stand_ins
from trms_ident.diagnosis.verdict import STAND_IN, stand_in, stand_in_sentence, stand_ins
from trms_ident.model import effects

#: key -> (the range's lower edge, its upper edge) as a bench allows them
EDGES = {
    "sensor_offset:pitch": (-math.radians(10), math.radians(10)),
    "com_offset:pitch": (-math.radians(10), math.radians(10)),
    "input_delay:both": (0.0, 0.15),
    "sensor_lag:both": (0.0, 0.2),
    "motor_lag:pitch": (0.05, 5.0),
    "motor_lag:yaw": (0.05, 5.0),
    "motor_second_lag:pitch": (0.0, 1.5),
    "motor_second_lag:yaw": (0.0, 1.5),
    "thrust_asymmetry:pitch": (-1.0, 1.0),
    "thrust_asymmetry:yaw": (-1.0, 1.0),
    "dead_zone:pitch": (0.0, 1.0),
    "shifted_dead_zone:yaw": (0.0, 1.0),
}


@pytest.mark.parametrize("key", sorted(EDGES))
def test_each_range_holds_just_inside_its_edges_and_refuses_just_outside(key):
    c = effects.by_key(key)
    lo, hi = EDGES[key]
    eps = 1e-3 * (hi - lo)
    assert c.plausible(lo + eps) and c.plausible(hi - eps)
    assert not c.plausible(lo - eps) and not c.plausible(hi + eps)
    assert not c.plausible(math.nan)


def test_a_49_degree_encoder_offset_is_said_as_a_stand_in_with_its_range():
    told = stand_in("sensor_offset", "pitch", -0.86)
    assert told["key"] == "sensor_offset:pitch" and told["parameter"] == -0.86
    assert told["reason"].startswith(STAND_IN)
    assert "delta = -0.86 rad (-49.3 deg) is outside a bench's plausible range (-0.1745 to 0.1745 rad)" in \
        told["reason"]
    assert "the pitch model lacks something it stands in for" in told["reason"]
    assert stand_in("sensor_offset", "pitch", 0.02) is None  # a degree is an encoder offset
    assert stand_in("known_value", "pitch", 1e9) is None  # not the library's: weighed by its own rule
    delay = stand_in("input_delay", "both", 0.28)
    assert "d = 0.28 s is outside a bench's plausible range (0 to 0.15 s)" in delay["reason"]
    assert "the motors model lacks" in delay["reason"]


def _finding(effect, axis, value):
    return Finding(effect, axis, {"name": "x", "value": value, "unit": ""}, 90.0, 99.0, "", "", 0.5, 3.0, 0.001)


def test_stand_ins_are_the_effect_findings_outside_their_ranges_and_the_sentence_names_them():
    found = [_finding("sensor_offset", "pitch", -0.86), _finding("cable_stiffness", "yaw", 0.004),
             _finding("motor_second_lag", "pitch", 6.06)]
    out = stand_ins(found)
    assert [r["key"] for r in out] == ["sensor_offset:pitch", "motor_second_lag:pitch"]
    words = stand_in_sentence(out + [{"effect": "coulomb_friction", "axis": "yaw", "parameter": 0.1,
                                      "reason": "held-out simulation: ..."}])
    assert words.startswith(" Not findings: sensor offset on pitch (-0.86); motor second lag on pitch (6.06)")
    assert "that part of the misfit is unexplained" in words and "coulomb" not in words
    assert stand_in_sentence([]) == ""


def test_findings_outside_their_ranges_never_leave_diagnose_and_the_verdict_says_unexplained():
    d = Diagnosis(True, [], {}, {}, {}, {}, {}, {}, {}, [], {}, {}, {}, {}, verdict="explained")
    d.findings = [_finding("sensor_offset", "pitch", -0.86), _finding("cable_stiffness", "yaw", 0.004)]
    out = _without_stand_ins(d, stand_ins(d.findings))
    assert [(f.effect, f.axis) for f in out.findings] == [("cable_stiffness", "yaw")]
    assert out.verdict == "partly_explained"
    assert out.refused[0]["effect"] == "sensor_offset" and out.refused[0]["reason"].startswith(STAND_IN)
    d.findings = d.findings[:1]
    assert _without_stand_ins(d, stand_ins(d.findings)).verdict == "unexplained"
    assert _without_stand_ins(d, []) is d


def test_the_shifted_dead_zone_is_simulinks_block_and_the_cut_off_one_passes_larger_voltages_unchanged():
    u = np.array([-2.0, -0.5, -0.2, 0.0, 0.1, 0.2, 0.3, 2.5])
    shifted = effects.by_key("shifted_dead_zone:pitch").modify(u, 0.2)
    np.testing.assert_allclose(shifted, [-1.8, -0.3, 0.0, 0.0, 0.0, 0.0, 0.1, 2.3], atol=1e-15)
    cut = effects.by_key("dead_zone:pitch").modify(u, 0.2)
    np.testing.assert_allclose(cut, [-2.0, -0.5, -0.2, 0.0, 0.0, 0.2, 0.3, 2.5])
    assert effects.other_form_key(effects.by_key("dead_zone:yaw")) == "shifted_dead_zone:yaw"
    assert effects.other_form_key(effects.by_key("input_saturation:yaw")) is None
