"""Give memory that has been freed back to the system (glibc keeps freed blocks of each thread's arena).

After a long log's parse the reader's threads have freed tens of megabytes that glibc would hold until the
process ends; returning them keeps an hour-long estimate's peak (the measured figure of benchmarks/ratios.py)
lower.  A no-op where the C library is not glibc.
"""
from __future__ import annotations

import ctypes


def _malloc_trim():
    try:
        return ctypes.CDLL(None).malloc_trim  # the C library the process already uses
    except (OSError, AttributeError):
        return None


_TRIM = _malloc_trim()


def give_back() -> None:
    """malloc_trim(0): release the free memory at the top of every arena."""
    if _TRIM is not None:
        _TRIM(0)
