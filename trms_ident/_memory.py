"""Give memory that has been freed back to the system (glibc keeps freed blocks of each thread's arena).

After a long log's parse the reader's threads have freed tens of megabytes that glibc would hold until the
process ends; returning them keeps an hour-long estimate's peak (the measured figure of benchmarks/ratios.py)
lower.  The command line also maps every block of MMAP_THRESHOLD_BYTES or more on its own (map_large_blocks):
glibc's default threshold grows with the blocks freed, up to 32 MB, after which an hour's 29 MB columns come
from the heap, where columns of other lengths (a long log's grid span, 4.8 MB) fragment it (measured: diagnose
of an hour at 1 kHz peaked at 1.61 GB with the default, 1.40-1.41 GB with 4 MiB mapped, in the same time).
No-ops where the C library is not glibc.
"""
from __future__ import annotations

import ctypes


def _malloc_trim():
    try:
        return ctypes.CDLL(None).malloc_trim  # the C library the process already uses
    except (OSError, AttributeError):
        return None


_TRIM = _malloc_trim()

#: blocks of at least this many bytes are mapped on their own and returned to the system when freed
MMAP_THRESHOLD_BYTES = 4 << 20
_M_MMAP_THRESHOLD = -3  # glibc's mallopt parameter number


def map_large_blocks() -> None:
    """mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES): a fixed threshold (module docstring).  For the command
    line's own process; a program that imports the library keeps its allocator's settings."""
    try:
        ctypes.CDLL(None).mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    except (OSError, AttributeError):
        pass


def give_back() -> None:
    """malloc_trim(0): release the free memory at the top of every arena."""
    if _TRIM is not None:
        _TRIM(0)
