"""A bench's model beyond eq. (1): the effects and structures a parameter file's ``[effects]`` table holds.

Diagnose finds them; ``export`` writes them; estimate, joint, simulate and design read them back, so the model
diagnose found is the bench's model from then on (docs/parameters.md, "The bench file").  Each effect is one
entry of the model room (model/effects.py, CANDIDATES) with its one parameter:

    [effects]
    "motor_second_lag:yaw" = { T2 = 0.463, from = "diagnose of run.mat (sha256 1f2e...)" }
    "cable_stiffness:yaw" = 0.004            # a bare number: the parameter's value

How the estimate carries them (trms_ident/identify.py): input modifications (dead zone, saturation, transport
delay, second-order motor) act on the logged voltages before DREM and the output-error refinement see them; a
motor time constant replaces T11 or T21; an acquisition lag is undone on the logged angles (the exact inverse of
its filter, diagnosis.model.observed_log); torque effects and the pitch offsets enter the output-error
refinement's model (numerics/refine.py's effect slots) at their values, or free beside J/B (``--free KEY``).
Pure: no files (params.py reads and writes the table).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from . import effects as room
from . import terms as term_room

#: effects the output-error refinement carries in its model with their parameter free or fixed (numerics/refine.py,
#: model.plant.EFFECT_SLOTS; listed here so that reading a parameter file does not load the compiled kernel)
TORQUE_KEYS = ("com_offset:pitch", "coulomb_friction:pitch", "coulomb_friction:yaw", "quadratic_drag:pitch",
               "quadratic_drag:yaw", "cable_stiffness:yaw", "thrust_asymmetry:pitch", "thrust_asymmetry:yaw",
               "yaw_inertia_pitch:yaw", "sensor_offset:pitch")
#: input modifications the output-error kernel integrates as states of its own (model.plant.LAG_SLOTS: exact
#: within each sample interval): the refinement takes them with the torque effects (identify.model_kw) and the
#: voltages without them (identify.under_model's ``kernel``); DREM's regressions take the voltages through them
KERNEL_KEYS = ("motor_second_lag:pitch", "motor_second_lag:yaw")
#: input modifications the output-error refinement estimates itself when they are freed: the voltages are clipped
#: (shifted) inside the fit and the level (width) is a Gauss-Newton unknown with J/B (numerics.refine.INPUT_SLOTS);
#: held, they are applied to the voltages like the others, and a freed one is first placed by its profile
#: (model_profile.py)
NATIVE_FREE_KEYS = ("input_saturation:pitch", "input_saturation:yaw", "shifted_dead_zone:pitch",
                    "shifted_dead_zone:yaw")
#: the shortest further lag [s] the kernel integrates: its RK4 sub-steps are up to numerics.refine.MAX_SUBSTEP_S
#: (2.5 ms) long, and a lag much shorter than a sub-step is neither stable nor resolved by a 100 Hz-1 kHz log
MIN_KERNEL_LAG_S = 2.5e-3
#: effects that change what drives the plant (the voltages, a motor's time constant) or what the log records
#: (the acquisition lag): applied to the log before the fit, their value held
MODIFICATION_KEYS = ("dead_zone:pitch", "dead_zone:yaw", "shifted_dead_zone:pitch", "shifted_dead_zone:yaw",
                     "input_saturation:pitch", "input_saturation:yaw",
                     "input_delay:both", "motor_lag:pitch", "motor_lag:yaw", "motor_second_lag:pitch",
                     "motor_second_lag:yaw", room.SENSOR_LAG)


#: the entry of diagnose's bench dict (params.merge's, beside model.structure.BENCH_KEY) holding the bench file's
#: input modifications (MODIFICATION_KEYS: key -> value, the file's order), which diagnose takes as given: its
#: search starts from the model they make (diagnosis.model.given_model) and adds to it.  The bench's torque effects
#: are not carried (diagnose searches the library for them as for any other)
GIVEN_KEY = "effects"


def with_given(p: dict, effects: dict | None) -> dict:
    """The bench ``p`` (known values by name) with the input modifications of ``effects`` (key -> value) in it under
    GIVEN_KEY; ``p`` itself when there are none."""
    mods = {k: float(v) for k, v in (effects or {}).items() if k in MODIFICATION_KEYS}
    return {**p, GIVEN_KEY: mods} if mods else p


def given_of(p: dict | None) -> dict:
    """The input modifications a bench dict holds (with_given): key -> value, {} without."""
    return dict((p or {}).get(GIVEN_KEY) or {})


def check_given(table) -> dict:
    """A bench dict's GIVEN_KEY entry checked as a bench file's [effects] entries are (parse_effect), input
    modifications only; raises BenchEffectError naming the entry."""
    if not isinstance(table, dict):
        raise BenchEffectError(f"{GIVEN_KEY} must be a table of \"effect:axis\" = value")
    out = {}
    for key, value in table.items():
        e = parse_effect(key, value)
        if key not in MODIFICATION_KEYS:
            raise BenchEffectError(f"\"{key}\": a torque effect; diagnose takes only the input modifications as "
                                   f"given ({', '.join(MODIFICATION_KEYS)})")
        out[key] = e.value
    return out


def inside_fit(free: tuple = ()) -> tuple:
    """The modifications the output-error fit applies itself, not the voltages handed to it: KERNEL_KEYS and the
    saturations ``free`` names (NATIVE_FREE_KEYS)."""
    return KERNEL_KEYS + tuple(k for k in free if k in NATIVE_FREE_KEYS)


#: what each key adds to eq. (1), in a few words (the report's model line)
PHRASES = {
    "coulomb_friction": "Coulomb friction", "quadratic_drag": "quadratic drag", "cable_stiffness": "a cable",
    "com_offset": "a centre-of-mass offset", "sensor_offset": "an encoder offset", "thrust_asymmetry":
    "a reversed rotor's thrust asymmetry", "yaw_inertia_pitch": "a pitch-dependent yaw inertia",
    "sensor_lag": "an acquisition lag", "dead_zone": "a cut-off dead zone", "shifted_dead_zone":
    "a dead zone", "input_saturation": "a saturation",
    "input_delay": "a transport delay", "motor_lag": "a motor time constant", "motor_second_lag":
    "a second-order motor"}
AXIS_WORDS = {"pitch": "pitch", "yaw": "yaw", "both": "both axes"}
MOTOR_WORDS = {"pitch": "main motor", "yaw": "tail motor"}


class BenchEffectError(ValueError):
    """An ``[effects]`` entry that cannot be read: the message names the entry and what was expected."""


@dataclass(frozen=True)
class BenchEffect:
    key: str  # "motor_second_lag:yaw": an effect of the model room on its axis
    value: float  # its parameter's value, in the parameter's unit (room.BY_KEY[key].parameter, .unit)
    source: str = ""  # where the value came from ("diagnose of run.mat (sha256 ...)"); "" when not said
    ci95: tuple | None = None  # its 95 % interval when it was estimated

    @property
    def candidate(self) -> room.Candidate:
        """Its entry of the model room: the library as imported (room.BY_KEY), a term's made from its key."""
        return term_room.candidate(self.key) if is_term(self.key) else room.BY_KEY[self.key]

    def phrase(self) -> str:
        """'a second-order tail motor (T2 = 0.463 s)'; a term's 'a pitch term c * M1 * sin(alpha) (c = 0.31)'."""
        effect, axis = self.key.rsplit(":", 1)
        c = self.candidate
        value = room.with_unit(self.value, c.unit)
        if is_term(self.key):
            what = f"a {axis} term c * {shown(self.key).partition(': ')[2]}"
        elif effect in ("motor_second_lag", "motor_lag", "dead_zone", "shifted_dead_zone", "input_saturation"):
            what = PHRASES[effect].replace("motor", MOTOR_WORDS[axis]) if "motor" in PHRASES[effect] else \
                f"{PHRASES[effect]} on the {MOTOR_WORDS[axis]}"
        else:
            what = f"{PHRASES[effect]}" + ("" if axis == "both" else f" on {AXIS_WORDS[axis]}")
        return f"{what} ({c.parameter} = {value}" + (f", from {self.source}" if self.source else "") + ")"


