"""MATLAB logs: .mat v4, v5/v7 and v7.3, plain variables and MATLAB class objects (read by mat-io).

What a lab's .mat holds, and how each becomes a log (t [s], u1, u2 [V], alpha, beta [rad]):
* named column vectors: found by name or a common alias (ALIASES, case-insensitive), e.g. the Humusoft CE150's
  psi/phi/u1/u2;
* a matrix: one signal per column, mapped with ``--signal alpha=data:2`` (or ``data[2]``; 0-based column);
* a Simulink "Structure With Time" (``time`` and ``signals(i).values``): ``--signal alpha=yout.signals[1]``, or by
  the signal's label (``yout.alpha``), which is also how a labelled signal is found without a mapping;
* a struct field: ``--signal alpha=logs.pitch``;
* MATLAB class objects (see mat_tree): a ``timeseries`` (``pitch_ts`` or a column ``pitch_ts:2``), a
  ``Simulink.SimulationOutput`` (``out.tout``, ``out.yout``, ``out.logsout.alpha``, ``out.my_timeseries:1``), a
  ``Simulink.SimulationData.Dataset`` (``logsout.alpha``: an element by name), a ``table`` (``tab.alpha``) or
  ``timetable`` (``tt.alpha``, on its row times).
Time: ``--signal t=PATH``; else ``--rate HZ``; else the mapped signals' own time base (a timeseries', a timetable's,
a Structure With Time's); else a vector ``t``/``time``/``tout``.  Signals on different time bases are refused.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LogFormatError, SettingsError
from ..log import JITTER_TOLERANCE, Log, angle_unit_of, validated
from .csv_log import Sha256Thread, check_readable
from .mat_tree import MatReadFailure, Series, Struct, Undecoded, load

SIGNALS = ("alpha", "beta", "u1", "u2")
ALIASES = {
    "t": ("t", "time", "tout", "t_s"),
    "alpha": ("alpha", "pitch", "psi", "elevation", "theta_v", "thtv", "alpha_rad"),
    "beta": ("beta", "yaw", "phi", "azimuth", "theta_h", "thth", "beta_rad"),
    "u1": ("u1", "u_main", "um", "uv", "u1_v"),
    "u2": ("u2", "u_tail", "ut", "uh", "u2_v"),
}
_PATH = re.compile(r"^(?P<var>[A-Za-z_]\w*)(?P<rest>(\.[A-Za-z_]\w*|\[\d+\])*)(:(?P<col>\d+))?$")
_LISTED = 12  # signals named in a one-line error


@dataclass
class Entry:
    """One numeric signal of the file: where it is, what it is."""

    path: str
    name: str  # the last name on the path, matched against ALIASES
    depth: int
    node: np.ndarray | Series
    klass: str

    @property
    def shape(self) -> tuple[int, int]:
        v = self.node.values if isinstance(self.node, Series) else np.squeeze(self.node)
        return (int(v.shape[0]), int(v.shape[1]) if v.ndim == 2 else 1)


def _entries(node, path: str = "", depth: int = 0, klass: str = "") -> list[Entry]:
    """Every numeric signal of at least two samples under ``node``, in the file's order."""
    if isinstance(node, Struct):
        out = []
        for key, child in node.items():
            if key == "signals" and node.klass == "Structure With Time":  # labelled ones are listed by label
                for i, s in enumerate(child):
                    if not any(v is s for v in node.values()):
                        out.append(Entry(f"{path}.signals[{i}]", "", depth + 1, s, s.klass))
                continue
            out += _entries(child, f"{path}.{key}" if path else key, depth + 1, node.klass)
        return out
    if isinstance(node, list):
        return [e for i, x in enumerate(node) for e in _entries(x, f"{path}[{i}]", depth + 1, klass)]
    name = path.rsplit(".", 1)[-1] if "[" not in path.rsplit(".", 1)[-1] else ""
    if isinstance(node, Series) and node.values.ndim in (1, 2) and node.samples >= 2:
        return [Entry(path, name, depth, node, node.klass)]
    if isinstance(node, np.ndarray) and np.squeeze(node).ndim in (1, 2) and np.squeeze(node).shape[0] >= 2:
        return [Entry(path, name, depth, node, "double" if node.dtype.kind == "f" else str(node.dtype))]
    return []


def _undecoded(node, path: str = "") -> list[tuple[str, Undecoded]]:
    if isinstance(node, Undecoded):
        return [(path, node)]
    if isinstance(node, Struct):
        return [u for k, v in node.items() for u in _undecoded(v, f"{path}.{k}" if path else k)]
    if isinstance(node, list):
        return [u for i, v in enumerate(node) for u in _undecoded(v, f"{path}[{i}]")]
    return []


