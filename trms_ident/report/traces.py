"""Estimate traces as CSV: t [s], J1, B1, J2, B2 (DREM gradient estimator, eq. 8)."""
from __future__ import annotations

from typing import TYPE_CHECKING

from pathlib import Path

from ..io.csv_log import write_columns
from ..params import ESTIMATED

if TYPE_CHECKING:
    from ..identify import Result


def write_traces(path: str | Path, result: Result) -> None:
    """Write the traces as identify kept them (every ``result.trace_step``-th sample)."""
    write_columns(path, {"t": result.t_s, **{name: result.traces[name] for name in ESTIMATED}})

