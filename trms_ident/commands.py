"""What each command does, as plain functions: read, compute, write. The CLI adds flags and exit codes."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from .io.csv_log import truth_path
from .log import Log
from .report.summary import load_truth
from .settings import Settings

if TYPE_CHECKING:
    from .identify import Result


@dataclass
class EstimateOutput:
    log: Log
    result: Result
    summary: dict
    written: list[Path]


def estimate_file(log_path: str | Path, settings: Settings, out_dir: str | Path | None,
                  *, angle_unit: str = "auto", time_unit: str = "auto", html: bool = True, truth_file: str | Path | None = None,
                  signals: list[str] | None = None, time_source: str = "auto", voltage_time: str = "stamp",
                  rate_hz: float | None = None,
                  on_stage: Callable[[str], None] | None = None) -> EstimateOutput:
    """Identify J1, B1, J2, B2 from one log (api.estimate_with, the library's own path) with the truth file
    beside a simulated log; write report.html, traces.csv and result.json to out_dir."""
    from .api import estimate_with

    tpath = Path(truth_file) if truth_file else truth_path(log_path)
    truth = load_truth(tpath)
    est = estimate_with(log_path, settings, truth=truth, truth_source=str(tpath) if truth else None,
                        on_stage=on_stage, angle_unit=angle_unit, signals=signals, time_source=time_source,
                        time_unit=time_unit, voltage_time=voltage_time, rate_hz=rate_hz)
    written = est.save(out_dir, html, on_stage) if out_dir is not None else []
    return EstimateOutput(est.log, est.result, est.doc, written)