def parse_effects(table: dict, where: str = "[effects]") -> tuple[BenchEffect, ...]:
    """The ``[effects]`` table of a parameter file as BenchEffects, in the file's order.  An unknown effect or
    axis, a missing or extra parameter, or a value out of the parameter's plausible range raises
    BenchEffectError naming the entry (the caller adds the file and line)."""
    if not isinstance(table, dict):
        raise BenchEffectError(f"{where} must be a table of \"effect:axis\" = {{ PARAMETER = value }}")
    out = []
    for key, spec in table.items():
        out.append(parse_effect(key, spec))
    return tuple(out)


def known_keys() -> tuple[str, ...]:
    return TORQUE_KEYS + MODIFICATION_KEYS


def is_term(key: str) -> bool:
    """Is ``key`` a term's (model/terms.py: 'term(M1*sin(alpha)):pitch')?"""
    return term_room.is_term_key(key)


def is_torque(key: str) -> bool:
    """Does ``key`` add a torque the output-error refinement carries (TORQUE_KEYS, or a term)?"""
    return key in TORQUE_KEYS or is_term(key)


def free_key(name: str) -> str:
    """A name --free takes: a known value's or an effect's key as it is, a term as written in [terms] ('pitch: M1 *
    sin(alpha)') as its key (BenchEffectError when it is not one)."""
    head = name.partition(":")[0].strip()
    if head in term_room.AXES:
        try:
            return term_room.parse_entry(name).key
        except term_room.TermError as exc:
            raise BenchEffectError(f"{name}: {exc.reason}") from None
    return name