def _listing(entries: list[Entry]) -> str:
    names = [e.path + (f" ({e.shape[0]} x {e.shape[1]})" if e.shape[1] > 1 else f" ({e.shape[0]})") for e in entries]
    more = len(names) - _LISTED
    return ", ".join(names[:_LISTED]) + (f" and {more} more (see `trms-ident inspect`)" if more > 0 else "") or "none"


def _find(entries: list[Entry], name: str) -> tuple[str | None, list[str]]:
    """The signal a name's aliases point to (the shallowest match), and every path that matched equally well."""
    vectors = [e for e in entries if e.shape[1] == 1 and (name != "t" or not isinstance(e.node, Series))]
    for alias in ALIASES[name]:
        hits = [e for e in vectors if e.name.lower() == alias]
        if hits:
            top = min(e.depth for e in hits)
            best = [e.path for e in hits if e.depth == top]
            return (best[0] if len(best) == 1 else None), best
    return None, []


def _resolve(tree: Struct, text: str, path: Path) -> tuple[np.ndarray, np.ndarray | None, str]:
    """``var``, ``var[col]``, ``var:col``, ``struct.field``, ``struct.signals[i]``, ``obj.element``: the samples
    (a vector), their own time [s] if the signal carries one, and how that time was stored."""
    m = _PATH.match(text)
    if not m:
        raise SettingsError(f"--signal ...={text}: expected a path such as var, var:COLUMN, struct.field, "
                            "out.logsout.NAME or yout.signals[i]")
    if m["var"] not in tree:
        raise LogFormatError(f"{path}: no variable {m['var']!r}; signals: {_listing(_entries(tree))}")
    node, where = tree[m["var"]], m["var"]
    parts = re.findall(r"\.\w+|\[\d+\]", m["rest"]) + ([f":{m['col']}"] if m["col"] is not None else [])
    for part in parts:
        if isinstance(node, Undecoded):
            break
        if part.startswith("."):
            if not isinstance(node, Struct) or part[1:] not in node:
                fields = ", ".join(k for k, v in node.items() if v is not None) if isinstance(node, Struct) else ""
                raise LogFormatError(f"{path}: {text}: {where} has no field {part[1:]!r}"
                                     + (f" (fields: {fields})" if fields else ""))
            node = node[part[1:]]
        elif isinstance(node, list):
            i = int(part[1:-1]) if part.startswith("[") else int(part[1:])
            if i >= len(node):
                raise LogFormatError(f"{path}: {text}: {where} has {len(node)} elements; index {i} (0-based) is past "
                                     "its end")
            node = node[i]
        else:
            node = _column(node, int(part[1:-1] if part.startswith("[") else part[1:]), text, where, path)
        where += part
    if isinstance(node, Undecoded):
        raise LogFormatError(f"{path}: {where} is a MATLAB object of class {node.klass} that could not be decoded "
                             f"({node.why}); save its data as numeric vectors")
    time, note = (node.time_s, node.time_note) if isinstance(node, Series) else (None, "")
    values = node.values if isinstance(node, Series) else node
    if not isinstance(values, np.ndarray) or values.dtype.kind not in "biuf":
        raise LogFormatError(f"{path}: {text} is not numeric ({_kind(values)}); expected a numeric vector")
    a = np.squeeze(values).astype(float)
    if a.ndim != 1:
        raise LogFormatError(f"{path}: {text} has shape {np.shape(values)}; expected a vector (map one column with "
                             f"--signal NAME={text}:COLUMN, 0-based)")
    if time is not None and time.size != a.size:
        raise LogFormatError(f"{path}: {text} has {a.size} samples on {time.size} time stamps; expected one stamp "
                             "per sample")
    return a, time, note


def _column(node, i: int, text: str, where: str, path: Path):
    values = node.values if isinstance(node, Series) else np.asarray(node)
    if values.ndim != 2 or i >= values.shape[1]:
        raise LogFormatError(f"{path}: {text}: column {i} of {where}, shaped {values.shape}; expected a matrix with "
                             "that column (0-based)")
    if isinstance(node, Series):
        return Series(values[:, i], node.time_s, node.klass, node.time_note, node.name)
    return values[:, i]


def _kind(x) -> str:
    if isinstance(x, Struct):
        return f"a {x.klass} with fields {', '.join(x)}" if x.klass != "struct" else f"a struct with fields {', '.join(x)}"
    if isinstance(x, list):
        return f"an array of {len(x)} elements"
    if isinstance(x, str):
        return "text"
    return type(x).__name__


