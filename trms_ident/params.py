"""The one parameter table of the TRMS model (paper eq. 1, Table 1).

Every default value, unit and meaning used by the estimator, the simulator, the
CLI help and the reports comes from :data:`PARAMETERS`.  Known values can be
overridden from a TOML file (:func:`load_parameter_file`).
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from .errors import ParameterFileError


@dataclass(frozen=True)
class Parameter:
    name: str
    value: float
    unit: str
    meaning: str
    role: str  # "estimated" (J, B) or "known"


PARAMETERS: tuple[Parameter, ...] = (
    Parameter("J1", 0.068, "kg m^2", "pitch moment of inertia", "estimated"),
    Parameter("B1", 0.006, "N m s/rad", "pitch viscous friction", "estimated"),
    Parameter("J2", 0.02, "kg m^2", "yaw moment of inertia", "estimated"),
    Parameter("B2", 0.1, "N m s/rad", "yaw viscous friction", "estimated"),
    Parameter("a1", 0.0135, "N m", "main rotor thrust, quadratic coefficient", "known"),
    Parameter("b1", 0.0924, "N m", "main rotor thrust, linear coefficient", "known"),
    Parameter("a2", 0.02, "N m", "tail rotor thrust, quadratic coefficient", "known"),
    Parameter("b2", 0.09, "N m", "tail rotor thrust, linear coefficient", "known"),
    Parameter("Mg", 0.32, "N m", "gravity moment", "known"),
    Parameter("Kg", 0.05, "s/rad", "gyroscopic coefficient", "known"),
    Parameter("k1", 1.1, "1/V", "main motor gain", "known"),
    Parameter("k2", 0.8, "1/V", "tail motor gain", "known"),
    Parameter("T11", 1.1, "s", "main motor time constant (s coefficient)", "known"),
    Parameter("T10", 1.0, "-", "main motor denominator constant", "known"),
    Parameter("T21", 1.0, "s", "tail motor time constant (s coefficient)", "known"),
    Parameter("T20", 1.0, "-", "tail motor denominator constant", "known"),
    Parameter("kc", -0.2, "N m", "main rotor reaction moment gain on yaw", "known"),
    Parameter("T0", 3.5, "s", "reaction moment lead time constant", "known"),
    Parameter("Tp", 2.0, "s", "reaction moment lag time constant", "known"),
)

ESTIMATED = tuple(p.name for p in PARAMETERS if p.role == "estimated")
KNOWN = tuple(p.name for p in PARAMETERS if p.role == "known")
BY_NAME: dict[str, Parameter] = {p.name: p for p in PARAMETERS}
UNITS: dict[str, str] = {p.name: p.unit for p in PARAMETERS}

THRUST_LAWS = {
    "quadratic": "M = a tau^2 + b tau (paper eq. 1, the seed model)",
    "signed": "M = a tau|tau| + b tau (sign-symmetric variant)",
}


def unit_of(name: str) -> str:
    """The unit of a parameter of the table or of an effect's parameter (its key, "cable_stiffness:yaw")."""
    if name in UNITS:
        return UNITS[name]
    from .model.effects import BY_KEY, by_key

    c = BY_KEY.get(name) or by_key(name)  # the library as imported, or a term (model/terms.py)
    return "" if c is None else c.unit


def defaults() -> dict[str, float]:
    """All parameter values of the table, by name."""
    return {p.name: p.value for p in PARAMETERS}


#: how far from Table 1 an estimated J or B may sit before it is called implausible: the laboratory twin-rotor
#: benches we know of sit within 15x of it (Feedback 33-949S / 33-007 and the paper's: Table 1; Rotondo et al.'s
#: model: about 0.03 kg m^2; the Humusoft CE150's published identification: I = 0.00437, I_phi = 0.00414 kg m^2,
#: B 0.0018-0.0087), so 100x leaves a wide margin; friction coefficients may be arbitrarily small, so B has only
#: the upper bound.  A real CE150 azimuth sweep estimated J2 = 6.5 kg m^2 and B1 = 41 N m s/rad
PLAUSIBLE_FACTOR = 1e2


