"""Pick the reader for a log file by its name."""
from __future__ import annotations

from pathlib import Path

from ..errors import LogFormatError
from ..log import Log
from .csv_log import check_readable, read_csv_log
from .signals import held_constants, split_signals

LOG_SUFFIXES = (".csv", ".mcap", ".mat")


def read_log(path: str | Path, angle_unit: str = "auto", signals: list[str] | None = None,
             time_source: str = "auto", time_unit: str = "auto", voltage_time: str = "stamp",
             rate_hz: float | None = None) -> Log:
    """Read a CSV, MCAP or MATLAB log; ``signals``: where each signal comes from (each format's own mapping), or
    ``u2=0``: an input not logged, held at that value [V] (a motor that was off); ``time_source`` applies to
    MCAP (see mcap_log), ``time_unit`` to CSV and MATLAB (MCAP stamps are nanoseconds by the format)."""
    path = Path(path)
    suffix = path.suffix.lower()
    signals, held = held_constants(split_signals(signals))
    if suffix == ".mcap":
        from .mcap_log import read_mcap_log  # mcap and its decoders only when needed

        return read_mcap_log(path, angle_unit=angle_unit, signals=signals, time_source=time_source,
                             voltage_time=voltage_time, held=held)
    if suffix == ".mat":
        from .mat_log import read_mat_log  # mat-io only when needed

        return read_mat_log(path, angle_unit=angle_unit, time_unit=time_unit, signals=signals, rate_hz=rate_hz,
                            held=held)
    from ..errors import SettingsError

    if rate_hz is not None:
        raise SettingsError(f"--rate applies to MATLAB logs without a time vector; {path} has its own stamps")
    if suffix in (".csv", ".txt", ".tsv"):
        return read_csv_log(path, angle_unit=angle_unit, time_unit=time_unit, signals=signals, held=held)
    check_readable(path)  # a missing file is reported as missing, not as a format problem
    raise LogFormatError(f"{path}: unknown log type {suffix or '(no suffix)'!r}; expected .csv, .mcap or .mat")


def describe(path: str | Path) -> dict:
    """What ``inspect`` shows: an MCAP's topics and fields, or a CSV log's columns and sampling."""
    path = Path(path)
    if path.suffix.lower() == ".mcap":
        from .mcap_log import inspect_mcap

        return inspect_mcap(path)
    if path.suffix.lower() == ".mat":
        from .mat_log import describe_mat

        return describe_mat(path)
    log = read_log(path)
    return {"file": str(path), "bytes": path.stat().st_size, "duration_s": log.duration_s,
            "samples": len(log), "sample_time_s": log.sample_time_s, "columns": ["t", "u1", "u2", "alpha", "beta"],
            "sha256": log.sha256}
