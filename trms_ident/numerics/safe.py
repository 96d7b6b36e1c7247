"""LAPACK only on finite numbers.

numpy hands a NaN or inf straight to LAPACK, which then writes "** On entry to DLASCL parameter number 4 had an
illegal value" to the process' stderr (C level: no Python warning to catch) and returns garbage.  A model far
off the log overflows its simulation, and its normal equations are then not finite.  These wrappers refuse such
input before LAPACK sees it: ``lstsq`` and ``pinv`` raise numpy.linalg.LinAlgError (callers treat it as a failed
fit, with a reason), ``polyfit`` returns None (the caller keeps its grid point)."""
from __future__ import annotations

import numpy as np


def _check(*arrays) -> None:
    for a in arrays:
        if not np.all(np.isfinite(a)):
            raise np.linalg.LinAlgError("the normal equations are not finite (the model overflowed on this log)")


def lstsq(a, b, rcond=None) -> np.ndarray:
    """numpy.linalg.lstsq's solution, or LinAlgError when a or b is not finite."""
    _check(a, b)
    return np.linalg.lstsq(a, b, rcond=rcond)[0]


def pinv(a, rcond=1e-15) -> np.ndarray:
    """numpy.linalg.pinv, or LinAlgError when a is not finite."""
    _check(a)
    return np.linalg.pinv(a, rcond=rcond)


def polyfit(x, y, deg: int):
    """numpy.polyfit's coefficients, or None when x or y is not finite."""
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        return None
    return np.polyfit(x, y, deg)
