"""A MATLAB .mat file as a tree of signals: what each MATLAB class means, nothing about TRMS logs.

mat-io (``matio.load_from_mat``) decodes v4, v5/v7 and v7.3 files, MATLAB class objects (MCOS) included, into
numpy arrays, record arrays (structs), object arrays (cells) and ``MatlabOpaque`` objects whose ``properties``
hold the stored properties; tables and timetables come back as pandas DataFrames. ``load`` turns that into a
tree of four node types, so that a path such as ``out.logsout.alpha`` or ``pitch_step_pitch:2`` means one thing:

* ``Struct`` (a dict with the MATLAB class it came from): struct fields, an object's meaningful parts;
* ``list``: struct arrays and cell arrays;
* ``Series``: sampled data with its own time base (a ``timeseries``, a Dataset ``Signal``'s values, a timetable
  column, a "Structure With Time" signal);
* ``numpy.ndarray``: plain numeric arrays;
* ``Undecoded``: an object mat-io could not decode (its class is kept for the error message).

The classes given a meaning: ``timeseries`` (``Data_`` and ``Time_``, or a uniform time kept as ``Start_`` +
``Increment_`` x ``Length`` in ``TimeInfo``), ``Simulink.SimulationOutput`` (its logged variables, ``tout``,
``yout``, ``logsout``), ``Simulink.SimulationData.Dataset`` (its elements by name), a Dataset element
(``Simulink.SimulationData.Signal``: its ``Values``), ``table`` (columns by name), ``timetable`` (columns by
name, on the row times) and Simulink's "Structure With Time" (``time`` + ``signals(i).values``, each signal
also reachable by its ``label`` or ``blockName``).  Any other object is read as a struct of its properties.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: timeseries TimeInfo.Units -> seconds
TIME_UNITS_S = {"seconds": 1.0, "milliseconds": 1e-3, "microseconds": 1e-6, "nanoseconds": 1e-9, "minutes": 60.0,
                "hours": 3600.0, "days": 86400.0}
_NAME = re.compile(r"[^A-Za-z0-9_]+")
#: parts of Simulink objects that hold no signals (metadata, diagnostics)
_SKIP_PROPERTIES = {"Metadata", "ErrorMessage", "FileSignatures", "DataInfo", "QualityInfo", "Events", "UserData",
                    "BlockPath", "ModelInfo", "TimingInfo", "ExecutionInfo"}


class Struct(dict):
    """Named fields; ``klass`` is the MATLAB class the fields came from ('struct' for a plain struct)."""

    def __init__(self, items=(), klass: str = "struct"):
        super().__init__(items)
        self.klass = klass


@dataclass
class Series:
    """Samples with their own time base: ``values`` (n,) or (n, k), ``time_s`` (n,) [s] or None."""

    values: np.ndarray
    time_s: np.ndarray | None
    klass: str
    time_note: str = ""  # how the time base was stored ("uniform: start 0 s, increment 0.01 s")
    name: str = ""

    @property
    def samples(self) -> int:
        return int(self.values.shape[0])


@dataclass
class Undecoded:
    klass: str
    why: str = field(default="")


class MatReadFailure(Exception):
    """The file is not a .mat mat-io can read (the message says why)."""


def _matio():
    """mat-io, imported without its side effects: at import it sets pandas' ``future.infer_string`` (pandas 3
    warns that the option is deprecated); the option is put back, so reading a .mat changes no CSV read after it."""
    import pandas as pd

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        before = pd.get_option("future.infer_string")
        import matio
        from matio.utils.matclass import MatlabOpaque
        pd.set_option("future.infer_string", before)
    return matio, MatlabOpaque


def load(path: Path) -> tuple[Struct, list[str]]:
    """The file's variables as a tree, and the warnings mat-io raised while reading (kept, not printed)."""
    with open(path, "rb") as f:
        head = f.read(8)
    if head == b"\x89HDF\r\n\x1a\n":  # HDF5 without MATLAB's 512-byte header: not written by MATLAB
        return _bare_hdf5(path), []
    matio, _ = _matio()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            raw = matio.load_from_mat(str(path))
        except Exception as exc:  # mat-io raises its own, numpy's and h5py's errors: one message for all
            raise MatReadFailure(f"{type(exc).__name__}: {exc}") from None
        with np.errstate(all="ignore"):
            tree = Struct({str(k): _node(v) for k, v in raw.items() if not str(k).startswith("__")}, "file")
    return tree, sorted({f"{w.category.__name__}: {w.message}" for w in caught})


