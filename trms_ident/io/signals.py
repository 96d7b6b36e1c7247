"""Where each log signal comes from in a message-based recording: ``NAME=TOPIC:FIELD``.

FIELD is a path into the message: ``position[pitch]`` (JointState: by joint name),
``position[0]`` or ``data[1]`` (by index), ``alpha`` or ``pose.position.z`` (by key/attribute).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..errors import SettingsError
from ..log import COLUMNS, VOLTAGE_TIME

SIGNALS = ("alpha", "beta", "u1", "u2")
_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?:\[([^\]]+)\])?")


@dataclass(frozen=True)
class Step:
    key: str
    index: int | None = None  # [3]
    name: str | None = None  # [pitch]: element whose sibling "name" entry matches


@dataclass(frozen=True)
class SignalSource:
    signal: str
    topic: str
    field: str

    @property
    def steps(self) -> tuple[Step, ...]:
        return parse_field(self.field)

    def __str__(self) -> str:
        return f"{self.signal}={self.topic}:{self.field}"


def parse_field(field: str) -> tuple[Step, ...]:
    steps = []
    for part in field.split("."):
        m = _STEP.fullmatch(part.strip())
        if not m:
            raise SettingsError(f"field {field!r}: cannot read {part!r}; expected name, name[index] or name[joint]")
        key, sub = m.group(1), m.group(2)
        if sub is None:
            steps.append(Step(key))
        elif sub.strip().lstrip("-").isdigit():
            steps.append(Step(key, index=int(sub)))
        else:
            steps.append(Step(key, name=sub.strip()))
    return tuple(steps)


def parse_signal(text: str) -> SignalSource:
    """'alpha=/arm/joint_states:position[pitch]' -> SignalSource."""
    name, eq, rest = text.partition("=")
    topic, colon, field = rest.rpartition(":")
    name = name.strip()
    if not eq or not colon or not topic or not field:
        raise SettingsError(f"--signal {text!r}: expected NAME=TOPIC:FIELD, e.g. alpha=/arm/joint_states:position[pitch]")
    if name not in SIGNALS:
        raise SettingsError(f"--signal {text!r}: signal must be one of {', '.join(SIGNALS)}")
    parse_field(field)
    return SignalSource(name, topic.strip(), field.strip())


#: a comma that starts the next NAME= of a --signal list (a field path or column name keeps its own commas)
_NEXT_SIGNAL = re.compile(r",\s*(?=(?:" + "|".join(map(re.escape, (*COLUMNS, VOLTAGE_TIME))) + r")\s*=)")


def split_signals(texts: list[str] | None) -> list[str] | None:
    """``--signal`` values as single NAME=SOURCE items: one value may list several, comma-separated
    (``alpha=psi,beta=phi``), as well as the option being repeated."""
    if texts is None:
        return None
    return [x.strip() for t in texts for x in _NEXT_SIGNAL.split(t) if x.strip()]


#: the signals a --signal NAME=NUMBER may hold at a constant: a motor's input (an angle is always measured)
HELD = ("u1", "u2")


def held_constants(texts: list[str] | None) -> tuple[list[str] | None, dict[str, float]]:
    """``--signal`` items split into the mappings a reader resolves and the inputs held at a constant:
    ``u2=0`` says the tail motor was off, so its input was not logged (the value in the input's unit, V)."""
    rest, held = [], {}
    for text in texts or []:
        name, eq, source = (x.strip() for x in text.partition("="))
        try:
            value = float(source) if eq else None
        except ValueError:
            value = None
        if value is None:
            rest.append(text)
            continue
        if name not in HELD or not math.isfinite(value):
            raise SettingsError(f"--signal {text!r}: a constant is for a motor that was off and not logged: expected "
                                f"{' or '.join(f'{k}=VALUE' for k in HELD)}, a finite number in V (e.g. u2=0)")
        held[name] = value
    return (rest if texts is not None else None), held


def held_note(held: dict[str, float]) -> dict:
    """What a Log's meta says of the inputs held at a constant (merged into the reader's meta)."""
    said = ", ".join(f"{k} = {v:g} V" for k, v in held.items())
    return {"held_inputs": dict(held),
            "assumed": {"held_inputs": f"{said} throughout: not logged, held at the value --signal gave (a motor "
                                      "that was off)"}}


def mapping(texts: list[str] | None, defaults: dict[str, SignalSource]) -> dict[str, SignalSource]:
    out = dict(defaults)
    for t in texts or []:
        s = parse_signal(t)
        out[s.signal] = s
    return out


DEFAULT_ROS2 = {s.signal: s for s in (
    SignalSource("alpha", "/trms/joint_states", "position[pitch]"),
    SignalSource("beta", "/trms/joint_states", "position[yaw]"),
    SignalSource("u1", "/trms/voltage", "data[0]"),
    SignalSource("u2", "/trms/voltage", "data[1]"),
)}
DEFAULT_JSON = {s.signal: s for s in (
    SignalSource("alpha", "/trms/joint_states", "alpha"),
    SignalSource("beta", "/trms/joint_states", "beta"),
    SignalSource("u1", "/trms/voltage", "u1"),
    SignalSource("u2", "/trms/voltage", "u2"),
)}

assert set(SIGNALS) | {"t"} == set(COLUMNS)


def extract(obj, steps: tuple[Step, ...]):
    """Follow a field path through a decoded message (attributes, dict keys, lists)."""
    cur = obj
    for st in steps:
        parent = cur
        cur = parent.get(st.key) if isinstance(parent, dict) else getattr(parent, st.key)
        if st.index is not None:
            cur = cur[st.index]
        elif st.name is not None:
            names = parent.get("name") if isinstance(parent, dict) else getattr(parent, "name")
            cur = cur[list(names).index(st.name)]
    return float(cur)
