"""One bench, many recordings: the joint estimate, the consistency test, manifests (issue #33)."""
import json

import numpy as np
import pytest
import scipy.io
from typer.testing import CliRunner

import trms_ident as ti
from sim import SimSettings, simulate
from trms_ident.cli import app
from trms_ident.errors import InputNotFoundError, LogFormatError
from trms_ident.identify import identify
from trms_ident.io.csv_log import write_csv_log
from trms_ident.joint import identify_joint
from trms_ident.log import validated

runner = CliRunner()
TRUE = {"J1": 0.08, "B1": 0.007, "J2": 0.025, "B2": 0.12}


def _run(ref, rate, seed, start=0.0, over=None, noise=5e-4, duration=50.0):
    return simulate(SimSettings(ref=ref, sample_rate_hz=rate, duration_s=duration, noise_std_rad=noise, seed=seed,
                                start_s=start, overrides={**TRUE, **(over or {})}))


def _log(r, name):
    return validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad, angle_unit="rad", source=name)


@pytest.fixture(scope="module")
def bench():
    return [_run("multisine", 200.0, 1), _run("steps", 500.0, 2, start=20.0), _run("sine", 100.0, 3, start=5.0)]


def test_the_joint_estimate_of_one_log_is_its_own_estimate(bench):
    log = _log(bench[0], "one")
    alone = identify(log)
    joint = identify_joint([log])
    for i, k in enumerate(TRUE):  # equal to the stopping rule's tolerance: a tenth of a standard error
        se = np.sqrt(alone.refined.cov_jb[i, i])
        assert abs(joint.fit.estimate[k] - alone.refined.estimate[k]) <= 0.1 * se
        assert joint.fit.ci95[k] == pytest.approx(alone.refined.ci95[k], abs=0.1 * se)
    assert joint.fit.cost <= alone.refined.cost + 0.1  # refine's MIN_COST_DECREASE
    assert joint.consistent is None and "cannot be tested" in joint.sentence


def test_logs_of_one_bench_agree_and_pool_tighter_than_any_alone(bench):
    logs = [_log(r, f"run{i}") for i, r in enumerate(bench)]
    j = identify_joint(logs)
    assert j.consistent is True and j.outliers == []
    for k, v in TRUE.items():
        assert j.estimates[k] == pytest.approx(v, rel=0.005 if k.startswith("J") else 0.02)
        lo, hi = j.ci95[k]
        assert lo <= v <= hi
        best_alone = min(v_.ci95[k][1] - v_.ci95[k][0] for v_ in j.logs if v_.estimates[k] is not None)
        assert hi - lo <= best_alone  # the efficient combination: no wider than any log's own
    assert all(v.model_check["adequate"] for v in j.logs)


def test_the_pool_is_the_precision_weighted_mean_of_the_logs_own_estimates():
    """The efficient step from the output-error fit: with each log's score variance S C S (C its own covariance),
    the pooled J/B is sum(C^-1)^-1 sum(C^-1 theta_log) and its covariance sum(C^-1)^-1, no wider than any log's in
    any direction, whatever the logs' normal matrices S (here far from C^-1: coloured noise)."""
    from types import SimpleNamespace

    from trms_ident.numerics.joint import _efficient_step

    rng = np.random.default_rng(4)

    def spd():
        a = rng.normal(size=(4, 4))
        return a @ a.T + 0.5 * np.eye(4)

    jb = np.array([0.08, 0.007, 0.025, 0.12])
    thetas = [jb * (1 + 1e-3 * rng.normal(size=4)) for _ in range(3)]
    covs = [1e-8 * spd() for _ in range(3)]
    system, meats = [], []
    for theta, c, w in zip(thetas, covs, (1.0, 0.3, 2.0)):  # a log's weight scales its S, r by w and M by w^2
        s = 1e6 * spd()
        system.append(SimpleNamespace(s_gg=w * s, r_gg=w * s @ (theta - jb)))
        meats.append(w * w * s @ c @ s)
    est, cov = _efficient_step(jb, system, meats)
    infos = [np.linalg.inv(c) for c in covs]
    expected_cov = np.linalg.inv(sum(infos))
    np.testing.assert_allclose(cov, expected_cov, rtol=1e-6, atol=1e-20)
    np.testing.assert_allclose(est, expected_cov @ sum(i @ t for i, t in zip(infos, thetas)), rtol=1e-9)
    for c in covs:  # C_log - C_pool is positive semi-definite
        assert np.linalg.eigvalsh(c - cov).min() >= -1e-12 * np.abs(c).max()