def implausible(name: str, value: float) -> str | None:
    """Why an estimated J or B (``name`` in ESTIMATED) is not credible as a bench's value, or None.

    Not finite or not positive: "not physical".  A J outside [1/PLAUSIBLE_FACTOR, PLAUSIBLE_FACTOR] times its
    Table 1 value, or a B above PLAUSIBLE_FACTOR times it: "implausible" (the least squares of a model far
    from the log returns such values; seen on the real CE150 recordings, J1 = 1.3e15 kg m^2)."""
    if not (math.isfinite(value) and value > 0):
        return "not physical"
    ratio = value / BY_NAME[name].value
    if ratio > PLAUSIBLE_FACTOR or (name.startswith("J") and ratio < 1.0 / PLAUSIBLE_FACTOR):
        return f"implausible: {ratio:.3g}x Table 1's {BY_NAME[name].value:g} {BY_NAME[name].unit}"
    return None


def not_credible(estimates: dict) -> dict[str, str]:
    """J/B name -> why it is not credible (:func:`implausible`), for the estimates given (None: not estimated)."""
    return {k: why for k in ESTIMATED if estimates.get(k) is not None and (why := implausible(k, estimates[k]))}


def marked(name: str, value: float) -> str:
    """An estimated J or B as text, followed by why it is not credible when it is not (:func:`implausible`)."""
    why = implausible(name, value)
    return f"{value:.6g}" + (f" ({why})" if why else "")


def merge(overrides: Mapping[str, float] | None, *, source: str = "overrides") -> dict[str, float]:
    """Table defaults updated by ``overrides``; unknown names or bad values raise.  A bench's structure and its
    given input modifications in ``overrides`` (model.structure.BENCH_KEY, model.bench.GIVEN_KEY: diagnose's bench
    dict) are carried over, checked."""
    from .model.bench import GIVEN_KEY, BenchEffectError, check_given
    from .model.structure import BENCH_KEY, StructureError, parse_structure

    values = defaults()
    for name, value in (overrides or {}).items():
        if name in (BENCH_KEY, GIVEN_KEY):
            try:
                values[name] = parse_structure(value) if name == BENCH_KEY else check_given(value)
            except (StructureError, BenchEffectError) as exc:
                raise ParameterFileError(f"{source}: {exc}") from None
            continue
        if name not in BY_NAME:
            raise ParameterFileError(
                f"{source}: unknown parameter {name!r}; expected one of {', '.join(BY_NAME)}"
            )
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ParameterFileError(f"{source}: parameter {name} must be a finite number, got {value!r}")
        values[name] = float(value)
    for name in ("J1", "J2", "T11", "T10", "T21", "T20", "Tp", "Mg"):
        if values[name] <= 0:
            raise ParameterFileError(f"{source}: parameter {name} must be > 0, got {values[name]}")
    return values


def to_toml(known: dict[str, float], identified: dict[str, float], header: list[str], effects: tuple = (),
            sources: dict | None = None, intervals: dict | None = None, structure: dict | None = None) -> str:
    """A parameter file: comment lines, [parameters] (known values, each with where it came from when
    ``sources`` says, and as ``{ value = ..., ci95 = [low, high] }`` when ``intervals`` holds its 95 % interval:
    an estimated value), [structure] (model/structure.py's canonical dict), [effects] (model.bench.BenchEffect
    each) and [identified] (J/B), with units."""
    from .model.bench import to_toml_lines
    from .model.structure import to_toml_lines as structure_lines

    sources, intervals = sources or {}, intervals or {}

    def entry(k, v):
        if k not in intervals:
            return f"{float(v)!r}"
        lo, hi = intervals[k]
        return f"{{ value = {float(v)!r}, ci95 = [{float(lo)!r}, {float(hi)!r}] }}"

    lines = [f"# {h}" for h in header] + ["", "[parameters]"]
    lines += [f"{k} = {entry(k, v)}  # {UNITS[k]}" + (f"; {sources[k]}" if k in sources else "")
              for k, v in known.items()]
    lines += structure_lines(structure)
    lines += to_toml_lines(tuple(effects))
    lines += ["", "# estimated; `simulate --params` uses them as the true values, `estimate --params` ignores them",
              "[identified]"]
    lines += [f"{k} = {float(v)!r}  # {UNITS[k]}" for k, v in identified.items() if v is not None]
    return "\n".join(lines) + "\n"


#: parameter files of benches other than Table 1's, shipped with the package: ``--params NAME``
BENCHES = Path(__file__).with_name("benches")


def bench_names() -> list[str]:
    """The bundled benches' names (``--params NAME``)."""
    return sorted(p.stem for p in BENCHES.glob("*.toml"))


def resolve_parameter_file(path: str | Path) -> Path:
    """``path`` itself when it exists or names a file; a bundled bench's file when it is a bare name of one."""
    p = Path(path)
    if not p.exists() and p.parent == Path(".") and not p.suffix and (BENCHES / f"{p.name}.toml").exists():
        return BENCHES / f"{p.name}.toml"
    return p


