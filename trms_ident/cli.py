"""Command line: flags, human text on stderr, --json on stdout or a file, exit codes.

Exit codes (also in README): 0 ok, 1 internal error, 2 usage or bad option value,
3 input file missing or unreadable, 4 log unusable, 5 parameter file invalid,
6 log does not excite the parameters, 7 output cannot be written,
8 batch: some logs failed, 9 batch: every log failed, 10 --strict: the model does not fit the log,
11 --strict: not decided, 130 interrupted, 141 the reader of --json - closed the pipe.
"""
from __future__ import annotations

import functools
import json
import math
import os
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

# BLAS on one thread unless the user set a thread count: this tool's matrices are small, and OpenBLAS's
# waiting threads spun on the second core that the log reader and the per-axis filter threads use (measured on
# 2 cores: batch of 8 logs -j2 4.5 -> 3.5 s, -j1 4.7 -> 4.3 s, diagnose of a sample log 15.0 -> 14.7 s).
# Set before numpy is first imported, so that its worker threads are never started.
if not {"OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"} & set(os.environ):
    os.environ.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")

import typer  # noqa: E402

from . import __version__
from .errors import (EXIT_ALL_FAILED, EXIT_INADEQUATE, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_PIPE_CLOSED,
                     EXIT_SOME_FAILED, EXIT_UNDECIDED, JoinedRunsError, SettingsError, TrmsError)
from .settings import GAIN_CONVENTIONS, HEADLINES, Settings
from .params import (ESTIMATED, THRUST_LAWS, UNITS, bench_names, bench_settings, diagnose_bench, load_parameter_file,
                     parameter_file_inputs_unit, refuse_structure, unit_of)

app = typer.Typer(
    name="trms-ident",
    help="Identify J1, B1, J2, B2 of a Twin Rotor MIMO System from recorded logs (DREM).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # help texts carry units in [brackets]; print them as written
)


def say(msg: str = "") -> None:
    """Human text goes to stderr, so that --json - on stdout stays machine-readable.  When the reader of stderr
    has gone (``2>&1 | head``) the text stops and the work goes on: the command's files are still written."""
    try:
        typer.echo(msg, err=True)
    except BrokenPipeError:
        _to_devnull(sys.stderr)


def _to_devnull(stream) -> None:
    """Point ``stream``'s file descriptor at the null device: a closed pipe is not written again (nor flushed at
    exit, which would print Python's own "Exception ignored" lines)."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), stream.fileno())
    except (OSError, ValueError):  # not a file descriptor (a test's captured stream): nothing to redirect
        pass


def handled(fn):
    """Map domain errors to one line on stderr and their exit code; never a traceback."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except TrmsError as exc:
            say(f"error: {exc}")
            raise typer.Exit(exc.exit_code) from None
        except (typer.Exit, typer.Abort):
            raise
        except KeyboardInterrupt:
            say("interrupted")
            raise typer.Exit(EXIT_INTERRUPTED) from None
        except BrokenPipeError:  # the reader of stdout went away (``--json - | head``): exit as a shell's pipe does
            _to_devnull(sys.stdout)
            _to_devnull(sys.stderr)
            raise typer.Exit(EXIT_PIPE_CLOSED) from None
        except Exception as exc:  # a bug: say so in one line, traceback only on request
            if os.environ.get("TRMS_IDENT_DEBUG"):
                raise
            say(f"internal error: {type(exc).__name__}: {exc} (set TRMS_IDENT_DEBUG=1 for a traceback)")
            raise typer.Exit(EXIT_INTERNAL) from None

    return wrapper


def _version(value: bool):
    if value:
        typer.echo(f"trms-ident {__version__}")
        raise typer.Exit()


@app.callback()
def main(version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                               help="Print the version and exit.")] = False) -> None:
    """trms-ident: DREM parameter identification for the TRMS bench."""


def parse_gamma(text: str) -> dict | None:
    """'auto' -> None; '100' -> all four; 'J1=10,B1=10,J2=100,B2=100' -> per parameter."""
    text = text.strip()
    if text.lower() == "auto":
        return None
    try:
        if "=" not in text:
            return {k: float(text) for k in ESTIMATED}
        out = {}
        for part in text.split(","):
            k, v = part.split("=")
            out[k.strip()] = float(v)
        return out
    except ValueError:
        raise SettingsError(f"--gamma {text!r}: expected 'auto', a number, or J1=..,B1=..,J2=..,B2=..") from None


def parse_auto(flag: str, text: str) -> float | None:
    if text.strip().lower() == "auto":
        return None
    try:
        return float(text)
    except ValueError:
        raise SettingsError(f"{flag} {text!r}: expected 'auto' or a number in rad/s") from None


def emit_json(doc: dict, target: str) -> None:
    from .io.atomic import write_text
    from .report.summary import to_json

    if target == "-":
        sys.stdout.write(to_json(doc))
    else:
        write_text(target, to_json(doc))


# ---- options shared by estimate and batch (defined once) ----------------------------------------
ParamsOpt = Annotated[Optional[Path], typer.Option("--params", help="TOML file overriding known parameters, with "
                                                   "the bench's [effects] (export writes it from a diagnosis), or a "
                                                   "bundled bench's name: humusoft_ce150.")]
AOpt = Annotated[str, typer.Option("--a", help="Bandwidth of F(s), eq. (3) [rad/s], or 'auto': designed from the "
                                   "log's noise level and excitation.")]
BOpt = Annotated[str, typer.Option("--b", help="Bandwidth of H(s), eq. (5) [rad/s], or 'auto' (2 a).")]
GainOpt = Annotated[str, typer.Option("--gain-convention", help=f"Filter gains: 'unit' (a^2/(s+a)^2, DC gain 1) or "
                                      f"'paper' (a/(s+a)^2 exactly as printed). One of {GAIN_CONVENTIONS}.")]
GammaOpt = Annotated[str, typer.Option("--gamma", help="Gradient gain of eq. (8): 'auto' (normalized), a number, "
                                       "or J1=..,B1=..,J2=..,B2=..")]
SettleOpt = Annotated[float, typer.Option("--settle", help="Auto gain: time for the trace error to fall to 1 % [s].")]
LawOpt = Annotated[str, typer.Option("--thrust-law", help=f"One of {tuple(THRUST_LAWS)}.")]
HeadlineOpt = Annotated[str, typer.Option("--headline", help=f"Which number is the estimate: {HEADLINES} ('refined' "
                                          "falls back to 'offline' when the refinement is skipped or not used).")]
RefineOpt = Annotated[str, typer.Option("--refine", help="Prediction-error refinement after DREM: 'auto' (logs up to "
                                        "~17 min at 1 kHz), 'on' or 'off'.")]
AngleOpt = Annotated[str, typer.Option("--angle-unit", help="Unit of the logged angles: auto (radians, or degrees "
                                       "where the pitch cannot be radians (beyond +-pi/2) and both angles lie within "
                                       "the bench's range in degrees: converted and said), rad (no guess) or deg.")]
TimeUnitOpt = Annotated[str, typer.Option("--time-unit", help="Unit of CSV time stamps: auto (told from the median "
                                          "step: <= 0.15 s, ms up to 150, else us; said on stderr), s, ms or us.")]
