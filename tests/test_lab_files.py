"""A lab's own files on the first try (issue #49): units that can only be one thing, messages in seconds, every
problem in one message, lost samples, a motor that is off, a first report that agrees with itself."""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.errors import EXIT_BAD_LOG, EXIT_USAGE, LogFormatError
from trms_ident.io.csv_log import write_csv_log
from trms_ident.log import angle_unit_of, validated

from .conftest import sim_cached

runner = CliRunner()
Q12 = 2 * np.pi / 4096
CE150 = Path(__file__).resolve().parents[2] / "shared" / "real_logs" / "ce150"


def _truth(r) -> dict:
    return r.truth["estimated"]


def _close(estimates: dict, truth: dict, j_rel=0.005, b_rel=0.02) -> None:
    for k, v in truth.items():
        assert estimates[k] == pytest.approx(v, rel=j_rel if k.startswith("J") else b_rel), k


def test_ms_stamps_and_degrees_without_a_unit_row_estimate_to_the_truth_and_say_both(tmp_path):
    """A clean 12-bit log written as labs often do: stamps in ms, angles in degrees, no unit row.  A 25 deg
    pitch is impossible in rad and ordinary in degrees, so the file can only mean degrees: read so, and said."""
    r = sim_cached("multisine", 200.0, 40.0, quantization=Q12, seed=4)
    p = tmp_path / "lab.csv"
    pd.DataFrame({"t": r.t_s * 1000.0, "u1": r.u1_v, "u2": r.u2_v, "alpha": np.degrees(r.alpha_rad),
                  "beta": np.degrees(r.beta_rad)}).to_csv(p, index=False)
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o"), "--json", "-"])
    assert res.exit_code == 0, res.output
    assert "note: stamps read as ms" in res.stderr
    assert "note: angles read as degrees and converted to rad (alpha reaches" in res.stderr
    assert "pass --angle-unit rad if they are radians" in res.stderr
    doc = json.loads(res.stdout)
    assert doc["input"]["units"]["angles"].startswith("deg (told from the values: alpha reaches")
    assert doc["input"]["assumed"]["angle_unit"].startswith("angles read as degrees")
    assert doc["model_check"]["adequate"] is True
    _close(doc["estimates"], _truth(r))


@pytest.mark.parametrize("alpha_peak, beta_peak, unit", [
    (1.2, 2.5, "rad"),  # plausible either way: radians, as always
    (45.0, 10.0, "deg"),  # a pitch of 45 rad cannot be; 45 deg is ordinary
    (90.1, 0.5, "deg"),  # a CE150's elevation at its top
    (30.0, 1516.0, "deg"),  # degrees by the pitch; the yaw drifted 4.2 turns (a blind benchmark's bench)
    (400.0, 1.0, None),  # neither: refused
    (1.0, 30.0, None),  # a yaw beyond four turns beside a small pitch: degrees, or a yaw that drifted
])
def test_the_angle_unit_is_told_only_where_the_values_allow_one_reading(alpha_peak, beta_peak, unit):
    t = np.linspace(0.0, 1.0, 101)
    alpha, beta = alpha_peak * np.sin(2 * np.pi * t), beta_peak * t  # the yaw drifts to its peak
    assert angle_unit_of(alpha, beta)[0] == unit
    if unit is None:
        with pytest.raises(LogFormatError, match=r"the angles are in no unit this tool can tell: .* --angle-unit deg"):
            validated(t, 0 * t, 0 * t, alpha, beta, source="x.csv")
        return
    log = validated(t, 0 * t, 0 * t, alpha, beta, source="x.csv")
    scale = np.pi / 180 if unit == "deg" else 1.0
    assert np.allclose(log.alpha_rad, alpha * scale) and ("angle_unit" in log.meta.get("assumed", {})) is (unit == "deg")


def test_an_error_on_a_ms_stamped_log_names_its_time_in_seconds_with_the_row(tmp_path):
    t = np.arange(200) * 10.0 + 5000.0  # ms, from 5 s
    alpha = 0.1 * np.sin(t / 1000.0)
    alpha[57] = np.nan
    p = tmp_path / "ms.csv"
    pd.DataFrame({"t": t, "u1": 0.5, "u2": 0.1, "alpha": alpha, "beta": 0.0}).to_csv(p, index=False)
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o")])
    assert res.exit_code == EXIT_BAD_LOG
    assert f"error: {p}: line 59 (t = 5.57 s, 0.57 s from the start): alpha is nan" in res.output
    assert "run 1" not in res.output


