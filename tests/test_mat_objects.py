"""MATLAB class objects in .mat files (read by mat-io): timeseries, Simulink.SimulationOutput, Dataset, table,
timetable, a labelled Structure With Time; v7 and v7.3; the public Simulink files in ../shared/real_logs/simulink/.

Fixtures are written with mat-io's own writer (``matio.save_to_mat``), in the layout MATLAB stores: a timeseries'
samples in ``Data_`` and its time in ``TimeInfo`` (stamps in ``Time_``, or a uniform time as ``Start_`` +
``Increment_`` x ``Length``); a Dataset's elements as ``Simulink.SimulationData.Signal`` objects whose ``Values``
are timeseries, in its storage's ``Elements`` cell.
"""
import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.io
from typer.testing import CliRunner

from sim import SimSettings, simulate
from trms_ident.cli import app
from trms_ident.errors import LogFormatError
from trms_ident.io import mat_log
from trms_ident.io.mat_tree import Struct, Undecoded
from trms_ident.io.readers import read_log

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    import matio
    from matio.utils.matclass import MatlabOpaque

runner = CliRunner()
REAL = Path(__file__).resolve().parents[2] / "shared" / "real_logs"
SIMULINK = REAL / "simulink"
NAMES = ("alpha", "beta", "u1", "u2")


@pytest.fixture(scope="module")
def run():
    return simulate(SimSettings(ref="multisine", sample_rate_hz=100.0, duration_s=40.0, noise_std_rad=5e-4, seed=4))


def _signals(r):
    return dict(zip(NAMES, (r.alpha_rad, r.beta_rad, r.u1_v, r.u2_v)))


def _same(log, r):
    np.testing.assert_allclose(log.t_s, r.t_s - r.t_s[0], atol=1e-9)
    for name, x in _signals(r).items():
        np.testing.assert_array_equal(getattr(log, {"alpha": "alpha_rad", "beta": "beta_rad"}.get(name, name + "_v")), x)


def _timeseries(x, t=None, start=0.0, step=0.01, unit="seconds", name=""):
    """A MATLAB timeseries as saved: uniform time kept as Start_/Increment_/Length, or stamps in TimeInfo.Time_."""
    x = np.asarray(x, dtype=float)
    x = x[:, None] if x.ndim == 1 else x
    info = {"Units": np.array([unit]), "Length": np.array([[float(x.shape[0])]])}
    if t is None:
        info.update(Time_=np.empty((0, 0)), Start_=np.array([[start]]), Increment_=np.array([[step]]))
    else:
        info.update(Time_=np.asarray(t, dtype=float)[:, None], Start_=np.empty((0, 0)), Increment_=np.empty((0, 0)))
    return MatlabOpaque({"Data_": x, "Time_": np.empty((0, 0)), "Name": np.array([name]),
                         "TimeInfo": MatlabOpaque(info, "tsdata.timemetadata")}, "timeseries")


def _dataset(elements: dict):
    cell = np.empty((1, len(elements)), dtype=object)
    for i, (name, values) in enumerate(elements.items()):
        cell[0, i] = MatlabOpaque({"Name": np.array([name]), "PortIndex": np.array([[1.0]]), "Values": values},
                                  "Simulink.SimulationData.Signal")
    storage = MatlabOpaque({"Elements": cell}, "Simulink.SimulationData.Storage.RamDatasetStorage")
    return MatlabOpaque({"Name": np.array(["logsout"]), "Storage_": storage}, "Simulink.SimulationData.Dataset")


def _save(path, variables, version):
    matio.save_to_mat(str(path), variables, version=version)
    return path


@pytest.mark.parametrize("version", ["v7", "v7.3"])
def test_timeseries_variables_with_a_uniform_time_are_found_by_name(tmp_path, run, version):
    step = float(run.t_s[1] - run.t_s[0])
    names = {"alpha": "pitch", "beta": "yaw", "u1": "u1", "u2": "u2"}
    p = _save(tmp_path / "ts.mat", {names[k]: _timeseries(x, step=step) for k, x in _signals(run).items()}, version)
    log = read_log(p)
    _same(log, run)
    assert log.meta["signals"] == "alpha=pitch beta=yaw u1=u1 u2=u2"
    assert "uniform: start 0, increment 0.01 [seconds]" in log.meta["time"]