def _tree(path: Path) -> tuple[Struct, list[str]]:
    try:
        return load(path)
    except MatReadFailure as exc:
        raise LogFormatError(f"{path}: not a readable MATLAB .mat file ({exc}); expected v4, v5, v7 or v7.3") from None


def read_mat_log(path: str | Path, angle_unit: str = "auto", time_unit: str = "auto",
                 signals: list[str] | None = None, rate_hz: float | None = None,
                 held: dict[str, float] | None = None) -> Log:
    """Read a MATLAB log (see the module docstring); ``signals``: NAME=PATH mappings; ``rate_hz``: the sample
    rate when the file has no time base; ``held``: inputs not logged, held at a constant [V] (``--signal u2=0``).
    What the file needs that no option gave (a signal's mapping, the rate, the angles' unit) is said in one
    error, each with the option to pass."""
    path = Path(path)
    check_readable(path)
    hasher = Sha256Thread(path)
    hasher.start()
    tree, warned = _tree(path)
    held = held or {}
    chosen = {}
    for text in signals or []:
        name, sep, where = text.partition("=")
        name = name.strip()
        if not sep or name not in (*SIGNALS, "t"):
            raise SettingsError(f"--signal {text!r}: expected NAME=PATH with NAME one of t, alpha, beta, u1, u2 "
                                "(PATH: var, var:COLUMN, struct.field, out.logsout.NAME or yout.signals[i])")
        chosen[name] = where.strip()
    entries = _entries(tree)
    cols, times, problems = {}, {}, []
    for name in SIGNALS:
        if name in held:
            continue
        if name not in chosen:
            where, problem = _auto(entries, tree, name)
            if where is None:
                problems.append(problem)
                continue
            chosen[name] = where
        cols[name], own, note = _resolve(tree, chosen[name], path)
        if own is not None:
            times[name] = (own, note)
    lengths = {name: a.size for name, a in cols.items()}
    first = next(iter(cols), None)
    for name, size in lengths.items():
        if size != lengths[first]:
            raise LogFormatError(f"{path}: {chosen[name]} has {size} samples, {chosen[first]} has {lengths[first]}; "
                                 "expected one value per sample for every signal")
    n = lengths[first] if first else 0
    t = t_where = None
    if rate_hz is not None:
        if not rate_hz > 0:
            raise SettingsError(f"--rate {rate_hz}: expected a sample rate > 0 [Hz]")
        t, t_where, time_unit = np.arange(n) / rate_hz, f"--rate {rate_hz:g} Hz", "s"
    elif "t" in chosen:
        t, _, _ = _resolve(tree, chosen["t"], path)
        t_where = chosen["t"]
    elif times:
        t, t_where = _shared_time(times, chosen, path)
        time_unit = "s"  # a timeseries' or timetable's time is in seconds once its unit is applied
        _fixed_step(t, t_where, path)
    else:
        t_where, candidates = _find(entries, "t")
        if t_where is None:
            problems.append(f"no time vector (several match equally: {', '.join(candidates)}; map one with --signal "
                            "t=PATH)" if candidates else
                            f"no time vector (looked for {', '.join(ALIASES['t'])}): pass the sample rate with "
                            "--rate HZ")
        else:
            t, _, _ = _resolve(tree, t_where, path)
    if problems and angle_unit == "auto" and "alpha" in cols and "beta" in cols:
        # said beside what must be settled, so the next run is the last (alone, validated tells and says it)
        told, why = angle_unit_of(cols["alpha"], cols["beta"])
        if told is None:
            problems.append(f"the angles are in no unit this tool can tell ({why}): pass --angle-unit deg or "
                            "--angle-unit rad")
        elif told == "deg":
            problems.append(f"the angles will be read as degrees ({why}; --angle-unit rad if they are radians)")
    if problems:
        raise LogFormatError(f"{path}: " + ("; ".join(problems) if len(problems) == 1 else
                                            f"{len(problems)} things to settle: " +
                                            "; ".join(f"({k + 1}) {p}" for k, p in enumerate(problems))))
    if angle_unit == "deg":
        cols["alpha"], cols["beta"] = np.radians(cols["alpha"]), np.radians(cols["beta"])
    meta = {"format": "mat", "signals": " ".join(f"{k}={chosen[k]}" for k in SIGNALS if k in chosen), "time": t_where}
    for name, value in held.items():
        cols[name] = np.full(n, value)
    if held:
        from .signals import held_note

        meta.update(held_note(held))
    if warned:
        meta["reader_warnings"] = warned
    return validated(t, cols["u1"], cols["u2"], cols["alpha"], cols["beta"], source=str(path),
                     sha256=hasher.result(), meta=meta, angle_unit=angle_unit, time_unit=time_unit)