FreeOpt = Annotated[str, typer.Option("--free", help="Known values to estimate with J/B by the refinement, e.g. "
                                      "Mg,kc (started from the table or --params), and effects of the bench file's "
                                      "[effects], e.g. cable_stiffness:yaw (an input modification by a profile), "
                                      "or its [terms], e.g. 'pitch: M1 * sin(alpha)'; results in "
                                      "refined.known_values_estimated.")]
StrictOpt = Annotated[bool, typer.Option("--strict", help="Exit with code 10 when the model does not fit the log "
                                          "(model_check.adequate false), 11 when that is not decided (adequate "
                                          "null: the fit did not converge, or the log's noise floor cannot be "
                                          "measured and its halves agree); batch: any log.")]
NoReportOpt = Annotated[bool, typer.Option("--no-report", help="Skip the HTML report.")]
SignalOpt = Annotated[Optional[list[str]], typer.Option("--signal", help="MCAP: where a signal comes from, "
                                                        "NAME=TOPIC:FIELD, e.g. alpha=/arm/joint_states:position[pitch]; "
                                                        "MATLAB: NAME=VARIABLE, e.g. alpha=psi, alpha=data[2], "
                                                        "alpha=yout.signals[0]; CSV: NAME=COLUMN, e.g. "
                                                        "alpha=pitch_rad (repeatable, or several comma-separated: "
                                                        "alpha=psi,beta=phi; see `inspect`). u2=0 (u1=0): that motor "
                                                        "was off and its input not logged, held at 0 V.")]
RateOpt = Annotated[Optional[float], typer.Option("--rate", help="MATLAB logs without a time vector: the sample "
                                                  "rate [Hz].")]
TimeSourceOpt = Annotated[str, typer.Option("--time-source", help="MCAP message time: auto (header.stamp when "
                                            "present, else log time), header, log or publish.")]
StrictGapsOpt = Annotated[bool, typer.Option("--strict-gaps", help="Refuse a log with a gap in its stamps (rows "
                                             "lost, a logger's pause) instead of estimating its parts jointly.")]
VoltageTimeOpt = Annotated[str, typer.Option("--voltage-time", help="MCAP: when a voltage message takes effect: "
                                             "'stamp' (at its own time, inside the angle interval where it falls) or "
                                             "'next-sample' (from the next angle sample on).")]


def check_units(angle_unit: str, time_unit: str) -> None:
    from .log import ANGLE_UNITS, TIME_UNITS

    if angle_unit not in ANGLE_UNITS:
        raise SettingsError(f"--angle-unit {angle_unit!r}: expected one of {', '.join(ANGLE_UNITS)}")
    if time_unit not in ("auto", *TIME_UNITS):
        raise SettingsError(f"--time-unit {time_unit!r}: expected one of auto, {', '.join(TIME_UNITS)}")


def build_settings(a: str, b: str, gain_convention: str, gamma: str, settle: float, thrust_law: str, headline: str,
                   params: Path | None, angle_unit: str, refine: str = "auto", free: str = "",
                   time_unit: str = "auto") -> Settings:
    check_units(angle_unit, time_unit)
    settings = Settings(filter_a_rad_s=parse_auto("--a", a), filter_b_rad_s=parse_auto("--b", b),
                        gain_convention=gain_convention, gamma=parse_gamma(gamma), settle_time_s=settle,
                        thrust_law=thrust_law, headline=headline, refine=refine,
                        free=free_keys(free), **bench_settings(params))
    settings.validate()
    return settings


def free_keys(free: str) -> tuple:
    """--free's comma-separated names, a bench file's term ('pitch: M1 * sin(alpha)') as the model room's key."""
    from .model.bench import BenchEffectError, free_key

    try:
        return tuple(free_key(x.strip()) for x in free.split(",") if x.strip())
    except BenchEffectError as exc:
        raise SettingsError(f"--free {exc}") from None


def stage_reporter(label: str):
    """A one-line status on a terminal for long single-log work; silent when stderr is piped."""
    if not sys.stderr.isatty():
        return None

    def report(stage: str) -> None:
        sys.stderr.write(f"\r\033[K{label}: {stage}...")
        sys.stderr.flush()

    return report


@contextmanager
def progress_bar(label: str):
    """Yield advance(stage, fraction): a transient bar with the stage on a terminal, a no-op when piped."""
    if not sys.stderr.isatty():
        yield None
        return
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    bar = Progress(TextColumn(Path(label).name), BarColumn(bar_width=20), TextColumn("{task.percentage:>3.0f} %"),
                   TimeElapsedColumn(), TextColumn("{task.description}"), transient=True, console=Console(stderr=True))
    task = bar.add_task("", total=1.0)
    with bar:
        yield lambda stage, done: bar.update(task, completed=done, description=stage)


def exit_if_strict(strict: bool, verdicts) -> None:
    """--strict: exit 10 when any verdict is "does not fit" (False), else 11 when any is not decided (None)."""
    verdicts = list(verdicts)
    if strict and False in verdicts:
        raise typer.Exit(EXIT_INADEQUATE)
    if strict and None in verdicts:
        raise typer.Exit(EXIT_UNDECIDED)


#: the first words of estimate's verdict line, by model_check.adequate
VERDICT_HEAD = {True: "MODEL FITS: ", False: "MODEL DOES NOT FIT: ", None: "FIT NOT DECIDED: "}
CONDITIONAL = {False: " (conditional on a model that does not fit)",
               None: " (no adequacy verdict: {because}; the interval assumes the model is right)"}

@app.command()
@handled
def estimate(
    logs: Annotated[Optional[list[Path]], typer.Argument(
        help="Log file: CSV (t,u1,u2,alpha,beta), MCAP or MATLAB .mat; with --joint, several logs of one bench.",
        show_default=False)] = None,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Folder for report.html, traces.csv, "
                                                "result.json [default: ./<log name>_ident; --joint: "
                                                "./joint_ident].")] = None,
    joint: Annotated[bool, typer.Option("--joint", help="One set of J/B over all the logs given (one bench), "
                                        "each log's own estimate beside it and a test that they agree.")] = False,
    manifest: Annotated[Optional[Path], typer.Option("--manifest", help="A CSV of logs for --joint: columns path "
                                                     "(required), signal, rate, angle_unit, time_unit, name, "
                                                     "bench, date; one row per log.", show_default=False)] = None,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Also write the result JSON here; '-' = stdout.")] = None,
    params: ParamsOpt = None,
    a: AOpt = "auto",
    b: BOpt = "auto",
    gain_convention: GainOpt = "unit",
    gamma: GammaOpt = "auto",
    settle: SettleOpt = Settings.settle_time_s,
    thrust_law: LawOpt = "quadratic",
    headline: HeadlineOpt = "refined",
    refine: RefineOpt = "auto",
    angle_unit: AngleOpt = "auto",
    time_unit: TimeUnitOpt = "auto",
    strict: StrictOpt = False,
    free: FreeOpt = "",
    truth: Annotated[Optional[Path], typer.Option(help="Ground-truth JSON [default: <log>.truth.json if present].")] = None,
    no_report: NoReportOpt = False,
    signal: SignalOpt = None,
    time_source: TimeSourceOpt = "auto",
    voltage_time: VoltageTimeOpt = "stamp",
    rate: RateOpt = None,
    strict_gaps: StrictGapsOpt = False,
) -> None:
    """Estimate J1, B1, J2, B2 from a log and write a report (--joint: one bench from several logs)."""
    settings = build_settings(a, b, gain_convention, gamma, settle, thrust_law, headline, params, angle_unit, refine,
                              free, time_unit)
    logs = list(logs or [])
    if joint or manifest:
        return _estimate_joint(logs, manifest, settings, out, json_path, no_report, strict, signal, rate,
                               angle_unit, time_unit, strict_gaps)
    if len(logs) != 1:
        raise SettingsError(f"estimate takes one log ({len(logs)} given): add --joint to estimate one bench from "
                            "several logs together, or use `trms-ident batch` for one estimate per log")
    log = logs[0]
    out_dir = out if out is not None else Path(f"{log.name.split('.')[0]}_ident")
    from . import CACHE_NOTE
    from ._cache import kernels_cached

    if CACHE_NOTE:
        say(f"note: {CACHE_NOTE}")
    cold = not kernels_cached(Path(__file__).resolve().parent.parent)
    progress = stage_reporter(str(log))

    def on_stage(stage: str) -> None:
        if cold and stage == "identifying":  # said once the log is read: bad input still gets one line
            say("note: first run here: compiling the numerical kernels (measured 10 s for the sample log; more the "
                "first time a refinement, diagnose or the simulator runs); later runs load them from the cache")
        if progress:
            progress(stage)

    try:
        res = _estimate_one(log, settings, out_dir, angle_unit, time_unit, no_report, truth, signal, time_source,
                            voltage_time, rate, on_stage)
    except JoinedRunsError as exc:  # runs joined in one file, or gaps in its stamps: its parts estimated jointly
        if progress:
            sys.stderr.write("\r\033[K")
        if strict_gaps and exc.gaps:
            raise
        return _estimate_joint([log], None, settings, out_dir, json_path, no_report, strict, signal, rate,
                               angle_unit, time_unit)
    if progress:
        sys.stderr.write("\r\033[K")
    _say_estimate(res, log, json_path, strict)


