"""Every bad-input case: a one-line message naming file and place, a documented exit code, no traceback."""
import numpy as np
import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.errors import EXIT_BAD_LOG, EXIT_INPUT_MISSING
from trms_ident.io.csv_log import read_csv_log

runner = CliRunner()


def _rows(n=50, dt=0.01):
    t = np.arange(n) * dt
    return [f"{ti:.6f},{0.5:.3f},{-0.2:.3f},{0.1 * np.sin(ti):.6f},{0.2 * np.cos(ti):.6f}" for ti in t]


def _write(tmp_path, lines, name="log.csv", encoding="utf-8"):
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n", encoding=encoding)
    return p


def _run(path, *extra):
    res = runner.invoke(app, ["estimate", str(path), "-o", str(path.parent / "out"), "--no-report", *extra])
    assert "Traceback" not in res.output
    return res


HEADER = "t,u1,u2,alpha,beta"


@pytest.mark.parametrize("mutate, message", [
    (lambda r: ["t,u1,u2,alpha"] + [x.rsplit(",", 1)[0] for x in r], r"line 1: missing column\(s\) beta"),
    (lambda r: [HEADER] + r[:9] + ["0.090000,0.5,abc,0.1,0.2"] + r[10:], r"line 11: column u2 holds 'abc'; expected a number"),
    (lambda r: [HEADER] + r[:4] + ["0.040000,0.5,-0.2,nan,0.2"] + r[5:], r"line 6 \(t = 0.04 s\): alpha is nan"),
    (lambda r: [HEADER] + r[:4] + ["0.040000,0.5,-0.2,,0.2"] + r[5:], r"line 6 \(t = 0.04 s\): alpha is nan"),
    (lambda r: [HEADER] + r[:5] + [r[4]] + r[6:], r"line 7 .*repeats the previous time"),
    (lambda r: [HEADER] + r[:5] + [r[3]] + r[6:], r"line 7 .*goes back in time"),
    (lambda r: [HEADER] + r[:20] + r[25:], r"line 22 \(t = 0.25 s\): a gap of 0.06 s after t = 0.19 s; each of its 2 parts is "
                                           r"shorter than the reaction lag Tp \(2 s; the longest is 0.24 s\)"),
    (lambda r: [HEADER] + r[:20] + ["0.193000" + r[20][8:]] + r[21:], r"line 22 .*a step of 0.003 s after t = 0.19 s"),
    (lambda r: [HEADER] + [",".join(x.split(",")[:3] + [str(float(x.split(",")[3]) * 57.3 + 300), x.split(",")[4]])
                           for x in r], r"the angles are in no unit this tool can tell: alpha reaches 30\d\.\d+, beyond "
                                        r"the pitch's \+-1.57 rad and its \+-180 deg; expected radians"),
    (lambda r: [HEADER] + r[:5], r"only 5 samples; expected at least 10"),
    (lambda r: [HEADER] + r[:5] + [r[5] + ",1,2"] + r[6:], r"Expected 5 fields in line 7, saw 7"),
])
def test_bad_csv(tmp_path, mutate, message):
    p = _write(tmp_path, mutate(_rows()))
    res = _run(p)
    assert res.exit_code == EXIT_BAD_LOG, res.output
    assert res.output.startswith(f"error: {p}: ")
    assert len(res.output.strip().splitlines()) == 1
    assert pytest.importorskip("re").search(message, res.output), res.output
    assert not (tmp_path / "out").exists()  # nothing written on failure


def test_empty_file(tmp_path):
    p = tmp_path / "empty.csv"
    p.write_bytes(b"")
    res = _run(p)
    assert res.exit_code == EXIT_BAD_LOG and "file is empty; expected a header line t,u1,u2,alpha,beta" in res.output


def test_missing_file(tmp_path):
    res = _run(tmp_path / "nope.csv")
    assert res.exit_code == EXIT_INPUT_MISSING and "nope.csv: no such file" in res.output


def test_unknown_suffix(tmp_path):
    p = _write(tmp_path, [HEADER] + _rows(), name="log.xlsx")
    res = _run(p)
    assert res.exit_code == EXIT_BAD_LOG and "unknown log type '.xlsx'; expected .csv, .mcap or .mat" in res.output


def test_binary_file(tmp_path):
    p = tmp_path / "bin.csv"
    p.write_bytes(bytes(range(256)) * 10)
    res = _run(p)
    assert res.exit_code == EXIT_BAD_LOG and "not a text file" in res.output


def test_bom_semicolon_and_unit_row_are_read(tmp_path):
    rows = _rows()
    plain = read_csv_log(_write(tmp_path, [HEADER] + rows, "plain.csv"))
    bom = read_csv_log(_write(tmp_path, [HEADER] + rows, "bom.csv", encoding="utf-8-sig"))
    semi = read_csv_log(_write(tmp_path, [HEADER.replace(",", ";")] + [r.replace(",", ";") for r in rows], "semi.csv"))
    deg_rows = [",".join(x.split(",")[:3] + [str(np.degrees(float(v))) for v in x.split(",")[3:]]) for x in rows]
    units = read_csv_log(_write(tmp_path, [HEADER, "s,V,V,deg,deg"] + deg_rows, "units.csv"))
    for other in (bom, semi):
        np.testing.assert_array_equal(other.alpha_rad, plain.alpha_rad)
    np.testing.assert_allclose(units.alpha_rad, plain.alpha_rad, atol=1e-12)
    # the units are said, and where they were assumed: the inputs' unit is in no log but a unit row
    assert units.meta["units"] == {"angles": "deg (the file's units row), converted to rad",
                                   "inputs": "V (the file's units row)"}
    assert plain.meta["units"]["angles"].startswith("rad (no unit given")
    assert plain.meta["units"]["inputs"].startswith("V (assumed")