@pytest.mark.parametrize("version", ["v7", "v7.3"])
def test_simulation_output_with_a_logsout_dataset_needs_no_mapping(tmp_path, run, version):
    out = MatlabOpaque({"tout": run.t_s[:, None], "logsout": _dataset({k: _timeseries(x, t=run.t_s) for k, x in
                                                                      _signals(run).items()})},
                       "Simulink.SimulationOutput")
    p = _save(tmp_path / "out.mat", {"out": out}, version)
    log = read_log(p)
    np.testing.assert_array_equal(log.alpha_rad, run.alpha_rad)
    np.testing.assert_allclose(log.t_s, run.t_s, atol=1e-12)
    assert log.meta["signals"] == "alpha=out.logsout.alpha beta=out.logsout.beta u1=out.logsout.u1 u2=out.logsout.u2"
    info = runner.invoke(app, ["inspect", str(p), "--json", "-"])
    doc = json.loads(info.stdout)
    assert [s["path"] for s in doc["signals"]] == ["out.tout", *(f"out.logsout.{k}" for k in NAMES)]
    assert doc["suggested_signals"]["alpha"] == "alpha=out.logsout.alpha" and "t" not in doc["suggested_signals"]
    if version == "v7.3":  # one end-to-end estimate: the object file gives the simulator's truth
        res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / "o"), "--no-report", "--json", "-"])
        assert res.exit_code == 0, res.output
        est = json.loads(res.stdout)
        assert est["model_check"]["adequate"] and est["input"]["format"] == "mat"
        for k, v in run.truth["estimated"].items():
            assert est["estimates"][k] == pytest.approx(v, rel=0.01 if k.startswith("J") else 0.03)


def test_timeseries_columns_are_mapped_with_path_colon_column(tmp_path, run):
    both = np.column_stack([run.u1_v, run.u2_v, run.alpha_rad, run.beta_rad])
    p = _save(tmp_path / "cols.mat", {"y": _timeseries(both, t=run.t_s, name="bench")}, "v7")
    res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / "o"), "--no-report"])
    assert res.exit_code == 4 and "no variable for alpha" in res.output and "y (4001 x 4)" in res.output
    by_colon = read_log(p, signals=["u1=y:0", "u2=y:1", "alpha=y:2", "beta=y:3"])
    by_index = read_log(p, signals=["u1=y[0],u2=y[1],alpha=y[2],beta=y[3]"])
    _same(by_colon, run)
    np.testing.assert_array_equal(by_colon.beta_rad, by_index.beta_rad)
    info = runner.invoke(app, ["inspect", str(p)])
    assert "y: timeseries, 4001 x 4 (one signal a column: PATH:0 to PATH:3), named 'bench'" in info.output
    with pytest.raises(LogFormatError, match=r"cols.mat: y:7: column 7 of y, shaped \(4001, 4\)"):
        read_log(p, signals=["u1=y:7", "u2=y:1", "alpha=y:2", "beta=y:3"])


@pytest.mark.parametrize("version", ["v7", "v7.3"])
def test_table_columns_by_name_and_timetable_on_its_row_times(tmp_path, run, version):
    table = pd.DataFrame({"t": run.t_s, "Pitch": run.alpha_rad, "Yaw": run.beta_rad, "u1": run.u1_v,
                          "u2": run.u2_v, "note": ["x"] * run.t_s.size})
    rows = pd.TimedeltaIndex(np.round(run.t_s * 1e6).astype("int64").astype("timedelta64[us]"))
    timetable = pd.DataFrame({"alpha": run.alpha_rad, "beta": run.beta_rad, "u1": run.u1_v, "u2": run.u2_v},
                             index=rows)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # mat-io says it stores durations in seconds
        pt = _save(tmp_path / "tab.mat", {"tab": table}, version)
        ptt = _save(tmp_path / "tt.mat", {"tt": timetable}, version)
    log = read_log(pt)
    _same(log, run)
    assert log.meta["signals"] == "alpha=tab.Pitch beta=tab.Yaw u1=tab.u1 u2=tab.u2" and log.meta["time"] == "tab.t"
    log = read_log(ptt)
    _same(log, run)
    assert log.meta["time"].startswith("tt.alpha's time (row times")


def test_a_labelled_structure_with_time_maps_by_label(tmp_path, run):
    p = tmp_path / "swt.mat"
    sigs = np.zeros((4,), dtype=[("values", object), ("label", object), ("blockName", object)])
    for i, name in enumerate(("u1", "u2", "alpha", "beta")):
        sigs[i] = (_signals(run)[name][:, None], name, f"trms/Scope{i}")
    scipy.io.savemat(p, {"yout": {"time": run.t_s[:, None], "signals": sigs}})
    log = read_log(p)
    _same(log, run)
    assert log.meta["signals"] == "alpha=yout.alpha beta=yout.beta u1=yout.u1 u2=yout.u2"
    _same(read_log(p, signals=["alpha=yout.signals[2]"]), run)  # by index still
    assert "yout.alpha: Structure With Time, 4001 samples" in runner.invoke(app, ["inspect", str(p)]).output


def test_signals_on_different_time_bases_are_refused(tmp_path, run):
    variables = {k: _timeseries(x, step=0.01) for k, x in _signals(run).items()}
    variables["u2"] = _timeseries(run.u2_v, step=0.02)
    p = _save(tmp_path / "mixed.mat", variables, "v7")
    with pytest.raises(LogFormatError, match=r"mixed.mat: alpha and u2 are on different time bases \(4001 stamps "
                                             r"from 0 s to 40 s against 4001 from 0 s to 80 s\)"):
        read_log(p)