def shown(key: str) -> str:
    """How a key reads to a user: a term as its [terms] entry is written ('pitch: M1 * sin(alpha)'), any other key
    as it is."""
    if not is_term(key):
        return key
    t = term_room.from_key(key)
    return f"{t.axis}: {' * '.join(t.factors)}"


def parse_terms(table: dict, where: str = "[terms]") -> tuple[BenchEffect, ...]:
    """The ``[terms]`` table of a parameter file as BenchEffects (a term's key, its c), in the file's order:
    ``"pitch: M1 * sin(alpha)" = c`` or ``= { c = value, from = "...", ci95 = [lo, hi] }``.  A product not written
    from model/terms.py's factors, a missing or extra parameter raise BenchEffectError naming the entry as written."""
    if not isinstance(table, dict):
        raise BenchEffectError(f"{where} must be a table of \"AXIS: PRODUCT\" = {{ c = value }}")
    out = []
    for name, spec in table.items():
        try:
            key = term_room.parse_entry(name).key
        except term_room.TermError as exc:
            raise BenchEffectError(f"\"{name}\": {exc.reason}") from None
        if key in {e.key for e in out}:
            raise BenchEffectError(f"\"{name}\": the same term as an entry above (write it once, with the sum of the "
                                   "values)")
        try:
            out.append(parse_effect(key, spec))
        except BenchEffectError as exc:
            raise BenchEffectError(str(exc).replace(f'"{key}"', f'"{name}"', 1)) from None
    return tuple(out)


