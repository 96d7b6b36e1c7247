"""CSV logs: header ``t,u1,u2,alpha,beta`` (any order, case-insensitive), one row per sample.

An optional column ``t_u`` gives the time each row's voltages took effect (in the unit of ``t``, within the
row's sample interval), for loggers that stamp voltages apart from the angles.

Also accepted: a UTF-8 byte-order mark, ``;`` or tab as delimiter, and an optional unit
row under the header (``s,V,V,rad,rad``; ``deg`` for angles and ``ms`` for time are
converted).  Messages name the file's own line numbers.
"""
from __future__ import annotations

import hashlib
import io
import math
import threading
from pathlib import Path

import numpy as np

from .._memory import give_back
from ..errors import InputNotFoundError, LogFormatError, SettingsError
from ..log import COLUMNS, VOLTAGE_TIME, Log, validated
from .atomic import atomic_path
from .signals import held_note

UNIT_SCALE = {
    "t": {"s": 1.0, "ms": 1e-3},
    "u1": {"v": 1.0},
    "u2": {"v": 1.0},
    "alpha": {"rad": 1.0, "deg": math.pi / 180},
    "beta": {"rad": 1.0, "deg": math.pi / 180},
}


def check_readable(path: Path) -> None:
    if not path.exists():
        raise InputNotFoundError(f"{path}: no such file")
    if path.is_dir():
        raise LogFormatError(f"{path}: is a folder; expected a log file")
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        raise InputNotFoundError(f"{path}: cannot read ({exc.strerror or exc})") from None


def read_bytes(path: Path) -> bytes:
    check_readable(path)
    return path.read_bytes()


class Sha256Thread(threading.Thread):
    """Hash a file in the background (hashlib releases the GIL) while it is being parsed."""

    def __init__(self, path: Path):
        super().__init__(daemon=True)
        self.path, self.hexdigest = path, None

    def run(self) -> None:
        h = hashlib.sha256()
        buf = memoryview(bytearray(1 << 20))  # one buffer refilled: no fresh 4 MB object per read
        with open(self.path, "rb", buffering=0) as f:
            while size := f.readinto(buf):
                h.update(buf[:size])
        self.hexdigest = h.hexdigest()

    def result(self) -> str:
        self.join()
        return self.hexdigest


def _is_number(token: str) -> bool:
    try:
        float(token)
        return True
    except ValueError:
        return False


def _mapped(names: list[str], signals: list[str] | None, path: Path) -> list[str]:
    """Header names with ``--signal NAME=COLUMN`` applied (NAME one of t, u1, u2, alpha, beta, t_u)."""
    header, names = list(names), list(names)
    for text in signals or []:
        name, sep, column = (x.strip() for x in text.partition("="))
        if not sep or name not in (*COLUMNS, VOLTAGE_TIME):
            raise SettingsError(f"--signal {text!r}: expected NAME=COLUMN with NAME one of "
                                f"{', '.join((*COLUMNS, VOLTAGE_TIME))}")
        if column.lower() not in names:
            raise LogFormatError(f"{path}: line 1: no column {column!r} (for {name}); columns: {', '.join(header)}")
        if name in names and names.index(name) != names.index(column.lower()):
            names[names.index(name)] = f"_unused_{name}"  # the file's own column of that name steps aside
        names[names.index(column.lower())] = name
    return names


