"""Every guard of diagnose's rule has a test that fails without it (issue #47): each guard is broken in a copy
of the repository (a constant moved far past its edge, so the guard no longer guards) and the tests that
exercise diagnose are run on the copy; the guard is held when at least one test goes red.

    python benchmarks/guards.py            # all guards, writes the "Guards" section of RESULTS.md
    python benchmarks/guards.py --only FAMILY_ALPHA --no-write

A copy is a `git worktree` of HEAD (so commit first): uncommitted changes are not in it.  The tests of diagnose
and the docs' examples run (FIRST; --all: then the rest of the default suite) with `-x` (the first red test ends
the run) on 2 processes, the edge tests (tests/test_guards.py, or the guard's own file) first and alone, in
seconds; a guard whose tests all pass took the whole run (about 6 minutes on this 2-core machine)."""
from __future__ import annotations

import argparse
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from results import publish  # noqa: E402

#: (file, constant, broken value, what breaking it lets through[, its edge tests' file when not EDGE])
GUARDS = [
    ("trms_ident/diagnosis/select.py", "FAMILY_ALPHA", "0.9", "the family-wise level: nearly any candidate passes"),
    ("trms_ident/diagnosis/select.py", "MIN_REL_GAIN", "0.0", "the equation error's practical size"),
    ("trms_ident/diagnosis/trials.py", "ALIAS_CORRELATION", "1.01", "look-alikes by residual shape: none flagged"),
    ("trms_ident/diagnosis/trials.py", "ALIAS_GAIN_RATIO", "1.01", "look-alikes by gain: none flagged"),
    ("trms_ident/diagnosis/trials.py", "SEPARATION_MARGIN", "-10.0", "told apart: every look-alike told apart"),
    ("trms_ident/diagnosis/trials.py", "MOTOR_LAG_NEUTRAL", "0.0", "a motor time constant at the table's value"),
    ("trms_ident/diagnosis/search.py", "STOP_OE_OVER_NOISE", "50.0", "the rounds stop far above the floor"),
    ("trms_ident/diagnosis/oe.py", "MIN_COST_DROP", "0.0", "the output-error test's practical size"),
    ("trms_ident/diagnosis/oe.py", "MIN_TORQUE_SHARE", "0.0", "a torque's share of the thrust torque"),
    ("trms_ident/diagnosis/oe.py", "MIN_MODIFICATION_SHARE", "0.0", "an input modification's share"),
    ("trms_ident/diagnosis/held_out.py", "LOWERED_BY_PERCENT", "1000.0", "the held-out gate: nothing refused"),
    ("trms_ident/diagnosis/verdict.py", "EXPLAINED_RMS_OVER_NOISE", "50.0", "'explained' by 2 s predictions"),
    ("trms_ident/numerics/adequacy.py", "RMS_OVER_NOISE", "50.0", "'fits' and 'explained' by simulation"),
    ("trms_ident/params.py", "PLAUSIBLE_FACTOR", "1e9", "'explained' with J/B any distance off the table"),
    ("trms_ident/diagnosis/discriminate.py", "MIN_COST_GAP", "0.0", "the two pitch offsets told apart on any gap"),
    ("trms_ident/diagnosis/compound.py", "VALUE_FIRST_OVER_NOISE", "1e9", "value-first on any misfit"),
    ("trms_ident/known_values.py", "PRACTICAL_CHANGE", "0.0", "a known value that barely moves explains"),
    ("trms_ident/known_values.py", "PLAUSIBLE_VALUE_FACTOR", "1e6", "a known value any distance off the table"),
    ("trms_ident/known_values.py", "JOINT_MIN_SHARE", "0.0", "known values together on any share"),
    # the search for physics outside the library (issue #76): terms and the sparse correction
    ("trms_ident/model/terms.py", "THRUST_SHARE", "(-1e9, 1e9)",
     "a thrust term changing its thrust any number of times", "tests/test_terms.py"),
    ("trms_ident/diagnosis/run.py", "TERM_STANDS_UNDER",
     '("explained", "consistent", "partly_explained", "unexplained")', "a term standing in beside an unexplained log",
     "tests/test_terms.py"),
    ("trms_ident/diagnosis/judge.py", "LIBRARY_BEFORE_TERM", "False", "a term named before the library effect it "
     "cannot be told from", "tests/test_terms.py"),
    ("trms_ident/diagnosis/sparse.py", "MAX_JB_CHANGE", "1e9", "a correction that replaces J or B",
     "tests/test_sparse_correction.py"),
    ("trms_ident/diagnosis/oe.py", "UNCONVERGED_BASE_OVER_NOISE", "1e9", "a candidate judged by its drop from a "
     "current model whose fit did not converge"),
    ("trms_ident/diagnosis/run.py", "INERT_FIT_RATIO", "1e9", "a finding dropped (inert, or beside a term) however "
     "much the fit needs it"),
]