def parameter_file_inputs_unit(path: str | Path) -> str | None:
    """The input unit a parameter file's known values take (``[units] inputs = "..."``), or None when it does not
    say (then eq. (1)'s volts).  Read after :func:`load_parameter_file` has checked the file."""
    units = tomllib.loads(resolve_parameter_file(path).read_text(encoding="utf-8")).get("units", {})
    unit = units.get("inputs") if isinstance(units, dict) else None
    return unit if isinstance(unit, str) and unit.strip() else None


def declared_inputs(meta_units: dict, unit: str | None) -> dict:
    """A log's units (Log.meta["units"]) with the inputs' unit a parameter file declares (``unit``) in place of
    the assumed volts; unchanged when the file does not say or the log itself says its unit."""
    from .log import INPUTS_ASSUMED

    if not unit or meta_units.get("inputs", INPUTS_ASSUMED) != INPUTS_ASSUMED:
        return meta_units
    return {**meta_units, "inputs": f"{unit} (the unit the known values of --params take; the log does not say)"}


def load_parameter_file(path: str | Path, allow_estimated: bool = False) -> dict[str, float]:
    """Read parameter overrides from TOML: top-level ``name = value`` or a ``[parameters]`` table; ``path`` may
    be a bundled bench's name (:func:`bench_names`, e.g. ``humusoft_ce150``).

    J1, B1, J2, B2 are refused unless ``allow_estimated`` (the simulator's true values): for estimate and
    diagnose they are the unknowns, and a value given for them would silently mean nothing.  An
    ``[identified]`` table (written by ``export``) holds J/B: read with ``allow_estimated``, ignored otherwise."""
    path = resolve_parameter_file(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ParameterFileError(f"{path}: parameter file not found; expected a TOML file or a bundled bench: "
                                 f"{', '.join(bench_names())}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ParameterFileError(f"{path}: not valid TOML ({exc})") from None
    table = raw.get("parameters", raw)
    if not isinstance(table, dict):
        raise ParameterFileError(f"{path}: [parameters] must be a table of name = value")
    overrides = {k: v for k, v in table.items()
                 if k not in ("parameters", "identified", "units", "effects", "structure", "terms")}
    overrides = {k: _value_of(path, k, v) for k, v in overrides.items()}
    identified = raw.get("identified", {})  # an exported model's J/B: true values for the simulator only
    if allow_estimated and isinstance(identified, dict):
        overrides.update({k: v for k, v in identified.items() if k in ESTIMATED})
    given = [k for k in ESTIMATED if k in overrides]
    if given and not allow_estimated:
        raise ParameterFileError(
            f"{path}: {', '.join(given)} given, but J1, B1, J2, B2 are the unknowns trms-ident estimates; expected "
            "known values only (remove them; `simulate --params` accepts them as the true values)")
    merge(overrides, source=str(path))  # validate now, with the file's name in the message
    _effects_of(path, raw)  # and the effects and structure, so that every command refuses a bad entry alike
    _structure_of(path, raw)
    return overrides


def _value_of(path: Path, name: str, entry):
    """A [parameters] entry's value: ``name = value``, or ``name = { value = ..., ci95 = [low, high] }`` (an
    estimated value with its 95 % interval: known_value_intervals); anything else is refused naming the line."""
    if not isinstance(entry, dict):
        return entry
    line = _line_of(path, name)
    where = f"{path}" + (f", line {line}" if line else "")
    extra = sorted(set(entry) - {"value", "ci95"})
    if "value" not in entry or extra:
        raise ParameterFileError(f"{where}: parameter {name} as a table takes value and optionally ci95 = [low, "
                                 f"high]; got {', '.join(sorted(entry))}")
    from .model.bench import finite_number

    ci = entry.get("ci95")
    if ci is not None and not (isinstance(ci, list) and len(ci) == 2 and all(map(finite_number, ci))
                               and ci[0] <= ci[1]):
        raise ParameterFileError(f"{where}: parameter {name}: ci95 must be [low, high] with low <= high, got {ci!r}")
    return entry["value"]


def known_value_intervals(path: str | Path | None) -> dict:
    """name -> (low, high): the 95 % intervals a parameter file gives its known values (``{ value = ..., ci95 =
    [...] }``: values estimated elsewhere, e.g. refitted by diagnose); empty without.  Read after
    :func:`load_parameter_file` has checked the file."""
    if not path:
        return {}
    path = resolve_parameter_file(path)
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    table = raw.get("parameters", raw)
    return {k: (float(v["ci95"][0]), float(v["ci95"][1])) for k, v in table.items()
            if isinstance(v, dict) and k in BY_NAME and v.get("ci95") is not None}


def bench_settings(path: str | Path | None) -> dict:
    """What a parameter file sets of the estimate's Settings: overrides (known values), inputs_unit, effects and
    effect_sources (its [effects]), structure (its [structure]); empty for None."""
    if not path:
        return {}
    overrides = load_parameter_file(path)  # checks the whole file, [effects] too
    effects = parameter_file_effects(path)
    return {"overrides": overrides, "inputs_unit": parameter_file_inputs_unit(path),
            "structure": parameter_file_structure(path),
            "effects": {e.key: e.value for e in effects}, "effect_sources": {e.key: e.source for e in effects},
            "held_ci95": {**{e.key: tuple(e.ci95) for e in effects if e.ci95 is not None},
                            **known_value_intervals(path)}}


def parameter_file_effects(path: str | Path) -> tuple:
    """The effects and structures beyond eq. (1) a parameter file's ``[effects]`` table holds (model.bench:
    BenchEffect each, in the file's order; empty when it has none).  Read after :func:`load_parameter_file`."""
    path = resolve_parameter_file(path)
    return _effects_of(path, tomllib.loads(path.read_text(encoding="utf-8")))


def parameter_file_structure(path: str | Path) -> dict:
    """The bench's structure a parameter file's ``[structure]`` table states (model/structure.py's canonical dict;
    empty: eq. (1)'s).  Read after :func:`load_parameter_file`."""
    path = resolve_parameter_file(path)
    return _structure_of(path, tomllib.loads(path.read_text(encoding="utf-8")))


def diagnose_bench(path: str | Path) -> dict:
    """The bench dict diagnose takes from a bench file: its known values, its structure (model.structure.BENCH_KEY)
    and its input modifications (model.bench.GIVEN_KEY: taken as given; its torque effects are searched for as any
    other effect of the library)."""
    from .model.bench import with_given
    from .model.structure import with_structure

    bench = with_structure(load_parameter_file(path), parameter_file_structure(path))
    return with_given(bench, {e.key: e.value for e in parameter_file_effects(path)})


def refuse_structure(path: str | Path | None, command: str) -> None:
    """A command that does not model a bench's ``[structure]`` yet refuses a bench file stating one (SettingsError),
    rather than run eq. (1) with values that mean something else under it (a voltage-driven Kg is per input unit)."""
    if not path:
        return
    from .errors import SettingsError
    from .model.structure import phrases

    structure = parameter_file_structure(path)
    if structure:
        raise SettingsError(f"{path}: states a [structure] ({'; '.join(phrases(structure))}), which {command} does not "
                            "model yet (estimate, batch, estimate --joint and diagnose do); for " + command + " against eq. (1) "
                            "give a bench file without [structure] (the CE150's: --params humusoft_ce150_eq1)")


def _structure_of(path: Path, raw: dict) -> dict:
    from .model.structure import StructureError, parse_structure

    try:
        return parse_structure(raw.get("structure"))
    except StructureError as exc:
        text = str(exc)
        key = text.split()[1].rstrip(":") if text.startswith("[structure] ") else None
        line = _line_of(path, key) if key else _line_of(path, "[structure]")
        raise ParameterFileError(f"{path}" + (f", line {line}" if line else "") + f": {text}") from None


def _effects_of(path: Path, raw: dict) -> tuple:
    """The [effects] table's entries, then the [terms] table's (model/terms.py), as model.bench.BenchEffect."""
    from .model.bench import BenchEffectError, parse_effects, parse_terms

    out = ()
    for table, parse in (("effects", parse_effects), ("terms", parse_terms)):
        if table not in raw:
            continue
        try:
            out += parse(raw[table])
        except BenchEffectError as exc:
            text = str(exc)
            key = text.split('"')[1] if text.startswith('"') else None
            line = _line_of(path, key) if key else _line_of(path, f"[{table}]")
            raise ParameterFileError(f"{path}" + (f", line {line}" if line else "") + f": [{table}] {text}") from None
    return out


def _line_of(path: Path, needle: str) -> int | None:
    """The first line of the file holding ``needle`` (1-based), or None."""
    for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if needle in line.split("#")[0] or (needle.startswith("[") and line.strip().startswith(needle)):
            return i
    return None
