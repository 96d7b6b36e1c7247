"""What the compiled kernels are handed, and how their helpers are compiled.

One array type at each compiled kernel's door, so numba compiles each kernel once.

numba compiles a kernel once per argument *type*, and a read-only array is a different type from a writable one:
the logged voltages reach the kernels as read-only views (diagnosis.model.modified_inputs) and as writable arrays
(a clipped or modified copy), so ``refine.windows_pass`` was compiled three times and ``refine.motor_starts`` three
times in one diagnose (measured with numba's compile events, 2 Dec 2026: 21 s and 11 s of a first run's 60 s of
compilation).  The kernels only read these arrays; a read-only view costs no copy.

Helpers without reference counts (HELPER): see there.
"""
from __future__ import annotations

import numpy as np
from numba.core.options import DefaultOptions

#: numba's compile options for a kernel's helper: a function called inside a kernel's loops (an RK4 step, a model's
#: right side, a filter's step) that takes arrays and allocates none.  numba counts the references to every array
#: a compiled function receives, or that a function inlined into it (``inline="always"``) binds: an atomic increment
#: on entry and a decrement on every way out, and its pruning pass cannot remove the pair across a helper's branches
#: and calls (numba issues #2345 and #2350, whose workaround this is).  Measured with perf on the output-error fit's
#: pass (refine.windows_pass, 12 000 samples, 6 Dec 2026): 72 % of its time in NRT_incref and NRT_decref,
#: 58 atomic operations a sample; without them the pass took 2.0 ms instead of 4.5 (predictions) and 3.6 instead of
#: 6.3 (with sensitivities), the same numbers to the last bit.  ``_nrt=False`` compiles the helper without numba's
#: runtime: it counts nothing, and numba refuses to compile it if it allocates an array.  LLVM still inlines it
#: into the kernel.  Empty (the counting kept, the same results) on a numba without the option.
HELPER = {"_nrt": False} if hasattr(DefaultOptions, "_nrt") else {}


def readonly(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array that cannot be written (a view when it already is one; else a copy)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a
