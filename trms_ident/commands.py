"""What each command does, as plain functions: read, compute, write. The CLI adds flags and exit codes."""
from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

from typing import TYPE_CHECKING, Callable

from .io.atomic import write_text
from .io.csv_log import truth_path
from .io.readers import read_log
from .log import Log
from .report.html import render
from .report.summary import load_truth, summarize, to_json
from .report.traces import write_traces
from .settings import Settings

if TYPE_CHECKING:
    from .identify import Result


def _load_numerics() -> None:
    """Import the compiled core and load its kernels (numba start-up ~0.7 s) off the critical path."""
    from .numerics.fused import warm_up

    warm_up()


#: CSV logs up to this size are likely to be refined under --refine auto (about 50 bytes a row and
#: REFINE_AUTO_MAX_STEPS rows at 1 kHz), so the refinement's kernel is loaded while the log is read
REFINE_WARM_UP_BYTES = 50_000_000


def _load_refinement() -> None:
    """Load the refinement's compiled kernel from numba's cache (~0.4 s) off the critical path."""
    from .numerics.refine import warm_up

    warm_up()


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
    """Identify J1, B1, J2, B2 from one log; write report.html, traces.csv and result.json to out_dir."""
    stage = on_stage or (lambda _: None)
    warm = threading.Thread(target=_load_numerics, daemon=True)  # overlaps with reading the log
    warm.start()
    if settings.refine == "on" or (settings.refine == "auto" and _size(log_path) <= REFINE_WARM_UP_BYTES):
        threading.Thread(target=_load_refinement, daemon=True).start()  # identify waits for it if needed
    stage("reading")
    log = read_log(log_path, angle_unit=angle_unit, signals=signals, time_source=time_source, time_unit=time_unit,
                   voltage_time=voltage_time, rate_hz=rate_hz)
    warm.join()
    from .identify import identify

    stage("identifying")

    result = identify(log, settings)
    tpath = Path(truth_file) if truth_file else truth_path(log_path)
    truth = load_truth(tpath)
    summary = summarize(result, log, truth, str(tpath) if truth else None)
    written: list[Path] = []
    if out_dir is not None:
        written = write_outputs(out_dir, summary, result, log, html, stage)
    return EstimateOutput(log, result, summary, written)


def write_outputs(out_dir: str | Path, summary: dict, result: Result, log: Log, html: bool = True,
                  stage: Callable[[str], None] = lambda _: None) -> list[Path]:
    """result.json, traces.csv and (html) report.html into out_dir, each atomically."""
    out = Path(out_dir)
    write_text(out / "result.json", to_json(summary))
    write_traces(out / "traces.csv", result)
    written = [out / "result.json", out / "traces.csv"]
    if html:
        stage("drawing the report")
        write_text(out / "report.html", render(summary, result, log))
        written.append(out / "report.html")
    return written


def _size(path: str | Path) -> int:
    try:
        return Path(path).stat().st_size
    except OSError:  # read_log reports a missing file with its own message
        return 0