def parse_effect(key: str, spec) -> BenchEffect:
    """One ``[effects]`` entry: ``"effect:axis" = value`` or ``= { PARAMETER = value, from = "...", ci95 = [lo,
    hi] }``; a term's key (parse_terms) takes its c alike."""
    if is_term(key):
        try:
            c = term_room.candidate(key)
        except term_room.TermError as exc:
            raise BenchEffectError(str(exc)) from None
        return _parse_value(key, c, spec)
    effect, _, axis = key.partition(":")
    names = sorted({k.split(":")[0] for k in known_keys()})
    if effect not in names:
        raise BenchEffectError(f"\"{key}\": unknown effect {effect!r}; expected one of {', '.join(names)}")
    axes = [k.split(":")[1] for k in known_keys() if k.split(":")[0] == effect]
    if axis not in axes:
        why = f" ({room.UNOBSERVABLE[key]})" if key in room.UNOBSERVABLE else ""
        raise BenchEffectError(f"\"{key}\": {effect} acts on {' or '.join(axes)}, not {axis or 'no axis'!r}{why}; "
                               f"write \"{effect}:{axes[0]}\"")
    return _parse_value(key, room.BY_KEY[key], spec)


def _parse_value(key: str, c: room.Candidate, spec) -> BenchEffect:
    """An entry's value, where from and interval, checked against the parameter of ``c``."""
    effect = key.partition(":")[0]
    source, ci95 = "", None
    if isinstance(spec, dict):
        extra = sorted(set(spec) - {c.parameter, "from", "ci95"})
        if extra:
            raise BenchEffectError(f"\"{key}\": unexpected {', '.join(extra)}; expected {c.parameter} "
                                   f"[{c.unit}], and optionally from and ci95")
        if c.parameter not in spec:
            raise BenchEffectError(f"\"{key}\": no value for its parameter {c.parameter} [{c.unit}]; expected "
                                   f"{{ {c.parameter} = value }}")
        value = spec[c.parameter]
        source = spec.get("from", "")
        if not isinstance(source, str):
            raise BenchEffectError(f"\"{key}\": from must be text (where the value came from), got {source!r}")
        ci95 = spec.get("ci95")
        if ci95 is not None and not (isinstance(ci95, list) and len(ci95) == 2 and
                                     all(map(finite_number, ci95))):
            raise BenchEffectError(f"\"{key}\": ci95 must be [low, high], got {ci95!r}")
        ci95 = tuple(float(v) for v in ci95) if ci95 is not None else None
    else:
        value = spec
    if not finite_number(value):
        raise BenchEffectError(f"\"{key}\": {c.parameter} must be a finite number [{c.unit}], got {value!r}")
    value = float(value)
    if not c.plausible(value) or (effect == "motor_lag" and not value > 0):
        lo, hi = c.bounds
        rng = (f"> {lo:g}" if math.isinf(hi) else f"between {lo:g} and {hi:g}")
        raise BenchEffectError(f"\"{key}\": {c.parameter} = {value:g} {c.unit} is not physical for a bench; "
                               f"expected {rng}")
    if key in KERNEL_KEYS and value < MIN_KERNEL_LAG_S:
        raise BenchEffectError(f"\"{key}\": {c.parameter} = {value:g} {c.unit} is shorter than the output-error fit "
                               f"integrates (at least {MIN_KERNEL_LAG_S:g} s, its sub-step); a lag this short is not "
                               "resolved by the log: leave the entry out")
    return BenchEffect(key, value, source, ci95)


def finite_number(v) -> bool:
    """A finite int or float, not a bool (a TOML value that can stand for a number)."""
    return not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)


def describe(effects: tuple[BenchEffect, ...]) -> str:
    """'eq. (1)' or 'eq. (1) + a second-order tail motor (T2 = 0.463 s, from ...)'."""
    return "eq. (1)" + "".join(f" + {e.phrase()}" for e in effects)


