"""Every benchmark script parses its command line: --help prints its usage and runs nothing.

benchmarks/known_values.py once read sys.argv for --no-write alone, so `--help` started its 4-minute run and
rewrote RESULTS.md; diagnose.py had no --no-write at all."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.name for p in BENCHMARKS.glob("*.py") if '__name__ == "__main__"' in p.read_text())


def test_every_script_is_found():
    assert {"known_values.py", "diagnose.py", "power.py", "independent.py"} <= set(SCRIPTS)


@pytest.mark.parametrize("script", SCRIPTS)
def test_help_prints_usage_and_runs_nothing(script, tmp_path):
    before = (BENCHMARKS / "RESULTS.md").stat().st_mtime_ns
    r = subprocess.run([sys.executable, str(BENCHMARKS / script), "--help"], capture_output=True, text=True,
                       timeout=120, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-500:]
    assert r.stdout.startswith("usage:"), r.stdout[:300]
    assert (BENCHMARKS / "RESULTS.md").stat().st_mtime_ns == before
