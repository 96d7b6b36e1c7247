"""Speed and memory ratios of issue #13 (points 3 and 7), each measured against its yardstick in one run.

    python benchmarks/ratios.py            # about 4 minutes; writes the "Ratios" section of RESULTS.md
    python benchmarks/ratios.py --repeat 5

Every figure is a fresh process timed from outside (start-up and imports included), the tool's command and
its yardstick run in turn (A B A B ...) and the ratio taken pair by pair, median over the pairs: the
machine is shared and its speed drifts.  Peak memory is the child's max RSS (os.wait4).  The logs are made in
a child process too: Linux counts a forked child's pages before exec in its max RSS, so a parent holding an hour
of simulated data (~670 MB) had set the hour's figure itself (it read 667 MB until this was found).

| tool command (A) | yardstick (B) | target |
|---|---|---|
| estimate, 20 s paper_square.csv | python -c "import numpy, pandas, scipy.signal" | A/B <= 1.5 |
| estimate, 10 min at 1 kHz (refinement runs) | plain scipy pipeline: pandas.read_csv + 16 scipy.signal.lfilter passes | A/B <= 1.0 |
| estimate, 1 h at 1 kHz, CSV | pyarrow.csv.read_csv of the same file, columns to numpy | A/B <= 1.3 |
| estimate, 1 h at 1 kHz, MCAP (ROS 2 CDR) | estimate of the same log as CSV | A/B <= 1.3 |
| estimate, 1 h, peak memory | - | <= 400 MB |
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from sim import SimSettings, simulate  # noqa: E402
from trms_ident.io.csv_log import write_columns  # noqa: E402
from trms_ident.io.mcap_log import write_mcap_log  # noqa: E402

PY = sys.executable
SCIPY_PIPELINE = """
import sys
import pandas as pd
from scipy import signal
f = pd.read_csv(sys.argv[1])
b, a = signal.butter(2, 0.01)
for name in ("u1", "u2", "alpha", "beta"):
    x = f[name].to_numpy()
    for _ in range(4):
        x = signal.lfilter(b, a, x)
"""
PYARROW_READ = """
import sys
import pyarrow.csv as pc
t = pc.read_csv(sys.argv[1])
cols = [c.to_numpy() for c in t.columns]
"""


def timed(cmd: list[str]) -> tuple[float, float]:
    """(wall [s], peak RSS [MB]) of one fresh process; raises on a non-zero exit."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise RuntimeError(f"{cmd}: exit {proc.returncode}: {err[-500:]}")
    return wall, usage.ru_maxrss / 1024.0


def estimate_cmd(path: Path, out: Path) -> list[str]:
    return [PY, "-m", "trms_ident", "estimate", str(path), "-o", str(out), "--no-report"]


def pairs(a: list[str], b: list[str], repeat: int) -> dict:
    timed(a), timed(b)  # warm the page cache and numba's
    ra, rb = [], []
    for _ in range(repeat):
        ra.append(timed(a))
        rb.append(timed(b))
    ratios = [x[0] / y[0] for x, y in zip(ra, rb)]
    return {"a_s": statistics.median(x[0] for x in ra), "b_s": statistics.median(y[0] for y in rb),
            "ratio": statistics.median(ratios), "ratio_min": min(ratios), "ratio_max": max(ratios),
            "a_peak_mb": max(x[1] for x in ra)}


def make_csv(path: Path, seconds: float, cable_yaw: float = 0.0) -> dict:
    effects = [dict(effect="cable_stiffness", axis="yaw", value=cable_yaw)] if cable_yaw else []
    r = simulate(SimSettings(ref="multisine", duration_s=seconds, quantization_rad=2 * np.pi / 4096, seed=5,
                             effects=effects))
    cols = {"t": np.round(r.t_s, 3), "u1": np.round(r.u1_v, 6), "u2": np.round(r.u2_v, 6),
            "alpha": np.round(r.alpha_rad, 9), "beta": np.round(r.beta_rad, 9)}
    write_columns(path, cols)
    return cols


