"""Reference files for the simulator's closed loop: ``t, alpha_ref, beta_ref`` [s, rad], one row per time.

The format ``trms-ident design`` writes (issue #35) and ``trms-ident simulate --ref-file`` reads: a header row
naming the three columns (any order, case-insensitive), comma, ``;`` or tab separated.  Times rise strictly and
start at 0 (the run's start); between rows the reference is interpolated linearly, and a run may not outlast the
file.  Messages name the file's own line numbers.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LogFormatError
from .csv_log import read_bytes, write_columns

COLUMNS = ("t", "alpha_ref", "beta_ref")


@dataclass(frozen=True)
class ReferenceTable:
    """A reference read from a file: times [s] and the two angle references [rad], with the file's checksum."""

    t_s: np.ndarray
    alpha_ref_rad: np.ndarray
    beta_ref_rad: np.ndarray
    source: str
    sha256: str

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1])


def read_reference(path: Path) -> ReferenceTable:
    """The reference file at ``path`` (InputNotFoundError when it is missing, LogFormatError naming the line and
    what was expected when it cannot be used)."""
    raw = read_bytes(path)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise LogFormatError(f"{path}: not UTF-8 text; expected a CSV file with columns t, alpha_ref, "
                             "beta_ref") from None
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip()]
    if not lines:
        raise LogFormatError(f"{path}: empty; expected a header row t, alpha_ref, beta_ref and one row per time")
    line0, head = lines[0]
    sep = next((s for s in (",", ";", "\t") if s in head), ",")
    names = [h.strip().lower() for h in head.split(sep)]
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise LogFormatError(f"{path}, line {line0}: header {head.strip()!r} lacks {', '.join(missing)}; expected "
                             "the columns t, alpha_ref, beta_ref [s, rad]")
    idx = [names.index(c) for c in COLUMNS]
    rows = np.empty((len(lines) - 1, 3))
    for k, (no, ln) in enumerate(lines[1:]):
        cells = ln.split(sep)
        try:
            rows[k] = [float(cells[i]) for i in idx]
        except (ValueError, IndexError):
            raise LogFormatError(f"{path}, line {no}: {ln.strip()!r} is not three numbers under t, alpha_ref, "
                                 "beta_ref") from None
        if not np.all(np.isfinite(rows[k])):
            raise LogFormatError(f"{path}, line {no}: {ln.strip()!r} is not finite; expected numbers [s, rad]")
    if rows.shape[0] < 2:
        raise LogFormatError(f"{path}: {rows.shape[0]} data row(s); expected at least two times")
    t = rows[:, 0]
    if t[0] != 0.0:
        raise LogFormatError(f"{path}, line {lines[1][0]}: the first time is {t[0]:.6g} s; expected 0 (the run's "
                             "start)")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        j = int(bad[0]) + 1
        raise LogFormatError(f"{path}, line {lines[j + 1][0]}: time {t[j]:.6g} s does not rise after "
                             f"{t[j - 1]:.6g} s; expected strictly rising times")
    return ReferenceTable(t.copy(), rows[:, 1].copy(), rows[:, 2].copy(), str(path),
                          hashlib.sha256(raw).hexdigest())


def write_reference(path: Path, t_s: np.ndarray, alpha_ref_rad: np.ndarray, beta_ref_rad: np.ndarray) -> None:
    """Write references atomically: ``.csv`` as read_reference reads it; ``.mat`` as a Simulink "From Workspace"
    Structure With Time in the variable ``ref`` (``ref.time`` [s], ``ref.signals.values`` (n, 2): alpha_ref,
    beta_ref [rad], ``ref.signals.dimensions`` 2)."""
    from .atomic import atomic_path

    path = Path(path)
    if path.suffix.lower() == ".mat":
        import scipy.io

        ref = {"time": np.asarray(t_s, dtype=float)[:, None],
               "signals": {"values": np.column_stack([alpha_ref_rad, beta_ref_rad]).astype(float),
                           "dimensions": 2.0}}
        with atomic_path(path) as tmp:
            scipy.io.savemat(tmp, {"ref": ref}, appendmat=False)
        return
    write_columns(path, dict(zip(COLUMNS, (t_s, alpha_ref_rad, beta_ref_rad))))
