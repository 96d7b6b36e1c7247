"""A manifest: several logs of one bench (or of several benches), one CSV row each.

    path,signal,rate,angle_unit,time_unit,name,bench,date
    runs/elev.mat,"alpha=psi,beta=phi",100,deg,,elevation ramp,ce150-a,2024-03-01
    runs/step.csv,,,,,steps,ce150-a,2024-03-02

Only ``path`` is required (relative paths are relative to the manifest's folder); ``signal`` is the --signal
mapping (NAME=PATH items, comma-separated), ``rate`` the sample rate [Hz] of a file without time stamps,
``angle_unit`` and ``time_unit`` as the options; ``name`` labels the log in sentences (default: the file name);
``bench`` and ``date`` group and order logs in batch. Every error names the manifest's line.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputNotFoundError, LogFormatError, SettingsError

COLUMNS = ("path", "signal", "rate", "angle_unit", "time_unit", "name", "bench", "date")


@dataclass(frozen=True)
class Entry:
    """One log of a manifest (or of the command line), with how to read it."""
    path: Path
    signals: list[str] | None = None
    rate_hz: float | None = None
    angle_unit: str = "auto"
    time_unit: str = "auto"
    name: str = ""
    bench: str = ""
    date: str = ""
    where: str = ""  # "manifest.csv: line 3" for messages ("" on the command line)

    @property
    def label(self) -> str:
        return self.name or self.path.name


def read_manifest(path: str | Path) -> list[Entry]:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputNotFoundError(f"{path}: no such manifest") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputNotFoundError(f"{path}: cannot read the manifest ({exc})") from None
    rows = list(csv.reader(text.splitlines()))
    if not rows or [c.strip().lower() for c in rows[0]][:1] != ["path"]:
        raise LogFormatError(f"{path}: line 1: expected a header starting with 'path' (columns: {', '.join(COLUMNS)})")
    head = [c.strip().lower() for c in rows[0]]
    unknown = [c for c in head if c not in COLUMNS]
    if unknown:
        raise LogFormatError(f"{path}: line 1: unknown column(s) {', '.join(unknown)}; expected {', '.join(COLUMNS)}")
    entries = []
    for number, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        if len(row) > len(head):
            raise LogFormatError(f"{path}: line {number}: {len(row)} cells, the header has {len(head)} (quote a "
                                 "mapping with commas: \"alpha=psi,beta=phi\")")
        cell = dict(zip(head, (c.strip() for c in row)))
        where = f"{path}: line {number}"
        log = Path(cell["path"])
        if not cell["path"]:
            raise LogFormatError(f"{where}: no path")
        log = log if log.is_absolute() else path.parent / log
        if not log.exists():
            raise InputNotFoundError(f"{where}: no such log {log}")
        rate = None
        if cell.get("rate"):
            try:
                rate = float(cell["rate"])
            except ValueError:
                raise SettingsError(f"{where}: rate {cell['rate']!r}; expected a sample rate in Hz") from None
        entries.append(Entry(log, [cell["signal"]] if cell.get("signal") else None, rate,
                             cell.get("angle_unit") or "auto", cell.get("time_unit") or "auto",
                             cell.get("name", ""), cell.get("bench", ""), cell.get("date", ""), where))
    if not entries:
        raise LogFormatError(f"{path}: no logs listed (one row per log under the header)")
    return entries