def make_logs(csv: Path, seconds: float, mcap: Path | None = None, cable_yaw: float = 0.0) -> None:
    """make_csv (and the same log as MCAP) in a child process, so that this one never holds the data.

    cable_yaw [N m/rad]: a yaw cable_stiffness effect of that size in the simulated bench (0: none)."""
    extra = ["--cable-yaw", str(cable_yaw)] if cable_yaw else []
    subprocess.run([PY, __file__, "--make", str(csv), str(seconds)] + ([str(mcap)] if mcap else []) + extra,
                   check=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--make", nargs="+", metavar="ARG", help="CSV SECONDS [MCAP]: only write the log (internal)")
    ap.add_argument("--cable-yaw", type=float, default=0.0, help="with --make: a yaw cable [N m/rad] (internal)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(Path(__file__).with_name("RESULTS.md")))
    args = ap.parse_args()
    if args.make:
        cols = make_csv(Path(args.make[0]), float(args.make[1]), args.cable_yaw)
        if len(args.make) > 2:
            write_mcap_log(Path(args.make[2]), cols["t"], cols["u1"], cols["u2"], cols["alpha"], cols["beta"],
                           encoding="cdr")
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        out = tmp / "out"
        short = ROOT / "sample_logs" / "paper_square.csv"
        rows.append(("estimate, 20 s paper_square.csv", 'python -c "import numpy, pandas, scipy.signal"', 1.5,
                     pairs(estimate_cmd(short, out), [PY, "-c", "import numpy, pandas, scipy.signal"], args.repeat)))
        print(rows[-1], file=sys.stderr)
        m10 = tmp / "10min.csv"
        make_logs(m10, 600.0)
        rows.append(("estimate, 10 min at 1 kHz (refinement runs)",
                     "pandas.read_csv + 16 scipy.signal.lfilter passes", 1.0,
                     pairs(estimate_cmd(m10, out), [PY, "-c", SCIPY_PIPELINE, str(m10)], args.repeat)))
        print(rows[-1], file=sys.stderr)
        m10.unlink()
        h1, h1m = tmp / "1h.csv", tmp / "1h.mcap"
        make_logs(h1, 3600.0, h1m)
        rows.append(("estimate, 1 h at 1 kHz, CSV", "pyarrow.csv.read_csv + columns to numpy", 1.3,
                     pairs(estimate_cmd(h1, out), [PY, "-c", PYARROW_READ, str(h1)], args.repeat)))
        print(rows[-1], file=sys.stderr)
        rows.append(("estimate, 1 h at 1 kHz, MCAP (ROS 2 CDR, zstd)", "estimate of the same log as CSV", 1.3,
                     pairs(estimate_cmd(h1m, out), estimate_cmd(h1, tmp / "out_csv"), args.repeat)))
        print(rows[-1], file=sys.stderr)
    lines = ["| tool command (A) | yardstick (B) | A median [s] | B median [s] | A/B median (min-max) | target A/B "
             "| met | A peak memory [MB] |", "|---|---|---|---|---|---|---|---|"]
    for a, b, target, r in rows:
        lines.append(f"| {a} | {b} | {r['a_s']:.2f} | {r['b_s']:.2f} | {r['ratio']:.2f} ({r['ratio_min']:.2f}-"
                     f"{r['ratio_max']:.2f}) | <= {target:g} | {'yes' if r['ratio'] <= target else 'no'} | "
                     f"{r['a_peak_mb']:.0f} |")
    peak = rows[2][3]["a_peak_mb"]
    text = (f"## Ratios (benchmarks/ratios.py, {args.repeat} alternating pairs, fresh processes, this 2-core "
            "machine)\n\n" + "\n".join(lines) +
            f"\n\n1 h estimate (CSV) peak memory: {peak:.0f} MB (target 400 MB: {'met' if peak <= 400 else 'not met'}).\n")
    from results import update_section
    update_section(Path(args.out), "Ratios", text)
    print(text)


if __name__ == "__main__":
    main()