def _estimate_one(log, settings, out_dir, angle_unit, time_unit, no_report, truth, signal, time_source, voltage_time,
                  rate, on_stage):
    from .commands import estimate_file

    return estimate_file(log, settings, out_dir, angle_unit=angle_unit, time_unit=time_unit, html=not no_report, truth_file=truth,
                        signals=signal, time_source=time_source, voltage_time=voltage_time, rate_hz=rate,
                        on_stage=on_stage)


def _say_estimate(res, log: Path, json_path: str | None, strict: bool) -> None:
    """estimate's lines on stderr (the verdict first), the JSON, and --strict's exit code."""
    from .model_profile import PROFILE_SPAN

    s = res.summary
    check = s["model_check"]
    say(VERDICT_HEAD[check["adequate"]] + check["sentence"])
    for warning in filter(None, [res.log.meta.get("warnings")]):
        say(f"warning: {warning}")
    for note in res.log.meta.get("assumed", {}).values():
        say(f"note: {note}")
    samp = s["input"]["sampling"]
    say(f"{log}: {s['input']['samples']} samples, {s['input']['duration_s']:.6g} s at "
        f"{1.0 / s['input']['sample_time_s']:.6g} Hz" +
        ("" if samp["uniform"] else f" (jittered stamps: steps {samp['min_step_over_median']:.3g}-"
         f"{samp['max_step_over_median']:.3g} x the median, {samp['dropped_samples']} dropped; voltages held over "
         "each actual interval)"))
    from .report.summary import interval_text, voltage_timing_text

    timing_line = voltage_timing_text(s["input"])
    if timing_line:
        say("  " + timing_line)
    say(f"  filters: a = {res.result.settings.filter_a_rad_s:g} rad/s, b = {res.result.settings.filter_b_rad_s:g} rad/s"
        f" ({'designed from the log' if res.result.design else 'given'})")
    if s["model"]["effects"]:
        say(f"  model: {s['model']['equation']}")
    say(f"  estimate: {res.result.headline}; {res.result.refine_note}")
    tv = s.get("truth", {})
    for k in ESTIMATED:
        est, (lo, hi) = s["estimates"][k], s["ci95"][k]
        if est is None:
            say(f"  {k}: not identifiable from this log ({s['identifiability'][k]})")
            continue
        line = f"  {k} = {est:<11.6g} {UNITS[k]:<10}"
        line += f" 95 % {interval_text(lo, hi, est)}" if lo is not None else " (no interval: log too short)"
        line += "" if check["adequate"] or lo is None else CONDITIONAL[check["adequate"]].format(
            because=check.get("undecided_because") or "not decided")
        if k in s["not_credible"]:
            line += (f" ({s['not_credible'][k]}: check the log's units and the known values; for a bench with "
                     f"its own: --params FILE or a bundled one, {', '.join(bench_names())})")
        if tv:
            line += f"   truth {tv['values'][k]:.6g}, error {tv['error_percent'][k]:+.3f} %"
        say(line)
    from .model.bench import shown

    for k, v in ((s.get("refined") or {}).get("known_values_estimated") or {}).items():
        say(f"  {shown(k)} = {v['estimate']:<11.6g} {unit_of(k):<10} 95 % {interval_text(*v['ci95'], v['estimate'])}   "
            f"(estimated with --free; given {v['table_or_file_value']:.6g})" + (
                f"; at the edge of its search, {PROFILE_SPAN:g}x the value given: give a closer one"
                if v.get("at_search_edge") else ""))
    say("wrote " + ", ".join(str(p) for p in res.written))
    if json_path:
        emit_json(s, json_path)
    exit_if_strict(strict, [check["adequate"]])


