"""CSV logs: header ``t,u1,u2,alpha,beta`` (any order, case-insensitive), one row per sample.

Also accepted: a UTF-8 byte-order mark, ``;`` or tab as delimiter, and an optional unit
row under the header (``s,V,V,rad,rad``; ``deg`` for angles and ``ms`` for time are
converted).  Messages name the file's own line numbers.
"""
from __future__ import annotations

import hashlib
import io
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputNotFoundError, LogFormatError
from ..log import COLUMNS, Log, validated
from .atomic import atomic_path

UNIT_SCALE = {
    "t": {"s": 1.0, "ms": 1e-3},
    "u1": {"v": 1.0},
    "u2": {"v": 1.0},
    "alpha": {"rad": 1.0, "deg": math.pi / 180},
    "beta": {"rad": 1.0, "deg": math.pi / 180},
}


def read_bytes(path: Path) -> bytes:
    if not path.exists():
        raise InputNotFoundError(f"{path}: no such file")
    if path.is_dir():
        raise LogFormatError(f"{path}: is a folder; expected a log file")
    try:
        return path.read_bytes()
    except OSError as exc:
        raise InputNotFoundError(f"{path}: cannot read ({exc.strerror or exc})") from None


def _is_number(token: str) -> bool:
    try:
        float(token)
        return True
    except ValueError:
        return False


def read_csv_log(path: str | Path, angle_unit: str = "rad") -> Log:
    """Read and validate a CSV log; ``angle_unit="deg"`` converts angle columns from degrees."""
    path = Path(path)
    raw = read_bytes(path)
    sha = hashlib.sha256(raw).hexdigest()
    try:
        text_head = raw[:65536].decode("utf-8-sig")
    except UnicodeDecodeError:
        raise LogFormatError(f"{path}: not a text file; expected a CSV log with header "
                             f"{','.join(COLUMNS)}") from None
    lines = text_head.splitlines()
    if not raw.strip() or not lines:
        raise LogFormatError(f"{path}: file is empty; expected a header line {','.join(COLUMNS)}")
    header = lines[0]
    delim = max((",", ";", "\t"), key=header.count)
    names = [c.strip().lower() for c in header.split(delim)]
    missing = [c for c in COLUMNS if c not in names]
    if missing:
        raise LogFormatError(f"{path}: line 1: missing column(s) {', '.join(missing)}; expected a header "
                             f"with {','.join(COLUMNS)} (found: {','.join(names) or 'nothing'})")
    dup = sorted({c for c in names if names.count(c) > 1 and c in COLUMNS})
    if dup:
        raise LogFormatError(f"{path}: line 1: column(s) {', '.join(dup)} appear twice; expected each once")
    scale = {c: 1.0 for c in COLUMNS}
    if angle_unit == "deg":
        scale["alpha"] = scale["beta"] = math.pi / 180
    first_data_line = 2
    if len(lines) > 1:
        tokens = [x.strip() for x in lines[1].split(delim)]
        if tokens and not any(_is_number(x) for x in tokens if x):
            for c in COLUMNS:
                unit = tokens[names.index(c)].strip("[]() ").lower() if names.index(c) < len(tokens) else ""
                if unit not in UNIT_SCALE[c]:
                    raise LogFormatError(f"{path}: line 2: unit {unit!r} for column {c}; expected one of "
                                         f"{', '.join(UNIT_SCALE[c])}")
                scale[c] = UNIT_SCALE[c][unit]
            first_data_line = 3
    frame = _parse(path, raw, delim, first_data_line)
    cols = [frame[c].to_numpy(dtype=float) * scale[c] if scale[c] != 1.0 else frame[c].to_numpy(dtype=float)
            for c in COLUMNS]
    t = cols[0]
    return validated(*cols, source=str(path), sha256=sha,
                     locate=lambda i: f"line {i + first_data_line} (t = {t[i]:.6g} s)",
                     meta={"format": "csv", "delimiter": delim})


def _parse(path: Path, raw: bytes, delim: str, first_data_line: int) -> pd.DataFrame:
    opts = dict(sep=delim, encoding="utf-8-sig", skiprows=range(1, first_data_line - 1),
                skip_blank_lines=False, skipinitialspace=True)
    try:
        frame = pd.read_csv(io.BytesIO(raw), dtype=np.float64, **opts)
    except pd.errors.ParserError as exc:
        raise LogFormatError(f"{path}: {str(exc).strip().splitlines()[-1]}; expected {len(COLUMNS)} or more "
                             "fields on every line, as many as the header") from None
    except (ValueError, TypeError):
        frame = None
    if frame is None:  # slow path, only to name the first cell that is not a number
        frame = pd.read_csv(io.BytesIO(raw), dtype=str, keep_default_na=False, **opts)
        frame.columns = [c.strip().lower() for c in frame.columns]
        for c in COLUMNS:
            cells = frame[c].str.strip()
            num = pd.to_numeric(cells, errors="coerce")
            bad = np.flatnonzero(num.isna().to_numpy() & (cells != "").to_numpy() &
                                 ~cells.str.lower().isin(["nan", "inf", "-inf"]).to_numpy())
            if bad.size:
                i = int(bad[0])
                raise LogFormatError(f"{path}: line {i + first_data_line}: column {c} holds "
                                     f"{cells.iloc[i]!r}; expected a number")
        raise LogFormatError(f"{path}: cannot parse as numbers; expected numeric columns {','.join(COLUMNS)}")
    frame.columns = [c.strip().lower() for c in frame.columns]
    return frame


def write_csv_log(path: str | Path, t_s, u1_v, u2_v, alpha_rad, beta_rad) -> None:
    """Write a log atomically; every double round-trips exactly."""
    frame = pd.DataFrame(dict(zip(COLUMNS, (t_s, u1_v, u2_v, alpha_rad, beta_rad))))
    with atomic_path(path) as tmp:
        frame.to_csv(tmp, index=False)  # shortest repr that round-trips exactly


def truth_path(log_path: str | Path) -> Path:
    """Sidecar ground-truth file of a simulated log: ``name.csv`` -> ``name.truth.json``."""
    p = Path(log_path)
    return p.with_name(p.name.split(".")[0] + ".truth.json")
