"""diagnose takes a bench file's input modifications as given (model.bench.GIVEN_KEY): its search starts from the
model they make, holds them at their values and adds its findings to them; export writes them back with the
findings; the terminal says what the search stood on."""
import html
import json

import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.errors import EXIT_USAGE, ParameterFileError
from trms_ident.log import validated
from trms_ident.model.bench import GIVEN_KEY, given_of, with_given
from trms_ident.params import diagnose_bench, merge

from .plants import ce150, textbook

CE150 = dict(J1=0.00437, B1=0.00184, J2=0.00414, B2=0.00869)
MOTORS = {"motor_second_lag:pitch": 0.3, "motor_second_lag:yaw": 0.25}


def test_a_bench_dict_carries_its_input_modifications_and_names_a_torque_effect_or_a_bad_value():
    bench = merge(with_given({"Mg": 0.3}, {**MOTORS, "cable_stiffness:yaw": 0.004}), source="bench.toml")
    assert bench["Mg"] == 0.3 and given_of(bench) == MOTORS  # the torque effect is not carried
    assert with_given({"Mg": 0.3}, {"cable_stiffness:yaw": 0.004}) == {"Mg": 0.3} and given_of(merge({})) == {}
    with pytest.raises(ParameterFileError, match=r"bench.toml: \"cable_stiffness:yaw\": a torque effect"):
        merge({GIVEN_KEY: {"cable_stiffness:yaw": 0.004}}, source="bench.toml")
    with pytest.raises(ParameterFileError, match=r"bench.toml: \"motor_second_lag:yaw\": T2 = 9 s is not physical"):
        merge({GIVEN_KEY: {"motor_second_lag:yaw": 9.0}}, source="bench.toml")
    # the bundled CE150 bench: its second-order motors, beside its structure and known values
    ce = diagnose_bench("humusoft_ce150")
    assert given_of(ce) == MOTORS and ce["structure"]["gyroscope"] == "voltage" and ce["Kg"] == 0.015


def test_the_search_adds_to_a_given_modification_and_never_names_it_again():
    """A plant of the textbook's forms with a second-order tail motor (T2 0.2 s) and a 0.2 V dead zone in the
    block's form on the main motor.  Given the tail motor, diagnose names the dead zone alone, at its width, and the
    log is explained: the search stood on the given lag (held, not searched, not reported)."""
    from trms_ident.api import diagnose

    t, u1, u2, a, b = textbook.simulate_log(40.0, 200.0, seed=3, ref="multisine", dead_zone_v=(0.2, 0.0),
                                            second_lag_s=(0.0, 0.2))
    log = validated(t, u1, u2, a, b, source="textbook", angle_unit="rad")
    d = diagnose(log, params={GIVEN_KEY: {"motor_second_lag:yaw": 0.2}})
    assert [(f.effect, f.axis) for f in d.findings] == [("shifted_dead_zone", "pitch")], d.findings
    assert d.findings[0].parameter["value"] == pytest.approx(0.2, rel=0.01)
    assert d.verdict == "explained" and d.settings["given_effects"] == {"motor_second_lag:yaw": 0.2}
    assert min(d.held_out["after"].values()) > 99.0, d.held_out["after"]  # the findings' model holds the lag