@app.command()
@handled
def batch(
    inputs: Annotated[Optional[list[str]], typer.Argument(
        help="Folders (searched recursively), glob patterns or log files.", show_default=False)] = None,
    manifest: Annotated[Optional[Path], typer.Option("--manifest", help="A CSV of logs (columns path, signal, rate, "
                                                     "angle_unit, time_unit, name, bench, date) for --joint-by.",
                                                     show_default=False)] = None,
    joint_by: Annotated[Optional[str], typer.Option("--joint-by", help="With --manifest: one joint estimate per "
                                                    "value of this column (bench), in its own folder, with "
                                                    "joint_summary.json and joint_index.html.",
                                                    show_default=False)] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for one output folder per log, summary.csv, "
                                      "summary.json and index.html.")] = Path("batch_out"),
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="Worker processes on this machine.")] = 1,
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="Run on a Dask distributed cluster at this "
                                                     "address, e.g. tcp://10.0.0.5:8786 (needs trms-ident[dask]).")] = None,
    force: Annotated[bool, typer.Option("--force", help="Redo logs whose outputs are up to date.")] = False,
    json_path: Annotated[Optional[str], typer.Option("--json", help="Also write summary.json here; '-' = stdout.")] = None,
    params: ParamsOpt = None,
    a: AOpt = "auto",
    b: BOpt = "auto",
    gain_convention: GainOpt = "unit",
    gamma: GammaOpt = "auto",
    settle: SettleOpt = Settings.settle_time_s,
    thrust_law: LawOpt = "quadratic",
    headline: HeadlineOpt = "refined",
    refine: RefineOpt = "auto",
    angle_unit: AngleOpt = "auto",
    time_unit: TimeUnitOpt = "auto",
    strict: StrictOpt = False,
    free: FreeOpt = "",
    no_report: NoReportOpt = False,
    signal: SignalOpt = None,
    time_source: TimeSourceOpt = "auto",
    voltage_time: VoltageTimeOpt = "stamp",
    rate: RateOpt = None,
    strict_gaps: StrictGapsOpt = False,
    diagnose: Annotated[bool, typer.Option("--diagnose", help="Diagnose every log the model does not fit: "
                                           "diagnosis.json beside its estimate, the verdict and findings in the "
                                           "summary.")] = False,
) -> None:
    """Estimate every CSV, MCAP and MATLAB log under folders or globs; carry on past bad files; write a summary.

    Exit code 0 when every log succeeded, 8 when some failed, 9 when all failed."""
    from . import batch as batch_mod

    if jobs < 1:
        raise SettingsError(f"--jobs {jobs}: expected 1 or more")
    settings = build_settings(a, b, gain_convention, gamma, settle, thrust_law, headline, params, angle_unit, refine,
                              free, time_unit)
    if joint_by or manifest:
        return _batch_joint(manifest, joint_by, inputs, out, settings, no_report, json_path, strict, diagnose)
    inputs = list(inputs or [])
    if not inputs:
        raise SettingsError("batch: no inputs; give folders, globs or log files (or --manifest FILE --joint-by bench)")
    paths = batch_mod.discover(inputs, out)
    if not paths:
        raise SettingsError(f"no .csv, .mcap or .mat logs found in {' '.join(inputs)}")
    options = {"html": not no_report, "signals": signal, "time_source": time_source, "angle_unit": angle_unit,
               "time_unit": time_unit, "voltage_time": voltage_time, "rate_hz": rate, "strict_gaps": strict_gaps,
               "diagnose": diagnose}
    if force:
        options["force_token"] = os.urandom(8).hex()
    bar = None
    if sys.stderr.isatty():
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        bar = Progress(TextColumn("batch"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(), transient=True)
        task = bar.add_task("logs", total=len(paths))
        bar.start()
    try:
        rows = batch_mod.run(paths, out, settings, options, jobs=jobs, scheduler=scheduler,
                             on_done=(lambda row: bar.advance(task)) if bar else None)
    finally:
        if bar:
            bar.stop()
    written = batch_mod.write_summary(out, rows)
    ok = sum(r["status"] == "ok" for r in rows)
    skipped = sum(r["skipped"] for r in rows)
    for r in rows:
        if r["status"] != "ok":
            say(f"failed: {r['error']}")
    bad_fit = [r for r in rows if r["adequate"] is False]
    undecided = [r for r in rows if r["status"] == "ok" and r["adequate"] is None]
    for r in bad_fit:
        dg = r.get("diagnosis")
        said = ("" if not dg else f"; not diagnosed: {dg['error']}" if not dg.get("file") else
                f"; diagnose: {dg['verdict'].upper().replace('_', ' ')}"
                + (": " + "; ".join(f["text"] for f in dg["findings"]) if dg["findings"] else ""))
        say(f"model does not fit: {r['path']}{said}")
    recurring = batch_mod.recurring_findings(rows)
    if recurring:
        say("findings across the logs: " + "; ".join(f"{k} in {n} of {m} diagnosed" for k, (n, m) in recurring.items()))
    for r in undecided:
        say(f"not decided whether the model fits (its fit did not converge, or its noise floor cannot be measured: "
            f"model_check in its result.json): {r['path']}")
    say(f"{ok} ok ({skipped} up to date, skipped), {len(rows) - ok} failed, the model does not fit {len(bad_fit)}; "
        "wrote " + ", ".join(map(str, written)))
    if json_path:
        emit_json(json.loads((out / "summary.json").read_text()), json_path)
    if ok < len(rows):
        raise typer.Exit(EXIT_ALL_FAILED if ok == 0 else EXIT_SOME_FAILED)
    exit_if_strict(strict, [r["adequate"] for r in bad_fit + undecided])


@app.command()
@handled
def diagnose(
    log: Annotated[Path, typer.Argument(help="Log file: CSV, MCAP or MATLAB .mat.", show_default=False)],
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the diagnosis JSON here; '-' = stdout.")] = None,
    report: Annotated[Optional[Path], typer.Option("--output", "-o", "--report", help="Folder for report.html "
                                                   "(figures) and diagnosis.json (--report: the older name).")] = None,
    params: ParamsOpt = None,
    a: AOpt = "auto",
    thrust_law: LawOpt = "quadratic",
    angle_unit: AngleOpt = "auto",
    time_unit: TimeUnitOpt = "auto",
    signal: SignalOpt = None,
    time_source: TimeSourceOpt = "auto",
    voltage_time: VoltageTimeOpt = "stamp",
    rate: RateOpt = None,
) -> None:
    """Find where the model and the recording disagree, name the missing physics, fit it, show the gain."""
    from .io.atomic import write_text
    from .io.readers import read_log
    from .report.diagnosis import render, to_doc
    from .report.summary import to_json
    from .report.terminal import diagnosis_lines

    from .api import diagnose as run_diagnosis
    from .api import with_inputs_unit

    check_units(angle_unit, time_unit)
    if thrust_law not in THRUST_LAWS:
        raise SettingsError(f"thrust law must be one of {tuple(THRUST_LAWS)}, got {thrust_law!r}")
    # the bench: its known values, its structure and its input modifications, taken as given (params.diagnose_bench)
    overrides = diagnose_bench(params) if params else {}
    progress = stage_reporter(str(log))
    progress and progress("reading")
    data = read_log(log, angle_unit=angle_unit, signals=signal, time_source=time_source, time_unit=time_unit,
                    voltage_time=voltage_time, rate_hz=rate)
    if params:  # checked above (load_parameter_file)
        data = with_inputs_unit(data, parameter_file_inputs_unit(params))
    for note in data.meta.get("assumed", {}).values():
        say(f"note: {note}")
    from .model.bench import TORQUE_KEYS, is_term
    from .params import parameter_file_effects

    held = parameter_file_effects(params) if params else ()
    torques = [e.key for e in held if e.key in TORQUE_KEYS]
    if torques:
        say(f"note: {params} holds torque effects ({', '.join(torques)}), which diagnose does not take as given: it "
            "starts without them and searches the whole library, those included (its input modifications it takes "
            "as given)")
    terms = [e.phrase() for e in held if is_term(e.key)]
    if terms:
        say(f"note: {params} holds terms outside the library ({'; '.join(terms)}), which diagnose does not take as "
            "given: it starts without them (what the library leaves, it describes again as a correction)")
    if progress:
        sys.stderr.write("\r\033[K")
    with progress_bar(str(log)) as advance:  # a bar on a terminal, nothing when stderr is piped
        d = run_diagnosis(data, params=overrides, thrust_law=thrust_law, filter_a_rad_s=parse_auto("--a", a),
                          progress=advance)
    doc = to_doc(d, data)
    for line in diagnosis_lines(d, str(log)):
        say(line)
    if report is not None:
        write_text(report / "diagnosis.json", to_json(doc))
        write_text(report / "report.html", render(doc, d, data))
        say(f"wrote {report / 'report.html'}, {report / 'diagnosis.json'}")
    if json_path:
        emit_json(doc, json_path)


def parse_effect(text: str) -> dict:
    """'name=value' or 'name:axis=value' (e.g. coulomb_friction:yaw=0.01)."""
    try:
        lhs, value = text.split("=")
        name, _, axis = lhs.partition(":")
        spec = {"effect": name.strip(), "value": float(value)}
        if axis:
            spec["axis"] = axis.strip()
        return spec
    except ValueError:
        raise SettingsError(f"--effect {text!r}: expected NAME=VALUE or NAME:AXIS=VALUE") from None


def _simulated_bench(params: Path | None) -> dict:
    """The simulator's values from a parameter file (J/B too: its true values); refused when the file states a
    [structure] the simulator (eq. 1) does not model."""
    refuse_structure(params, "simulate")
    return load_parameter_file(params, allow_estimated=True) if params else {}


def _sim_effects(params: Path | None, given: list[str] | None) -> list[dict]:
    """The simulator's effects: the parameter file's [effects] (the bench as diagnosed), then --effect (which
    replaces the file's value of the same effect and axis)."""
    from sim.effects import EFFECTS

    from .model.bench import simulator_specs
    from .params import parameter_file_effects

    specs = {f"{x['effect']}:{x['axis']}": x for x in
             (simulator_specs({e.key: e.value for e in parameter_file_effects(params)}) if params else [])}
    for text in given or []:
        spec = parse_effect(text)
        known = EFFECTS.get(spec["effect"])
        specs[f"{spec['effect']}:{spec.get('axis', known.axes[0] if known else '')}"] = spec  # unknown: sim says
    return list(specs.values())


@app.command(short_help="Simulate the bench in closed loop; write a log and its ground truth.")
@handled
def simulate(
    ref: Annotated[Optional[str], typer.Option(help="Reference: square (default), sine (the paper's), multisine, "
                                               "steps, chirp.")] = None,
    ref_file: Annotated[Optional[Path], typer.Option("--ref-file", help="Reference from a CSV file with columns t, "
                                                     "alpha_ref, beta_ref [s, rad], times from 0 (what trms-ident "
                                                     "design writes); the run lasts as long as the file unless "
                                                     "--duration is given.")] = None,
    output: Annotated[Optional[Path], typer.Option("--output", "-o", help="Log to write [default: sim_<ref>.csv or "
                                                   ".mcap]; the truth goes beside it as <name>.truth.json.")] = None,
    fmt: Annotated[str, typer.Option("--format", help="csv, mcap (ROS 2 CDR) or mcap-json.")] = "csv",
    duration: Annotated[Optional[float], typer.Option(help="Length [s] (default: 60 for square, 120 otherwise).")] = None,
    rate: Annotated[float, typer.Option("--rate", help="Sample rate of the controller and the log [Hz].")] = 1000.0,
    seed: Annotated[int, typer.Option(help="Seed for noise and random references.")] = 0,
    noise: Annotated[float, typer.Option(help="Gaussian measurement noise, standard deviation [rad].")] = 0.0,
    quantization: Annotated[float, typer.Option(help="Encoder quantum [rad] (0 = none).")] = 0.0,
    encoder_bits: Annotated[Optional[int], typer.Option(help="Encoder resolution; sets quantum = 2 pi / 2^bits.")] = None,
    params: Annotated[Optional[Path], typer.Option("--params", help="TOML file overriding true parameters, or a "
                                                   "bundled bench's name: humusoft_ce150.")] = None,
    thrust_law: Annotated[str, typer.Option(help=f"One of {tuple(THRUST_LAWS)}.")] = "quadratic",
    u_limit: Annotated[float, typer.Option(help="Controller output limit [V].")] = 2.5,
    effect: Annotated[Optional[list[str]], typer.Option(help="Inject unmodelled physics, NAME[:AXIS]=VALUE "
                                                        "(repeatable); recorded only in the truth file.")] = None,
    jitter: Annotated[float, typer.Option(help="Stamp jitter: each sample interval is the nominal step times a "
                                          "uniform draw in [1 - jitter, 1 + jitter] (0..0.5).")] = 0.0,
    start: Annotated[float, typer.Option("--start", help="The log begins this many seconds into the run (0: from "
                                         "rest; > 0: a log cut from the middle of a run) [s].")] = 0.0,
    voltage_offset: Annotated[float, typer.Option("--voltage-offset", help="Voltages reach the motors this fraction "
                                                  "of a step after the angle sample, and stamps them then (MCAP: "
                                                  "the voltage messages' time; CSV: a t_u column) (0..0.99).")] = 0.0,
) -> None:
    """Simulate the closed-loop bench (paper eq. 1 with PID eq. 9) and write a log with its ground truth."""
    from .api import simulate as run_sim
    from .io.atomic import write_text
    from .io.csv_log import truth_path, write_csv_log

    formats = {"csv": ".csv", "mcap": ".mcap", "mcap-json": ".mcap"}
    table = None
    if ref_file is not None:
        from .io.reference import read_reference
        from sim.references import TABLE

        if ref is not None:
            raise SettingsError(f"--ref {ref} and --ref-file {ref_file}: give one reference, not both")
        table = read_reference(ref_file)
        ref = TABLE
    ref = ref or "square"
    if fmt not in formats:
        raise SettingsError(f"--format {fmt!r}: expected one of {', '.join(formats)}")
    if encoder_bits is not None:
        if not 1 <= encoder_bits <= 32:
            raise SettingsError(f"--encoder-bits {encoder_bits}: expected 1..32")
        quantization = 2 * math.pi / 2 ** encoder_bits
    options = dict(duration_s=duration, sample_rate_hz=rate, seed=seed, noise_std_rad=noise,
                   quantization_rad=quantization, thrust_law=thrust_law, u_limit_v=u_limit,
                   overrides=_simulated_bench(params),
                   effects=_sim_effects(params, effect), jitter=jitter, start_s=start,
                   voltage_offset=voltage_offset)
    if table is not None:
        options["ref_table"] = (table.t_s, table.alpha_ref_rad, table.beta_ref_rad)
    try:
        result = run_sim(ref, **options)
    except ValueError as exc:
        where = f"--ref-file {ref_file}: " if table is not None and "reference table" in str(exc) else ""
        raise SettingsError(where + str(exc)) from None
    if table is not None:  # the file itself is not copied into the truth: its name and checksum are
        result.truth["reference_file"] = {"path": table.source, "sha256": table.sha256}
    path = output or Path(f"sim_{ref_file.stem if table is not None else ref}{formats[fmt]}")
    if path.suffix.lower() != formats[fmt]:
        raise SettingsError(f"--output {path}: expected a {formats[fmt]} file name for --format {fmt}")
    columns = (result.t_s, result.u1_v, result.u2_v, result.alpha_rad, result.beta_rad)
    if fmt == "csv":
        write_csv_log(path, *columns, u_t_s=result.u_time_s if voltage_offset else None)
    else:
        from .io.mcap_log import write_mcap_log

        write_mcap_log(path, *columns, encoding="cdr" if fmt == "mcap" else "json", u_t_s=result.u_time_s)
    write_text(truth_path(path), json.dumps(result.truth, indent=2) + "\n")
    t0 = float(result.t_s[0])
    say(f"wrote {path} ({result.t_s.size} samples, {float(result.t_s[-1]) - t0:.6g} s at {rate:g} Hz"
        + (f", stamps from {t0:.6g} s into the run" if t0 else "") + f") and {truth_path(path)}")


@app.command(short_help="Plan the next experiment: references that keep the bench within its limits and make "
                        "J/B as precise as they can be.")
@handled
def design(
    duration: Annotated[float, typer.Option(help="Length of the run [s].")] = 60.0,
    rate: Annotated[float, typer.Option("--rate", help="Sample rate of the controller and the log [Hz].")] = 1000.0,
    encoder_bits: Annotated[Optional[int], typer.Option(help="Encoder resolution: noise sd = (2 pi / 2^bits) / "
                                                        "sqrt(12) [default: 12].")] = None,
    noise_std: Annotated[Optional[float], typer.Option("--noise-std", help="Gaussian noise of the logged angles, "
                                                       "standard deviation [rad] (instead of --encoder-bits).")] = None,
    params: ParamsOpt = None,
    from_result: Annotated[Optional[Path], typer.Option("--from", help="A result.json of estimate: its known values, "
                                                        "J/B and measured noise floors are the bench (instead of "
                                                        "--params and the noise options).")] = None,
    controller: Annotated[Optional[Path], typer.Option("--controller", help="TOML file with a [controller] table: "
                                                       "Kp1, Ki1, Kd1, Kp2, Ki2, Kd2, Tf and u_limit [V] (default: "
                                                       "the simulator's PID, 2.5 V).")] = None,
    pitch_limit: Annotated[float, typer.Option("--pitch-limit", help="Largest |pitch| the run may reach [rad].")] = 1.0,
    yaw_limit: Annotated[float, typer.Option("--yaw-limit", help="Largest |yaw| the run may reach [rad] (the "
                                             "cable).")] = 3.0,
    max_saturated: Annotated[float, typer.Option("--max-saturated", help="Largest share of samples with a motor "
                                                 "voltage at its limit (0..1).")] = 0.05,
    max_ref_rate: Annotated[Optional[float], typer.Option("--max-ref-rate", help="Largest rate of either reference "
                                                          "[rad/s] (default: none).")] = None,
    robust: Annotated[float, typer.Option("--robust", help="The limits must also hold on benches whose J/B are "
                                          "this far off the given ones (relative, e.g. 0.05; default 0: on the "
                                          "given bench, what a bench 5 % off would do is said).")] = 0.0,
    objective: Annotated[str, typer.Option(help="worst: the largest relative 95 % half-width of J1, B1, J2, B2 "
                                           "(E-optimal); d: the determinant of their relative covariance.")] = "worst",
    effect: Annotated[Optional[str], typer.Option("--effect", help="Design to find this effect instead (NAME:AXIS, "
                                                  "a torque effect: coulomb_friction:pitch, cable_stiffness:yaw, ...); "
                                                  "needs --size.")] = None,
    size: Annotated[Optional[float], typer.Option("--size", help="The effect's size to find, in its parameter's "
                                                  "unit (e.g. 0.001 N m).")] = None,
    discriminate: Annotated[Optional[Path], typer.Option("--discriminate", help="A diagnosis.json of diagnose: design "
                                                         "to tell its first finding from its flagged look-alikes "
                                                         "(the bench: --params as diagnose was given, the "
                                                         "findings' J/B; the noise diagnose measured).")] = None,
    thrust_law: LawOpt = "quadratic",
    output: Annotated[Path, typer.Option("--output", "-o", help="References to write: .csv with t, alpha_ref, "
                                         "beta_ref [s, rad] (run it first with simulate --ref-file), or .mat: "
                                         "Simulink From Workspace, Structure With Time, variable ref.")
                  ] = Path("design.csv"),
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the design's JSON here; '-' = "
                                                     "stdout.")] = None,
    no_report: Annotated[bool, typer.Option("--no-report", help="Do not write the HTML page (<output>.html: the "
                                            "references, predicted angles and voltages, the intervals).")] = False,
) -> None:
    """Plan the next experiment: references for the lab's closed loop (multisines, square waves, or a pitch square
    with the yaw following the pitch rotor's push) that keep the limits and make J1, B1, J2, B2 as precise as they
    can be, predicted beside the paper's square reference."""
    from . import design as planner

    if not duration > 0 or not rate > 0:
        raise SettingsError(f"--duration {duration:g} and --rate {rate:g}: both must be > 0")
    if duration * rate < 100:
        raise SettingsError(f"--duration {duration:g} s at --rate {rate:g} Hz is {duration * rate:.0f} samples; "
                            "expected at least 100")
    if output.suffix.lower() not in (".csv", ".mat"):
        raise SettingsError(f"--output {output}: expected a .csv (t, alpha_ref, beta_ref) or .mat (Simulink From "
                            "Workspace, Structure With Time) file name")
    if noise_std is not None and encoder_bits is not None:
        raise SettingsError("--noise-std and --encoder-bits: give one noise, not both")
    if from_result is not None and params is not None:
        raise SettingsError("--from and --params: give one bench, not both")
    if noise_std is not None and not noise_std > 0:
        raise SettingsError(f"--noise-std {noise_std:g}: expected > 0 [rad]")
    if encoder_bits is not None and not 1 <= encoder_bits <= 32:
        raise SettingsError(f"--encoder-bits {encoder_bits}: expected 1..32")
    for name, v in (("--pitch-limit", pitch_limit), ("--yaw-limit", yaw_limit)):
        if not v > 0:
            raise SettingsError(f"{name} {v:g}: expected > 0 [rad] (a limit that excludes zero leaves no run)")
    if not 0 <= max_saturated <= 1:
        raise SettingsError(f"--max-saturated {max_saturated:g}: expected a share in 0..1")
    if max_ref_rate is not None and not max_ref_rate > 0:
        raise SettingsError(f"--max-ref-rate {max_ref_rate:g}: expected > 0 [rad/s]")
    if not 0 <= robust < 0.5:
        raise SettingsError(f"--robust {robust:g}: expected a relative J/B error in 0..0.5 (e.g. 0.05)")
    if objective not in planner.OBJECTIVES:
        raise SettingsError(f"--objective {objective!r}: expected one of {', '.join(planner.OBJECTIVES)}")
    if (effect is None) != (size is None):
        raise SettingsError("--effect and --size go together: the effect to find and its size")
    if discriminate is not None and effect is not None:
        raise SettingsError("--discriminate and --effect: design to tell hypotheses apart or to find an effect, "
                            "not both")
    if effect is not None and effect not in planner.EFFECTS:
        raise SettingsError(f"--effect {effect}: expected one of {', '.join(planner.EFFECTS)}")
    if size is not None and not (math.isfinite(size) and size != 0):
        raise SettingsError(f"--size {size:g}: expected a nonzero number")
    if thrust_law not in THRUST_LAWS:
        raise SettingsError(f"thrust law must be one of {tuple(THRUST_LAWS)}, got {thrust_law!r}")
    from .commands import design_files

    limits = planner.Limits(pitch_limit, yaw_limit, max_saturated, max_ref_rate, robust)
    with progress_bar("design") as advance:
        out = design_files(duration, rate, limits, output, noise_std=noise_std, encoder_bits=encoder_bits,
                           params=params, from_result=from_result, controller=controller, objective=objective,
                           effect=None if effect is None else (effect, size), thrust_law=thrust_law,
                           html=not no_report, discriminate=discriminate,
                           progress=(lambda f: advance("simulating candidates", f)) if advance else None)
    d, doc, r, page = out.design, out.doc, out.design.run, out.page
    say(f"wrote {output} ({r.t_s.size} samples, {duration:g} s at {rate:g} Hz; run it first with trms-ident simulate "
        f"--ref-file {output})" + (f" and {page}" if page else ""))
    say(f"  {doc['sentence']}")
    say(f"  references: pitch {planner.describe(d.pitch)}, yaw {planner.describe(d.yaw)} ({d.candidates} candidates "
        f"simulated, {d.feasible} within the limits)")
    say("  predicted 95 % half-width      design      square (the paper's)")
    for k in ESTIMATED:  # the square's run may diverge: no precision then
        sq = d.square.precision.get(k)
        say(f"    {k:<3}                       {100 * r.precision[k]['relative']:9.3g} %  "
            + (f"{100 * sq['relative']:9.3g} %" if sq else "      n/a (its run diverges)"))
    if r.discrimination is not None:
        q = d.square.discrimination
        for k, v in r.discrimination["rivals"].items():
            say(f"  {k} against {r.discrimination['truth']}: predicted cost gap {v['gap']:.3g}, error RMS over the "
                f"floor pitch {v['rms_over_noise']['alpha']:.3g}x, yaw {v['rms_over_noise']['beta']:.3g}x; chance "
                f"told apart {100 * v['power']:.3g} % (by diagnose's {v['rule'].replace('_', ' ')} rule"
                + (f"; the square reference: {100 * q['rivals'][k]['power']:.3g} %)" if q else ")"))
        for k, why in (doc["settings"].get("not_weighed") or {}).items():
            say(f"  not weighed: {k} ({why})")
    if r.effect is not None:
        q = d.square.effect
        say(f"  {effect} of {size:g}: predicted t {r.effect['t']:.3g}, chance diagnose's output-error test finds it "
            f"{100 * r.effect['power']:.3g} % (the square reference: "
            + (f"t {q['t']:.3g}, {100 * q['power']:.3g} %)" if q else "n/a, its run diverges)"))
    e, s = r.envelope, d.square.envelope
    say(f"  largest |pitch| {e['alpha_rad']:.3g} rad (square {s['alpha_rad']:.3g}), |yaw| {e['beta_rad']:.3g} rad "
        f"(square {s['beta_rad']:.3g}), time at the voltage limit {100 * e['saturated_share']:.3g} % (square "
        f"{100 * s['saturated_share']:.3g} %)")
    if json_path:
        emit_json(doc, json_path)


