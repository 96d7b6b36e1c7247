"""diagnose's time a log, this tree against a base revision side by side, on logs nobody here tuned on.

    python benchmarks/diagnose_speed.py --seed 515                 # 12 logs, against HEAD~1; writes "Diagnose speed"
    python benchmarks/diagnose_speed.py --seed 515 --base 587442f --n 20
    python benchmarks/diagnose_speed.py --seed 515 --no-base       # this tree alone
    python benchmarks/diagnose_speed.py --seed 515 --head HEAD      # a commit of its own as A (the tree may change)

The logs are benchmarks/independent.py's benches (tests/plants/textbook.py: clean, dead zones in the block's
form on one and both motors, second-order motors, a known value off beside a dead zone, saturations), the
first ``--n`` of the kinds taken in turn, written as CSV.  Each log is diagnosed in a fresh process
(`trms-ident diagnose LOG --json OUT`, start-up and report-free) by this tree (A) and, right after, by the base
revision (B: a `git worktree`, the same interpreter and packages, numba's cache warmed first), so that the
ratio of each pair is measured on one machine state; one process at a time, the cores the machine has (diagnose
uses them itself).  Reported: each side's median and slowest time a log, the median of the pairs' ratios, peak
memory, and how many logs got the same diagnosis (verdict, findings and their values) on both sides.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from independent import KINDS, cases, draw_log  # noqa: E402
from against_base import run_in  # noqa: E402
from ratios import timed  # noqa: E402



def diagnose_in(tree: Path, log: Path, out: Path) -> list[str]:
    return run_in(tree, "diagnose", str(log), "--json", str(out))


def said(path: Path) -> tuple:
    """What a diagnosis says, as the terminal says it: the verdict and each finding's effect, axis, value to 4
    significant digits and alternatives (a refit's last digits, ~1e-7, are not a different diagnosis)."""
    d = json.loads(path.read_text(encoding="utf-8"))
    return (d.get("verdict"), tuple((f.get("effect"), f.get("axis"), f"{f['parameter']['value']:.4g}",
                                     tuple(f.get("alternatives") or ())) for f in d.get("findings") or ()))


def picked(seed: int, n: int) -> list[dict]:
    """The first n benches taking the kinds in turn (independent.py numbers them by kind)."""
    by_kind = [[c for c in cases(seed, 30) if c["kind"] == k] for k, _ in KINDS]
    out = []
    while len(out) < n and any(by_kind):
        for group in by_kind:
            if group and len(out) < n:
                out.append(group.pop(0))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, required=True, help="the benches' seed (say which in RESULTS.md)")
    ap.add_argument("--n", type=int, default=12, help="how many logs (default 12, at most 30)")
    ap.add_argument("--base", default="HEAD~1", help="the revision to compare against (default HEAD~1)")
    ap.add_argument("--no-base", action="store_true", help="time this tree alone")
    ap.add_argument("--head", help="a revision to time as A instead of the working tree (a worktree of its own)")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    git = lambda *a: subprocess.run(["git", "-C", str(ROOT), *a], check=True, capture_output=True,  # noqa: E731
                                    text=True).stdout.strip()
    here = (git("rev-parse", "--short", args.head) if args.head else
            git("rev-parse", "--short", "HEAD") + (" + working tree" if git("status", "--porcelain", "--",
                                                                             "trms_ident") else ""))
    base = None if args.no_base else git("rev-parse", "--short", args.base)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        tree, head = tmp / "base", tmp / "head"
        if base:
            git("worktree", "add", "--detach", "-q", str(tree), base)
        if args.head:
            git("worktree", "add", "--detach", "-q", str(head), here)
        try:
            from trms_ident.io.csv_log import write_columns

            logs = []
            for c in picked(args.seed, args.n):
                kw, truth, cols = draw_log(c)
                path = tmp / f"bench{c['i']:02d}.csv"
                write_columns(path, dict(zip(("t", "u1", "u2", "alpha", "beta"), cols)))
                logs.append((c, kw, truth, path))
            sides = {"A": head if args.head else ROOT} | ({"B": tree} if base else {})
            for name, t in sides.items():  # numba's cache of each tree
                timed(diagnose_in(t, logs[0][3], tmp / f"warm{name}.json"))
            for c, kw, truth, path in logs:
                row = {"i": c["i"], "kind": c["kind"], "log": f"{kw['ref']} {kw['rate_hz']:g} Hz"
                       f" {'from rest' if not kw['start_s'] else 'mid-run'}"}
                for name, t in sides.items():
                    out = tmp / f"{path.stem}.{name}.json"
                    row[name], row[name + "_mb"] = timed(diagnose_in(t, path, out))
                    row[name + "_said"] = said(out)
                print(f"bench {c['i']:2d} ({c['kind']}, {row['log']}): "
                      + ", ".join(f"{k} {row[k]:.1f} s" for k in sides), file=sys.stderr, flush=True)
                rows.append(row)
        finally:
            for t in (tree, head):
                if t.exists():
                    subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(t)], check=False)
    text = table(rows, args.seed, here, base)
    print(text)
    if not args.no_write:
        from results import update_section
        update_section(ROOT / "benchmarks" / "RESULTS.md", "Diagnose speed", text)


def table(rows: list[dict], seed: int, here: str, base: str | None) -> str:
    sides = ["A"] + (["B"] if base else [])
    med = {k: statistics.median(r[k] for r in rows) for k in sides}
    top = {k: max(r[k] for r in rows) for k in sides}
    peak = {k: max(r[k + "_mb"] for r in rows) for k in sides}
    lines = [f"## Diagnose speed (benchmarks/diagnose_speed.py --seed {seed}, {len(rows)} logs, one at a time)", "",
             f"A = {here}" + (f", B = {base}" if base else "") + ": `trms-ident diagnose LOG --json OUT` in a fresh "
             "process, independent.py's benches written as CSV, each log's pair run back to back.", "",
             f"A: median **{med['A']:.1f} s** a log, slowest {top['A']:.1f} s, peak {peak['A']:.0f} MB."]
    if base:
        ratios = [r["A"] / r["B"] for r in rows]
        same = sum(r["A_said"] == r["B_said"] for r in rows)
        lines[-1] += (f" B: median {med['B']:.1f} s, slowest {top['B']:.1f} s, peak {peak['B']:.0f} MB. "
                      f"A/B median {statistics.median(ratios):.2f} ({min(ratios):.2f}-{max(ratios):.2f}); "
                      f"the same diagnosis on {same}/{len(rows)} logs.")
    lines += ["", "| # | kind | log | " + " | ".join(f"{k} [s]" for k in sides) + " | same |",
              "|---|---|---|" + "---|" * len(sides) + "---|"]
    for r in rows:
        same = "-" if not base else ("yes" if r["A_said"] == r["B_said"] else "no")
        lines.append(f"| {r['i']} | {r['kind']} | {r['log']} | " + " | ".join(f"{r[k]:.1f}" for k in sides)
                     + f" | {same} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    main()