def read_csv_log(path: str | Path, angle_unit: str = "auto", time_unit: str = "auto",
                 signals: list[str] | None = None, held: dict[str, float] | None = None) -> Log:
    """Read and validate a CSV log; ``angle_unit="deg"`` converts angle columns from degrees, "rad" says they
    are radians (no guess); ``time_unit`` s, ms, us or auto (see log.validated).  A unit row overrides both.
    ``held``: inputs not logged, held at a constant [V] (io.signals.held_constants: ``--signal u2=0``)."""
    held = held or {}
    path = Path(path)
    check_readable(path)
    hasher = Sha256Thread(path)
    hasher.start()
    with open(path, "rb") as f:
        head = f.read(65536)
    try:
        text_head = head.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise LogFormatError(f"{path}: not a text file; expected a CSV log with header "
                             f"{','.join(COLUMNS)}") from None
    lines = text_head.splitlines()
    if not head.strip() or not lines:
        raise LogFormatError(f"{path}: file is empty; expected a header line {','.join(COLUMNS)}")
    header = lines[0]
    delim = max((",", ";", "\t"), key=header.count)
    names = _mapped([c.strip().strip('"').strip().lower() for c in header.split(delim)], signals, path)
    missing = [c for c in COLUMNS if c not in names and c not in held]
    if missing:
        off = [c for c in missing if c in ("u1", "u2")]
        raise LogFormatError(f"{path}: line 1: missing column(s) {', '.join(missing)}; expected a header "
                             f"with {','.join(COLUMNS)} (found: {','.join(names) or 'nothing'})"
                             + (f"; map a column with --signal NAME=COLUMN, or {off[0]}=0 if that motor was off "
                                "and its input not logged" if off else ""))
    dup = sorted({c for c in names if names.count(c) > 1 and c in COLUMNS})
    if dup:
        raise LogFormatError(f"{path}: line 1: column(s) {', '.join(dup)} appear twice; expected each once")
    scale = {c: 1.0 for c in COLUMNS}
    if angle_unit == "deg":
        scale["alpha"] = scale["beta"] = math.pi / 180
    first_data_line = 2
    meta = {"format": "csv", "delimiter": delim}
    if len(lines) > 1:
        tokens = [x.strip() for x in lines[1].split(delim)]
        if tokens and not any(_is_number(x) for x in tokens if x):
            for c in (c for c in COLUMNS if c not in held):
                unit = tokens[names.index(c)].strip("[]() ").lower() if names.index(c) < len(tokens) else ""
                if unit not in UNIT_SCALE[c]:
                    raise LogFormatError(f"{path}: line 2: unit {unit!r} for column {c}; expected one of "
                                         f"{', '.join(UNIT_SCALE[c])}")
                scale[c] = UNIT_SCALE[c][unit]
            first_data_line = 3
            angle_unit, time_unit = "rad", "s"  # the file says its units: converted above, nothing guessed
            ua, ub = (tokens[names.index(c)].strip("[]() ").lower() for c in ("alpha", "beta"))
            angles = (ua if ua == ub else f"alpha {ua}, beta {ub}") + " (the file's units row)"
            meta["units"] = {"angles": angles + (", converted to rad" if "deg" in (ua, ub) else ""),
                             "inputs": "V (the file's units row)"}
    wanted = tuple(c for c in COLUMNS if c not in held) + ((VOLTAGE_TIME,) if VOLTAGE_TIME in names else ())
    parsed = _parse_fast(path, names, delim, first_data_line, wanted)
    if parsed is None:  # something is off: the slow parser names the line and cell
        parsed = _parse_located(path, delim, first_data_line, wanted, names)
    if held:
        parsed.update({c: np.full(parsed["t"].size, v) for c, v in held.items()})
        meta.update(held_note(held))
    cols = [parsed[c] * scale[c] if scale[c] != 1.0 else parsed[c] for c in COLUMNS]
    t_u = parsed.get(VOLTAGE_TIME)
    return validated(*cols, source=str(path), sha256=hasher.result(),
                     locate=lambda i: f"line {i + first_data_line}",
                     meta=meta, angle_unit=angle_unit, time_unit=time_unit,
                     u_switch_s=None if t_u is None else np.repeat((t_u * scale["t"])[:, None], 2, axis=1))


#: bytes pyarrow parses at a time: small blocks keep the parse buffers small (the columns are copied out of
#: each block as it comes) and, measured on an hour at 1 kHz, parse faster than 16 MB ones
BLOCK_BYTES = 1 << 19


def _parse_fast(path: Path, names: list[str], delim: str, first_data_line: int,
                wanted: tuple = COLUMNS) -> dict | None:
    """pyarrow's streaming parser, block by block into columns sized from the file's length (an hour at 1 kHz
    peaked at 550 MB read whole as a table, 235 MB streamed); None when the file is not clean."""
    import pyarrow as pa
    import pyarrow.csv as pc

    unique = [n if n in wanted else f"_extra{i}" for i, n in enumerate(names)]
    cols = {c: np.empty(_expected_rows(path)) for c in wanted}
    n = blocks = 0
    try:
        reader = pc.open_csv(
            path,
            read_options=pc.ReadOptions(column_names=unique, skip_rows=first_data_line - 1, block_size=BLOCK_BYTES),
            parse_options=pc.ParseOptions(delimiter=delim, ignore_empty_lines=False),
            convert_options=pc.ConvertOptions(column_types={c: pa.float64() for c in wanted},
                                              include_columns=list(wanted)),
            memory_pool=pa.system_memory_pool())  # frees each block's buffers at once (mimalloc kept ~50 MB)
        for batch in reader:
            m = batch.num_rows
            if n + m > cols[wanted[0]].size:  # more rows than the length foretold: grow by a quarter
                size = max(n + m, int(1.25 * cols[wanted[0]].size))
                for c in wanted:
                    grown = np.empty(size)
                    grown[:n] = cols[c][:n]
                    cols[c] = grown
            for c in wanted:
                _into(batch.column(c), cols[c][n:n + m])
            n += m
            del batch
            if (blocks := blocks + 1) % 32 == 0:
                pa.default_memory_pool().release_unused()  # the reader's own buffers (mimalloc keeps them)
    except (pa.ArrowInvalid, pa.ArrowKeyError, UnicodeDecodeError):
        return None
    finally:
        pa.default_memory_pool().release_unused()
        give_back()
    return {c: v[:n] for c, v in cols.items()}


