"""Keep benchmarks/RESULTS.md as sections, each rewritten by its own benchmark script."""
from __future__ import annotations

import re
from pathlib import Path


def update_section(path: Path, name: str, text: str) -> None:
    old = path.read_text(encoding="utf-8") if path.exists() else "# Benchmark results\n\n"
    pattern = re.compile(rf"^## {re.escape(name)}\b.*?(?=^## |\Z)", re.S | re.M)
    new = pattern.sub(lambda _: text.rstrip() + "\n\n", old) if pattern.search(old) else old.rstrip() + "\n\n" + text
    path.write_text(new, encoding="utf-8")