#: the guards' edge tests: each guard just inside and just outside its edge (run first, alone)
EDGE = "tests/test_guards.py"
#: the tests that exercise diagnose's rule (and the docs' runnable examples, whose printed lines are checked);
#: with --all the rest of the default suite after them
FIRST = ["tests/test_guards.py", "tests/test_terms.py", "tests/test_sparse_correction.py",
         "tests/test_known_values.py", "tests/test_compound.py", "tests/test_both_motors.py",
         "tests/test_diagnose.py", "tests/test_held_out.py", "tests/test_second_order_motor.py",
         "tests/test_sensor_lag.py", "tests/test_model_room.py", "tests/test_real_recordings.py", "tests/test_docs.py"]


def broken(tree: Path, path: str, name: str, value: str) -> str:
    """Set ``name = value`` in ``tree/path``; the line it replaced."""
    p = tree / path
    text = p.read_text(encoding="utf-8")
    pattern = re.compile(rf"^{name} = .*$", re.M)
    found = pattern.findall(text)
    if len(found) != 1:
        raise SystemExit(f"{path}: expected one line '{name} = ...', found {len(found)}")
    p.write_text(pattern.sub(f"{name} = {value}", text), encoding="utf-8")
    return found[0]


def run_tests(tree: Path, timeout_s: float, everything: bool, edge: str = EDGE) -> tuple[str, float]:
    """The first failing test's id ('' when all passed) and the seconds it took; ``edge`` the file of the guard's edge
    tests, run first."""
    t0 = time.perf_counter()
    rest = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "tests").glob("test_*.py")
                  if str(p.relative_to(ROOT)) not in FIRST) if everything else []
    # the edge tests first, alone and in one process (seconds): most guards are held there, and the run ends
    for files, workers in (([edge], []), ([f for f in FIRST if f != edge] + rest, ["-n", "2"])):
        cmd = [sys.executable, "-m", "pytest", "-x", "-q", *workers, "-p", "no:cacheprovider", *files]
        proc = subprocess.Popen(cmd, cwd=tree, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env={**os.environ, "PYTHONPATH": str(tree)}, start_new_session=True)
        try:
            out, _ = proc.communicate(timeout=max(timeout_s - (time.perf_counter() - t0), 1.0))
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)  # pytest and its workers
            proc.communicate()
            return "(timed out)", time.perf_counter() - t0
        failed = re.findall(r"^FAILED (\S+)", out, re.M) or re.findall(r"^ERROR (\S+)", out, re.M)
        if proc.returncode != 0:
            return (failed[0] if failed else f"(exit {proc.returncode})"), time.perf_counter() - t0
    return "", time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="the guards' constant names to break (default: all)")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    ap.add_argument("--timeout", type=float, default=1800.0, help="seconds per broken copy's test run")
    ap.add_argument("--all", action="store_true", help="run the whole default suite on each copy, not only FIRST")
    args = ap.parse_args()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                          check=True).stdout.strip()
    rows, held, t_all = [], 0, time.perf_counter()
    chosen = [g for g in GUARDS if not args.only or g[1] in args.only]
    for path, name, value, what, *edge in chosen:
        with tempfile.TemporaryDirectory(prefix="guard-") as tmp:
            tree = Path(tmp) / "tree"
            subprocess.run(["git", "worktree", "add", "-q", "--detach", str(tree), "HEAD"], cwd=ROOT, check=True)
            at = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=tree, capture_output=True, text=True,
                                check=True).stdout.strip()  # HEAD may move while the sweep runs
            shared = ROOT.parent / "shared"
            if shared.exists() and not (tree.parent / "shared").exists():
                (tree.parent / "shared").symlink_to(shared)  # the real recordings' tests read ../shared
            try:
                was = broken(tree, path, name, value)
                first, seconds = run_tests(tree, args.timeout, args.all, *edge)
            finally:
                subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, check=False)
        ok = bool(first) and not first.startswith("(")  # a red test named (not a time-out or a crash)
        held += ok
        rows.append(f"| `{name}` ({Path(path).name}) | `{was.split('=', 1)[1].strip()}` -> `{value}` | {what} | "
                    f"{'yes' if ok else '**NO**'} | {first or 'all passed'} | {at} | {seconds:.0f} s |")
        print(rows[-1], flush=True)
    lines = ["Each guard broken in a copy of the repository (from " + head + "; each row's commit is its copy's; its "
             "constant moved far past its edge) "
             + ("and the default test suite run on the copy with `-x`, the tests of diagnose first"
                if args.all else "and the tests of diagnose and the docs' examples (FIRST) run on the copy with `-x`")
             + ": held when a test goes red.", "",
             "| guard | broken | what it lets through | held | first red test | commit | time |",
             "|---|---|---|---|---|---|---|", *rows, "",
             f"Held: {held}/{len(rows)}. Total {time.perf_counter() - t_all:.0f} s on 2 processes."]
    publish("Guards", "## Guards (benchmarks/guards.py, mutation check)\n\n" + "\n".join(lines),
            write=not args.no_write and not args.only)


if __name__ == "__main__":
    main()