def _expected_rows(path: Path, probes: int = 8, probe_bytes: int = 1 << 16) -> int:
    """The file's row count foretold from the density of line ends in ``probes`` samples spread over the file
    (the densest one counts: a log whose first rows are long and the rest short would otherwise be foretold
    short).  An over-estimate costs nothing (pages of np.empty never written are never resident); an
    under-estimate makes the reader grow its columns, with old and new copies alive at once."""
    size = path.stat().st_size
    density = 0.0
    with open(path, "rb") as f:
        for i in range(probes):
            f.seek(i * max(size - probe_bytes, 0) // max(probes - 1, 1))
            chunk = f.read(probe_bytes)
            if chunk:
                density = max(density, chunk.count(b"\n") / len(chunk))
    return int(1.02 * size * density) + 1024


def _into(array, out: np.ndarray) -> None:
    """Copy one float64 pyarrow array into ``out`` through a view of its data buffer (Array.to_numpy() makes
    pyarrow import pandas, 0.6 s); nulls (empty cells) become NaN, which the validator reports with their line."""
    data = array.buffers()[1]
    if data is None:  # a block of empty cells only
        out[:] = np.nan
        return
    out[:] = np.frombuffer(data, dtype=np.float64)[array.offset:array.offset + len(array)]
    if array.null_count:
        out[np.asarray(array.is_null(), dtype=bool)] = np.nan


def _parse_located(path: Path, delim: str, first_data_line: int, wanted: tuple = COLUMNS,
                   names: list[str] | None = None) -> dict:
    """pandas, cell by cell when needed: slow, but it names the first bad line and cell."""
    import pandas as pd

    raw = read_bytes(path)
    opts = dict(sep=delim, encoding="utf-8-sig", skiprows=range(1, first_data_line - 1),
                skip_blank_lines=False, skipinitialspace=True)
    try:
        frame = pd.read_csv(io.BytesIO(raw), dtype=np.float64, **opts)
    except pd.errors.ParserError as exc:
        raise LogFormatError(f"{path}: {str(exc).strip().splitlines()[-1]}; expected {len(COLUMNS)} or more "
                             "fields on every line, as many as the header") from None
    except (ValueError, TypeError):
        frame = None
    if frame is None:
        frame = pd.read_csv(io.BytesIO(raw), dtype=str, keep_default_na=False, **opts)
        frame.columns = names or [c.strip().lower() for c in frame.columns]
        for c in wanted:
            cells = frame[c].str.strip()
            num = pd.to_numeric(cells, errors="coerce")
            bad = np.flatnonzero(num.isna().to_numpy() & (cells != "").to_numpy() &
                                 ~cells.str.lower().isin(["nan", "inf", "-inf"]).to_numpy())
            if bad.size:
                i = int(bad[0])
                raise LogFormatError(f"{path}: line {i + first_data_line}: column {c} holds "
                                     f"{cells.iloc[i]!r}; expected a number")
        raise LogFormatError(f"{path}: cannot parse as numbers; expected numeric columns {','.join(COLUMNS)}")
    frame.columns = names or [c.strip().lower() for c in frame.columns]
    logged = [c for c in wanted if c in COLUMNS]  # an input held at a constant (--signal u2=0) is not in the file
    blank = np.flatnonzero(frame[logged].isna().all(axis=1).to_numpy())
    if blank.size:
        raise LogFormatError(f"{path}: line {int(blank[0]) + first_data_line} is empty; expected "
                             f"{len(logged)} numbers")
    return {c: frame[c].to_numpy(dtype=float) for c in wanted}


def write_csv_log(path: str | Path, t_s, u1_v, u2_v, alpha_rad, beta_rad, u_t_s=None) -> None:
    """Write a log atomically; every double round-trips exactly (shortest repr).  ``u_t_s``: when each row's
    voltages took effect [s], written as the optional column t_u (omitted when None)."""
    cols = dict(zip(COLUMNS, (t_s, u1_v, u2_v, alpha_rad, beta_rad)))
    if u_t_s is not None:
        cols[VOLTAGE_TIME] = u_t_s
    write_columns(path, cols)


def write_columns(path: str | Path, columns: dict[str, np.ndarray]) -> None:
    """Numeric columns to CSV, atomically, with pyarrow's writer (exact round trip)."""
    import pyarrow as pa
    import pyarrow.csv as pc

    arrays = [np.ascontiguousarray(v, dtype=np.float64) for v in columns.values()]
    # from raw buffers: pa.array(ndarray) would make pyarrow import pandas (0.3-0.6 s)
    table = pa.Table.from_arrays([pa.Array.from_buffers(pa.float64(), a.size, [None, pa.py_buffer(a)]) for a in arrays],
                                 names=list(columns))
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write((",".join(columns) + "\n").encode())  # pyarrow would quote the names
            pc.write_csv(table, f, write_options=pc.WriteOptions(include_header=False, quoting_style="none"))


def truth_path(log_path: str | Path) -> Path:
    """Sidecar ground-truth file of a simulated log: ``name.csv`` -> ``name.truth.json``."""
    p = Path(log_path)
    return p.with_name(p.name.split(".")[0] + ".truth.json")
