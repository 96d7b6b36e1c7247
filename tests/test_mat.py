"""MATLAB logs: v5/v7 (scipy.io) and v7.3 (HDF5) with named vectors, matrices, Simulink structures."""
import html
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from typer.testing import CliRunner

from sim import SimSettings, simulate
from trms_ident.cli import app
from trms_ident.io.readers import read_log

runner = CliRunner()
CE150 = Path(__file__).resolve().parents[2] / "shared" / "real_logs" / "ce150"


@pytest.fixture(scope="module")
def run():
    return simulate(SimSettings(ref="multisine", sample_rate_hz=100.0, duration_s=60.0, noise_std_rad=5e-4, seed=2))


def _same(log, r):
    np.testing.assert_allclose(log.t_s, r.t_s, atol=1e-12)
    for a, b in ((log.alpha_rad, r.alpha_rad), (log.beta_rad, r.beta_rad), (log.u1_v, r.u1_v), (log.u2_v, r.u2_v)):
        np.testing.assert_array_equal(a, b)


def test_named_vectors_with_aliases_and_a_time_vector(tmp_path, run):
    p = tmp_path / "named.mat"
    scipy.io.savemat(p, {"tout": run.t_s[:, None], "Pitch": run.alpha_rad[:, None], "yaw": run.beta_rad,
                         "u1": run.u1_v, "u2": run.u2_v})
    _same(read_log(p), run)
    res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / "o"), "--no-report", "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["model_check"]["adequate"] and doc["input"]["format"] == "mat"
    for k, v in run.truth["estimated"].items():
        assert doc["estimates"][k] == pytest.approx(v, rel=0.01 if k.startswith("J") else 0.03)


def test_a_matrix_with_a_column_mapping_and_a_rate(tmp_path, run):
    p = tmp_path / "matrix.mat"
    scipy.io.savemat(p, {"data": np.column_stack([run.u1_v, run.u2_v, run.alpha_rad, run.beta_rad])})
    res = runner.invoke(app, ["estimate", str(p), "-o", str(tmp_path / "o"), "--no-report"])
    assert res.exit_code == 4 and "no variable for alpha" in res.output and "--signal alpha=PATH" in res.output
    signals = ["--signal", "u1=data[0]", "--signal", "u2=data[1]", "--signal", "alpha=data[2]",
               "--signal", "beta=data[3]"]
    res = runner.invoke(app, ["estimate", str(p), *signals, "-o", str(tmp_path / "o"), "--no-report"])
    assert res.exit_code == 4 and "no time vector" in res.output and "--rate HZ" in res.output
    _same(read_log(p, signals=signals[1::2], rate_hz=100.0), run)
    listed = runner.invoke(app, ["estimate", str(p), "--signal", "u1=data[0],u2=data[1],alpha=data[2],beta=data[3]",
                                 "--rate", "100", "-o", str(tmp_path / "l"), "--no-report", "--json", "-"])
    assert listed.exit_code == 0, listed.output
    assert json.loads(listed.stdout)["input"]["samples"] == run.t_s.size


def test_simulink_structure_with_time(tmp_path, run):
    p = tmp_path / "simulink.mat"
    sigs = np.zeros((4,), dtype=[("values", object), ("label", object)])
    for i, (x, name) in enumerate(((run.u1_v, "u1"), (run.u2_v, "u2"), (run.alpha_rad, "alpha"),
                                   (run.beta_rad, "beta"))):
        sigs[i] = (x[:, None], name)
    scipy.io.savemat(p, {"yout": {"time": run.t_s[:, None], "signals": sigs}})
    m = [f"{k}=yout.signals[{i}]" for i, k in enumerate(("u1", "u2", "alpha", "beta"))]
    _same(read_log(p, signals=m), run)


def test_matlab_v73_hdf5(tmp_path, run):
    h5py = pytest.importorskip("h5py")
    p = tmp_path / "v73.mat"
    with h5py.File(p, "w") as f:  # MATLAB writes column vectors as 1 x n datasets (column-major)
        for name, x in (("t", run.t_s), ("alpha", run.alpha_rad), ("beta", run.beta_rad), ("u1", run.u1_v),
                        ("u2", run.u2_v)):
            f[name] = x[None, :]
    _same(read_log(p), run)


@pytest.mark.parametrize("name", ["Data100_ea_a0", "Data100_ea_e675_aN130toP130"])
def test_real_ce150_mat_files_load_with_a_rate_and_get_a_verdict(tmp_path, name):
    path = CE150 / f"{name}.mat"
    if not path.exists():
        pytest.skip("the shared real recordings are not beside this checkout")
    info = runner.invoke(app, ["inspect", str(path)])
    assert "--signal alpha=psi --signal beta=phi" in info.output and "pass --rate HZ" in info.output
    res = runner.invoke(app, ["estimate", str(path), "--rate", "100", "--angle-unit", "deg", "-o",
                              str(tmp_path / "o"), "--no-report", "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["model_check"]["adequate"] is False and doc["input"]["samples"] == 10001


def test_batch_of_real_ce150_files_marks_what_is_not_credible(tmp_path):
    from trms_ident.params import implausible

    if not CE150.exists():
        pytest.skip("the shared real recordings are not beside this checkout")
    res = runner.invoke(app, ["batch", str(CE150), "-o", str(tmp_path / "b"), "--rate", "100", "--angle-unit", "deg",
                              "--no-report", "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    page = (tmp_path / "b" / "index.html").read_text()
    assert len(doc["files"]) == 2 and all(f["adequate"] is False for f in doc["files"])
    for f in doc["files"]:  # every estimate's credibility, in the summary and on the page
        expected = {k: implausible(k, v) for k, v in f["estimates"].items() if v is not None and implausible(k, v)}
        assert f["not_credible"] == expected
        for why in expected.values():
            assert html.escape(why) in page
