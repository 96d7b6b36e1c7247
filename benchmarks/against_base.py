"""estimate on the hour at 1 kHz: this tree against an earlier revision and the plain scipy pipeline, in one run.

    python benchmarks/against_base.py                   # against HEAD~1, 5 rounds
    python benchmarks/against_base.py --base 587442f --rounds 7

The issue's log (`trms-ident simulate --ref multisine --duration 3600 --encoder-bits 12 --seed 5`) is made once;
then each round runs, in fresh processes and in turn, this tree's `estimate LOG --no-report` (A), the base
revision's (B, a `git worktree` of it, the same interpreter and packages) and the plain scipy pipeline of ratios.py
(C: pandas.read_csv and 16 scipy.signal.lfilter passes), each run once first (numba's cache, every module's
bytecode, as an installed package has them, and the page cache).  Ratios are taken round by round and their median
printed with min and max: the machine is shared and its speed drifts, so only figures measured side by side are
compared.  Peak memory is each child's max RSS (os.wait4).  Writes the
section "Against the base revision" of RESULTS.md unless --no-write.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from ratios import SCIPY_PIPELINE, timed  # noqa: E402

PY = sys.executable


def run_in(tree: Path, *argv: str) -> list[str]:
    """`trms-ident ARGV` from the package in ``tree`` (first on sys.path), as a fresh interpreter's command."""
    return [PY, "-c", f"import sys; sys.path.insert(0, {str(tree)!r}); import runpy; "
            "sys.argv = ['trms-ident'] + sys.argv[1:]; runpy.run_module('trms_ident', run_name='__main__')", *argv]


def estimate_in(tree: Path, log: Path, out: Path) -> list[str]:
    return run_in(tree, "estimate", str(log), "-o", str(out), "--no-report")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base", default="HEAD~1", help="the revision to compare against (default HEAD~1)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=3600.0, help="the log's length (default the hour)")
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "RESULTS.md"))
    args = ap.parse_args()
    base = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.base], check=True,
                          capture_output=True, text=True).stdout.strip()
    here = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], check=True,
                          capture_output=True, text=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--", "trms_ident"],
                                capture_output=True, text=True).stdout.strip())
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        tree = tmp / "base"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(tree), base], check=True)
        try:
            log = tmp / "hour.csv"
            subprocess.run([PY, "-m", "trms_ident", "simulate", "--ref", "multisine", "--duration",
                            f"{args.seconds:g}", "--encoder-bits", "12", "--seed", "5", "-o", str(log)],
                           check=True, cwd=tmp, capture_output=True)
            cmds = {"A": estimate_in(ROOT, log, tmp / "a"), "B": estimate_in(tree, log, tmp / "b"),
                    "C": [PY, "-c", SCIPY_PIPELINE, str(log)]}
            for c in cmds.values():  # numba's cache of each tree, the bytecode of its modules, the page cache
                timed(c)
            runs = {k: [] for k in cmds}
            for i in range(args.rounds):
                for k, c in cmds.items():
                    runs[k].append(timed(c))
                print(f"round {i + 1}: " + ", ".join(f"{k} {runs[k][-1][0]:.2f} s" for k in cmds), file=sys.stderr)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)], check=False)

    def ratio(a: str, b: str) -> str:
        r = [x[0] / y[0] for x, y in zip(runs[a], runs[b])]
        return f"{statistics.median(r):.2f} ({min(r):.2f}-{max(r):.2f})"

    med = {k: statistics.median(x[0] for x in v) for k, v in runs.items()}
    peak = {k: max(x[1] for x in v) for k, v in runs.items()}
    name = f"{here}{' + working tree' if dirty else ''}"
    text = (f"## Against the base revision (benchmarks/against_base.py, {args.rounds} rounds, fresh processes)\n\n"
            f"estimate of the {args.seconds:g} s log at 1 kHz (`simulate --ref multisine --encoder-bits 12 --seed 5`)"
            f", `--no-report`.  A = {name}, B = {base}, C = the plain scipy pipeline.\n\n"
            "| | A | B | C |\n|---|---|---|---|\n"
            f"| median wall [s] | {med['A']:.2f} | {med['B']:.2f} | {med['C']:.2f} |\n"
            f"| peak memory [MB] | {peak['A']:.0f} | {peak['B']:.0f} | {peak['C']:.0f} |\n\n"
            f"A/B {ratio('A', 'B')}, A/C {ratio('A', 'C')}, B/C {ratio('B', 'C')} (median of the rounds' ratios, "
            "min-max).\n")
    print(text)
    if not args.no_write:
        from results import update_section
        update_section(Path(args.out), "Against the base revision", text)


if __name__ == "__main__":
    # each side's modules as bytecode, as an installed package has them (pip writes it at install, an editable install
    # at the first import): the warm-up run writes what is missing.  This machine sets PYTHONDONTWRITEBYTECODE, and
    # with it every timed run of a fresh worktree parsed and compiled the package's source again (~0.3 s of CPU)
    # where the plain pipeline's modules had their bytecode
    os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    main()