@app.command()
@handled
def inspect(
    file: Annotated[Path, typer.Argument(help="An MCAP recording, a MATLAB .mat log (or a CSV log).",
                                         show_default=False)],
    json_path: Annotated[Optional[str], typer.Option("--json", help="Write the description as JSON here; '-' = "
                                                     "stdout.")] = None,
) -> None:
    """Describe a recording: topics, types, encodings, counts, rates, time span, numeric fields, --signal mapping."""
    from .io.readers import describe

    doc = describe(file)
    if json_path:
        emit_json(doc, json_path)
        if json_path == "-":
            return
    say(f"{doc['file']}: {doc['bytes']:,} bytes" +
        (f", {doc['duration_s']:.6g} s" if "duration_s" in doc else ""))
    for t in doc.get("topics", []):
        rate = f"{t['rate_hz']:.6g} Hz" if t.get("rate_hz") else "-"
        say(f"  {t['topic']}  {t['type'] or '?'} ({t['message_encoding']}): {t['messages']} messages, {rate}")
        if t["numeric_fields"]:
            say("      numeric: " + ", ".join(t["numeric_fields"]))
    for c in doc.get("columns", []):
        say(f"  column {c}")
    for s in doc.get("signals", []):
        say("  " + mat_signal_line(s))
    for u in doc.get("undecoded", []):
        say(f"  {u['path']}: a MATLAB object of class {u['class']} that could not be decoded ({u['why']})")
    for m, paths in doc.get("ambiguous", {}).items():
        say(f"  several signals could be {m}: {', '.join(paths)} (map one: --signal {m}=PATH)")
    for m in doc.get("missing", []):
        say(f"  no variable found for {m}" + (" (pass --rate HZ)" if m == "t" else f" (map it: --signal {m}=PATH)"))
    if doc.get("suggested_signals"):
        say("suggested mapping: " + " ".join(f"--signal {v}" for v in doc["suggested_signals"].values()))
    elif "topics" in doc:
        say("no obvious mapping for alpha, beta, u1, u2: pass --signal NAME=TOPIC:FIELD for each")
    elif "signals" in doc:
        say("no variable matches a known name: pass --signal NAME=PATH for alpha, beta, u1 and u2 "
            "(PATH as listed above; one column of a matrix as PATH:COLUMN)")
    for w in doc.get("warnings", []):
        say(f"warning: {w}")