def test_the_published_ce150_model_is_consistent_under_its_bench_file_and_exported_with_its_motors(tmp_path):
    """`--params humusoft_ce150` states the CE150's second-order motors in [effects]: diagnose takes them as given,
    so a log of the published model is consistent, nothing found, J/B at the published values (without them the
    search had to find both motors again: 90-800 s, partly explained; benchmarks/RESULTS.md, "CE150 diagnosed").
    The terminal says what the search stood on, and export writes the motors back as given."""
    from trms_ident.api import diagnose
    from trms_ident.commands import bench_from_diagnosis
    from trms_ident.report.diagnosis import render, to_doc
    from trms_ident.report.summary import to_json
    from trms_ident.report.terminal import diagnosis_lines

    t, u1, u2, a, b = ce150.simulate_log(30.0, 100.0, seed=7, ref="steps", encoder_bits=12)
    log = validated(t, u1, u2, a, b, source="ce150 steps", angle_unit="rad")
    d = diagnose(log, params="humusoft_ce150")
    assert d.verdict == "consistent" and not d.findings, (d.verdict, d.findings)
    for k, v in CE150.items():
        assert d.augmented[k] == pytest.approx(v, rel=0.02), k
    lines = "\n".join(diagnosis_lines(d, "ce150.csv"))
    assert "searched on top of the bench's effects (taken as given, held at their values): a second-order main " \
        "motor (T2 = 0.3 s); a second-order tail motor (T2 = 0.25 s)" in lines, lines
    doc = to_doc(d, log)
    page = html.unescape(render(doc, d, log))  # the report says it too, and the structure
    assert "<p>Searched under the bench's structure: the gyroscopic torque driven by the voltage u1 (Kg u1 beta' " \
        "cos alpha);" in page and "Searched on top of the bench's effects" in page
    path = tmp_path / "diagnosis.json"
    path.write_text(to_json(doc))
    bench = bench_from_diagnosis(path)
    assert [(e.key, e.value, e.source) for e in bench["effects"]] == [
        (k, v, "given to diagnose (--params)") for k, v in MOTORS.items()]


def test_a_bench_files_torque_effects_are_said_not_to_be_taken_as_given(tmp_path, monkeypatch):
    """diagnose takes a bench file's input modifications as given, not its torque effects: the CLI says so in one
    note, and hands the search the modifications alone."""
    import trms_ident.api as api

    seen = {}

    class Stop(Exception):
        pass

    def fake(data, params=None, **kwargs):
        seen.update(params)
        raise Stop

    monkeypatch.setattr(api, "diagnose", fake)
    bench = tmp_path / "bench.toml"
    bench.write_text('[effects]\n"cable_stiffness:yaw" = 0.004\n"shifted_dead_zone:pitch" = 0.2\n')
    t, u1, u2, a, b = textbook.simulate_log(5.0, 100.0, seed=3)
    csv = tmp_path / "log.csv"
    rows = (",".join(f"{float(x)!r}" for x in r) for r in zip(t, u1, u2, a, b))
    csv.write_text("t,u1,u2,alpha,beta\n" + "\n".join(rows))
    res = CliRunner().invoke(app, ["diagnose", str(csv), "--params", str(bench)])
    assert "internal error: Stop" in res.output, res.output  # the fake diagnose stopped there, as it should
    assert "holds torque effects (cable_stiffness:yaw), which diagnose does not take as given" in res.output
    assert given_of(seen) == {"shifted_dead_zone:pitch": 0.2}


def test_design_refuses_a_diagnosis_made_on_top_of_given_effects(tmp_path):
    """design --discriminate weighs a diagnosis' look-alikes under eq. (1) and its findings alone: a diagnosis made
    on top of a bench file's effects is refused in one line, not planned without them."""
    from .test_design import _diagnosis

    dia = tmp_path / "diagnosis.json"
    _diagnosis(dia, {"effect": "sensor_offset", "axis": "pitch", "parameter": {"name": "delta", "value": 0.03}},
               ["com_offset:pitch"])
    doc = json.loads(dia.read_text())
    doc["settings"]["given_effects"] = {"motor_second_lag:yaw": 0.25}
    dia.write_text(json.dumps(doc))
    res = CliRunner().invoke(app, ["design", "--duration", "10", "--rate", "50", "--discriminate", str(dia),
                                   "-o", str(tmp_path / "d.csv")])
    assert res.exit_code == EXIT_USAGE and "diagnosed on top of the bench file's effects (motor_second_lag:yaw)" \
        in res.output, res.output
    assert len(res.output.strip().splitlines()) == 1 and not (tmp_path / "d.csv").exists()
