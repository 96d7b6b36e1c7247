"""The library face: estimate, diagnose and simulate from Python (notebooks, scripts).

    import trms_ident as ti
    est = ti.estimate("log.csv")                 # or a pandas DataFrame with t, u1, u2, alpha, beta
    est.adequate, est.estimates, est.ci95        # does the model fit? J1, B1, J2, B2 with 95 % intervals
    est.traces                                   # DataFrame: t [s], J1, B1, J2, B2 (DREM traces, eq. 8)
    est.save("out/"); est.plot(); est.to_json()
    ti.diagnose("log.csv").verdict               # consistent | explained | partly_explained | unexplained
    log = ti.simulate(ref="square", noise=1e-3)  # a synthetic log with its ground truth

The command line calls the same functions (commands.py: estimate_with, Estimate.save); nothing here prints.
"""
from __future__ import annotations

import hashlib
import math
import threading
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .log import Log, validated
from .settings import Settings

#: estimate()'s options that are settings (the rest select how the file is read)
_SETTINGS = {f.name for f in fields(Settings)}
_READ = ("angle_unit", "time_unit", "signals", "time_source", "voltage_time", "rate_hz")


def _as_log(data, read: dict) -> Log:
    """A Log from a path, a DataFrame (columns t [s], u1, u2 [V], alpha, beta [rad], optional t_u) or a Log.
    ``read``: the reader's options (a path), angle_unit and time_unit (a DataFrame), nothing (a Log): any other
    keyword is refused, never ignored (``overrides=`` meant for ``params=`` once went unnoticed)."""
    if not isinstance(data, (str, Path)):
        unknown = sorted(set(read) - ({"angle_unit", "time_unit"} if not isinstance(data, Log) else set()))
        if unknown:
            raise TypeError(f"unexpected keyword argument(s) {', '.join(unknown)} for a "
                            f"{'Log' if isinstance(data, Log) else 'DataFrame'} (the values given go in params=)")
    if isinstance(data, Log):
        return data
    if isinstance(data, (str, Path)):
        from .io.readers import read_log

        return read_log(data, **read)
    try:
        cols = {str(c).strip().lower(): c for c in data.columns}
    except AttributeError:
        raise TypeError(f"expected a log file path, a pandas DataFrame or a Log, got {type(data).__name__}") from None
    from .errors import LogFormatError
    from .log import COLUMNS

    missing = [c for c in COLUMNS if c not in cols]
    if missing:
        raise LogFormatError(f"<DataFrame>: missing column(s) {', '.join(missing)}; expected {', '.join(COLUMNS)}")
    arrays = [np.asarray(data[cols[c]], dtype=float) for c in COLUMNS]
    digest = hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)).hexdigest()
    t_u = np.asarray(data[cols["t_u"]], dtype=float) if "t_u" in cols else None
    if read.get("angle_unit") == "deg":
        arrays[3], arrays[4] = np.radians(arrays[3]), np.radians(arrays[4])
    return validated(*arrays, source="<DataFrame>", sha256=digest, meta={"format": "dataframe"},
                     angle_unit=read.get("angle_unit", "auto"), time_unit=read.get("time_unit", "auto"),
                     u_switch_s=None if t_u is None else np.repeat(t_u[:, None], 2, axis=1))


