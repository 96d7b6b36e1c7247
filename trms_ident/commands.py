"""What each command does, as plain functions: read, compute, write. The CLI adds flags and exit codes."""
from __future__ import annotations

import dataclasses
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


def read_result(result: Path) -> tuple[dict, dict, dict, dict]:
    """(the document, its known values with any --free estimates, those --free estimates, J/B estimates) of a
    result.json written by estimate; one-line errors naming the file."""
    import json

    from .errors import InputNotFoundError, LogFormatError

    try:
        doc = json.loads(result.read_text(encoding="utf-8"))
        known = {k: v["value"] for k, v in doc["parameters"].items()}
        freed = ((doc.get("refined") or {}).get("known_values_estimated") or {})
        known.update({k: v["estimate"] for k, v in freed.items() if k in known})  # an effect's: its [effects]
        estimates, _ = doc["estimates"], doc["model_check"]["adequate"]
    except FileNotFoundError:
        raise InputNotFoundError(f"{result}: no such file") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise LogFormatError(f"{result}: not a result.json of trms-ident estimate ({exc})") from None
    return doc, known, freed, estimates


def bench_from_diagnosis(path: Path) -> dict | None:
    """The bench file ``export`` writes from a diagnosis.json of diagnose, or None when the file is not one:
    {"known": the known values given with the known-value findings' refits, "sources": name -> where from,
    "intervals": name -> the 95 % interval of a known value refitted with the findings,
    "effects": the findings as model.bench.BenchEffect (and the terms of its corrections), "identified": J/B of the findings' model, "header",
    "warnings": what cannot go into the file or does not hold}.  One-line errors naming the file."""
    import json
    from dataclasses import replace

    from .errors import LogFormatError
    from .model import effects as room
    from .model.bench import BenchEffect, BenchEffectError, from_findings, parse_effect

    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError):
        return None
    if not (isinstance(doc, dict) and "findings" in doc and "verdict" in doc):
        return None
    try:
        given = doc["settings"]["known_values"]
        known = {k: float(v["value"]) for k, v in given.items()}
        sources = {k: "given to diagnose (--params)" for k, v in given.items() if v.get("source") == "override"}
        where = f"diagnose of {doc['input']['path']} (sha256 {str(doc['input']['sha256'])[:12]})"
        refits, effects, warnings = from_findings(doc["findings"], where)
        # the bench file's input modifications diagnose took as given (settings.given_effects): the model the
        # findings were found on top of, so theirs first
        effects = [BenchEffect(k, float(v), "given to diagnose (--params)")
                   for k, v in ((doc.get("settings") or {}).get("given_effects") or {}).items()] + list(effects)
        known.update(refits)
        sources.update({f["parameter"]["name"]: f"refitted by {where}; the table's {f['parameter'].get('table')}"
                        for f in doc["findings"] if f["effect"] == "known_value"})
        together = doc["estimates"].get("with_findings") or {}
        jb = together.get("estimates") or doc["estimates"]["augmented"]
        verdict = doc["verdict"]
        # the findings' parameters refitted together with J/B (estimates.with_findings.values): one fit, the model
        intervals = {}
        for name, v in (together.get("values") or {}).items():
            if name in known:
                known[name] = float(v["estimate"])
                intervals[name] = tuple(float(x) for x in v["ci95"])
                was = (given.get(name) or {}).get("value")  # (v["given"] is where that fit started: the refit)
                sources[name] = (f"refitted with J/B and the other findings by {where}; "
                                 + (f"the table's {was}" if given.get(name, {}).get("source") == "table" else
                                    f"given {was}"))
        effects = [replace(e, value=float(together["values"][e.key]["estimate"]),
                           ci95=tuple(float(x) for x in together["values"][e.key]["ci95"]))
                   if e.key in (together.get("values") or {}) else e for e in effects]
    except (KeyError, TypeError, AttributeError) as exc:
        raise LogFormatError(f"{path}: a diagnosis.json, but not one this version can export (missing {exc}); "
                             "run trms-ident diagnose again") from None
    carried = []
    for c in doc.get("corrections") or []:  # physics outside the library: its terms go into [terms]
        fit = c.get("output_error")  # its output-error refit with the findings (held_out.correction_fits)
        if fit and not fit["held_out"]["after"] > fit["held_out"]["before"]:
            warnings.append(f"outside the library: {c['sentence']}; left out (fitted by output error it simulates "
                            f"the {c['axis']} no better on samples it was not fitted on: "
                            f"{fit['held_out']['before']:.1f} % -> {fit['held_out']['after']:.1f} %)")
            continue
        for t in c.get("terms") or []:
            if not t.get("key"):  # a diagnosis.json written before terms had keys
                warnings.append(f"outside the library: {t['sentence']} (written before terms could be carried: run "
                                "diagnose again to have it in the file)")
                continue
            refit = (fit or {}).get("values", {}).get(t["key"])
            spec = ({"ci95": list(refit["ci95"]), "from": f"the correction of {where}, fitted by output error"}
                    if refit else {"from": f"the equation error's correction by {where}"})
            try:
                e = parse_effect(t["key"], {room.by_key(t["key"]).parameter: refit["estimate"] if refit else
                                            t["coefficient"], **spec})
            except (BenchEffectError, AttributeError) as exc:
                warnings.append(f"outside the library: {t['sentence']}; left out ({exc})")
                continue
            if e.key in {x.key for x in effects}:
                warnings.append(f"outside the library: {t['sentence']}; left out ({e.key} is a finding already)")
                continue
            effects.append(e)
            carried.append(e.phrase())
    if carried:
        warnings.append("outside the library, carried as diagnose's correction described it (the file's J/B are the "
                        "findings' model's without it; estimate --params refits them, --free on it its value): "
                        + "; ".join(carried))
    if together.get("adequate") is False and verdict in ("explained", "consistent"):
        warnings.append("the findings' model fitted as one (estimates.with_findings) does not fit the log: estimate "
                        "under this file will say so")
    if verdict not in ("explained", "consistent"):
        warnings.append(f"the diagnosis is {verdict.replace('_', ' ')}: the findings do not bring the model to the "
                        "noise level, so this model still misses something")
    header = [f"the bench as diagnosed by trms-ident {doc.get('versions', {}).get('trms-ident', '?')}: {where}",
              f"verdict: {verdict}; findings: " + (", ".join(
                  f"{f['effect']}:{f['axis']}" if f["effect"] != "known_value" else f["parameter"]["name"]
                  for f in doc["findings"]) or "none"),
              "estimate, simulate and design read it with --params; the J/B below are diagnose's (simulate takes "
              "them as the true values, estimate ignores them)"]
    identified = {k: v for k, v in (jb or {}).items() if isinstance(v, (int, float)) and v > 0}
    # the bench's structure diagnose searched under (its --params' [structure]; absent before 2026-12: eq. 1)
    structure = (doc.get("settings") or {}).get("structure") or {}
    return {"known": known, "sources": sources, "effects": tuple(effects), "identified": identified,
            "header": header, "warnings": warnings, "intervals": intervals, "structure": structure}