def test_the_ce150_ramp_without_a_rate_gets_one_error_naming_the_rate_and_the_angle_unit():
    path = CE150 / "Data100_ea_a0.mat"
    if not path.exists():
        pytest.skip("the shared real recordings are not beside this checkout")
    res = runner.invoke(app, ["estimate", str(path), "--no-report"])
    assert res.exit_code == EXIT_BAD_LOG and len(res.output.strip().splitlines()) == 1, res.output
    assert "2 things to settle: (1) no time vector" in res.output and "--rate HZ" in res.output
    assert "(2) the angles will be read as degrees (alpha reaches 90.1" in res.output
    assert "--angle-unit rad if they are radians" in res.output


def _dropped(r, spans_s: list[tuple[float, float]]) -> np.ndarray:
    keep = np.ones(r.t_s.size, bool)
    for a, b in spans_s:
        keep &= ~((r.t_s > a) & (r.t_s < b))
    return keep


@pytest.mark.parametrize("spans", [[(20.0, 20.3)], [(9.0, 9.05), (21.0, 23.0), (33.0, 33.6)]],
                         ids=["one gap", "three gaps"])
def test_lost_samples_split_the_log_into_parts_estimated_jointly(tmp_path, spans):
    r = sim_cached("multisine", 200.0, 45.0, quantization=Q12, seed=6)
    keep = _dropped(r, spans)
    p = tmp_path / "lost.csv"
    write_csv_log(p, r.t_s[keep], r.u1_v[keep], r.u2_v[keep], r.alpha_rad[keep], r.beta_rad[keep])
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o"), "--json", "-"])
    assert res.exit_code == 0, res.output
    gaps = "a gap of" if len(spans) == 1 else f"{len(spans)} gaps in its stamps"
    assert res.stderr.startswith(f"note: {p}: ") and gaps in res.stderr.splitlines()[0]
    assert f"its {len(spans) + 1} parts estimated jointly, as runs of one bench" in res.stderr
    doc = json.loads(res.stdout)["joint"]
    assert [g["length_s"] for g in doc["split"][0]["gaps"]] == pytest.approx([b - a for a, b in spans], abs=0.006)
    assert [g["after_s"] for g in doc["split"][0]["gaps"]] == pytest.approx([a for a, _ in spans], abs=0.006)
    assert doc["split"][0]["left_out"] == [] and len(doc["logs"]) == len(spans) + 1
    _close(doc["estimates"], _truth(r))
    strict = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "s"), "--strict-gaps"])
    assert strict.exit_code == EXIT_BAD_LOG and "expected steps of 0.005 s" in strict.output
    assert not (tmp_path / "s").exists()


def test_a_part_too_short_to_use_is_left_out_and_named(tmp_path):
    r = sim_cached("multisine", 200.0, 45.0, quantization=Q12, seed=6)
    keep = _dropped(r, [(25.0, 25.4), (42.0, 44.0)])  # leaves 44-45 s: 1 s, shorter than Tp = 2 s
    p = tmp_path / "short.csv"
    write_csv_log(p, r.t_s[keep], r.u1_v[keep], r.u2_v[keep], r.alpha_rad[keep], r.beta_rad[keep])
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o"), "--json", "-"])
    assert res.exit_code == 0, res.output
    assert "its 2 parts estimated jointly" in res.stderr
    assert f"note: {p} part 3 (t = 44" in res.stderr and "left out: 1 s long, shorter than the reaction lag Tp (2 s)" \
        in res.stderr
    doc = json.loads(res.stdout)["joint"]
    assert [x["part"] for x in doc["split"][0]["left_out"]] == [f"{p} part 3"] and len(doc["logs"]) == 2
    _close(doc["estimates"], _truth(r))


def test_a_tail_motor_that_was_off_is_held_at_zero_with_signal_u2_0(tmp_path):
    """The tail motor off (its controller's gains zero), its u2 column dropped: refused with the hint, then
    estimated with --signal u2=0; the yaw moves under the main rotor's reaction alone, and every J/B is a number
    with an interval or is said to be not identifiable."""
    from sim import SimSettings, simulate
    from sim.simulate import DEFAULT_PID

    r = simulate(SimSettings(ref="multisine", sample_rate_hz=200.0, duration_s=40.0, quantization_rad=Q12, seed=2,
                             pid=dict(DEFAULT_PID, Kp2=0.0, Ki2=0.0, Kd2=0.0)))
    assert not np.any(r.u2_v)
    p = tmp_path / "tail_off.csv"
    pd.DataFrame({"t": r.t_s, "u1": r.u1_v, "alpha": r.alpha_rad, "beta": r.beta_rad}).to_csv(p, index=False)
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o")])
    assert res.exit_code == EXIT_BAD_LOG and "u2=0 if that motor was off" in res.output
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o"), "--signal", "u2=0",
                              "--json", "-"])
    assert res.exit_code == 0, res.output
    assert "note: u2 = 0 V throughout: not logged" in res.stderr
    doc = json.loads(res.stdout)
    assert doc["input"]["held_inputs"] == {"u2": 0.0}
    _close({k: doc["estimates"][k] for k in ("J1", "B1")}, {k: _truth(r)[k] for k in ("J1", "B1")})
    for k in ("J2", "B2"):
        if doc["estimates"][k] is None:
            assert doc["identifiability"][k]
        else:
            lo, hi = doc["ci95"][k]
            assert lo is not None and lo <= doc["estimates"][k] <= hi
    bad = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "b"), "--signal", "alpha=0"])
    assert bad.exit_code == EXIT_USAGE and "a constant is for a motor that was off" in bad.output