@dataclass
class Estimate:
    """The result of :func:`estimate`: numbers with units, the adequacy verdict, traces, and the outputs."""

    log: Log
    result: Any  # identify.Result
    doc: dict  # the result.json contract (report/summary.py)

    @property
    def adequate(self) -> bool | None:
        """Does the model fit the log to its noise level?  (``model_check``; read before any number.)  None: not
        decided, the output-error fit did not converge and could still reach the noise level."""
        return self.doc["model_check"]["adequate"]

    @property
    def model_check(self) -> dict:
        return self.doc["model_check"]

    @property
    def estimates(self) -> dict:
        """J1, J2 [kg m^2], B1, B2 [N m s/rad]; None where the log does not determine one."""
        return dict(self.doc["estimates"])

    @property
    def ci95(self) -> dict:
        """95 % intervals, name -> [low, high] (conditional on the model when it does not fit)."""
        return dict(self.doc["ci95"])

    @property
    def traces(self):
        """DataFrame of the DREM estimate traces (eq. 8): t [s], J1, B1, J2, B2."""
        import pandas as pd

        r = self.result
        return pd.DataFrame({"t": r.t_s, **{k: r.traces[k] for k in ("J1", "B1", "J2", "B2")}})

    def to_json(self) -> str:
        from .report.summary import to_json

        return to_json(self.doc)

    def save(self, out_dir: str | Path, html: bool = True, on_stage: Callable[[str], None] | None = None
             ) -> list[Path]:
        """Write result.json, traces.csv and report.html (atomically) into out_dir; returns their paths."""
        from .io.atomic import write_text
        from .report.summary import to_json
        from .report.traces import write_traces

        out = Path(out_dir)
        write_text(out / "result.json", to_json(self.doc))
        write_traces(out / "traces.csv", self.result)
        written = [out / "result.json", out / "traces.csv"]
        if html:
            from .report.html import render

            if on_stage:
                on_stage("drawing the report")
            write_text(out / "report.html", render(self.doc, self.result, self.log))
            written.append(out / "report.html")
        return written

    def plot(self):
        """Measured against simulated angles with the fit in % (as ``compare``); a matplotlib Figure."""
        from .report.figures import compare_plot

        return compare_plot(self.log, self.result.simulated, self.model_check)

    def __repr__(self) -> str:
        head = {True: "model fits", False: "MODEL DOES NOT FIT", None: "fit not decided"}[self.adequate]
        est = ", ".join(f"{k}={v:.6g}" if v is not None else f"{k}=n.i." for k, v in self.estimates.items())
        return f"<Estimate {self.log.source}: {head}; {est}>"


def estimate(log, *, params: dict | str | Path | None = None, truth: dict | None = None, **options) -> Estimate:
    """Estimate J1, B1, J2, B2 of a TRMS log with DREM (eqs. 3-8) and the output-error refinement.

    ``log``: a CSV, MCAP or MATLAB .mat path, a pandas DataFrame (t [s], u1, u2 [V], alpha, beta [rad]) or a Log.
    ``params``: known values (dict, or a TOML file) replacing Table 1's.  ``truth``: J/B ground truth for the
    error columns (simulated logs).  Other options: the Settings fields (``refine``, ``headline``, ``free``,
    ``thrust_law``, ``filter_a_rad_s``, ...) and the reader's (``angle_unit``, ``time_unit``, ``signals``,
    ``time_source``, ``voltage_time``).  Same numbers as ``trms-ident estimate`` with the same options."""
    settings, read = _settings_and_read(params, options)
    return estimate_with(log, settings, truth=truth, **read)


def _settings_and_read(params: dict | str | Path | None, options: dict) -> tuple[Settings, dict]:
    """The library's keyword options split into validated Settings (known values from ``params``, a dict or a
    TOML file whose declared input unit is kept) and the reader's options; an unknown option is refused."""
    from .errors import SettingsError
    from .params import bench_settings

    options = dict(options)
    unknown = set(options) - _SETTINGS - set(_READ)
    if unknown:
        raise SettingsError(f"unknown option(s) {', '.join(sorted(unknown))}; expected settings "
                            f"{', '.join(sorted(_SETTINGS - {'overrides'}))} or {', '.join(_READ)}")
    read = {k: options.pop(k) for k in _READ if k in options}
    if isinstance(params, (str, Path)):
        bench = bench_settings(params)
        params = bench.pop("overrides")
        for k, v in bench.items():
            if v:
                options.setdefault(k, v)
    settings = Settings(overrides=dict(params or {}), **{k: (tuple(v) if k == "free" else v)
                                                          for k, v in options.items()})
    settings.validate()
    return settings, read