def read_diagnosis(path: Path) -> tuple[dict, object, tuple, dict, dict]:
    """What ``design --discriminate`` needs from a diagnosis.json of diagnose: (the document, its first finding as
    a design.Hypothesis, the rivals design can weigh (its flagged look-alikes), those it cannot -> why, the J/B
    the findings' model was refitted to).  One-line errors naming the file."""
    import json

    from . import design as planner
    from .errors import InputNotFoundError, LogFormatError, SettingsError
    from .params import ESTIMATED

    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        findings = doc["findings"]
        jb = {k: v for k, v in doc["estimates"]["augmented"].items()}
    except FileNotFoundError:
        raise InputNotFoundError(f"{path}: no such file") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise LogFormatError(f"{path}: not a diagnosis.json of trms-ident diagnose ({exc})") from None
    if not findings:
        raise SettingsError(f"{path}: diagnose found nothing ({doc.get('verdict')}): there is nothing to tell apart")
    f = findings[0]
    try:
        first = f"known_value:{f['parameter']['name']}" if f["effect"] == "known_value" else f"{f['effect']}:{f['axis']}"
        truth = planner.Hypothesis(planner.hypothesis_key(first), float(f["parameter"]["value"]))
    except (KeyError, TypeError) as exc:
        raise LogFormatError(f"{path}: its first finding is not one of diagnose's ({exc})") from None
    except ValueError as exc:
        raise SettingsError(f"{path}: its first finding, {exc}") from None
    rivals, skipped = [], {}
    for alt in f.get("alternatives") or []:
        try:
            key = planner.hypothesis_key(str(alt))
        except ValueError as exc:
            skipped[str(alt)] = str(exc)
            continue
        if key != truth.key and key not in rivals:
            rivals.append(key)
    if not rivals:
        raise SettingsError(f"{path}: its first finding ({first}) has no look-alike design can weigh"
                            + (f" ({'; '.join(skipped.values())})" if skipped else
                               ": diagnose told it apart from its rivals already"))
    bad = [k for k in ESTIMATED if not (isinstance(jb.get(k), (int, float)) and jb[k] > 0)]
    if bad:
        raise SettingsError(f"{path}: the findings' model has no physical {', '.join(bad)}; give the bench with "
                            "--params (J/B too) and design for precision first")
    return doc, truth, tuple(rivals), skipped, {k: float(jb[k]) for k in ESTIMATED}


