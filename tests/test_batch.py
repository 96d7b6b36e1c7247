"""Batch over a folder: nothing lost, failures carried past, exit codes, re-runs, and Dask."""
import csv
import json
import math
import os

import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.errors import EXIT_ALL_FAILED, EXIT_SOME_FAILED, EXIT_USAGE
from trms_ident.io.csv_log import write_csv_log
from trms_ident.io.mcap_log import write_mcap_log

from .conftest import sim_cached

runner = CliRunner()


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """20 logs: 14 CSV and 4 MCAP that are fine, 2 broken (a CSV without beta, a truncated MCAP)."""
    d = tmp_path_factory.mktemp("lab")
    (d / "day2").mkdir()
    for i in range(18):
        r = sim_cached("steps", 100.0, 12.0, 0.0, 0.0, i)
        cols = (r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
        if i < 14:
            write_csv_log(d / f"run{i:02d}.csv", *cols)
        else:
            write_mcap_log(d / "day2" / f"run{i:02d}.mcap", *cols)
    (d / "broken.csv").write_text("t,u1,u2,alpha\n0,1,2,3\n")
    (d / "day2" / "cut.mcap").write_bytes((d / "day2" / "run14.mcap").read_bytes()[:2000])
    return d


def _batch(inputs, out, *extra):
    res = runner.invoke(app, ["batch", *map(str, inputs), "-o", str(out), "--no-report", *extra])
    assert "Traceback" not in res.output
    return res


def test_folder_of_20_with_2_broken(folder, tmp_path):
    out = tmp_path / "out"
    res = _batch([folder], out, "--jobs", "2")
    assert res.exit_code == EXIT_SOME_FAILED, res.output
    doc = json.loads((out / "summary.json").read_text())
    assert len(doc["files"]) == 20 and doc["ok"] == 18 and doc["failed"] == 2
    failed = {os.path.basename(f["path"]): f["error"] for f in doc["files"] if f["status"] == "failed"}
    assert set(failed) == {"broken.csv", "cut.mcap"}
    assert "missing column(s) beta" in failed["broken.csv"]
    assert "truncated" in failed["cut.mcap"]
    for f in doc["files"]:
        if f["status"] == "ok":
            assert f["estimates"]["J1"] == pytest.approx(0.068, rel=0.01)
            assert (tmp_path / "out" / os.path.basename(f["output"]) / "result.json").exists()
    assert len((out / "summary.csv").read_text().strip().splitlines()) == 21
    assert "18 ok, 2 failed" in (out / "index.html").read_text()
    assert "18 ok (0 up to date, skipped), 2 failed" in res.output

    # same results with one process; re-runs skip what is up to date, and redo a changed log
    again = _batch([folder], out)
    assert "18 ok (18 up to date, skipped), 2 failed, the model does not fit 0" in again.output
    os.utime(folder / "run03.csv")
    third = _batch([folder], out)
    assert "18 ok (17 up to date, skipped), 2 failed" in third.output
    serial = json.loads((out / "summary.json").read_text())
    assert [f["estimates"] for f in serial["files"]] == [f["estimates"] for f in doc["files"]]


def test_all_failed_and_nothing_found(folder, tmp_path):
    res = _batch([folder / "broken.csv"], tmp_path / "o")
    assert res.exit_code == EXIT_ALL_FAILED
    empty = tmp_path / "empty"
    empty.mkdir()
    res = _batch([empty], tmp_path / "o2")
    assert res.exit_code == EXIT_USAGE and "no .csv, .mcap or .mat logs found" in res.output
    res = _batch([tmp_path / "nope*.csv"], tmp_path / "o3")
    assert res.exit_code == EXIT_USAGE and "no such file, folder or matching pattern" in res.output


def test_dask_cluster_gives_the_same_summary(folder, tmp_path):
    distributed = pytest.importorskip("distributed")
    local = _batch([folder], tmp_path / "local", "--jobs", "2")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        res = _batch([folder], tmp_path / "dask", "--scheduler", cluster.scheduler_address)
    assert res.exit_code == local.exit_code == EXIT_SOME_FAILED, res.output
    a = json.loads((tmp_path / "local" / "summary.json").read_text())["files"]
    b = json.loads((tmp_path / "dask" / "summary.json").read_text())["files"]
    assert [(f["path"], f["status"], f["error"], f["estimates"]) for f in a] == \
           [(f["path"], f["status"], f["error"], f["estimates"]) for f in b]


def test_unreachable_scheduler(folder, tmp_path):
    pytest.importorskip("distributed")
    res = _batch([folder / "run00.csv"], tmp_path / "o", "--scheduler", "tcp://127.0.0.1:1")
    assert res.exit_code == EXIT_USAGE and "cannot connect" in res.output


def test_earlier_outputs_are_never_inputs(folder, tmp_path, monkeypatch):
    monkeypatch.chdir(folder.parent)
    first = _batch([folder.name], folder / "results_a")  # outputs inside the searched folder, relative paths
    assert first.exit_code == EXIT_SOME_FAILED, first.output
    again = _batch([folder.name], tmp_path / "results_b")  # a new output folder: the old one's files are ignored
    doc = json.loads((tmp_path / "results_b" / "summary.json").read_text())
    assert len(doc["files"]) == 20, [f["path"] for f in doc["files"]]
    assert all(os.path.isabs(f["output"]) for f in doc["files"]) and again.exit_code == EXIT_SOME_FAILED


def test_a_folder_diagnosed_names_each_misfits_findings_and_which_recur(tmp_path):
    """batch --diagnose (issue #48): two runs of a bench with a yaw cable (the model does not fit them: both
    diagnosed, the cable found in both) and one of Table 1's bench (fits: not diagnosed)."""
    folder = tmp_path / "lab"
    folder.mkdir()
    cable = (("effect", "cable_stiffness"), ("axis", "yaw"), ("value", 0.004))
    for name, ref, seed, effects in (("cable_a", "multisine", 2, (cable,)), ("cable_b", "steps", 3, (cable,)),
                                     ("clean", "multisine", 4, ())):
        r = sim_cached(ref, 100.0, 30.0, 0.0, 2 * math.pi / 4096, seed, effects)
        write_csv_log(folder / f"{name}.csv", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    out = tmp_path / "out"
    res = runner.invoke(app, ["batch", str(folder), "-o", str(out), "--diagnose"])
    assert res.exit_code == 0, res.output
    doc = json.loads((out / "summary.json").read_text())
    by = {os.path.basename(f["path"]): f for f in doc["files"]}
    assert by["clean.csv"]["adequate"] is True and by["clean.csv"]["diagnosis"] is None
    for name in ("cable_a.csv", "cable_b.csv"):
        dg = by[name]["diagnosis"]
        assert by[name]["adequate"] is False and dg["verdict"] == "explained", dg
        assert [f["key"] for f in dg["findings"]] == ["cable_stiffness:yaw"]
        assert os.path.exists(dg["file"])
        page = (out / name.split(".")[0] / "diagnosis.html").read_text()
        assert "Under the findings' model</b> (eq. (1) + a cable on yaw (k = 0.004 N m/rad); it fits this log)" in page
    assert doc["findings_across_logs"] == {"cable_stiffness:yaw": {"logs": 2, "diagnosed": 2}}
    rows = {r[0].rsplit("/", 1)[-1]: r for r in csv.reader((out / "summary.csv").read_text().splitlines()[1:])}
    assert rows["cable_a.csv"][-2] == "explained" and rows["cable_a.csv"][-1].startswith("a cable on yaw (k = 0.004")
    assert rows["clean.csv"][-2:] == ["", ""]
    page = (out / "index.html").read_text()
    assert "Findings across the logs" in page and "cable_stiffness:yaw: in 2 of the 2 logs diagnosed" in page
    assert "diagnose: EXPLAINED: a cable on yaw (k = 0.004" in res.stderr
    assert "findings across the logs: cable_stiffness:yaw in 2 of 2 diagnosed" in res.stderr


def test_a_bench_pooled_and_diagnosed_says_which_findings_recur_across_its_logs(tmp_path):
    """batch --manifest --joint-by bench --diagnose (issue #48): two runs of a bench with a yaw cable, pooled; the
    model does not fit either alone, so each is diagnosed, and the cable recurs in both."""
    folder = tmp_path / "lab"
    folder.mkdir()
    cable = (("effect", "cable_stiffness"), ("axis", "yaw"), ("value", 0.004))
    for name, ref, seed in (("cable_a", "multisine", 2), ("cable_b", "steps", 3)):
        r = sim_cached(ref, 100.0, 30.0, 0.0, 2 * math.pi / 4096, seed, (cable,))
        write_csv_log(folder / f"{name}.csv", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
    (folder / "runs.csv").write_text("path,bench\ncable_a.csv,cable\ncable_b.csv,cable\n")
    res = runner.invoke(app, ["batch", "--manifest", str(folder / "runs.csv"), "--joint-by", "bench", "-o",
                              str(tmp_path / "joint"), "--diagnose"])
    assert res.exit_code == 0, res.output
    group, = json.loads((tmp_path / "joint" / "joint_summary.json").read_text())["groups"]
    assert [lg["diagnosis"]["findings"][0]["key"] for lg in group["per_log"]] == ["cable_stiffness:yaw"] * 2
    assert all(os.path.exists(lg["diagnosis"]["file"]) for lg in group["per_log"])
    assert group["findings_across_logs"] == {"cable_stiffness:yaw": {"logs": 2, "diagnosed": 2}}
    assert "cable_stiffness:yaw: found in 2 of the 2 logs diagnosed" in res.stderr
    assert "cable_stiffness:yaw: in 2 of the 2 logs diagnosed" in (tmp_path / "joint" / "joint_index.html").read_text()
