"""One array type at each compiled kernel's door, so numba compiles each kernel once.

numba compiles a kernel once per argument *type*, and a read-only array is a different type from a writable one:
the logged voltages reach the kernels as read-only views (diagnosis.model.modified_inputs) and as writable arrays
(a clipped or modified copy), so ``refine.windows_pass`` was compiled three times and ``refine.motor_starts`` three
times in one diagnose (measured with numba's compile events, 2 Dec 2026: 21 s and 11 s of a first run's 60 s of
compilation).  The kernels only read these arrays; a read-only view costs no copy.
"""
from __future__ import annotations

import numpy as np


def readonly(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array that cannot be written (a view when it already is one; else a copy)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a
