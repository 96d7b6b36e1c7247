"""Estimate traces as CSV: t [s], J1, B1, J2, B2 (DREM gradient estimator, eq. 8)."""
from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..identify import Result
from ..io.atomic import atomic_path
from ..params import ESTIMATED


def write_traces(path: str | Path, result: Result) -> None:
    frame = pd.DataFrame({"t": result.t_s, **{k: result.traces[k] for k in ESTIMATED}})
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False, float_format="%.10g")