def _batch_joint(manifest: Path | None, joint_by: str | None, inputs, out: Path, settings: Settings,
                 no_report: bool, json_path: str | None, strict: bool, diagnose: bool = False) -> None:
    """batch --manifest FILE --joint-by COLUMN: one joint estimate per group, a summary over the groups; with
    ``diagnose``, each log the model does not fit alone diagnosed, and the findings across a group's logs."""
    from . import batch as batch_mod
    from .io.manifest import read_manifest

    if not (manifest and joint_by):
        raise SettingsError("batch: --joint-by and --manifest go together (the grouping column lives in the manifest)")
    if inputs:
        raise SettingsError("batch --joint-by: the logs come from the manifest; leave out the inputs "
                            f"({' '.join(inputs)})")
    entries = read_manifest(manifest)
    bar = None
    if sys.stderr.isatty():
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

        bar = Progress(TextColumn("benches"), BarColumn(), MofNCompleteColumn(), transient=True)
        task = bar.add_task("groups", total=None)
        bar.start()
    try:
        rows = batch_mod.run_joint(entries, joint_by, out, settings, html_report=not no_report,
                                   progress=(lambda done, total: bar.update(task, completed=done, total=total))
                                   if bar else None, diagnose=diagnose)
    finally:
        if bar:
            bar.stop()
    written = batch_mod.write_joint_summary(out, rows, html_report=not no_report)
    for r in rows:
        if r["status"] != "ok":
            say(f"failed: {r['group']}: {r['error']}")
        else:
            say(f"{r['group']} ({len(r['logs'])} logs): {r['sentence']}")
            for k, v in (r.get("findings_across_logs") or {}).items():
                say(f"  {k}: found in {v['logs']} of the {v['diagnosed']} logs diagnosed"
                    + (" (one log only: suspect until another run of the bench shows it)"
                       if v["logs"] == 1 and v["diagnosed"] > 1 else ""))
    ok = sum(r["status"] == "ok" for r in rows)
    say(f"{ok} group(s) estimated, {len(rows) - ok} failed; wrote " + ", ".join(map(str, written)))
    if json_path:
        emit_json(json.loads((out / "joint_summary.json").read_text()), json_path)
    if ok < len(rows):
        raise typer.Exit(EXIT_ALL_FAILED if ok == 0 else EXIT_SOME_FAILED)
    exit_if_strict(strict, [r["adequate"] for r in rows])


