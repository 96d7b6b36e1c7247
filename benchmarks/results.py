"""Keep benchmarks/RESULTS.md as sections, each rewritten by its own benchmark script."""
from __future__ import annotations

import re
from pathlib import Path


def _section(name: str) -> re.Pattern:
    """The section headed "## <name>" exactly (optionally followed by " (...)"), up to the next heading: not
    the ones whose names merely begin with it ("Diagnose" is not "Diagnose power")."""
    return re.compile(rf"^## {re.escape(name)}(?: \([^\n]*)?\n.*?(?=^## |\Z)", re.S | re.M)


def update_section(path: Path, name: str, text: str) -> None:
    """Replace the section ``name`` with ``text`` (appended when absent; later copies of it are removed)."""
    old = path.read_text(encoding="utf-8") if path.exists() else "# Benchmark results\n\n"
    pattern = _section(name)
    if not pattern.search(old):
        path.write_text(old.rstrip() + "\n\n" + text.rstrip() + "\n", encoding="utf-8")
        return
    first = [True]

    def put(_):
        keep, first[0] = first[0], False
        return text.rstrip() + "\n\n" if keep else ""

    path.write_text(pattern.sub(put, old).rstrip() + "\n", encoding="utf-8")


def percent_errors(estimates: dict, truth: dict) -> dict:
    """|estimate / truth - 1| in %, per parameter of ``truth``; inf where the tool gave no number."""
    import math

    return {k: (100 * abs(estimates[k] / v - 1) if estimates[k] is not None else math.inf) for k, v in truth.items()}


def publish(section: str, text: str, write: bool = True) -> None:
    """Print a benchmark's section and, unless ``write`` is false (--no-write), put it into RESULTS.md."""
    print(text)
    if write:
        update_section(Path(__file__).with_name("RESULTS.md"), section, text)


def plain_args(doc: str):
    """The options of a benchmark without its own: --help (``doc``, the script's docstring) and --no-write.  Every
    script parses its command line, so that --help or a mistyped option never starts a run that takes minutes and
    rewrites RESULTS.md."""
    import argparse

    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    return ap.parse_args()


def seed_args(doc: str, n: int = 20, only: bool = False):
    """The options of a benchmark over seeds: --n (how many, default ``n``) and --no-write; with ``only``, --only
    (the cases to run again, by number: printed, RESULTS.md left as it is); ``doc``: the script's docstring,
    whose first line describes it."""
    import argparse

    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--n", type=int, default=n, help=f"number of seeds (default {n})")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    if only:
        ap.add_argument("--only", type=int, nargs="+", help="run only these cases (print only)")
    return ap.parse_args()

