"""Pick the reader for a log file by its name."""
from __future__ import annotations

from pathlib import Path

from ..errors import LogFormatError
from ..log import Log
from .csv_log import check_readable, read_csv_log

LOG_SUFFIXES = (".csv", ".mcap")


def read_log(path: str | Path, angle_unit: str = "rad") -> Log:
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".mcap":
        from .mcap_log import read_mcap_log  # optional heavy import, only when needed

        return read_mcap_log(path, angle_unit=angle_unit)
    if suffix in (".csv", ".txt", ".tsv"):
        return read_csv_log(path, angle_unit=angle_unit)
    check_readable(path)  # a missing file is reported as missing, not as a format problem
    raise LogFormatError(f"{path}: unknown log type {suffix or '(no suffix)'!r}; expected .csv or .mcap")