def _bare_hdf5(path: Path) -> Struct:
    import h5py

    def node(x, root):
        if isinstance(x, h5py.Group):
            return Struct({k: node(x[k], root) for k in x.keys()})
        data = x[()]
        if x.dtype == h5py.ref_dtype:  # cell arrays: references
            return [node(root[r], root) for r in np.ravel(data)]
        return np.asarray(data).T  # MATLAB stores column-major

    try:
        with h5py.File(path, "r") as h:
            return Struct({k: node(h[k], h) for k in h.keys() if not k.startswith("#")}, "file")
    except (OSError, ValueError) as exc:
        raise MatReadFailure(f"an HDF5 file h5py cannot read ({exc})") from None


def _node(x):
    """One decoded value as a tree node (None: nothing numeric in it)."""
    import pandas as pd

    _, MatlabOpaque = _matio()
    if isinstance(x, MatlabOpaque):
        return _object(x.classname, x.properties)
    if isinstance(x, pd.DataFrame):  # mat-io's table and timetable
        return _frame(x)
    if isinstance(x, dict):
        return Struct({str(k): _node(v) for k, v in x.items()})
    if not isinstance(x, np.ndarray):
        return None
    klass = getattr(x, "classname", None)
    if x.dtype.names:  # a struct (or an old-style class object): one element a Struct, several a list
        items = [Struct({n: _node(e[n]) for n in x.dtype.names}, klass or "struct") for e in x.ravel()]
        items = [_structure_with_time(s) for s in items]
        return items[0] if len(items) == 1 else items
    if x.dtype == object:  # a cell array, or an array of objects
        items = [_node(e) for e in x.ravel()]
        return items[0] if len(items) == 1 and klass else items
    if x.dtype.kind in "biuf":
        return x
    if x.dtype.kind == "U":
        return _text(x)  # kept for labels and names; never a signal
    return None  # dates and the like carry no signal


def _object(klass: str, props) -> object:
    if not isinstance(props, dict):
        return Undecoded(klass, "mat-io returned no properties for it")
    if klass == "timeseries":
        return _timeseries(props)
    if klass == "Simulink.SimulationOutput":
        data = _node(props.get("Data"))  # the logged variables, by name
        out = Struct(data if isinstance(data, Struct) else {}, klass)
        out.update({k: _node(v) for k, v in props.items() if k not in _SKIP_PROPERTIES and k != "Data"})
        return out
    if klass == "Simulink.SimulationData.Dataset" or klass.endswith("DatasetStorage"):
        out = Struct({}, klass)
        for i, (name, element) in enumerate(_elements(props)):
            out[_unique(out, _key(name) or f"element{i}")] = element
        return out
    if "Values" in props:  # a Dataset element (Simulink.SimulationData.Signal and its kin)
        values = _node(props["Values"])
        if isinstance(values, Series):
            values.name = values.name or _text(props.get("Name"))
        return values
    return Struct({k: _node(v) for k, v in props.items() if k not in _SKIP_PROPERTIES}, klass)


def _elements(props: dict):
    """(name, node) of every element a Dataset holds, wherever its storage keeps them."""
    _, MatlabOpaque = _matio()

    def walk(x):
        if isinstance(x, MatlabOpaque) and isinstance(x.properties, dict):
            if "Values" in x.properties:
                p = x.properties
                yield _text(p.get("Name")) or _text(p.get("PropagatedName")), _object(x.classname, p)
            else:
                for v in x.properties.values():
                    yield from walk(v)
        elif isinstance(x, np.ndarray) and x.dtype == object:
            for v in x.ravel():
                yield from walk(v)
        elif isinstance(x, np.ndarray) and x.dtype.names:
            for e in x.ravel():
                for n in x.dtype.names:
                    yield from walk(e[n])

    for k, v in props.items():
        if k not in _SKIP_PROPERTIES:
            yield from walk(v)