def test_ambiguous_names_and_undecoded_objects_give_one_line(tmp_path, run, monkeypatch):
    p = tmp_path / "two.mat"
    scipy.io.savemat(p, {"a": {"alpha": run.alpha_rad}, "b": {"alpha": run.alpha_rad}, "beta": run.beta_rad,
                         "u1": run.u1_v, "u2": run.u2_v, "t": run.t_s})
    res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / "o")])
    assert res.exit_code == 4
    assert "several signals could be alpha (a.alpha, b.alpha); map one with --signal alpha=PATH" in res.output
    _same(read_log(p, signals=["alpha=b.alpha"]), run)
    tree = Struct({"out": Struct({"logsout": Undecoded("Simulink.SimulationData.Dataset", "no properties")},
                                 "Simulink.SimulationOutput")}, "file")
    monkeypatch.setattr(mat_log, "load", lambda path: (tree, []))
    with pytest.raises(LogFormatError, match=r"could not decode out.logsout \(class Simulink.SimulationData.Dataset\)"):
        read_log(p)
    with pytest.raises(LogFormatError, match=r"out.logsout is a MATLAB object of class "
                                             r"Simulink.SimulationData.Dataset that could not be decoded"):
        read_log(p, signals=["alpha=out.logsout.alpha"])


def test_a_file_that_is_not_a_mat_file_is_one_line(tmp_path):
    p = tmp_path / "junk.mat"
    p.write_bytes(b"not a MATLAB file at all " * 10)
    res = runner.invoke(app, ["inspect", str(p)])
    assert res.exit_code == 4 and "junk.mat: not a readable MATLAB .mat file" in res.output
    assert "Traceback" not in res.output


def _need_simulink():
    if not SIMULINK.exists():
        pytest.skip("the shared real recordings are not beside this checkout")


def test_simulink_simulation_output_is_listed_and_refused_with_one_line(tmp_path):
    _need_simulink()
    p = SIMULINK / "tras_reg_step_pitch_simout.mat"
    out = runner.invoke(app, ["inspect", str(p)]).output
    assert ("out.azimuth_regulator_step_pitch: timeseries, 251 x 15 (one signal a column: PATH:0 to PATH:14), named "
            "'comanda azimuth'; time 0 to 0.06 s variable step") in out
    assert "out.tout: double, 251 samples" in out and "suggested mapping: --signal t=out.tout" in out
    res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / "o")])
    assert res.exit_code == 4 and len(res.output.strip().splitlines()) == 1
    assert "no variable for alpha" in res.output and "out.pitch_regulator_step_pitch (251 x 15)" in res.output


def test_simulink_timeseries_with_a_mapping_are_refused_as_variable_step(tmp_path):
    _need_simulink()
    p = SIMULINK / "tras_date_step_pitch_timeseries.mat"
    doc = json.loads(runner.invoke(app, ["inspect", str(p), "--json", "-"]).stdout)
    assert [(s["path"], s["samples"], s["columns"]) for s in doc["signals"]] == [
        ("azimuth_step_pitch", 4274, 3), ("pitch_step_pitch", 4274, 3)]
    assert doc["signals"][0]["t1_s"] == pytest.approx(20.0) and doc["signals"][0]["uniform"] is False
    res = runner.invoke(app, ["estimate", str(p), "--signal", "alpha=pitch_step_pitch:1,beta=azimuth_step_pitch:1,"
                              "u1=pitch_step_pitch:2,u2=azimuth_step_pitch:2", "-o", str(tmp_path / "o")])
    assert res.exit_code == 4 and len(res.output.strip().splitlines()) == 1
    assert "pitch_step_pitch:1's time (own stamps [seconds]) is a variable-step time base" in res.output


@pytest.mark.parametrize("name", sorted(p.relative_to(REAL).as_posix() for p in REAL.glob("*/*.mat")) or ["none"])
def test_no_library_warning_on_stderr_for_any_real_file(tmp_path, name):
    """Each shared recording, inspected and estimated in a process of its own: stderr holds the tool's words only.
    (The CE150 recordings' estimates: test_real_recordings runs them so, with --rate 100 --angle-unit deg.)"""
    if name == "none":
        pytest.skip("the shared real recordings are not beside this checkout")
    path = REAL / name
    ran = {}
    runs = [["inspect", str(path)]] + ([] if "ce150" in name else [["estimate", str(path), "-o", str(tmp_path / "o"),
                                                                     "--no-report", "--json", "-"]])
    for args in runs:
        proc = ran[args[0]] = subprocess.run([sys.executable, "-m", "trms_ident", *args], capture_output=True,
                                             text=True, timeout=300)
        assert proc.returncode in (0, 4), proc.stderr
        for bad in ("Warning", "warnings.warn", "DLASCL", "On entry to", "RuntimeWarning", "Traceback"):
            assert bad not in proc.stderr, proc.stderr
    if "ce150" in name:  # a real recording: inspect names the mapping and the rate
        said = ran["inspect"].stdout + ran["inspect"].stderr
        assert "--signal alpha=psi --signal beta=phi" in said and "pass --rate HZ" in said
