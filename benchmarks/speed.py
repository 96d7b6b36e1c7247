"""Speed benchmark (issue #3): `trms-ident estimate` end to end on 10 min, 1 h and 4 h of 1 kHz data.

    python benchmarks/speed.py              # all three lengths, writes the speed section of RESULTS.md
    python benchmarks/speed.py --only 1h

Logs come from the simulator (multisine, 12-bit encoder) written at logger precision
(t to 1 ms, u to 1 uV, angles to 1 nrad): one hour is 3.6 M rows, about 200 MB of CSV.
End to end = a fresh `python -m trms_ident estimate LOG --no-report` process (imports,
reading and hashing the CSV, validation, identification, result.json and traces.csv);
the HTML report is excluded as the issue states.  Peak memory is the child's max RSS.
Estimation = `identify()` alone, in a warm process.  Median of --repeat runs.  The logs are made, and the
estimation timed, in child processes: this one stays small, so that no child inherits its pages in its max
RSS (Linux counts a forked child's pages before exec; see ratios.py).
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

LENGTHS_S = {"10min": 600.0, "1h": 3600.0, "4h": 14400.0}


def make_log(path: Path, seconds: float) -> int:
    """The log written by a child process (ratios.make_logs: the same simulation and rounding); its rows."""
    from ratios import make_logs

    make_logs(path, seconds)
    with open(path, "rb") as f:
        return sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 22), b"")) - 1


def end_to_end(path: Path, out: Path) -> tuple[float, float]:
    """(wall [s], peak RSS [MB]) of `python -m trms_ident estimate PATH -o OUT --no-report`, a fresh process timed
    from outside (ratios.timed: os.wait4), its start-up and exit included."""
    from ratios import estimate_cmd, timed

    return timed(estimate_cmd(path, out))


def estimation_only(path: Path, refine: str = "auto") -> tuple[float, float, str]:
    """_estimation_only in a child process."""
    proc = subprocess.run([sys.executable, __file__, "--estimation-only", str(path), refine], capture_output=True,
                          text=True)
    if proc.returncode:
        raise RuntimeError(proc.stderr)
    return tuple(json.loads(proc.stdout.strip().splitlines()[-1]))


def _estimation_only(path: Path, refine: str = "auto") -> tuple[float, float, str]:
    """identify() in a warm process: (total [s], DREM alone with --refine off [s], what the refinement did)."""
    from trms_ident.identify import Settings, identify
    from trms_ident.io.readers import read_log

    log = read_log(path)
    identify(log, Settings(refine=refine))  # load compiled kernels
    t0 = time.perf_counter()
    res = identify(log, Settings(refine=refine))
    total = time.perf_counter() - t0
    t0 = time.perf_counter()
    identify(log, Settings(refine="off"))
    drem = time.perf_counter() - t0
    return total, drem, "yes" if res.refined is not None else "skipped (auto limit)"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", choices=list(LENGTHS_S))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--skip-forced", action="store_true", help="skip the 1 h --refine on measurement")
    ap.add_argument("--out", default=str(Path(__file__).with_name("RESULTS.md")))
    ap.add_argument("--estimation-only", nargs=2, metavar=("LOG", "REFINE"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.estimation_only:
        print(json.dumps(_estimation_only(Path(args.estimation_only[0]), args.estimation_only[1])))
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, seconds in LENGTHS_S.items():
            if args.only and name != args.only:
                continue
            path = Path(tmp) / f"{name}.csv"
            n = make_log(path, seconds)
            size_mb = path.stat().st_size / 1e6
            runs = [end_to_end(path, Path(tmp) / "out") for _ in range(args.repeat)]
            wall = statistics.median(r[0] for r in runs)
            best = min(r[0] for r in runs)
            rss = max(r[1] for r in runs)
            ests = [estimation_only(path) for _ in range(args.repeat)]
            rows.append(dict(name=name, samples=n, csv_mb=size_mb, wall_s=wall, best_s=best,
                             estimation_s=statistics.median(e[0] for e in ests),
                             drem_s=statistics.median(e[1] for e in ests), refined=ests[0][2], peak_mb=rss,
                             ns_per_sample=1e9 * wall / n))
            print(json.dumps(rows[-1]), file=sys.stderr)
            if name == "1h" and not args.skip_forced:  # what forcing the refinement on a long log costs
                forced = estimation_only(path, "on")
                rows.append(dict(name="1h, --refine on", samples=n, csv_mb=size_mb, wall_s=None, best_s=None,
                                 estimation_s=forced[0], drem_s=forced[1], refined="yes (forced)", peak_mb=None,
                                 ns_per_sample=None))
                print(json.dumps(rows[-1]), file=sys.stderr)
            path.unlink()
    head = ("| log | samples | CSV [MB] | end to end, median [s] | best [s] | estimation only [s] | of which DREM [s] "
            "| refinement | peak memory [MB] | end to end per sample [ns] |")
    dash = lambda v, f: "-" if v is None else format(v, f)  # noqa: E731
    lines = [head, "|---|---|---|---|---|---|---|---|---|---|"] + [
        f"| {r['name']} | {r['samples']:,} | {r['csv_mb']:.0f} | {dash(r['wall_s'], '.2f')} | {dash(r['best_s'], '.2f')} | "
        f"{r['estimation_s']:.2f} | {r['drem_s']:.2f} | {r['refined']} | {dash(r['peak_mb'], '.0f')} | "
        f"{dash(r['ns_per_sample'], '.0f')} |" for r in rows]
    text = ("## Speed (benchmarks/speed.py, median of %d runs, this 2-core machine)\n\n" % args.repeat) + \
        "\n".join(lines) + "\n\nTargets for 1 h: end to end <= 3 s, estimation <= 1 s, peak <= 1 GB, linear growth.\n" + \
        "Default options: the prediction-error refinement runs on logs up to 1 000 000 integration steps (10 min " \
        "at 1 kHz: yes; 1 h and 4 h: skipped, DREM's offline optimum is the estimate); the '--refine on' row is " \
        "what forcing it on the hour costs.\n" + \
        "The machine is shared; with other work on it identical 1 h runs took 2.8-6.9 s in earlier measurements " \
        "(CPU time is about 4.5 s over the 2 cores).\n"
    from results import update_section
    update_section(Path(args.out), "Speed", text)
    print(text)


if __name__ == "__main__":
    main()