def _timeseries(props: dict):
    data = props.get("Data_")
    if data is None:
        data = props.get("Data")
    data = np.asarray(data if data is not None else [], dtype=float)
    info = props.get("TimeInfo")
    info = info.properties if hasattr(info, "properties") and isinstance(info.properties, dict) else {}
    unit = _text(info.get("Units")) or "seconds"
    scale = TIME_UNITS_S.get(unit.lower())
    time, note = None, ""
    for stamps in (props.get("Time_"), props.get("Time"), info.get("Time_")):
        if stamps is not None and np.size(stamps):
            time, note = np.ravel(np.asarray(stamps, dtype=float)), f"own stamps [{unit}]"
            break
    length = _scalar(info.get("Length"))
    start, step = _scalar(info.get("Start_")), _scalar(info.get("Increment_"))
    if time is None and length and step is not None:
        time = (start or 0.0) + step * np.arange(int(length))
        note = f"uniform: start {start or 0.0:g}, increment {step:g} [{unit}]"
    n = time.size if time is not None else (int(length) if length else None)
    if data.ndim > 2 or (n is not None and data.ndim == 2 and data.shape[0] != n and data.shape[-1] == n):
        data = np.moveaxis(data, -1, 0).reshape(data.shape[-1], -1)  # time last (IsTimeFirst_ false)
    if data.ndim == 2 and data.shape[1] == 1:
        data = data[:, 0]
    if time is not None and scale is None:
        return Undecoded("timeseries", f"its time unit {unit!r} is not one of {', '.join(TIME_UNITS_S)}")
    return Series(data, None if time is None else time * scale, "timeseries", note, _text(props.get("Name")))


def _frame(df):
    """A table (columns by name) or a timetable (columns on the row times, in seconds from the first row)."""
    import pandas as pd

    index = df.index
    time, note, klass = None, "", "table"
    if isinstance(index, pd.TimedeltaIndex):
        time, note, klass = index.total_seconds().to_numpy(), "row times (duration)", "timetable"
    elif isinstance(index, pd.DatetimeIndex):
        time = (index - index[0]).total_seconds().to_numpy()
        note, klass = f"row times from {index[0]}", "timetable"
    out = Struct({}, klass)
    for name in df.columns:
        col = df[name]
        if col.dtype.kind not in "biuf":
            continue
        values = col.to_numpy(dtype=float)
        out[_unique(out, _key(str(name)) or "column")] = values if time is None else Series(values, time, klass, note)
    return out


def _structure_with_time(s: Struct):
    """Simulink's "Structure With Time": ``signals(i).values`` on ``time``; each signal also by its label."""
    time, signals = s.get("time"), s.get("signals")
    if not isinstance(time, np.ndarray) or signals is None:
        return s
    signals = signals if isinstance(signals, list) else [signals]
    if not all(isinstance(x, Struct) and isinstance(x.get("values"), np.ndarray) for x in signals):
        return s
    t = np.ravel(time).astype(float)
    series = [Series(_columns(x["values"], t.size), t, "Structure With Time", "the structure's time") for x in signals]
    out = Struct({"time": time, "signals": series}, "Structure With Time")
    for x, ser in zip(signals, series):
        name = _key(x.get("label") or str(x.get("blockName") or "").rsplit("/", 1)[-1])
        if name and name not in out:
            out[name] = ser
            ser.name = name
    return out


def _columns(values: np.ndarray, n: int) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.ndim == 2 and v.shape[1] == 1:
        return v[:, 0]
    if v.ndim == 2 and v.shape[0] != n and v.shape[1] == n:
        return v.T
    return v


def _key(name) -> str:
    """A name usable in a path (``--signal alpha=out.logsout.<name>``)."""
    name = _NAME.sub("_", str(name or "")).strip("_")
    return ("_" + name) if name[:1].isdigit() else name


def _unique(d: dict, name: str) -> str:
    k, i = name, 1
    while k in d:
        i += 1
        k = f"{name}_{i}"
    return k


def _text(x) -> str:
    if isinstance(x, str):
        return x
    if isinstance(x, np.ndarray) and x.dtype.kind == "U" and x.size:
        return str(x.ravel()[0])
    return ""


def _scalar(x) -> float | None:
    if x is None or not np.size(x):
        return None
    v = np.ravel(np.asarray(x, dtype=float))
    return float(v[0]) if v.size == 1 else None