def _estimate_joint(logs: list[Path], manifest: Path | None, settings: Settings, out: Path | None,
                    json_path: str | None, no_report: bool, strict: bool, signal, rate, angle_unit: str,
                    time_unit: str, strict_gaps: bool = False) -> None:
    """estimate --joint: read, pool, test, write; the verdict first, then the pooled and per-log numbers."""
    from .api import estimate_joint_with
    from .io.manifest import Entry, read_manifest
    from .report.joint import VERDICT
    from .report.summary import interval_text

    entries = read_manifest(manifest) if manifest else []
    entries += [Entry(p, signal, rate, angle_unit, time_unit) for p in logs]
    if not entries:
        raise SettingsError("estimate --joint: no logs; give their paths or --manifest FILE")
    progress = stage_reporter(f"{len(entries)} logs")
    if progress:
        progress("each alone, then pooled")
    est = estimate_joint_with(entries, settings, strict_gaps=strict_gaps)
    if progress:
        sys.stderr.write("\r\033[K")
    j = est.doc["joint"]
    for split in j.get("split", []):  # a file that broke into parts: what was found, what was left out
        say(f"note: {split['found']}: " + (f"its {split['parts'] - len(split['left_out'])} parts estimated jointly"
                                           if split["gaps"] else "estimated jointly") + ", as runs of one bench")
        for left in split["left_out"]:
            say(f"note: {left['part']} (t = {left['from_s']:.6g} to {left['to_s']:.6g} s) left out: {left['why']}")
    say(("LOGS DISAGREE: " if j["consistent"] is False else "AGREEMENT NOT TESTED: " if j["consistent"] is None
         else "LOG(S) LEFT OUT: " if j["outliers"] else "LOGS AGREE: ") + j["sentence"])
    if j["model"]["effects"]:
        say(f"  model: {j['model']['equation']}")
    for lg in j["logs"]:
        check = lg["model_check"]
        say(f"  {lg['name']}: " + ("left out of the pool" if not lg["in_pool"] else
                                   "pooled model " + VERDICT[check["adequate"]]) +
            "; alone " + ", ".join(f"{k} {'n.i.' if v is None else f'{v:.6g}'}" for k, v in lg["estimates"].items()))
    for k in ESTIMATED:
        v, (lo, hi) = j["estimates"][k], j["ci95"][k]
        say(f"  {k} = {v:<11.6g} {UNITS[k]:<10} 95 % {interval_text(lo, hi, v)}" if v is not None else
            f"  {k}: {j['identifiability'][k]}")
    written = est.save(out if out is not None else Path("joint_ident"), html=not no_report)
    say("wrote " + ", ".join(map(str, written)))
    if json_path:
        emit_json(est.doc, json_path)
    exit_if_strict(strict, [j["adequate"]])


