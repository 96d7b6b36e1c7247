"""Logs of every odd shape never crash estimate or diagnose: a documented exit code and one line, or a result."""
import numpy as np
import pytest
from typer.testing import CliRunner

from trms_ident.cli import app
from trms_ident.io.csv_log import write_csv_log

runner = CliRunner()


def _odd_log(kind: str, seed: int, duration_s: float, rate_hz: float):
    rng = np.random.default_rng(seed)
    n = int(duration_s * rate_hz) + 1
    t = np.arange(n) / rate_hz
    if kind == "constant":  # a bench switched on and left alone
        return t, np.full(n, rng.uniform(-1, 1)), np.full(n, rng.uniform(-1, 1)), np.zeros(n), np.zeros(n)
    if kind == "noise":  # inputs and angles that have nothing to do with each other
        return t, rng.normal(0, 1, n), rng.normal(0, 1, n), rng.normal(0, 0.01, n), rng.normal(0, 0.01, n)
    if kind == "weak":  # tiny steps, angles barely move
        u1 = np.repeat(rng.uniform(-0.01, 0.01, n // 50 + 1), 50)[:n]
        return t, u1, 0.01 * np.sin(t), np.cumsum(rng.normal(0, 1e-5, n)), np.cumsum(rng.normal(0, 1e-5, n))
    q = 2 * np.pi / 4096  # quasi-static sweep on an encoder, like the CE150 recordings
    return (t, 0.5 + 0.05 * np.sin(0.1 * t), 0.1 * np.sin(0.03 * t), np.round(0.3 * np.sin(0.05 * t) / q) * q,
            np.round(1.5 * np.sin(0.02 * t) / q) * q)


@pytest.mark.parametrize("duration_s", [0.2, 40.0])
@pytest.mark.parametrize("kind", ["constant", "noise", "weak", "sweep"])
def test_odd_logs_never_crash(tmp_path, kind, duration_s):
    path = tmp_path / f"{kind}.csv"
    write_csv_log(path, *_odd_log(kind, 7, duration_s, 100.0))
    for cmd in (["diagnose", str(path), "--json", "-"], ["estimate", str(path), "-o", str(tmp_path / "o"),
                                                           "--no-report"]):
        res = runner.invoke(app, cmd)
        assert "Traceback" not in res.output and "internal error" not in res.output, res.output
        assert res.exit_code in (0, 4, 6), (cmd[0], res.exit_code, res.output)
        if res.exit_code:  # one line of error (a note that the kernels compile, on a cold cache, is not part of it)
            lines = [x for x in res.output.strip().splitlines() if not x.startswith("note: ")]
            assert len(lines) == 1 and str(path) in lines[0], res.output