def test_bad_unit_row(tmp_path):
    p = _write(tmp_path, [HEADER, "s,V,V,grad,rad"] + _rows())
    res = _run(p)
    assert res.exit_code == EXIT_BAD_LOG and "line 2: unit 'grad' for column alpha; expected one of rad, deg" in res.output


def test_angle_unit_option_converts_degrees(tmp_path):
    rows = [",".join(x.split(",")[:3] + [str(np.degrees(float(v))) for v in x.split(",")[3:]]) for x in _rows()]
    p = _write(tmp_path, [HEADER] + rows)
    deg = read_csv_log(p, angle_unit="deg")
    rad = read_csv_log(_write(tmp_path, [HEADER] + _rows(), "rad.csv"))
    np.testing.assert_allclose(deg.beta_rad, rad.beta_rad, atol=1e-12)


def test_csv_column_mapping(tmp_path):
    rows = _rows()
    std = _write(tmp_path, [HEADER] + rows, "std.csv")
    other = _write(tmp_path, ["time;um;ut;pitch_rad;yaw_rad;alpha"] +
                   [x.replace(",", ";") + ";9" for x in rows], "other.csv")  # a stray 'alpha' column too
    a = read_csv_log(std)
    b = read_csv_log(other, signals=["t=time", "u1=um", "u2=ut", "alpha=pitch_rad", "beta=yaw_rad"])
    for x, y in ((a.t_s, b.t_s), (a.u1_v, b.u1_v), (a.alpha_rad, b.alpha_rad), (a.beta_rad, b.beta_rad)):
        np.testing.assert_array_equal(x, y)
    from trms_ident.io.readers import read_log
    listed = read_log(other, signals=["t=time,u1=um", "u2=ut, alpha=pitch_rad,beta=yaw_rad"])  # as --signal takes
    for x, y in ((a.t_s, listed.t_s), (a.u2_v, listed.u2_v), (a.alpha_rad, listed.alpha_rad)):
        np.testing.assert_array_equal(x, y)
    res = _run(other, "--signal", "alpha=pitch")
    assert res.exit_code == EXIT_BAD_LOG and "line 1: no column 'pitch' (for alpha); columns: time, um" in res.output
    res = _run(other, "--signal", "t=time,beta=pitch")  # the file's own names, not those mapped before
    assert res.exit_code == EXIT_BAD_LOG and "no column 'pitch' (for beta); columns: time, um, ut" in res.output


@pytest.mark.parametrize("kind", ["rounded", "dropped", "jittered", "back_in_time"])
def test_step_statistics_equal_numpy_on_the_whole_step_array(kind, monkeypatch):
    """The validator's chunked step figures (no array the size of the log) are numpy's exactly: min, max, first
    non-increasing sample, RMS about the mean step and median, across chunk boundaries and both median paths
    (counted distinct steps, and the fallback that sorts them all)."""
    import trms_ident.log as L

    rng = np.random.default_rng(7)
    for trial in range(40):
        n = int(rng.integers(11, 2000))
        steps = {"rounded": lambda: np.diff(np.round(np.arange(n + 1) * 0.001, 3)),
                 "dropped": lambda: rng.choice([0.001, 0.002, 0.0015], size=n),
                 "jittered": lambda: 0.001 + 1e-5 * rng.standard_normal(n),
                 "back_in_time": lambda: rng.choice([0.001, -0.001, 0.002, 0.0], size=n)}[kind]()
        t = np.concatenate([[0.0], np.cumsum(steps)])
        monkeypatch.setattr(L, "STEP_CHUNK", int(rng.integers(1, 300)))
        monkeypatch.setattr(L, "MAX_DISTINCT_STEPS", int(rng.integers(1, 60)))
        mean = float((t[-1] - t[0]) / (t.size - 1))
        lo, hi, back, spread, median = L._step_statistics(t, mean)
        dt = np.diff(t)
        bad = np.flatnonzero(dt <= 0)
        assert (lo, hi, median) == (dt.min(), dt.max(), np.median(dt))
        assert back == (int(bad[0]) + 1 if bad.size else None)
        assert spread == pytest.approx(np.std(dt), rel=1e-9, abs=1e-15)


def test_csv_longer_than_its_first_lines_foretell_is_read_whole(tmp_path, monkeypatch):
    """The streaming reader sizes its columns from line-end densities sampled over the file: a file whose later
    lines are much shorter than its first is still foretold at no fewer rows than it has; and if the columns
    must grow anyway (a foretelling forced short here), no row is lost."""
    import trms_ident.io.csv_log as C

    n_long = 2000
    t = np.arange(60000) * 0.001
    lines = [HEADER] + [f"{t[i]:.9f},{0.123456789:.9f},{-0.2:.9f},{1e-3 * np.sin(t[i]):.12f},0.000000000001"
                        for i in range(n_long)]
    lines += [f"{t[i]:.3f},1,0,0,0" for i in range(n_long, t.size)]
    path = _write(tmp_path, lines)
    assert C._expected_rows(path) >= t.size
    monkeypatch.setattr(C, "BLOCK_BYTES", 4096)  # many blocks, so the growth happens mid-stream
    monkeypatch.setattr(C, "_expected_rows", lambda p: 1000)
    log = read_csv_log(path)
    assert len(log) == t.size
    np.testing.assert_allclose(log.t_s, np.round(t, 9), atol=1e-9)
    assert log.u1_v[n_long - 1] == pytest.approx(0.123456789) and log.u1_v[-1] == 1.0