def test_a_motor_off_in_a_mat_file_and_every_missing_signal_in_one_message(tmp_path):
    scipy_io = pytest.importorskip("scipy.io")
    r = sim_cached("steps", 100.0, 20.0)
    p = tmp_path / "run.mat"
    scipy_io.savemat(p, {"pitch": r.alpha_rad, "yaw": r.beta_rad, "u1": r.u1_v})
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o")])
    assert res.exit_code == EXIT_BAD_LOG and len(res.output.strip().splitlines()) == 1
    assert "2 things to settle: (1) no variable for u2" in res.output and "(2) no time vector" in res.output
    assert "u2=0 if that motor was off" in res.output
    res = runner.invoke(app, ["estimate", str(p), "--no-report", "-o", str(tmp_path / "o"), "--rate", "100",
                              "--signal", "u2=0", "--json", "-"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["input"]["held_inputs"] == {"u2": 0.0}


def test_residual_tests_do_not_apply_where_the_noise_floor_cannot_be_measured(tmp_path):
    """A noise-free log: the residual is the integrator's, coloured whatever the model; its tests say they do not
    apply (in the JSON and the report, with no figure of them) instead of failing under a fitting verdict.  A
    12-bit log keeps its tests and figure."""
    for name, noisy in (("clean", False), ("encoder", True)):
        r = sim_cached("multisine", 200.0, 30.0, quantization=Q12 if noisy else 0.0, seed=1)
        p = tmp_path / f"{name}.csv"
        write_csv_log(p, r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
        res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / name), "--json", "-"])
        assert res.exit_code == 0, res.output
        doc = json.loads(res.stdout)
        page = (tmp_path / name / "report.html").read_text()
        for axis in doc["model_check"]["axes"].values():
            assert axis["whiteness"]["applies"] is noisy and axis["input_correlation"]["applies"] is noisy
            assert (axis["whiteness"]["white"] is None) is not noisy
        assert ("does not apply (no measurable noise)" in page) is not noisy
        assert ('alt="residual correlations"' in page) is noisy


def test_batch_estimates_a_log_with_lost_samples_as_its_parts(tmp_path):
    r = sim_cached("multisine", 200.0, 45.0, quantization=Q12, seed=6)
    keep = _dropped(r, [(20.0, 20.3)])
    folder = tmp_path / "lab"
    folder.mkdir()
    write_csv_log(folder / "lost.csv", r.t_s[keep], r.u1_v[keep], r.u2_v[keep], r.alpha_rad[keep], r.beta_rad[keep])
    write_csv_log(folder / "whole.csv", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    res = runner.invoke(app, ["batch", str(folder), "-o", str(tmp_path / "out"), "--no-report", "--json", "-"])
    assert res.exit_code == 0, res.output
    rows = {Path(f["path"]).name: f for f in json.loads(res.stdout)["files"]}
    assert rows["lost.csv"]["status"] == "ok" and "a gap of" in rows["lost.csv"]["error"]
    assert "estimated jointly as its parts" in rows["lost.csv"]["error"]
    _close(rows["lost.csv"]["estimates"], _truth(r))
    assert json.loads((tmp_path / "out" / "lost" / "result.json").read_text())["joint"]["split"]
    strict = runner.invoke(app, ["batch", str(folder), "-o", str(tmp_path / "s"), "--no-report", "--strict-gaps",
                                 "--json", "-"])
    assert strict.exit_code == 8  # some failed: the log with a gap, refused
    rows = {Path(f["path"]).name: f for f in json.loads(strict.stdout)["files"]}
    assert rows["lost.csv"]["status"] == "failed" and "expected steps of 0.005 s" in rows["lost.csv"]["error"]