#: CSV logs up to this size are likely to be refined under refine="auto" (about 50 bytes a row and
#: REFINE_AUTO_MAX_STEPS rows at 1 kHz), so the refinement's kernel is loaded while the log is read
REFINE_WARM_UP_BYTES = 50_000_000


def _load_numerics() -> None:
    """Import the compiled core and load its kernels from numba's cache (numba start-up ~0.6 s)."""
    from .numerics.fused import warm_up

    warm_up()


def _load_refinement() -> None:
    """Load the refinement's compiled kernels from numba's cache (~0.2 s)."""
    from .numerics.refine import warm_up

    warm_up()


def estimate_with(log, settings: Settings, *, truth: dict | None = None, truth_source: str | None = None,
                  on_stage: Callable[[str], None] | None = None, **read) -> Estimate:
    """:func:`estimate` with ready (validated) Settings: the one path of the library and the command line.

    ``truth_source``: where the truth came from (the report names it); ``on_stage(name)`` is told "reading"
    and "identifying" as they begin.  When ``log`` is a file, the identification's modules (numba, scipy.special:
    a quarter of a second) and its compiled kernels load in a thread while it is read (they need the GIL little:
    the read is pyarrow's, the kernels come from numba's cache); the read itself imports none of them."""
    stage = on_stage or (lambda _: None)
    refinement = isinstance(log, (str, Path)) and (settings.refine == "on" or (
        settings.refine == "auto" and _size(log) <= REFINE_WARM_UP_BYTES))

    def load() -> None:  # one thread, one kernel after the other, joined before identify: numba loading or
        _load_numerics()  # compiling in two threads at once aborted the process (LLVM) in this project's tests
        if refinement:
            _load_refinement()
        from . import model_profile  # noqa: F401  (identify and its imports, before the main thread needs them)
        from .report import summary  # noqa: F401

    warm = threading.Thread(target=load, daemon=True)
    warm.start()
    stage("reading")
    data = with_inputs_unit(_as_log(log, read), settings.inputs_unit)
    warm.join()
    from .model_profile import identify_with_profiles
    from .report.summary import summarize

    stage("identifying")
    result = identify_with_profiles(data, settings)  # identify, and --free input modifications by their profiles
    return Estimate(data, result, summarize(result, data, truth, truth_source or ("given" if truth else None)))


def with_inputs_unit(log: Log, unit: str | None) -> Log:
    """``log`` with the inputs' unit a parameter file declares said in its units (params.declared_inputs)."""
    import dataclasses

    from .params import declared_inputs

    units = log.meta.get("units", {})
    said = declared_inputs(units, unit)
    return log if said is units else dataclasses.replace(log, meta={**log.meta, "units": said})


def _size(path: str | Path) -> int:
    try:
        return Path(path).stat().st_size
    except OSError:  # read_log reports a missing file with its own message
        return 0


def diagnose(log, *, params: dict | str | Path | None = None, thrust_law: str = "quadratic",
             filter_a_rad_s: float | None = None, progress: Callable[[str, float], None] | None = None, seed=None,
             **read):
    """Where the model and the log disagree: the verdict, the findings with their physics, the fit before and
    after.  Returns diagnosis.run.Diagnosis (``.verdict``, ``.findings``, ``.fit_before``, ``.fit_after``).
    ``progress(stage, fraction done)`` is called as the search advances (the CLI draws its bar with it).
    ``seed``: the estimate of this log under Settings(thrust_law=thrust_law, overrides=params) when the caller has
    made it (identify's Result: diagnose's seed-model check is that estimate's, not made again)."""
    from .diagnosis.run import diagnose as run
    from .errors import SettingsError
    from .params import THRUST_LAWS, diagnose_bench, parameter_file_inputs_unit

    if thrust_law not in THRUST_LAWS:
        raise SettingsError(f"thrust law must be one of {tuple(THRUST_LAWS)}, got {thrust_law!r}")
    data = _as_log(log, read)
    if isinstance(params, (str, Path)):
        # the bench: its known values, its structure and its input modifications, taken as given (diagnose reads
        # them from the one dict: params.diagnose_bench)
        path, params = params, diagnose_bench(params)
        data = with_inputs_unit(data, parameter_file_inputs_unit(path))
    d = run(data, dict(params or {}), thrust_law, filter_a_rad_s, progress=progress, seed=seed)
    if progress is not None:
        progress("J/B under the findings' model", 0.99)
    return replace(d, with_findings=under_findings(data, d, dict(params or {}), thrust_law))


