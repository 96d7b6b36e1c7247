"""Batch scaling (issue #13): `trms-ident batch` on a folder of 8 logs with -j1 and -j2, wall time each.

    python benchmarks/batch_speed.py     # 8 logs of 5 min at 1 kHz (12-bit), 3 alternating runs each

Each run is a fresh `python -m trms_ident batch DIR -o OUT --force --no-report` process; the ratio is
computed run by run (j1 / j2) because the machine is shared.  Writes the "Batch scaling" section of
benchmarks/RESULTS.md.

Measured on 2 cores: -j1 already keeps about 1.45 cores busy (5.6 s CPU in 3.8 s wall: the CSV is parsed by
pyarrow's threads while the file is hashed and the kernels load, and the two axes run in parallel), so -j2
can be at most ~1.4x faster here; it measured 1.18-1.23x.  Before the command line asked BLAS for one thread,
-j1 took 7.7 s of CPU in 5.2 s and -j2 was 1.02-1.14x faster: OpenBLAS's idle threads spun on both cores.
"""
from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from sim import SimSettings, simulate  # noqa: E402
from trms_ident.io.csv_log import write_csv_log  # noqa: E402


def main() -> None:
    from results import plain_args

    args = plain_args(__doc__)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "logs"
        folder.mkdir()
        for i in range(8):
            r = simulate(SimSettings(ref="multisine", sample_rate_hz=1000.0, duration_s=300.0,
                                     quantization_rad=2 * np.pi / 4096, seed=i))
            write_csv_log(folder / f"run{i}.csv", r.t_s, r.u1_v, r.u2_v, r.alpha_rad, r.beta_rad)

        def run(jobs: int) -> float:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "trms_ident", "batch", str(folder), "-o", str(Path(tmp) / "out"),
                            "--force", "--no-report", "-j", str(jobs)], check=True, capture_output=True)
            return time.perf_counter() - t0

        run(2)  # warm: compiled kernels cached, files in the page cache
        pairs = [(run(1), run(2)) for _ in range(3)]
    ratios = [a / b for a, b in pairs]
    text = ("## Batch scaling\n\n`python benchmarks/batch_speed.py`: 8 logs of 5 min at 1 kHz, `batch --force "
            "--no-report`, 3 alternating runs.\n\n"
            f"- -j1: median {statistics.median(a for a, _ in pairs):.1f} s; -j2: median "
            f"{statistics.median(b for _, b in pairs):.1f} s\n"
            f"- speed-up j1/j2 per run: {', '.join(f'{x:.2f}' for x in ratios)} (median "
            f"{statistics.median(ratios):.2f}; target >= 1.6)\n")
    print(text)
    from results import update_section

    if not args.no_write:
        update_section(Path(__file__).with_name("RESULTS.md"), "Batch scaling", text)


if __name__ == "__main__":
    main()
