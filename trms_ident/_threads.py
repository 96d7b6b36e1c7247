"""How many threads one process may use for its own parallel work: the refinement's windows, the two axes'
filters, pyarrow's CSV parser and the MCAP chunk workers.  Standard library only.

``TRMS_IDENT_THREADS`` wins when set (``batch -jN`` sets it in its workers to the cores shared out among them,
so that N processes do not each start a thread per core); else the cores this process may run on, at most 4.
The numbers never depend on it: every split computes the same windows and axes the same way.
"""
from __future__ import annotations

import os

ENV = "TRMS_IDENT_THREADS"
MAX_THREADS = 4


def cores() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def budget() -> int:
    """Threads this process may use (>= 1)."""
    value = os.environ.get(ENV, "")
    if value.strip().isdigit() and int(value) >= 1:
        return int(value)
    return min(cores(), MAX_THREADS)


def share(jobs: int) -> int:
    """Threads each of ``jobs`` worker processes gets: the cores divided among them (>= 1)."""
    return max(1, cores() // max(jobs, 1))