def under_findings(log, d, overrides: dict, thrust_law: str) -> dict | None:
    """The findings' model fitted once, as ``estimate --params --free ...`` would: the known-value findings among
    the known values and the effect findings in the model (model/bench.py), every finding's parameter that the
    refinement carries (known values, torque effects) estimated together with J/B, the input modifications held at
    their profiled values, J/B's intervals widened by what each one's 95 % interval moves them (as estimate under
    the exported file: model_profile.identify_with_profiles).  The findings' own values come from separate fits,
    each given the findings before it;
    this one fit is the model the bench file is (``export`` writes its values).  J/B with the same 95 % intervals,
    identifiability and adequacy verdict as estimate (identify), and ``values``: each freed parameter's estimate and
    95 % interval; None without findings."""
    from .errors import TrmsError
    from .identify import model_name
    from .model.bench import from_findings, is_torque
    from .model_profile import identify_with_profiles
    from .params import ESTIMATED
    from .diagnosis.model import settings_of
    from .report.summary import interval_text

    if not d.findings:
        return None
    refits, found, _ = from_findings(d.findings)
    free = tuple(refits) + tuple(e.key for e in found if is_torque(e.key))
    # the modifications held at their values, with their intervals: J/B's intervals carry them (as estimate's
    # under the exported file; measured: a second-order pitch motor's T2 held without its interval left J2 and
    # B1 7-8 half-widths off on diagnosed_model.py's seed 23)
    held = {e.key: tuple(e.ci95) for e in found if e.ci95 is not None and e.key not in free}
    settings = settings_of({**overrides, **refits}, thrust_law, effects={e.key: e.value for e in found}, free=free,
                           held_ci95=held)
    # the refinement starts from diagnose's own J/B with the findings and its motor start states: next to the
    # optimum (an hour at 1 kHz with a cable: three passes over the log instead of five from DREM's), the same
    # optimum (DREM's and the table's start follow when this one does not reach the noise level)
    start = {**{k: float(v) for k, v in (d.augmented or {}).items() if k in ESTIMATED},
             "start_states": d.settings.get("start_states_after"), "from": "diagnose's J/B with its findings"}
    try:
        with np.errstate(all="ignore"):  # as diagnose's own fits: a model far off the log overflows (no number)
            res = identify_with_profiles(log, settings, start=start)
    except (TrmsError, np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
        return {"model": model_name(settings), "estimates": None, "error": str(exc)}
    iv = {k: res.intervals[k] for k in ESTIMATED}  # J1, B1, J2, B2 (DREM's intervals come axis by axis)
    freed = res.refined.freed if res.refined is not None and res.headline == "refined" else {}
    values = {k: {"estimate": v["estimate"], "ci95": list(v["ci95"]), "given": v["table_or_file_value"]}
              for k, v in freed.items()}
    return {"model": model_name(settings), "headline": res.headline, "values": values,
            "estimates": {k: res.estimates[k] for k in iv},
            "ci95": {k: [iv[k].low, iv[k].high] if math.isfinite(iv[k].low) else None for k in iv},
            "identifiable": {k: iv[k].identifiable for k in iv}, "identifiability": {k: iv[k].reason for k in iv},
            "adequate": res.model_check["adequate"], "sentence": res.model_check["sentence"],
            "text": "  ".join(f"{k} {res.estimates[k]:.6g} {interval_text(iv[k].low, iv[k].high, res.estimates[k])}"
                              if res.estimates[k] is not None else f"{k} not identifiable" for k in iv)}


def simulate(ref: str = "square", **options):
    """The bundled closed-loop simulator (sim/): returns its SimResult (t_s, u1_v, u2_v, alpha_rad, beta_rad,
    true_state, truth, u_time_s).  Options: sim.SimSettings' fields (duration_s, sample_rate_hz, seed,
    noise_std_rad, quantization_rad, jitter, start_s, voltage_offset, overrides, effects, ...)."""
    from sim import SimSettings
    from sim import simulate as run

    from .errors import SettingsError

    r = run(SimSettings(ref=ref, **options))
    # the PID of eq. (9) is tuned for Table 1's bench: other parameters (a bundled bench's, a --params file's)
    # can leave it unstable, and a log whose pitch leaves the bench's range is no recording of anything
    bad = ~np.isfinite(r.alpha_rad) | (np.abs(r.alpha_rad) > PITCH_RANGE_RAD) | ~np.isfinite(r.beta_rad)
    if np.any(bad):
        k = int(np.argmax(bad))
        raise SettingsError(
            f"the simulated closed loop is unstable with these parameters: at t = {r.t_s[k]:.4g} s the pitch is "
            f"{r.alpha_rad[k]:.4g} rad (the bench's range is +/- {PITCH_RANGE_RAD:.3g} rad); the PID of eq. (9) is "
            "tuned for Table 1's bench: change --u-limit, the reference or the parameters")
    return r


#: the pitch a simulated log may reach [rad]: a TRMS arm swings less than +/- 90 deg (logs beyond it read as
#: degrees, io/csv_log.py)
PITCH_RANGE_RAD = math.pi / 2


def log_frame(sim_result):
    """A simulator result as the DataFrame estimate() takes (t, u1, u2, alpha, beta)."""
    import pandas as pd

    r = sim_result
    return pd.DataFrame({"t": r.t_s, "u1": r.u1_v, "u2": r.u2_v, "alpha": r.alpha_rad, "beta": r.beta_rad})


@dataclass
class JointEstimate:
    """One bench from several logs (:func:`estimate_joint`): the pooled J/B, each log's own, and whether they agree."""

    logs: list  # the Logs, in the order given
    result: object  # joint.JointResult
    doc: dict  # result.json's contract (report/joint.py)

    @property
    def estimates(self) -> dict:
        """Pooled J1, J2 [kg m^2], B1, B2 [N m s/rad]; None where the logs together do not determine one."""
        return dict(self.doc["joint"]["estimates"])

    @property
    def ci95(self) -> dict:
        return {k: tuple(v) for k, v in self.doc["joint"]["ci95"].items()}

    @property
    def consistent(self) -> bool | None:
        """Do the logs agree (one bench)?  None: fewer than two determine a common parameter."""
        return self.doc["joint"]["consistent"]

    @property
    def outliers(self) -> list[str]:
        return list(self.doc["joint"]["outliers"])

    def save(self, out_dir: str | Path, html: bool = True) -> list[Path]:
        """Write result.json and report.html (atomically) into out_dir; returns their paths."""
        from .io.atomic import write_text
        from .report.summary import to_json

        out = Path(out_dir)
        write_text(out / "result.json", to_json(self.doc))
        written = [out / "result.json"]
        if html:
            from .report.joint import render

            write_text(out / "report.html", render(self.doc, self.result, self.logs))
            written.append(out / "report.html")
        return written

    def __repr__(self) -> str:
        est = ", ".join(f"{k}={v:.6g}" if v is not None else f"{k}=n.i." for k, v in self.estimates.items())
        return f"<JointEstimate of {len(self.logs)} logs: consistent={self.consistent}; {est}>"


def estimate_joint(logs, *, params: dict | str | Path | None = None, names: list[str] | None = None,
                   **options) -> JointEstimate:
    """One set of J1, B1, J2, B2 fitted by output error over several logs of one bench, each log with its own start
    states, windows, noise floor and sample rate; each log's own estimate beside it and a test that they agree.

    ``logs``: paths (CSV, MCAP, .mat), DataFrames or Logs, or a manifest's path (a .csv whose header starts with
    ``path``: see io/manifest.py).  ``params``, ``options``: as :func:`estimate` (the reader's options apply to
    every path).  Same numbers as ``trms-ident estimate --joint`` with the same options."""
    from .io.manifest import Entry

    settings, read = _settings_and_read(params, options)
    if isinstance(logs, (str, Path)):  # a manifest
        from .io.manifest import read_manifest

        entries = read_manifest(logs)
    else:
        entries = [Entry(Path(x), read.get("signals"), read.get("rate_hz"), read.get("angle_unit", "auto"),
                         read.get("time_unit", "auto")) if isinstance(x, (str, Path)) else x for x in logs]
    return estimate_joint_with(entries, settings, names)


def estimate_joint_with(entries: list, settings: Settings, names: list[str] | None = None,
                        strict_gaps: bool = False) -> JointEstimate:
    """:func:`estimate_joint` with ready settings; ``entries``: io.manifest.Entry items, DataFrames or Logs.
    A file that breaks into parts (runs joined end to end, gaps in its stamps) gives each part as a log; parts
    shorter than the slowest time constant are left out and named (``doc["joint"]["split"]``);
    ``strict_gaps``: a gap is refused instead (LogFormatError)."""
    from .errors import JoinedRunsError, TrmsError
    from .io.manifest import Entry
    from .io.readers import read_log
    from .joint import identify_joint
    from .report.joint import joint_doc

    logs, labels, split = [], [], []
    for i, e in enumerate(entries):
        if isinstance(e, Entry):
            try:
                logs.append(read_log(e.path, angle_unit=e.angle_unit, signals=e.signals, time_unit=e.time_unit,
                                     rate_hz=e.rate_hz))
                labels.append(e.label)
            except JoinedRunsError as exc:  # runs joined end to end, or gaps: each part a log of the joint estimate
                if strict_gaps and exc.gaps:
                    raise
                kept, said = usable_parts(exc, settings)
                logs += kept
                labels += [f"{e.label} {' '.join(r.source.split(' ')[-2:])}" for r in kept]
                split.append(said)
            except TrmsError as exc:
                if e.where:  # a manifest's line
                    raise type(exc)(f"{e.where}: {exc}") from None
                raise
        else:
            logs.append(_as_log(e, {}))
            labels.append(logs[-1].source if logs[-1].source != "<memory>" else f"log {i + 1}")
    result = identify_joint(logs, settings, names or labels)
    doc = joint_doc(result, logs)
    if split:
        doc["joint"]["split"] = split
    return JointEstimate(logs, result, doc)


def usable_parts(exc, settings: Settings) -> tuple[list[Log], dict]:
    """The parts of a file that broke into parts (errors.JoinedRunsError) long enough to estimate from (at least
    the slowest time constant of the known values: identify's own rule), and what was done, for the result:
    {"file", "found", "gaps": [{"after_s", "length_s", "where"}], "parts", "left_out": [{"part", "from_s", "to_s",
    "why"}]}.  None long enough: LogFormatError naming the parts' lengths and the length needed."""
    from .errors import LogFormatError
    from .identify import slowest_time_constant_s
    from .params import merge

    need, name = slowest_time_constant_s(merge(settings.overrides, source="parameter overrides"))
    kept = [r for r in exc.runs if r.duration_s >= need]
    left = [{"part": r.source, "from_s": float(r.t_s[0]), "to_s": float(r.t_s[-1]),
             "why": f"{r.duration_s:.3g} s long, shorter than {name} ({need:.3g} s): too short to estimate from"}
            for r in exc.runs if r.duration_s < need]
    if not kept:
        raise LogFormatError(f"{exc.found}; each of its {len(exc.runs)} parts is shorter than {name} ({need:.3g} s; "
                             f"the longest is {max(r.duration_s for r in exc.runs):.3g} s): expected a part at least "
                             "that long to estimate from")
    return kept, {"file": exc.runs[0].source.rsplit(" ", 2)[0], "found": exc.found, "gaps": exc.gaps,
                  "parts": len(exc.runs), "left_out": left}
