"""MATLAB logs: .mat v5/v7 (scipy.io) and v7.3 (HDF5, h5py).

What a lab's .mat holds, and how each becomes a log (t [s], u1, u2 [V], alpha, beta [rad]):
* named column vectors: found by name or a common alias (ALIASES, case-insensitive), e.g. the Humusoft CE150's
  psi/phi/u1/u2;
* a matrix: one signal per column, mapped with ``--signal alpha=data[2]`` (0-based column);
* a Simulink "Structure With Time" (``time`` and ``signals(i).values``) or a struct field: ``--signal
  alpha=yout.signals[1]`` (the i-th signal's values, 0-based) or ``--signal alpha=logs.pitch``.
The time vector is ``t``/``time``/``tout`` (or the structure's ``time``); a file without one needs ``--rate HZ``.
MATLAB timeseries/timetable objects are stored as opaque class objects: export them as vectors first.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import LogFormatError, SettingsError
from ..log import Log, validated
from .csv_log import Sha256Thread, check_readable

SIGNALS = ("alpha", "beta", "u1", "u2")
ALIASES = {
    "t": ("t", "time", "tout", "t_s"),
    "alpha": ("alpha", "pitch", "psi", "elevation", "theta_v", "thtv", "alpha_rad"),
    "beta": ("beta", "yaw", "phi", "azimuth", "theta_h", "thth", "beta_rad"),
    "u1": ("u1", "u_main", "um", "uv", "u1_v"),
    "u2": ("u2", "u_tail", "ut", "uh", "u2_v"),
}
_PATH = re.compile(r"^(?P<var>[A-Za-z_]\w*)(?P<rest>(\.[A-Za-z_]\w*|\[\d+\])*)$")


def _load(path: Path) -> dict:
    """Variables of a .mat file as nested dicts / numpy arrays."""
    with open(path, "rb") as f:
        head = f.read(128)
    if head[:8] == b"\x89HDF\r\n\x1a\n" or b"MATLAB 7.3" in head:
        try:
            import h5py
        except ImportError:  # pragma: no cover - h5py is a dependency
            raise LogFormatError(f"{path}: a MATLAB v7.3 (HDF5) file; reading it needs h5py") from None
        with h5py.File(path, "r") as h:
            return {k: _h5(h[k], h) for k in h.keys() if not k.startswith("#")}
    import scipy.io

    try:
        raw = scipy.io.loadmat(path, simplify_cells=True)
    except (ValueError, NotImplementedError, OSError) as exc:
        raise LogFormatError(f"{path}: not a readable MATLAB .mat file ({exc}); expected v5, v7 or v7.3") from None
    return {k: v for k, v in raw.items() if not k.startswith("__")}


def _h5(node, root):
    import h5py

    if isinstance(node, h5py.Group):
        return {k: _h5(node[k], root) for k in node.keys()}
    data = node[()]
    if node.dtype == h5py.ref_dtype:  # cell arrays: references
        return [_h5(root[r], root) for r in np.ravel(data)]
    return np.asarray(data).T  # MATLAB stores column-major


def _vector(v, where: str, path: Path) -> np.ndarray:
    a = np.asarray(v)
    if a.dtype == object or not np.issubdtype(a.dtype, np.number):
        raise LogFormatError(f"{path}: {where} is not numeric (a MATLAB object?); expected a numeric vector "
                             "(export timeseries/timetable data as plain vectors)")
    a = np.squeeze(a).astype(float)
    if a.ndim != 1:
        raise LogFormatError(f"{path}: {where} has shape {np.shape(v)}; expected a vector (map a matrix column with "
                             f"--signal NAME={where}[COLUMN])")
    return a


def _resolve(variables: dict, text: str, path: Path) -> np.ndarray:
    """``var``, ``var[col]``, ``struct.field``, ``struct.signals[i]`` (Simulink: the i-th signal's values)."""
    m = _PATH.match(text)
    if not m or m["var"] not in variables:
        raise LogFormatError(f"{path}: no variable {text.split('.')[0].split('[')[0]!r}; variables: "
                             f"{', '.join(sorted(variables)) or 'none'}")
    node = variables[m["var"]]
    for part in re.findall(r"\.\w+|\[\d+\]", m["rest"]):
        if part.startswith("."):
            if not isinstance(node, dict) or part[1:] not in node:
                raise LogFormatError(f"{path}: {text}: no field {part[1:]!r}")
            node = node[part[1:]]
        else:
            i = int(part[1:-1])
            if isinstance(node, list):
                node = node[i]
            else:
                arr = np.asarray(node)
                if arr.ndim != 2 or i >= arr.shape[1]:
                    raise LogFormatError(f"{path}: {text}: column {i} of a {arr.shape} array; expected a matrix "
                                         "with that column (0-based)")
                node = arr[:, i]
        if isinstance(node, dict) and "values" in node:  # a Simulink signal struct
            node = node["values"]
    return _vector(node, text, path)


def _find(variables: dict, name: str) -> str | None:
    low = {k.lower(): k for k in variables}
    return next((low[a] for a in ALIASES[name] if a in low), None)


def read_mat_log(path: str | Path, angle_unit: str = "auto", time_unit: str = "auto",
                 signals: list[str] | None = None, rate_hz: float | None = None) -> Log:
    """Read a MATLAB log (see the module docstring); ``signals``: NAME=PATH mappings; ``rate_hz``: the sample
    rate when the file has no time vector."""
    path = Path(path)
    check_readable(path)
    hasher = Sha256Thread(path)
    hasher.start()
    variables = _load(path)
    chosen = {}
    for text in signals or []:
        name, sep, where = text.partition("=")
        name = name.strip()
        if not sep or name not in (*SIGNALS, "t"):
            raise SettingsError(f"--signal {text!r}: expected NAME=VARIABLE with NAME one of t, alpha, beta, u1, u2 "
                                "(VARIABLE: var, var[column], struct.field or struct.signals[i])")
        chosen[name] = where.strip()
    cols = {}
    for name in SIGNALS:
        where = chosen.get(name) or _find(variables, name)
        if where is None:
            raise LogFormatError(f"{path}: no variable for {name} (looked for {', '.join(ALIASES[name])}); "
                                 f"variables: {', '.join(sorted(variables))}; map it with --signal {name}=VARIABLE")
        cols[name] = _resolve(variables, where, path)
        chosen[name] = where
    n = cols["alpha"].size
    for name, a in cols.items():
        if a.size != n:
            raise LogFormatError(f"{path}: {chosen[name]} has {a.size} samples, {chosen['alpha']} has {n}; "
                                 "expected one value per sample for every signal")
    t_where = chosen.get("t") or _find(variables, "t")
    if t_where is None:
        for v in variables.values():  # a Simulink structure with time
            if isinstance(v, dict) and "time" in v and np.size(v["time"]) == n:
                t_where, t = "structure time", _vector(v["time"], "time", path)
                break
    if t_where is not None and t_where != "structure time":
        t = _resolve(variables, t_where, path)
    if rate_hz is not None:
        if not rate_hz > 0:
            raise SettingsError(f"--rate {rate_hz}: expected a sample rate > 0 [Hz]")
        t, t_where = np.arange(n) / rate_hz, f"--rate {rate_hz:g} Hz"
    elif t_where is None:
        raise LogFormatError(f"{path}: no time vector (looked for {', '.join(ALIASES['t'])}); pass the sample "
                             "rate with --rate HZ")
    if angle_unit == "deg":
        cols["alpha"], cols["beta"] = np.radians(cols["alpha"]), np.radians(cols["beta"])
    meta = {"format": "mat", "signals": " ".join(f"{k}={chosen[k]}" for k in SIGNALS), "time": t_where}
    return validated(t, cols["u1"], cols["u2"], cols["alpha"], cols["beta"], source=str(path),
                     sha256=hasher.result(), meta=meta, angle_unit=angle_unit,
                     time_unit="s" if rate_hz is not None else time_unit)


def describe_mat(path: str | Path) -> dict:
    """What ``inspect`` shows for a .mat: each variable's shape (struct fields one level down) and a mapping."""
    path = Path(path)
    check_readable(path)
    variables = _load(path)

    def shape(v):
        if isinstance(v, dict):
            return {k: shape(x) for k, x in v.items()}
        if isinstance(v, list):
            return f"cell/struct array of {len(v)}"
        return list(np.shape(v))

    found = {name: _find(variables, name) for name in ("t", *SIGNALS)}
    return {"file": str(path), "bytes": path.stat().st_size, "variables": {k: shape(v) for k, v in variables.items()},
            "suggested_signals": {k: f"{k}={v}" for k, v in found.items() if v},
            "missing": [k for k, v in found.items() if v is None]}
