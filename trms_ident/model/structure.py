"""A bench's structure where it is not eq. (1)'s: what drives the gyroscopic and the reaction torque, and the end
stops its angles rest on.  A bench file states it in a ``[structure]`` table (docs/parameters.md):

    [structure]
    gyroscope = "voltage"           # Kg u1 beta' cos(alpha) instead of eq. (1)'s Kg M1 beta' cos(alpha)
    reaction = "voltage"            # M_R = kc (T0 s + 1)/(Tp s + 1) u1 instead of eq. (1)'s ... tau1
    pitch_stops_deg = [45, 135]     # the pitch angle cannot pass these (or pitch_stops_rad)
    yaw_stops_deg = [-130, 130]

The Humusoft CE150's published model is written so (trms_ident/benches/humusoft_ce150.toml): its gyroscopic torque is
K_gyro u1 phi' cos(psi) and its reaction K_r (T_0r s + 1)/(T_pr s + 1) u1, both driven by the main motor's input, not
its speed; its elevation rests on a stop at 45 degrees until the thrust lifts it.  Kg, kc, T0 and Tp of the table
keep their names and meaning (the coefficient, the lead and the lag); only the signal they act on changes.

Every stage that evaluates eq. (1) reads the structure: the output-error kernel through the model vector's
structure slots (model.plant.STRUCTURE_SLOTS; an angle at its stop is held there, Simulink's Second-Order Integrator
with position limits), DREM's regressions (numerics.fused) with the samples at a stop, and those the filters carry
their torque into, left out of the sums (a stop's contact torque is in no regression).  The canonical form (what
Settings.structure holds and the report records) is a dict of the non-default entries: "gyroscope", "reaction",
"pitch_stops_rad", "yaw_stops_rad".  Pure: no numba, no files.

diagnose's passes take the bench as one dict of known values by name (``p``, params.merge's), hundreds of calls
deep; the bench's structure rides in it under BENCH_KEY (with_structure), so that every stage below reads the same
structure from the same dict (of_bench) rather than a second argument threaded beside it.  model_vector and the
table's readers take known values by name and never see the entry.
"""
from __future__ import annotations

import math

DRIVES = {"gyroscope": ("thrust", "voltage"), "reaction": ("motor", "voltage")}
STOP_AXES = ("pitch", "yaw")
#: what each entry means, for the report's model line and docs
WORDS = {"gyroscope": "the gyroscopic torque driven by the voltage u1 (Kg u1 beta' cos alpha)",
         "reaction": "the reaction torque driven by the voltage u1 (kc (T0 s + 1)/(Tp s + 1) u1)"}


class StructureError(ValueError):
    """A ``[structure]`` entry that cannot be read: the message names the entry and what was expected."""


def parse_structure(table) -> dict:
    """The ``[structure]`` table of a bench file (or Settings.structure itself) in its canonical form; raises
    StructureError naming the entry."""
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise StructureError("[structure] must be a table: gyroscope, reaction, pitch_stops_deg, yaw_stops_deg")
    out = {}
    known = set(DRIVES) | {f"{a}_stops_{u}" for a in STOP_AXES for u in ("deg", "rad")}
    for key, value in table.items():
        if key not in known:
            raise StructureError(f"[structure] {key}: unknown entry; expected one of {', '.join(sorted(known))}")
        if key in DRIVES:
            if value not in DRIVES[key]:
                raise StructureError(f"[structure] {key} = {value!r}: expected " +
                                     " or ".join(f'"{v}"' for v in DRIVES[key]))
            if value != DRIVES[key][0]:
                out[key] = value
            continue
        axis, unit = key.split("_stops_")
        if f"{axis}_stops_rad" in out:
            raise StructureError(f"[structure] {key}: the {axis} stops are given twice; keep one entry")
        if not (isinstance(value, (list, tuple)) and len(value) == 2 and
                all(not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) for v in value)):
            raise StructureError(f"[structure] {key} = {value!r}: expected [low, high], two finite angles in {unit}")
        lo, hi = (math.radians(v) if unit == "deg" else float(v) for v in value)
        if not lo < hi:
            raise StructureError(f"[structure] {key} = {list(value)!r}: the low stop must be below the high one")
        out[f"{axis}_stops_rad"] = (lo, hi)
    return out


#: the entry of a bench's dict of known values (params.merge's) that holds its structure, canonical form
BENCH_KEY = "structure"


def with_structure(p: dict, structure: dict | None) -> dict:
    """The bench ``p`` (known values by name) with ``structure`` in it (BENCH_KEY); ``p`` itself under eq. (1)."""
    return {**p, BENCH_KEY: dict(structure)} if structure else p


def of_bench(p: dict | None) -> dict:
    """The structure a bench dict holds (with_structure), {} under eq. (1)."""
    return (p or {}).get(BENCH_KEY) or {}


def gyroscope_voltage(structure: dict | None) -> bool:
    return (structure or {}).get("gyroscope") == "voltage"


def reaction_voltage(structure: dict | None) -> bool:
    return (structure or {}).get("reaction") == "voltage"


def stops(structure: dict | None, axis: str) -> tuple[float, float] | None:
    """The (low, high) stops [rad] of "pitch" or "yaw", or None."""
    s = (structure or {}).get(f"{axis}_stops_rad")
    return None if s is None else (float(s[0]), float(s[1]))


def slot_values(structure: dict | None) -> dict:
    """The structure as the output-error kernel's model-vector entries (model.plant.STRUCTURE_SLOTS): empty under
    eq. (1)."""
    out = {}
    if gyroscope_voltage(structure):
        out["structure:gyroscope_voltage"] = 1.0
    if reaction_voltage(structure):
        out["structure:reaction_voltage"] = 1.0
    for axis in STOP_AXES:
        s = stops(structure, axis)
        if s is not None:
            out[f"structure:{axis}_stop_low"], out[f"structure:{axis}_stop_high"] = s
    return out


def phrases(structure: dict | None) -> list[str]:
    """What the structure changes of eq. (1), in words (the report's model line)."""
    out = [WORDS[k] for k in DRIVES if (structure or {}).get(k) == "voltage"]
    for axis in STOP_AXES:
        s = stops(structure, axis)
        if s is not None:
            out.append(f"{axis} end stops at {math.degrees(s[0]):.4g} and {math.degrees(s[1]):.4g} deg")
    return out


def to_toml_lines(structure: dict | None) -> list[str]:
    """The ``[structure]`` table's lines (empty list: eq. (1)'s structure)."""
    if not structure:
        return []
    lines = ["", "# the bench's structure where it is not eq. (1)'s (docs/parameters.md)", "[structure]"]
    for key in DRIVES:
        if key in structure:
            lines.append(f'{key} = "{structure[key]}"')
    for axis in STOP_AXES:
        s = stops(structure, axis)
        if s is not None:
            lines.append(f"{axis}_stops_deg = [{math.degrees(s[0])!r}, {math.degrees(s[1])!r}]")
    return lines
