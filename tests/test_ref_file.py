"""`trms-ident simulate --ref-file`: a reference read from a file (issue #35, item 5: a design run through the
simulator before the bench runs it)."""
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from sim import SimSettings, simulate
from sim.references import reference
from trms_ident.cli import app
from trms_ident.errors import EXIT_BAD_LOG, EXIT_INPUT_MISSING, EXIT_USAGE

runner = CliRunner()


def _write(path, t, a, b, header="t,alpha_ref,beta_ref"):
    path.write_text(header + "\n" + "".join(f"{float(x)!r},{float(y)!r},{float(z)!r}\n" for x, y, z in zip(t, a, b)))
    return path


def test_a_reference_file_drives_the_same_run_as_the_built_in_reference_it_holds(tmp_path):
    # the paper's sine written at the controller's own rate: interpolation returns it exactly at every sample, so
    # the run from the file is the built-in run, sample for sample
    t = np.arange(0, 20001) / 1000.0
    a, b = reference("sine", t)
    ref = _write(tmp_path / "design.csv", t, a, b)
    log = tmp_path / "run.csv"
    res = runner.invoke(app, ["simulate", "--ref-file", str(ref), "--rate", "1000", "-o", str(log)])
    assert res.exit_code == 0, res.output
    got = np.genfromtxt(log, delimiter=",", names=True)
    want = simulate(SimSettings(ref="sine", duration_s=20.0, sample_rate_hz=1000.0))
    assert got.size == want.t_s.size  # the run lasts as long as the file
    np.testing.assert_allclose(got["alpha"], want.alpha_rad, atol=1e-12)
    np.testing.assert_allclose(got["u2"], want.u2_v, atol=1e-12)
    truth = json.loads((tmp_path / "run.truth.json").read_text())
    assert truth["settings"]["ref"] == "file" and truth["settings"]["ref_table"] == {"rows": 20001, "end_s": 20.0}
    assert len(truth["reference_file"]["sha256"]) == 64


def test_between_rows_the_reference_is_linear():
    table = (np.array([0.0, 1.0, 3.0]), np.array([0.0, 0.2, -0.2]), np.array([0.0, -0.1, 0.1]))
    r = simulate(SimSettings(ref="file", ref_table=table, sample_rate_hz=100.0))
    assert r.t_s[-1] == pytest.approx(3.0)
    from sim.references import tabulated
    a, b = tabulated(table, np.array([0.5, 2.0, 2.5]))
    np.testing.assert_allclose(a, [0.1, 0.0, -0.1])
    np.testing.assert_allclose(b, [-0.05, 0.0, 0.05])


@pytest.mark.parametrize("text, args, code, message", [
    ("t,alpha_ref\n0,0\n1,0\n", [], EXIT_BAD_LOG, "line 1: header 't,alpha_ref' lacks beta_ref"),
    ("t,alpha_ref,beta_ref\n0,0,0\n1,x,0\n", [], EXIT_BAD_LOG, "line 3: '1,x,0' is not three numbers"),
    ("t,alpha_ref,beta_ref\n0.5,0,0\n1,0,0\n", [], EXIT_BAD_LOG, "line 2: the first time is 0.5 s; expected 0"),
    ("t,alpha_ref,beta_ref\n0,0,0\n1,0,0\n1,0,0\n", [], EXIT_BAD_LOG, "line 4: time 1 s does not rise after 1 s"),
    ("t,alpha_ref,beta_ref\n0,0,0\n1,0,0\n", ["--duration", "5"], EXIT_USAGE,
     "the reference table covers 0 to 1 s; the run needs 0 to 5 s"),
    ("t,alpha_ref,beta_ref\n0,0,0\n1,0,0\n", ["--ref", "sine"], EXIT_USAGE, "give one reference, not both"),
])
def test_a_bad_reference_file_is_refused_in_one_line_naming_it(tmp_path, text, args, code, message):
    ref = tmp_path / "design.csv"
    ref.write_text(text)
    res = runner.invoke(app, ["simulate", "--ref-file", str(ref), "-o", str(tmp_path / "x.csv"), *args])
    assert res.exit_code == code
    assert message in res.output and str(ref) in res.output and "Traceback" not in res.output
    assert not (tmp_path / "x.csv").exists()


def test_a_missing_reference_file_exits_3(tmp_path):
    res = runner.invoke(app, ["simulate", "--ref-file", str(tmp_path / "none.csv"), "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == EXIT_INPUT_MISSING and "no such file" in res.output