def test_a_log_from_another_bench_is_named_and_left_out(bench):
    odd = _run("chirp", 250.0, 4, over={"J1": 1.1 * TRUE["J1"]})
    logs = [_log(r, f"run{i}") for i, r in enumerate(bench)] + [_log(odd, "rotor changed")]
    j = identify_joint(logs)
    assert j.outliers == ["rotor changed"] and j.consistent is True
    assert j.sentence.startswith("Left out of the pool: J1 in rotor changed is 10")
    assert "% above the others" in j.sentence
    assert j.estimates["J1"] == pytest.approx(TRUE["J1"], rel=0.005)
    assert [v.in_pool for v in j.logs] == [True, True, True, False]


def test_logs_of_mixed_rates_and_formats_through_the_command_line(bench, tmp_path):
    a, b, c = bench
    write_csv_log(tmp_path / "a.csv", a.t_s, a.u1_v, a.u2_v, a.alpha_rad, a.beta_rad)
    scipy.io.savemat(tmp_path / "b.mat", {"t": b.t_s, "pitch": b.alpha_rad, "yaw": b.beta_rad, "u1": b.u1_v,
                                          "u2": b.u2_v})
    scipy.io.savemat(tmp_path / "c.mat", {"data": np.column_stack([c.u1_v, c.u2_v, c.alpha_rad, c.beta_rad])})
    (tmp_path / "runs.csv").write_text('path,signal,rate,name\nb.mat,,,fast steps\n'
                                       'c.mat,"u1=data:0,u2=data:1,alpha=data:2,beta=data:3",100,slow sine\n')
    res = runner.invoke(app, ["estimate", "--joint", str(tmp_path / "a.csv"), "--manifest", str(tmp_path / "runs.csv"),
                              "-o", str(tmp_path / "out"), "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)["joint"]
    assert [lg["name"] for lg in doc["logs"]] == ["fast steps", "slow sine", "a.csv"]
    assert [round(1 / lg["sample_time_s"]) for lg in doc["logs"]] == [500, 100, 200]
    assert doc["consistent"] is True and res.stderr.startswith("LOGS AGREE: The 3 logs agree")
    for k, v in TRUE.items():
        assert doc["estimates"][k] == pytest.approx(v, rel=0.005 if k.startswith("J") else 0.02)
    page = (tmp_path / "out" / "report.html").read_text()
    assert "Do the logs agree?" in page and "forest plot" in page and page.count("<h3>") == 3
    api = ti.estimate_joint(tmp_path / "runs.csv")
    assert api.consistent is True and api.estimates["J1"] == pytest.approx(TRUE["J1"], rel=0.005)


def test_several_logs_without_joint_are_refused():
    res = runner.invoke(app, ["estimate", "a.csv", "b.csv"])
    assert res.exit_code == 2 and "estimate takes one log (2 given): add --joint" in res.output


def test_a_manifest_error_names_its_line(bench, tmp_path):
    a = bench[0]
    write_csv_log(tmp_path / "a.csv", a.t_s, a.u1_v, a.u2_v, a.alpha_rad, a.beta_rad)
    m = tmp_path / "m.csv"
    m.write_text("path,name\na.csv,first\nmissing.csv,second\n")
    with pytest.raises(InputNotFoundError, match=r"m.csv: line 3: no such log .*missing.csv"):
        ti.estimate_joint(m)
    m.write_text("path,signal\na.csv,alpha=nope\n")
    res = runner.invoke(app, ["estimate", "--manifest", str(m), "-o", str(tmp_path / "o")])
    assert res.exit_code == 4 and len(res.output.strip().splitlines()) == 1, res.output
    assert "m.csv: line 2:" in res.output and "nope" in res.output
    m.write_text("file,name\na.csv,x\n")
    with pytest.raises(LogFormatError, match=r"m.csv: line 1: expected a header starting with 'path'"):
        ti.estimate_joint(m)


def _joined(tmp_path, restart: bool):
    parts = [_run(ref, 200.0, seed, start=st, duration=30.0) for ref, seed, st in
             (("multisine", 11, 0.0), ("steps", 12, 15.0), ("sine", 13, 0.0))]
    if restart:  # each run's clock starts at 0 again
        t = np.concatenate([p.t_s - p.t_s[0] for p in parts])
    else:  # one clock, but the angles jump where the runs meet
        t = np.arange(sum(p.t_s.size for p in parts)) * 0.005
    cat = lambda f: np.concatenate([getattr(p, f) + (0.0 if restart or f != "beta_rad" else 3.0 * k)
                                    for k, p in enumerate(parts)])
    path = tmp_path / "joined.csv"
    write_csv_log(path, t, cat("u1_v"), cat("u2_v"), cat("alpha_rad"), cat("beta_rad"))
    return path


@pytest.mark.parametrize("restart", [True, False], ids=["time restarts", "angles jump"])
def test_runs_joined_in_one_file_are_found_and_estimated_jointly(tmp_path, restart):
    path = _joined(tmp_path, restart)
    res = runner.invoke(app, ["estimate", str(path), "-o", str(tmp_path / "o"), "--json", "-"])
    assert res.exit_code == 0, res.output
    note = res.stderr.splitlines()[0]
    assert note.startswith(f"note: {path}: holds 3 runs joined end to end (line 6003 (t = ")
    assert ("time restarts" if restart else "rad in one sample") in note and note.endswith("as runs of one bench")
    doc = json.loads(res.stdout)["joint"]
    assert [lg["name"] for lg in doc["logs"]] == ["joined.csv run 1", "joined.csv run 2", "joined.csv run 3"]
    assert doc["consistent"] is True and doc["estimates"]["J1"] == pytest.approx(TRUE["J1"], rel=0.005)


def test_batch_estimates_each_bench_jointly_and_flags_a_change_over_time(tmp_path):
    rows = ["path,name,bench,date"]
    for bench, over in (("A", {}), ("B", {"J2": 0.03})):
        for k, (ref, rate, date) in enumerate((("multisine", 200.0, "2024-01-10"), ("steps", 500.0, "2024-02-11"),
                                               ("sine", 100.0, "2024-03-12"))):
            changed = {"J1": 0.088} if bench == "B" and k == 2 else {}
            r = _run(ref, rate, 20 + k, over={**over, **changed}, duration=40.0)
            write_csv_log(tmp_path / f"{bench}_{ref}.csv", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)
            rows.append(f"{bench}_{ref}.csv,{bench} {ref},{bench},{date}")
    (tmp_path / "archive.csv").write_text("\n".join(rows) + "\n")
    res = runner.invoke(app, ["batch", "--manifest", str(tmp_path / "archive.csv"), "--joint-by", "bench", "-o",
                              str(tmp_path / "out"), "--json", "-"])
    assert res.exit_code == 0, res.output
    groups = {g["group"]: g for g in json.loads(res.stdout)["groups"]}
    assert groups["A"]["outliers"] == [] and groups["A"]["estimates"]["J1"] == pytest.approx(TRUE["J1"], rel=0.005)
    assert groups["B"]["outliers"] == ["B sine"] and groups["B"]["estimates"]["J2"] == pytest.approx(0.03, rel=0.005)
    assert "J1 in B sine is 10" in groups["B"]["sentence"]
    page = (tmp_path / "out" / "joint_index.html").read_text()
    assert page.count("estimates over time") == 2 and (tmp_path / "out" / "B" / "report.html").exists()
    res = runner.invoke(app, ["batch", "--joint-by", "bench", "-o", str(tmp_path / "x")])
    assert res.exit_code == 2 and "--joint-by and --manifest go together" in res.output


def test_a_yaw_wrapped_by_its_logger_is_not_a_join(bench):
    r = bench[0]
    wrapped = (r.beta_rad + np.pi) % (2 * np.pi) - np.pi  # into [-pi, pi)
    assert np.any(np.abs(np.diff(wrapped)) > 6.0)  # the wrap happens in this run
    log = validated(r.t_s, r.u1_v, r.u2_v, r.alpha_rad, wrapped, angle_unit="rad", source="wrapped")
    assert len(log) == r.t_s.size


def test_a_pooled_fit_that_overflows_from_the_logs_estimates_starts_again_from_the_table(bench, monkeypatch):
    """The CE150's recordings under eq. (1) pooled from their own estimates (J2 0.0018-0.07) overflowed before
    the first step and ended in an internal error; the pool starts again from the table's J/B, and where that fails
    too it says so in one line naming the logs."""
    import trms_ident.joint as joint_module
    from trms_ident.errors import IdentificationError
    from trms_ident.params import defaults

    real = joint_module.refine_joint
    starts = []

    def overflow_first(runs, params, law, theta0, **kw):
        starts.append(dict(theta0))
        if len(starts) == 1:
            raise np.linalg.LinAlgError("the normal equations are not finite (the model overflowed on this log)")
        return real(runs, params, law, theta0, **kw)

    logs = [_log(bench[0], "a"), _log(bench[1], "b")]
    monkeypatch.setattr(joint_module, "refine_joint", overflow_first)
    res = identify_joint(logs)
    table = defaults()
    assert starts[1] == {k: table[k] for k in TRUE} and starts[0] != starts[1]
    assert res.fit.converged
    for k, v in TRUE.items():
        assert res.fit.estimate[k] == pytest.approx(v, rel=0.02)

    def always(*args, **kw):
        raise np.linalg.LinAlgError("the normal equations are not finite")

    monkeypatch.setattr(joint_module, "refine_joint", always)
    with pytest.raises(IdentificationError, match="the pooled fit of a, b failed from the logs' own estimates and "
                                                  "from the table's J/B"):
        identify_joint(logs)