@dataclass
class DesignOutput:
    design: object  # design.Design
    doc: dict  # its JSON (report.design.design_doc)
    written: list[Path]
    page: Path | None


def design_files(duration_s: float, rate_hz: float, limits, output: Path, *, noise_std: float | None = None,
                 encoder_bits: int | None = None, params: str | Path | None = None,
                 from_result: Path | None = None, controller: Path | None = None, objective: str = "worst",
                 effect: tuple[str, float] | None = None, thrust_law: str = "quadratic", html: bool = True,
                 progress: Callable[[float], None] | None = None, discriminate: Path | None = None) -> DesignOutput:
    """Plan the next experiment (design.design) for the bench in ``params`` (a parameter file or a bundled bench)
    or ``from_result`` (an estimate's result.json: its known values, J/B and measured noise floors), under the PID
    of ``controller`` (a TOML [controller] table; default the simulator's), and write the references to
    ``output`` (.csv or .mat) and, with ``html``, the page beside them (<output>.html).  The noise is
    ``noise_std`` [rad], else 2 pi / 2^encoder_bits / sqrt(12) (12 bits by default), else from_result's floors.
    Errors: InputNotFoundError, ParameterFileError (the controller file), LogFormatError (the result file),
    SettingsError (no reference keeps the limits; a result whose floors were not measured).
    ``discriminate``: a diagnosis.json; design to tell its first finding from its look-alikes (read_diagnosis):
    the bench is ``params`` (the table diagnose was given) with the findings' J/B and the finding in, the noise
    the floors diagnose measured unless ``noise_std`` or ``encoder_bits`` is given.  The bench's model is the
    parameter file's [effects] (a bench file export wrote) or the result's "model" (the effects it was estimated
    under): the candidates are simulated on it, their information is that estimate --params would have under it."""
    import hashlib
    import math
    import tomllib

    from sim.simulate import DEFAULT_PID

    from . import design as planner
    from .errors import InputNotFoundError, LogFormatError, ParameterFileError, SettingsError
    from .io.atomic import write_text
    from .io.reference import write_reference
    from .model.bench import BenchEffect, describe, is_term
    from .params import ESTIMATED, load_parameter_file, merge, parameter_file_effects, refuse_structure
    from .report.design import design_doc, render

    if discriminate is not None and from_result is not None:
        raise SettingsError("--discriminate and --from: the bench comes from the diagnosis (with --params for "
                            "the table diagnose was given)")
    pid, u_limit = dict(DEFAULT_PID), 2.5
    if controller is not None:
        if not Path(controller).is_file():
            raise InputNotFoundError(f"{controller}: no such file")
        try:
            pid, u_limit = planner.controller_from(tomllib.loads(Path(controller).read_text(encoding="utf-8")),
                                                   str(controller))
        except tomllib.TOMLDecodeError as exc:
            raise ParameterFileError(f"{controller}: not TOML ({exc})") from None
        except ValueError as exc:
            raise ParameterFileError(str(exc)) from None
    quantum = 2 * math.pi / 2 ** (encoder_bits or 12)  # the encoders' [rad], unless the noise is given otherwise
    sd = noise_std if noise_std is not None else quantum / math.sqrt(12.0)
    noise = {"alpha": sd, "beta": sd}
    if from_result is not None:  # the bench as estimate found it: known values, J/B, the noise it measured
        doc_in, known, _, estimates = read_result(Path(from_result))
        if (doc_in.get("settings") or {}).get("structure"):  # as refuse_structure does for a bench file
            raise SettingsError(f"--from {from_result}: estimated under a bench's [structure] "
                                f"({(doc_in.get('model') or {}).get('equation', '')}), which design does not model yet")
        missing = [k for k in ESTIMATED if estimates.get(k) is None]
        if missing:
            raise LogFormatError(f"{from_result}: {', '.join(missing)} not identified there; give the bench with "
                                 "--params")
        overrides = {**known, **{k: float(estimates[k]) for k in ESTIMATED}}
        bench = {k: float(v["value"]) for k, v in ((doc_in.get("model") or {}).get("effects") or {}).items()}
        if noise_std is None and encoder_bits is None:
            axes = doc_in["model_check"].get("axes") or {}
            floors = {a["angle"]: a.get("noise_floor_rad") for a in axes.values()
                      if a.get("noise_floor_measured") and a.get("noise_floor_rad")}
            if set(floors) != {"alpha", "beta"}:
                raise SettingsError(f"--from {from_result}: that log's noise floor was not measured on both angles; "
                                    "give --encoder-bits or --noise-std")
            noise, sd = {k: float(v) for k, v in floors.items()}, None
    else:
        refuse_structure(params, "design")
        overrides = load_parameter_file(params, allow_estimated=True) if params else {}
        bench = {e.key: e.value for e in parameter_file_effects(params)} if params else {}
    terms = [k for k in bench if is_term(k)]
    if terms:  # design's information runs through the kernel's effect slots, which hold no term (model/terms.py)
        raise SettingsError(f"{from_result or params}: the bench has terms outside the effect library "
                            f"({', '.join(BenchEffect(k, bench[k]).phrase() for k in terms)}), which design does not "
                            "model yet; design for the bench without them (a copy of the file without [terms])")
    told = None
    if discriminate is not None:
        ddoc, truth, rivals, skipped, jb = read_diagnosis(Path(discriminate))
        structure = (ddoc.get("settings") or {}).get("structure")
        if structure:  # as refuse_structure does for a bench file: design plans under eq. (1) alone
            from .model.structure import phrases

            raise SettingsError(f"--discriminate {discriminate}: diagnosed under a bench's [structure] "
                                f"({'; '.join(phrases(structure))}), which design does not model yet")
        given = (ddoc.get("settings") or {}).get("given_effects")
        if given:  # its findings hold on top of those: design's rivals would be weighed without them
            raise SettingsError(f"--discriminate {discriminate}: diagnosed on top of the bench file's effects "
                                f"({', '.join(given)}), which design --discriminate does not take yet; diagnose "
                                "with a bench file without [effects] to plan a run that tells its look-alikes apart")
        overrides = {**overrides, **jb}
        floors = (ddoc.get("settings") or {}).get("floors") or {}
        if noise_std is None and encoder_bits is None:
            if not all((floors.get(a) or {}).get("used") == "noise" for a in ("pitch", "yaw")):
                raise SettingsError(f"--discriminate {discriminate}: that log's noise floor was not measured on both "
                                    "angles; give --encoder-bits or --noise-std")
            noise, sd = {"alpha": float(floors["pitch"]["rad"]), "beta": float(floors["yaw"]["rad"])}, None
        told = (truth, rivals)
    p = merge(overrides, source="parameter overrides")
    bits = None if noise_std is not None or sd is None else (encoder_bits or 12)  # None: the noise is not rounding
    try:
        d = planner.design(duration_s, rate_hz, p, thrust_law, noise, pid, u_limit, limits, objective,
                           progress=progress, effect=effect, discriminate=told, quantum_rad=quantum if bits else 0.0,
                           bench=bench)
    except ValueError as exc:
        raise SettingsError(str(exc)) from None
    r = d.run
    write_reference(output, r.t_s, r.alpha_ref_rad, r.beta_ref_rad)
    inputs = [f for f in (params, from_result, controller, discriminate) if f and Path(f).is_file()]
    doc = design_doc(d, p, dict(
        duration_s=duration_s, rate_hz=rate_hz, noise_std_rad=noise,
        encoder_bits=bits,
        params=str(params) if params else None, from_result=str(from_result) if from_result else None,
        controller=str(controller) if controller else None, pid=pid, u_limit_v=u_limit,
        limits=dataclasses.asdict(limits), objective=objective, thrust_law=thrust_law, output=str(output),
        effect=None if effect is None else effect[0], size=None if effect is None else effect[1],
        discriminate=str(discriminate) if discriminate else None,
        model={"equation": describe(tuple(BenchEffect(k, v) for k, v in bench.items())), "effects": bench},
        not_weighed=skipped if discriminate is not None else None,
        sha256={str(f): hashlib.sha256(Path(f).read_bytes()).hexdigest() for f in inputs}))
    written, page = [Path(output)], None
    if html:
        page = Path(output).with_suffix(".html")
        write_text(page, render(doc, d, limits, u_limit))
        written.append(page)
    return DesignOutput(d, doc, written, page)
