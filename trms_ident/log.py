"""A validated TRMS recording: uniformly sampled t [s], u1, u2 [V], alpha, beta [rad].

Validation is pure (arrays in, LogFormatError out); readers of each file format pass a
``locate`` function so that messages name the file's own line numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .errors import LogFormatError

COLUMNS = ("t", "u1", "u2", "alpha", "beta")
COLUMN_UNITS = {"t": "s", "u1": "V", "u2": "V", "alpha": "rad", "beta": "rad"}
MIN_SAMPLES = 10
#: relative deviation of a sample step from the median step that counts as irregular
SAMPLING_TOLERANCE = 0.01
#: |alpha| beyond this is not a pitch angle in rad (the beam stops well before vertical)
PITCH_LIMIT_RAD = math.pi / 2
#: |beta| beyond this (four turns) is not a yaw angle in rad on a cabled bench
YAW_LIMIT_RAD = 8 * math.pi


@dataclass(frozen=True)
class Log:
    t_s: np.ndarray
    u1_v: np.ndarray
    u2_v: np.ndarray
    alpha_rad: np.ndarray
    beta_rad: np.ndarray
    source: str = "<memory>"
    sha256: str | None = None
    meta: dict = field(default_factory=dict)

    @property
    def sample_time_s(self) -> float:
        return float((self.t_s[-1] - self.t_s[0]) / (self.t_s.size - 1))

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0])

    def __len__(self) -> int:
        return int(self.t_s.size)


def _default_locate(i: int, t: np.ndarray) -> str:
    return f"sample {i} (t = {t[i]:.6g} s)"


def validated(t, u1, u2, alpha, beta, *, source: str = "<memory>", sha256: str | None = None,
              locate: Callable[[int], str] | None = None, meta: dict | None = None) -> Log:
    """Check a recording and return it as a Log; the first problem raises LogFormatError.

    ``locate(i)`` renders sample i's position for messages (e.g. "line 57 (t = 0.055 s)").
    """
    arrays = {name: np.ascontiguousarray(v, dtype=float) for name, v in zip(COLUMNS, (t, u1, u2, alpha, beta))}
    t = arrays["t"]
    where = locate or (lambda i: _default_locate(i, t))
    n = t.size
    if any(a.shape != (n,) for a in arrays.values()):
        raise LogFormatError(f"{source}: columns have different lengths; expected one value per column per row")
    if n < MIN_SAMPLES:
        raise LogFormatError(f"{source}: only {n} samples; expected at least {MIN_SAMPLES}")
    for name, a in arrays.items():
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise LogFormatError(f"{source}: {where(int(bad[0]))}: {name} is {a[bad[0]]}; "
                                 f"expected a finite number in {COLUMN_UNITS[name]}")
    dt = np.diff(t)
    back = np.flatnonzero(dt <= 0)
    if back.size:
        i = int(back[0]) + 1
        what = "repeats the previous time" if dt[i - 1] == 0 else "goes back in time"
        raise LogFormatError(f"{source}: {where(i)}: t = {t[i]:.9g} s {what} (t = {t[i - 1]:.9g} s); "
                             "expected strictly increasing time")
    step = float(np.median(dt))
    off = np.flatnonzero(np.abs(dt - step) > SAMPLING_TOLERANCE * step)
    if off.size:
        i = int(off[0]) + 1
        kind = "a gap" if dt[i - 1] > step else "an irregular step"
        raise LogFormatError(
            f"{source}: {where(i)}: {kind} of {dt[i - 1]:.6g} s after t = {t[i - 1]:.9g} s; expected uniform "
            f"sampling every {step:.6g} s (within {SAMPLING_TOLERANCE:.0%}); resample or split the log")
    for name, limit in (("alpha", PITCH_LIMIT_RAD), ("beta", YAW_LIMIT_RAD)):
        a = arrays[name]
        i = int(np.argmax(np.abs(a)))
        if abs(a[i]) > limit:
            raise LogFormatError(
                f"{source}: {where(i)}: {name} = {a[i]:.6g} exceeds {limit:.3g} rad; the angles look like "
                "degrees, expected radians (convert them, or pass --angle-unit deg)")
    return Log(*arrays.values(), source=source, sha256=sha256, meta=dict(meta or {}))