def to_toml_lines(effects: tuple[BenchEffect, ...]) -> list[str]:
    """The ``[effects]`` table's lines, then the ``[terms]`` table's (empty list: neither)."""
    lines = []
    library = [e for e in effects if not is_term(e.key)]
    terms = [e for e in effects if is_term(e.key)]
    if library:
        lines += ["", "# effects and structures beyond eq. (1) (docs/parameters.md): estimate, joint, simulate and "
                  "design use them", "[effects]"]
        lines += [f"\"{e.key}\" = {_toml_entry(e)}  # {e.candidate.unit}" for e in library]
    if terms:
        lines += ["", "# torques outside the effect library, c x a product of the model's signals (docs/parameters.md)",
                  "[terms]"]
        for e in terms:
            t = term_room.from_key(e.key)
            lines.append(f"\"{shown(e.key)}\" = {_toml_entry(e)}  # " + ("c dimensionless" if t.unit == "1" else
                                                                          f"c in {t.unit}"))
    return lines


def _toml_entry(e: BenchEffect) -> str:
    parts = [f"{e.candidate.parameter} = {e.value!r}"]
    if e.ci95 is not None:
        parts.append(f"ci95 = [{e.ci95[0]!r}, {e.ci95[1]!r}]")
    if e.source:
        parts.append("from = " + _toml_string(e.source))
    return f"{{ {', '.join(parts)} }}"


def _toml_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def from_findings(findings, source: str = "") -> tuple[dict, tuple, list]:
    """Diagnose's findings (each with effect, axis and parameter {"name", "value"}: diagnosis.result.Finding or
    its diagnosis.json entry) as the bench's model: (the known values they refit: name -> value, the effects as
    BenchEffects from ``source``, the findings a bench file cannot hold: why each is left out)."""
    known, effects, left = {}, [], []
    for f in findings:
        effect, axis, p = (f["effect"], f["axis"], f["parameter"]) if isinstance(f, dict) else             (f.effect, f.axis, f.parameter)
        if effect == "known_value":
            known[p["name"]] = float(p["value"])
            continue
        key = f"{effect}:{axis}"
        if key not in known_keys() and not is_term(key):
            left.append(f"{key}: not an effect a bench file can hold; left out")
            continue
        try:
            effects.append(parse_effect(key, {"from": source, p["name"]: p["value"],
                                              **({"ci95": list(p["ci95"])} if p.get("ci95") else {})}))
        except BenchEffectError as exc:
            left.append(f"{exc}; left out")
    return known, tuple(effects), left


def simulator_specs(effects: dict) -> list[dict]:
    """Settings.effects (key -> value) as the simulator's effect list (sim.SimSettings.effects; a term as
    {"effect": "term", "product": 'M1*sin(alpha)', ...})."""
    out = []
    for k, v in effects.items():
        if is_term(k):
            t = term_room.from_key(k)
            out.append({"effect": "term", "axis": t.axis, "product": t.product, "value": float(v)})
        else:
            out.append({"effect": k.split(":")[0], "axis": k.split(":")[1], "value": float(v)})
    return out


def model_doc(effects: dict, sources: dict, freed: dict, structure: dict | None = None) -> dict:
    """result.json's "model": which model the estimate was made under.  ``effects`` key -> value (Settings),
    ``sources`` key -> where from, ``freed`` the refinement's freed values (an effect's estimate and ci95),
    ``structure`` the bench's (model/structure.py)."""
    from .structure import phrases

    # a freed value is this log's estimate, not the file's (its "from" would say where the start came from)
    items = tuple(BenchEffect(k, float(freed[k]["estimate"]), "this log, estimated with J/B") if k in freed else
                  BenchEffect(k, float(v), sources.get(k, "")) for k, v in effects.items())
    return {"equation": describe(items) + "".join(f" + {p}" for p in phrases(structure)),
            "structure": dict(structure or {}),
            "effects": {e.key: {"parameter": e.candidate.parameter, "unit": e.candidate.unit, "value": e.value,
                                "from": sources.get(e.key) or None, "estimated": e.key in freed,
                                "ci95": freed[e.key]["ci95"] if e.key in freed else None,
                                "how": ("profiled: the output-error fit repeated over its value" if
                                        freed.get(e.key, {}).get("profiled") else "estimated with J/B by the "
                                        "output-error refinement") if e.key in freed else "held at the file's value"}
                        for e in items}}