def _auto(entries: list[Entry], tree: Struct, name: str) -> tuple[str | None, str]:
    """The path a signal's aliases find, or None and what to do about it."""
    where, candidates = _find(entries, name)
    if where is not None:
        return where, ""
    if candidates:
        return None, f"several signals could be {name} ({', '.join(candidates)}); map one with --signal {name}=PATH"
    broken = _undecoded(tree)
    extra = ("; could not decode " + ", ".join(f"{p} (class {u.klass})" for p, u in broken)) if broken else ""
    hint = " (or u{0}=0 if that motor was off and its input not logged)".format(name[1]) if name in ("u1", "u2") else ""
    return None, (f"no variable for {name} (looked for {', '.join(ALIASES[name])}; signals: {_listing(entries)}"
                  f"{extra}): map it with --signal {name}=PATH{hint}")


def _shared_time(times: dict, chosen: dict, path: Path) -> tuple[np.ndarray, str]:
    """The one time base the mapped signals carry; signals on different time bases are refused."""
    (first, (t, note)), *rest = times.items()
    for name, (other, _) in rest:
        if other.size != t.size or not np.allclose(other, t, rtol=0, atol=1e-9 * max(1.0, float(np.abs(t).max()))):
            raise LogFormatError(
                f"{path}: {chosen[first]} and {chosen[name]} are on different time bases ({t.size} stamps from "
                f"{t[0]:.6g} s to {t[-1]:.6g} s against {other.size} from {other[0]:.6g} s to {other[-1]:.6g} s); "
                "expected one time base for alpha, beta, u1 and u2 (resample them onto one in MATLAB first)")
    return t, f"{chosen[first]}'s time ({note})"


def _fixed_step(t: np.ndarray, where: str, path: Path) -> None:
    """A variable-step solver's time base (Simulink's default) is named as such: it is not a sampled log."""
    steps = np.diff(t)
    if steps.size < 10:
        return
    lo, mid, hi = np.percentile(steps, [10, 50, 90])
    if not (lo > 0.5 * hi and steps.min() > 1e-3 * mid):
        raise LogFormatError(f"{path}: {where} is a variable-step time base (steps from {steps.min():.3g} s to "
                             f"{steps.max():.3g} s, median {np.median(steps):.3g} s): a variable-step solver's "
                             "output, not a sampled log; expected a fixed sample time (log with a fixed-step solver "
                             "or a sample time on the logging block)")


def describe_mat(path: str | Path) -> dict:
    """What ``inspect`` shows for a .mat: every signal with its path, size and time base, and a mapping."""
    path = Path(path)
    check_readable(path)
    tree, warned = _tree(path)
    entries = _entries(tree)
    listed = []
    for e in entries:
        n, k = e.shape
        row = {"path": e.path, "class": e.klass, "samples": n, "columns": k}
        if isinstance(e.node, Series) and e.node.time_s is not None:
            t = e.node.time_s
            steps = np.diff(t)
            mid = float(np.median(steps)) if steps.size else None
            spread = float(max(steps.max() - mid, mid - steps.min())) / mid if mid else 0.0
            row.update(time=e.node.time_note, t0_s=float(t[0]), t1_s=float(t[-1]), median_step_s=mid,
                       uniform=bool(steps.size and spread <= 1e-6),
                       steps="uniform" if spread <= 1e-6 else "jittered" if spread <= JITTER_TOLERANCE else "variable")
        if isinstance(e.node, Series) and e.node.name and e.node.name != e.name:
            row["name"] = e.node.name
        listed.append(row)
    found = {name: _find(entries, name) for name in ("t", *SIGNALS)}
    doc = {"file": str(path), "bytes": path.stat().st_size, "signals": listed,
           "suggested_signals": {k: f"{k}={v}" for k, (v, _) in found.items() if v},
           "missing": [k for k, (v, c) in found.items() if v is None and not c],
           "ambiguous": {k: c for k, (v, c) in found.items() if v is None and c},
           "undecoded": [{"path": p, "class": u.klass, "why": u.why} for p, u in _undecoded(tree)],
           "warnings": warned}
    timed = {r["path"] for r in listed if "time" in r}
    if any(v in timed for v, _ in found.values()):  # the signals carry their own time base: read it, not a t
        doc["suggested_signals"].pop("t", None)
        if "t" in doc["missing"]:
            doc["missing"].remove("t")
    return doc
