"""Both cores for independent fits: a process-wide thread pool and a map over it.

The refinement's kernels (numerics/refine.windows_pass) are numba functions compiled with ``nogil=True``: two
fits in two threads run on two cores.  A fit splits its own windows across threads only when nothing above it
does (``in_worker``): a log of one 40 s window (most diagnose logs) cannot split at all, whereas the values of a
profile, the points of a screen and the candidates of a round are independent fits that can.  Results are
returned in the order of the items and each fit is computed the same way in any thread, so the numbers do not
depend on the machine or the scheduling.  Standard library only.
"""
from __future__ import annotations

import contextvars
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, Iterable, TypeVar

T = TypeVar("T")
R = TypeVar("R")

_LOCAL = threading.local()
_POOLS: dict = {}  # workers -> ThreadPoolExecutor; emptied in a forked child (_after_fork)
_LOCK = threading.Lock()


def _after_fork() -> None:
    """A forked child (batch's worker processes) has none of the parent's threads: its own pools and lock."""
    global _LOCK
    _LOCK = threading.Lock()
    _POOLS.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork)


def cores() -> int:
    """The processors this process may run on (at most 4)."""
    try:
        return max(1, min(len(os.sched_getaffinity(0)), 4))
    except AttributeError:  # not on Linux
        return max(1, min(os.cpu_count() or 1, 4))


def pool(workers: int) -> ThreadPoolExecutor:
    """The process's pool of ``workers`` threads, made on first use."""
    with _LOCK:
        if workers not in _POOLS:
            _POOLS[workers] = ThreadPoolExecutor(workers, thread_name_prefix=f"trms-{workers}")
        return _POOLS[workers]


def in_worker() -> bool:
    """True inside fan_out's work: the fit's windows then stay in this thread (the cores are taken)."""
    return getattr(_LOCAL, "busy", False)


def fan_out(fn: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """[fn(x) for x in items], the items spread over the cores; in order.  Serial inside another fan_out (no
    nesting: a worker waiting for work queued behind it would wait for ever) and with one core or one item.
    ``fn`` must not touch shared state other than caches whose entries it writes whole (dict assignment)."""
    items = list(items)
    n = cores()
    if len(items) < 2 or n < 2 or in_worker():
        return [fn(x) for x in items]

    def job(task):
        x, context = task
        _LOCAL.busy = True
        try:
            return context.run(fn, x)
        finally:
            _LOCAL.busy = False

    # each item runs in a copy of the caller's context: numpy's error state lives in a context variable, so a
    # caller's np.errstate(all="ignore") holds in the workers too (a pool thread starts from an empty context, and
    # an overflow the caller silences printed a RuntimeWarning on the terminal of a diagnose)
    return list(pool(n).map(job, [(x, contextvars.copy_context()) for x in items]))
