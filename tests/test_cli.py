"""The command line through typer's runner, and one real subprocess."""
import json
import os
import re
import subprocess
import sys

import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.errors import EXIT_BAD_PARAMETERS, EXIT_OUTPUT, EXIT_USAGE

runner = CliRunner()


def test_help_lists_commands():
    res = runner.invoke(app, ["--help"])
    assert res.exit_code == 0
    for cmd in ("estimate", "simulate"):
        assert cmd in res.output
    res = runner.invoke(app, ["estimate", "--help"])
    assert res.exit_code == 0 and "--gain-convention" in res.output and "[rad/s]" in res.output


def test_simulate_then_estimate_with_json_on_stdout(tmp_path):
    log = tmp_path / "sq.csv"
    res = runner.invoke(app, ["simulate", "--ref", "square", "--duration", "15", "--rate", "500", "-o", str(log)])
    assert res.exit_code == 0, res.output
    assert log.exists() and (tmp_path / "sq.truth.json").exists()
    out = tmp_path / "out"
    res = runner.invoke(app, ["estimate", str(log), "-o", str(out), "--json", "-"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert set(doc["estimates"]) == {"J1", "B1", "J2", "B2"}
    assert doc["estimates"]["J1"] == pytest.approx(0.068, rel=1e-3)
    assert doc["truth"]["values"]["B2"] == 0.1
    assert len(doc["input"]["sha256"]) == 64
    assert doc["settings"]["filter_a_rad_s"] == 10.0 and "numpy" in doc["versions"]  # noise-free: fast filters
    assert "fastest candidate" in doc["settings"]["filter_design"]
    lo, hi = doc["ci95"]["J1"]
    assert lo <= doc["estimates"]["J1"] <= hi and doc["identifiable"] == {k: True for k in ("J1", "B1", "J2", "B2")}
    assert doc["parameters"]["Mg"] == {"value": 0.32, "unit": "N m", "meaning": "gravity moment", "source": "table"}
    for name in ("report.html", "traces.csv", "result.json"):
        assert (out / name).stat().st_size > 0
    shown = re.search(r"J1 = (\S+)\s+kg m\^2\s+95 % \[\S+, \S+\]\s+truth 0.068, error ([-+]\d+\.\d+) %",
                      res.stderr)
    assert shown and float(shown.group(1)) == pytest.approx(0.068, rel=1e-3), res.stderr
    assert abs(float(shown.group(2))) < 0.1
    header = (out / "traces.csv").read_text().splitlines()[0]
    assert header == "t,J1,B1,J2,B2"
    html = (out / "report.html").read_text()
    assert "data:image/png;base64," in html and "kg m^2" in html


def test_json_to_file_and_params_file(square_csv, tmp_path):
    params = tmp_path / "bench.toml"
    params.write_text("[parameters]\nMg = 0.33\n")
    target = tmp_path / "r.json"
    res = runner.invoke(app, ["estimate", str(square_csv), "-o", str(tmp_path / "o"), "--no-report",
                              "--params", str(params), "--json", str(target)])
    assert res.exit_code == 0, res.output
    doc = json.loads(target.read_text())
    assert doc["parameters"]["Mg"]["value"] == 0.33 and doc["parameters"]["Mg"]["source"] == "override"
    assert doc["table_defaults_changed"] == ["Mg"]


@pytest.mark.parametrize("args, code, message", [
    (["--a", "-1"], EXIT_USAGE, "filter_a_rad_s must be a positive number"),
    (["--a", "fast"], EXIT_USAGE, "--a 'fast': expected 'auto' or a number in rad/s"),
    (["--a", "2", "--b", "2"], EXIT_USAGE, "must differ"),
    (["--gamma", "fast"], EXIT_USAGE, "--gamma 'fast': expected 'auto'"),
    (["--gamma", "J9=3"], EXIT_USAGE, "gamma given for 'J9'"),
    (["--thrust-law", "cubic"], EXIT_USAGE, "thrust law must be one of"),
    (["--angle-unit", "grad"], EXIT_USAGE, "--angle-unit 'grad': expected one of auto, rad, deg"),
])
def test_bad_options(square_csv, tmp_path, args, code, message):
    res = runner.invoke(app, ["estimate", str(square_csv), "-o", str(tmp_path / "o"), *args])
    assert res.exit_code == code and message in res.output and "Traceback" not in res.output


def test_bad_params_file_exit_code(square_csv, tmp_path):
    p = tmp_path / "p.toml"
    p.write_text("Jx = 1\n")
    res = runner.invoke(app, ["estimate", str(square_csv), "--params", str(p), "-o", str(tmp_path / "o")])
    assert res.exit_code == EXIT_BAD_PARAMETERS and "unknown parameter 'Jx'" in res.output


def test_unwritable_output_leaves_nothing_behind(square_csv, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    res = runner.invoke(app, ["estimate", str(square_csv), "-o", str(blocker / "sub"), "--no-report"])
    assert res.exit_code == EXIT_OUTPUT and "cannot write" in res.output
    assert blocker.read_text() == "x"


def test_existing_outputs_survive_a_failed_run(square_csv, tmp_path):
    out = tmp_path / "o"
    assert runner.invoke(app, ["estimate", str(square_csv), "-o", str(out), "--no-report"]).exit_code == 0
    before = (out / "result.json").read_bytes()
    bad = tmp_path / "bad.csv"
    bad.write_text("t,u1,u2,alpha,beta\n1,2,3\n")
    assert runner.invoke(app, ["estimate", str(bad), "-o", str(out), "--no-report"]).exit_code != 0
    assert (out / "result.json").read_bytes() == before
    assert not [p for p in out.iterdir() if p.name.endswith(".part")]


def test_simulate_bad_options(tmp_path):
    res = runner.invoke(app, ["simulate", "--ref", "ramp", "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == EXIT_USAGE and "unknown reference 'ramp'" in res.output
    res = runner.invoke(app, ["simulate", "--effect", "coulomb_friction", "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == EXIT_USAGE and "expected NAME=VALUE" in res.output
    # the CE150's values mapped onto eq. (1) with Table 1's PID: the loop is unstable, and no log of it is written
    res = runner.invoke(app, ["simulate", "--params", "humusoft_ce150_eq1", "--duration", "20", "-o",
                              str(tmp_path / "x.csv")])
    assert res.exit_code == EXIT_USAGE and "the simulated closed loop is unstable with these parameters: at t = " in \
        res.output and "the PID of eq. (9) is tuned for Table 1's bench" in res.output
    assert not (tmp_path / "x.csv").exists() and not (tmp_path / "x.truth.json").exists()
    # the CE150 with its own structure: the simulator (eq. 1) does not model it, and says so rather than simulate
    # another model under its values
    res = runner.invoke(app, ["simulate", "--params", "humusoft_ce150", "--duration", "20", "-o",
                              str(tmp_path / "x.csv")])
    assert res.exit_code == EXIT_USAGE and "states a [structure] (the gyroscopic torque driven by the voltage u1" in \
        res.output and "which simulate does not model yet" in res.output
    assert not (tmp_path / "x.csv").exists()


def test_python_dash_m_subprocess(square_csv, tmp_path):
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}
    proc = subprocess.run([sys.executable, "-m", "trms_ident", "estimate", str(square_csv), "-o", str(tmp_path / "o"),
                           "--no-report", "--json", "-"], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["estimates"]["J2"] == pytest.approx(0.02, rel=1e-3)
    proc = subprocess.run([sys.executable, "-m", "trms_ident", "estimate", str(tmp_path / "missing.csv")],
                          capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 3 and proc.stderr.strip() == f"error: {tmp_path / 'missing.csv'}: no such file"


def test_simulate_says_the_log_length_and_where_its_stamps_begin(tmp_path):
    out = tmp_path / "mid.csv"
    res = CliRunner().invoke(app, ["simulate", "--ref", "square", "--rate", "100", "--duration", "12", "--start",
                                   "30", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "(1201 samples, 12 s at 100 Hz, stamps from 30 s into the run)" in res.output


TWO = str(min(2, os.cpu_count() or 1))  # OpenBLAS starts no more threads than cores


@pytest.mark.parametrize("given, expected", [({}, "1"), ({"OPENBLAS_NUM_THREADS": "2"}, TWO),
                                             ({"OMP_NUM_THREADS": "2"}, TWO)])
def test_the_command_line_runs_blas_on_one_thread_unless_told(given, expected):
    """Before numpy loads, the CLI asks BLAS for one thread; a thread count the user set wins."""
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                                            "MKL_NUM_THREADS")}
    code = ("import trms_ident.cli, numpy\nfrom threadpoolctl import threadpool_info\n"
            "print(max(i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env={**env, **given},
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == expected


def test_an_interval_is_printed_with_the_digits_that_show_its_width():
    from trms_ident.report.summary import interval_text

    assert interval_text(0.067996, 0.0680131, 0.0680046) == "[0.067996, 0.0680131]"
    # +/- 4e-7 about 0.1 was printed "[0.1, 0.1]"
    assert interval_text(0.09999996, 0.1000005, 0.1000002) == "[0.09999996, 0.1000005]"
    assert interval_text(1.0, 1.0) == "[1, 1]"  # a zero-width interval stays what it is


def test_a_reader_that_goes_away_stops_the_text_not_the_work(square_csv, tmp_path):
    # `2>&1 | head` closes the pipe early: the text stops, the command still writes its files and exits 0;
    # `--json - | head`: the product itself is cut off, so the exit is a shell's for a closed pipe (141)
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}
    out = tmp_path / "o"
    args = [sys.executable, "-m", "trms_ident", "estimate", str(square_csv), "-o", str(out), "--no-report"]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    proc.stderr.close()  # the reader is gone before the first line
    assert proc.wait(timeout=300) == 0
    assert (out / "result.json").exists()
    proc = subprocess.Popen([*args, "--json", "-"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141, err
    assert "Traceback" not in err and "Exception ignored" not in err and "internal error" not in err