def mat_signal_line(s: dict) -> str:
    """One signal of a .mat as ``inspect`` lists it: path, class, size, time base."""
    n, k = s["samples"], s["columns"]
    size = f"{n} samples" if k == 1 else f"{n} x {k} (one signal a column: PATH:0 to PATH:{k - 1})"
    line = f"{s['path']}: {s['class']}, {size}"
    if s.get("name"):
        line += f", named {s['name']!r}"
    if "time" in s:
        step = {"uniform": f"every {s['median_step_s']:.6g} s",
                "jittered": f"every {s['median_step_s']:.6g} s, jittered",
                "variable": f"variable step (median {s['median_step_s']:.6g} s)"}[s["steps"]] \
            if s.get("median_step_s") else ""
        line += f"; time {s['t0_s']:.6g} to {s['t1_s']:.6g} s {step} ({s['time']})"
    return line


@app.command()
@handled
def export(
    result: Annotated[Path, typer.Argument(help="A result.json written by estimate, or a diagnosis.json written by "
                                          "diagnose.", show_default=False)],
    output: Annotated[Optional[Path], typer.Option("--output", "-o", help="TOML file to write [default: model.toml "
                                                   "beside a result.json, bench.toml beside a diagnosis.json].")] = None,
) -> None:
    """Write the identified model as a TOML parameter file for --params: from a result.json its known values
    and J/B; from a diagnosis.json the bench as diagnosed (known values with the refitted ones, the findings as
    [effects], the findings' model's J/B)."""
    from .errors import InputNotFoundError
    from .io.atomic import write_text
    from .params import to_toml

    from .commands import bench_from_diagnosis, read_result

    if not result.is_file():
        raise InputNotFoundError(f"{result}: no such file")
    bench = bench_from_diagnosis(result)
    if bench is not None:  # a diagnosis.json: the bench as diagnosed
        path = output or result.with_name("bench.toml")
        write_text(path, to_toml(bench["known"], bench["identified"], bench["header"], bench["effects"],
                                 bench["sources"], bench["intervals"], structure=bench["structure"]))
        for w in bench["warnings"]:
            say(f"warning: {w}")
        what = ", ".join(e.key for e in bench["effects"]) or "no effect"
        refitted = any(src.startswith("refitted") for src in bench["sources"].values())
        say(f"wrote {path} ({what}; known values {'with refits' if refitted else 'as given'})")
        return
    doc, known, freed, estimates = read_result(result)
    check = doc["model_check"]
    missing = [k for k in ESTIMATED if estimates.get(k) is None]
    header = [f"identified by trms-ident {doc.get('versions', {}).get('trms-ident', '?')} from "
              f"{doc.get('input', {}).get('path')} (sha256 {doc.get('input', {}).get('sha256')})",
              f"headline estimate: {doc.get('headline')}; model fits the log: {check['adequate']}",
              f"thrust law: {doc.get('settings', {}).get('thrust_law')}"]
    if missing:
        header.append(f"not identifiable from that log, left out: {', '.join(missing)}")
    if freed:
        from .model.bench import shown

        header.append(f"estimated with --free: {', '.join(map(shown, freed))}")
    from .model.bench import BenchEffectError, parse_effect
    from .model.structure import parse_structure

    # the model the estimate was made under goes with the values: its structure (Settings.structure, recorded
    # verbatim) and its effects (result.json's model: a freed one at its estimate, with its interval)
    structure = parse_structure(doc.get("settings", {}).get("structure") or {})
    effects = []
    for k, e in ((doc.get("model") or {}).get("effects") or {}).items():
        try:
            spec = {e["parameter"]: e["value"], **({"from": e["from"]} if e.get("from") else {}),
                    **({"ci95": list(e["ci95"])} if e.get("ci95") else {})}
            effects.append(parse_effect(k, spec))
        except BenchEffectError as exc:  # a freed value estimated outside the effect's plausible range
            say(f"warning: {exc}; left out of {output or result.with_name('model.toml')}")
    path = output or result.with_name("model.toml")
    write_text(path, to_toml(known, estimates, header, tuple(effects), structure=structure))
    if check["adequate"] is False:
        say("warning: the model did NOT fit that log; these values are those of a model that does not fit")
    elif check["adequate"] is None:
        why = check.get("undecided_because") or "see its model_check"
        say(f"warning: whether the model fits that log was not decided ({why})")
    say(f"wrote {path}" + (f" (without {', '.join(missing)}: not identifiable)" if missing else ""))


def run() -> None:
    """The console script: the command, then the process ends without the interpreter's teardown (modules, numba,
    the log's arrays freed one by one: 0.1 s of an hour's estimate, measured, for memory the system takes back at
    once).  Every output file is written and closed by then; standard output and error are flushed here, and a
    closed pipe exits as the commands' own handler does (EXIT_PIPE_CLOSED)."""
    from ._memory import map_large_blocks

    map_large_blocks()  # the command's own process: long logs' columns mapped, returned when freed (_memory.py)
    try:
        app()
        code = 0
    except SystemExit as done:
        code = done.code
    if code is None:
        code = 0
    elif not isinstance(code, int):  # SystemExit("message"): Python prints it and exits 1
        print(code, file=sys.stderr)
        code = 1
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except BrokenPipeError:
        code = EXIT_PIPE_CLOSED
    os._exit(code)
