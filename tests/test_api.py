"""The library face (trms_ident.estimate / diagnose / simulate): same numbers as the CLI, clear errors."""
import json
import math

import pytest
from typer.testing import CliRunner

import trms_ident as ti
from trms_ident.cli import app
from trms_ident.errors import LogFormatError, SettingsError
from trms_ident.io.csv_log import write_csv_log


def test_estimate_from_a_dataframe_equals_the_cli_on_the_same_csv(tmp_path):
    r = ti.simulate(ref="multisine", duration_s=60.0, sample_rate_hz=200.0, noise_std_rad=5e-4, seed=1)
    path = tmp_path / "run.csv"
    write_csv_log(path, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    est = ti.estimate(ti.log_frame(r), truth=r.truth["estimated"], free=["Mg"])
    cli = CliRunner().invoke(app, ["estimate", str(path), "--free", "Mg", "-o", str(tmp_path / "o"), "--no-report",
                                   "--json", "-"])
    doc = json.loads(cli.stdout)
    assert est.adequate is True and est.model_check == doc["model_check"]
    assert est.estimates == doc["estimates"] and est.ci95 == doc["ci95"]
    for k, v in r.truth["estimated"].items():
        assert est.estimates[k] == pytest.approx(v, rel=0.01)
    assert list(est.traces.columns) == ["t", "J1", "B1", "J2", "B2"] and est.traces["t"].iloc[-1] == 60.0
    assert json.loads(est.to_json())["refined"]["known_values_estimated"]["Mg"]["estimate"] == pytest.approx(0.32,
                                                                                                         rel=1e-2)
    written = est.save(tmp_path / "api")
    assert {p.name for p in written} == {"result.json", "traces.csv", "report.html"}
    assert est.plot().axes[0].get_ylabel() == "alpha [rad]"
    assert "model fits" in repr(est)


def test_estimate_from_a_path_with_options_and_clear_errors(tmp_path):
    est = ti.estimate("sample_logs/paper_square.csv", refine="off")
    assert est.doc["headline"] == "offline" and est.adequate
    with pytest.raises(SettingsError, match="unknown option\\(s\\) gamma_typo"):
        ti.estimate("sample_logs/paper_square.csv", gamma_typo=3)
    frame = ti.log_frame(ti.simulate(duration_s=2.0)).drop(columns=["beta"])
    with pytest.raises(LogFormatError, match="missing column\\(s\\) beta"):
        ti.estimate(frame)


def test_diagnose_from_python():
    """A DataFrame diagnosed (the CLI's path on sample_logs/concealed_effect.csv: docs/diagnose.md's example): the
    cable named, and J/B under the findings' model with intervals that cover the truth."""
    from trms_ident.api import log_frame

    r = ti.simulate("multisine", duration_s=40.0, sample_rate_hz=100.0, quantization_rad=2 * math.pi / 4096, seed=2,
                    effects=[{"effect": "cable_stiffness", "axis": "yaw", "value": 0.004}])
    d = ti.diagnose(log_frame(r))
    assert d.verdict == "explained" and [f.effect for f in d.findings] == ["cable_stiffness"]
    assert d.findings[0].parameter["value"] == pytest.approx(0.004, rel=0.02)
    w = d.with_findings
    assert w["adequate"] is True and w["model"] == "eq. (1) + a cable on yaw (k = 0.004 N m/rad)"
    for k, v in r.truth["estimated"].items():
        assert w["ci95"][k][0] <= v <= w["ci95"][k][1], (k, w["estimates"][k], w["ci95"][k])


def test_export_writes_a_model_simulate_and_params_accept(tmp_path):
    runner = CliRunner()
    res = runner.invoke(app, ["estimate", "sample_logs/bench_multisine_12bit.csv", "--free", "Mg", "-o",
                              str(tmp_path / "o"), "--no-report", "--json", "-"])
    est = json.loads(res.stdout)
    out = runner.invoke(app, ["export", str(tmp_path / "o" / "result.json"), "-o", str(tmp_path / "m.toml")])
    assert out.exit_code == 0 and "wrote" in out.stderr
    from trms_ident.params import load_parameter_file

    as_truth = load_parameter_file(tmp_path / "m.toml", allow_estimated=True)
    assert as_truth["J2"] == est["estimates"]["J2"]  # the simulator's true values
    assert as_truth["Mg"] == est["refined"]["known_values_estimated"]["Mg"]["estimate"]
    known = load_parameter_file(tmp_path / "m.toml")  # estimate --params: known values only
    assert "J2" not in known and known["Mg"] == as_truth["Mg"]
    bad = runner.invoke(app, ["export", str(tmp_path / "m.toml")])
    assert bad.exit_code == 4 and "not a result.json of trms-ident estimate" in bad.output


def test_an_estimate_far_from_any_bench_is_marked_in_the_json_and_the_report():
    import dataclasses
    from pathlib import Path

    from trms_ident.report.html import render
    from trms_ident.report.summary import summarize

    est = ti.estimate(Path(__file__).resolve().parents[1] / "sample_logs" / "bench_multisine_12bit.csv")
    assert est.doc["not_credible"] == {}
    # a J1 of 150 kg m^2 (e.g. voltages logged in another unit) stays a number, with why it is not credible
    r = dataclasses.replace(est.result, estimates={**est.result.estimates, "J1": 150.0})
    doc = summarize(r, est.log)
    assert doc["not_credible"] == {"J1": "implausible: 2.21e+03x Table 1's 0.068 kg m^2"}
    assert "150 (implausible: 2.21e+03x Table 1" in render(doc, r, est.log)
