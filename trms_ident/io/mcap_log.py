"""MCAP recordings: ROS 2 (CDR) or JSON messages, read into a Log; written by ``simulate``.

Default layout (no options needed):
  /trms/joint_states  sensor_msgs/msg/JointState, joints "pitch" and "yaw", position [rad]
  /trms/voltage       std_msgs/msg/Float64MultiArray, data = [u1, u2] [V]
or the same topics JSON-encoded: {"alpha":..,"beta":..} and {"u1":..,"u2":..}.
Anything else via ``--signal NAME=TOPIC:FIELD``.

The angles' timestamps are the log's time grid; the voltages are held (zero-order hold, as
the bench applies them) onto it.  Gaps and stale voltages are errors, never interpolated.
"""
from __future__ import annotations

import json
import math
import struct
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import LogFormatError, SettingsError
from ..log import Log, validated
from .atomic import atomic_path
from .cdr import (BIG_ENDIAN, FLOAT64_MULTIARRAY_MSGDEF, INDEX_OUT_OF_RANGE, JOINT_STATE_MSGDEF, NO_SUCH_JOINT, OK,
                  SHORT, decode_float64_multiarray, decode_joint_state, float64_multiarray_encoder,
                  joint_state_encoder, scan_chunk)
from .csv_log import Sha256Thread, check_readable
from .merge import lead_after_grid, place
from .signals import DEFAULT_JSON, DEFAULT_ROS2, SIGNALS, SignalSource, extract, mapping

TIME_SOURCES = ("auto", "header", "log", "publish")
#: when a voltage message takes effect: at its own time, inside the angle interval where it falls ("stamp"),
#: or from the next angle sample on ("next-sample": the voltage in force at each angle stamp, held over it)
VOLTAGE_TIMES = ("stamp", "next-sample")
JOINT_STATE = "sensor_msgs/msg/JointState"
MULTIARRAY = "std_msgs/msg/Float64MultiArray"
ENCODINGS = ("cdr", "json")
#: a voltage older than this many of its own median periods at an angle sample is stale
STALE_PERIODS = 3.0
MAGIC = b"\x89MCAP0\r\n"


@dataclass
class Channel:
    id: int
    topic: str
    message_encoding: str
    schema_name: str
    schema_encoding: str
    schema_data: bytes


@dataclass
class Series:
    """Decoded values of the wanted fields of one topic."""

    time_ns: list = field(default_factory=list)
    values: list = field(default_factory=list)  # arrays (n, k), views of field-major (k, n) memory
    clock: str = ""  # which time was used: header, log or publish


@dataclass
class Scan:
    channels: dict[int, Channel]
    counts: dict[int, int]
    first_ns: dict[int, int]
    last_ns: dict[int, int]
    series: dict[str, Series]
    warnings: list[str]
    chunk_compression: set


def _records(path: Path, fh, warnings: list[str]):
    """Top-level records of the data section (chunks not broken up), CRCs checked; a truncated file stops with a
    warning.

    The records are framed here (opcode, length) and only those this reader uses are parsed, by the mcap
    library's record classes: message indexes and other index records are read as bytes (for the data
    section's CRC) but never parsed; parsing them entry by entry in Python was 85 % of reading an MCAP log.
    Reading stops at DataEnd: the summary section repeats schemas and channels and holds indexes only."""
    import io
    import zlib

    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError
    from mcap.records import Channel as ChannelRecord
    from mcap.records import Chunk, DataEnd, Footer, Header, Message, Schema

    parse = {0x01: Header, 0x02: Footer, 0x03: Schema, 0x04: ChannelRecord, 0x06: Chunk, 0x0F: DataEnd}
    magic = fh.read(8)
    if magic != MAGIC:
        raise LogFormatError(f"{path}: not an MCAP file (the magic bytes are missing); expected an .mcap recording")
    crc = zlib.crc32(magic)

    def truncated(pos: int, why: str) -> None:
        warnings.append(f"the file ends early near byte {pos} ({why}): it looks truncated; using the messages read "
                        "before that point")

    while True:
        pos = fh.tell()
        head = fh.read(9)
        if len(head) < 9:
            truncated(pos, "EndOfFile")
            return
        op, length = head[0], int.from_bytes(head[1:9], "little")
        if length > 1 << 32:
            truncated(pos, f"a record of {length} bytes")
            return
        body = fh.read(length)
        if len(body) < length:
            truncated(pos, "EndOfFile")
            return
        if op == 0x0F:  # DataEnd: the data section's CRC covers everything before this record
            end = DataEnd.read(ReadDataStream(io.BytesIO(body)))
            if end.data_section_crc not in (0, crc):
                raise LogFormatError(f"{path}: CRC mismatch in the data section before byte {pos} (expected "
                                     f"{end.data_section_crc:#010x}, computed {crc:#010x}); the file is corrupt")
            return
        crc = zlib.crc32(body, zlib.crc32(head, crc))
        if op != 0x05 and op not in parse:
            continue  # message/chunk indexes, attachments, metadata, statistics: not needed
        try:
            stream = ReadDataStream(io.BytesIO(body))
            rec = Message.read(stream, length) if op == 0x05 else parse[op].read(stream)
        except (McapError, EOFError, ValueError, struct.error) as exc:
            truncated(pos, type(exc).__name__)
            return
        if op == 0x02:
            return
        yield rec


def scan(path: Path, wanted: dict[str, list[SignalSource]] | None, time_source: str = "auto") -> Scan:
    """Read every record; decode the wanted fields of the wanted topics (topic -> sources)."""
    from mcap.records import Channel as ChannelRecord
    from mcap.records import Chunk, Message, Schema
    from mcap.data_stream import ReadDataStream
    import io

    check_readable(path)
    with open(path, "rb") as fh:
        head = fh.read(8)
        if not head:
            raise LogFormatError(f"{path}: file is empty; expected an MCAP recording")
        if head != MAGIC:
            raise LogFormatError(f"{path}: not an MCAP file (the magic bytes are missing); expected an .mcap recording")
        fh.seek(0)
        warnings: list[str] = []
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        counts: dict[int, int] = {}
        first: dict[int, int] = {}
        last: dict[int, int] = {}
        series = {topic: Series() for topic in (wanted or {})}
        compression: set = set()
        decoders: dict[int, object] = {}

        def add_schema(s: Schema):
            schemas[s.id] = s

        def add_channel(c: ChannelRecord):
            s = schemas.get(c.schema_id)
            channels[c.id] = Channel(c.id, c.topic, c.message_encoding, s.name if s else "", s.encoding if s else "",
                                     s.data if s else b"")

        def count(ids, cnt, lo, hi) -> None:
            """Add a chunk's per-channel statistics (from scan_chunk) to the file's."""
            for cid, k, a, b in zip(ids.tolist(), cnt.tolist(), lo.tolist(), hi.tolist()):
                counts[cid] = counts.get(cid, 0) + k
                first[cid] = min(first.get(cid, a), a)
                last[cid] = max(last.get(cid, b), b)

        def add(decoded: dict) -> None:
            for topic, clock, t, vals in decoded.values():
                series[topic].clock = clock
                series[topic].time_ns.append(t)
                series[topic].values.append(vals)

        def take(pending_chunk) -> None:
            rec, fut = pending_chunk
            try:
                data, scanned, decoded = fut.result()
            except LogFormatError:
                raise
            except Exception as exc:  # noqa: BLE001 - CRC or decompression failure: the file is corrupt
                raise LogFormatError(f"{path}: chunk starting at log time {rec.message_start_time} ns cannot "
                                     f"be read ({type(exc).__name__}: {exc}); the file is corrupt") from None
            buf = np.frombuffer(data, dtype=np.uint8)
            ids, other, complete = scanned[0], scanned[9], scanned[10]
            if not complete:
                warnings.append("a chunk ends inside a record; using the complete records before it")
            for off in other:  # schemas and channels stored inside the chunk
                op, ln = buf[off], int.from_bytes(data[off + 1:off + 9], "little")
                rs = ReadDataStream(io.BytesIO(data[off + 9:off + 9 + ln]))
                if op == 0x03:
                    add_schema(Schema.read(rs))
                elif op == 0x04:
                    add_channel(ChannelRecord.read(rs))
            if ids.size:
                count(ids, *scanned[2:5])
                late = [c for c in ids.tolist() if c not in decoded]  # channels the worker did not know yet
                if late:
                    decoded.update(_decode(path, buf, data, scanned, channels, wanted, decoders, time_source, late))
                add({c: decoded[c] for c in ids.tolist() if c in decoded})

        # Chunks are decompressed, CRC-checked, framed and decoded (for the channels known when the chunk is
        # met) by worker threads: zstd, zlib and the compiled scan and decoders release the GIL.  This thread
        # reads the file and collects the results in file order, a few chunks behind at most, so memory
        # stays bounded.
        pending: deque = deque()
        with ThreadPoolExecutor(max_workers=2) as pool:
            for rec in _records(path, fh, warnings):
                if isinstance(rec, Chunk):
                    compression.add(rec.compression or "none")
                    pending.append((rec, pool.submit(_open_chunk, rec, path, dict(channels), wanted, decoders,
                                                     time_source)))
                    if len(pending) > 4:
                        take(pending.popleft())
                    continue
                while pending:  # records outside chunks apply after the chunks before them
                    take(pending.popleft())
                if isinstance(rec, Schema):
                    add_schema(rec)
                elif isinstance(rec, ChannelRecord):
                    add_channel(rec)
                elif isinstance(rec, Message):  # unchunked file
                    one = lambda x: np.array([x], np.int64)  # noqa: E731
                    scanned = (one(rec.channel_id), one(0), one(1), one(rec.log_time), one(rec.log_time),
                               one(rec.log_time), one(rec.publish_time), one(0), one(len(rec.data)))
                    count(scanned[0], *scanned[2:5])
                    data = rec.data
                    add(_decode(path, np.frombuffer(data, dtype=np.uint8), data, scanned, channels, wanted, decoders,
                                time_source, [rec.channel_id]))
            while pending:
                take(pending.popleft())
    return Scan(channels, counts, first, last, series, warnings, compression)


def _open_chunk(rec, path, channels, wanted, decoders, time_source):
    """Decompressed bytes of a chunk (CRC checked), its record framing, per-channel statistics and the decoded
    wanted fields of the channels in ``channels`` (those known before the chunk)."""
    from mcap.stream_reader import get_chunk_data_stream

    stream, size = get_chunk_data_stream(rec, validate_crc=True)
    data = stream.read(size)
    buf = np.frombuffer(data, dtype=np.uint8)
    scanned = scan_chunk(buf)
    known = [c for c in scanned[0].tolist() if c in channels]
    decoded = _decode(path, buf, data, scanned, channels, wanted, decoders, time_source, known) if known else {}
    return data, scanned, decoded


def _decode(path, buf, data, scanned, channels, wanted, decoders, time_source, which) -> dict:
    """channel id -> (topic, clock used, time [ns], values (n, k)) for the wanted channels among ``which``
    (``scanned``: the chunk's records grouped by channel, as scan_chunk returns them)."""
    out: dict = {}
    if not wanted:
        return out
    ids, first, cnt = scanned[0].tolist(), scanned[1], scanned[2]
    logt, pubt, start, length = scanned[5:9]
    for cid in which:
        ch = channels.get(cid)
        if ch is None or ch.topic not in wanted:
            continue
        c = ids.index(cid)
        sel = slice(first[c], first[c] + cnt[c])
        srcs = wanted[ch.topic]
        if ch.message_encoding not in ENCODINGS:
            raise LogFormatError(f"{path}: topic {ch.topic}: message encoding {ch.message_encoding!r} is not one this "
                                 f"tool reads; expected {' or '.join(ENCODINGS)}")
        st, ln, lt, pt = start[sel], length[sel], logt[sel], pubt[sel]
        tsrc = time_source
        fast = ch.message_encoding == "cdr" and ch.schema_name in (JOINT_STATE, MULTIARRAY)
        if fast:
            vals, stamp = _decode_fast(path, ch, buf, st, ln, srcs)
            if vals is None:
                fast = False
        if not fast:
            vals, stamp = _decode_general(path, ch, data, st, ln, srcs, decoders)
        if tsrc in ("auto", "header"):  # header.stamp where the message has one, else log time
            tsrc = "header" if stamp is not None else "log"
        t = stamp if tsrc == "header" else (lt if tsrc == "log" else pt)
        out[cid] = (ch.topic, tsrc, np.asarray(t, dtype=np.int64), vals)
    return out


_STATUS_TEXT = {SHORT: "is shorter than its layout", BIG_ENDIAN: "is big-endian CDR",
                NO_SUCH_JOINT: "has no joint of that name", INDEX_OUT_OF_RANGE: "has too few elements"}


def _decode_fast(path, ch, buf, st, ln, srcs):
    n, k = st.size, len(srcs)
    fields = np.full((k, n), np.nan)  # field-major memory, each field one block: always C order (one compiled kernel)
    status = np.zeros(n, np.int64)
    if ch.schema_name == JOINT_STATE:
        steps = [s.steps for s in srcs]
        if any(len(p) != 1 or p[0].key not in ("position", "velocity", "effort") for p in steps) or \
                len({p[0].key for p in steps}) != 1:
            return None, None
        names = [p[0].name or "" for p in steps]
        flat = np.frombuffer("".join(names).encode() or b"\x00", dtype=np.uint8)
        lens = np.array([len(x.encode()) for x in names], np.int64)
        starts = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int64)
        index = np.array([p[0].index if p[0].index is not None else (-1 if p[0].name else 0) for p in steps], np.int64)
        stamp = np.zeros(n, np.int64)
        decode_joint_state(buf, st, ln, ("position", "velocity", "effort").index(steps[0][0].key), flat, starts, lens,
                           index, fields, stamp, status)
    else:
        steps = [s.steps for s in srcs]
        if any(len(p) != 1 or p[0].key != "data" or p[0].index is None for p in steps):
            return None, None
        decode_float64_multiarray(buf, st, ln, np.array([p[0].index for p in steps], np.int64), fields, status)
        stamp = None
    bad = np.flatnonzero(status != OK)
    if bad.size:
        i = int(bad[0])
        if status[i] == BIG_ENDIAN:
            return None, None
        which = ", ".join(s.field for s in srcs)
        raise LogFormatError(f"{path}: topic {ch.topic}: message {i} {_STATUS_TEXT[int(status[i])]} ({which}); "
                             f"expected {ch.schema_name} with those fields")
    return fields.T, stamp  # (n, k)


def _decode_general(path, ch, data, st, ln, srcs, decoders):
    if ch.message_encoding == "json":
        decode = json.loads
    else:
        decode = decoders.get(ch.id)
        if decode is None:
            from mcap_ros2._dynamic import generate_dynamic

            try:
                decode = generate_dynamic(ch.schema_name, ch.schema_data.decode())[ch.schema_name]
            except Exception as exc:  # noqa: BLE001 - unparsable schema text
                raise LogFormatError(f"{path}: topic {ch.topic}: cannot use its schema {ch.schema_name!r} ({exc})") \
                    from None
            decoders[ch.id] = decode
    n, k = st.size, len(srcs)
    vals = np.empty((k, n)).T
    stamp = np.empty(n, np.int64)
    has_stamp = True
    steps = [s.steps for s in srcs]  # each field path parsed once, not per message
    decoded = None
    if ch.message_encoding == "json":  # the chunk's messages as one JSON array: one call into the C parser
        try:
            decoded = json.loads(b"[" + b",".join([data[a:a + b] for a, b in zip(st.tolist(), ln.tolist())]) + b"]")
        except ValueError:
            decoded = None  # a malformed message: decoded one by one below, which names it
    for i in range(n):
        try:
            msg = decoded[i] if decoded is not None else decode(data[st[i]:st[i] + ln[i]])
        except Exception as exc:  # noqa: BLE001 - malformed payload
            raise LogFormatError(f"{path}: topic {ch.topic}: message {i} cannot be decoded ({exc})") from None
        for j, s in enumerate(srcs):
            try:
                vals[i, j] = extract(msg, steps[j])
            except (KeyError, AttributeError, IndexError, ValueError, TypeError):
                raise LogFormatError(f"{path}: topic {ch.topic}: message {i} has no field {s.field!r} "
                                     f"(for {s.signal}); see `trms-ident inspect {path}`") from None
        if has_stamp:
            try:
                hs = msg["header"]["stamp"] if isinstance(msg, dict) else msg.header.stamp
                stamp[i] = (hs["sec"] if isinstance(hs, dict) else hs.sec) * 1_000_000_000 + \
                    (hs["nanosec"] if isinstance(hs, dict) else hs.nanosec)
            except (KeyError, AttributeError, TypeError):
                has_stamp = False
    return vals, (stamp if has_stamp else None)


def _defaults_for(path: Path) -> dict[str, SignalSource]:
    """ROS 2 or JSON default layout, chosen by the joint_states channel's encoding (from the summary
    section when the file has one, else from the first channel records)."""
    from mcap.reader import make_reader

    encodings: dict[str, str] = {}
    try:
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
        if summary is not None:
            encodings = {c.topic: c.message_encoding for c in summary.channels.values()}
    except Exception:  # noqa: BLE001 - no usable summary (e.g. truncated): fall back to a scan
        summary = None
    if summary is None:
        encodings = {c.topic: c.message_encoding for c in scan(path, None).channels.values()}
    return DEFAULT_JSON if encodings.get(DEFAULT_ROS2["alpha"].topic) == "json" else DEFAULT_ROS2


def read_mcap_log(path: str | Path, angle_unit: str = "auto", signals: list[str] | None = None,
                  time_source: str = "auto", voltage_time: str = "stamp",
                  held: dict[str, float] | None = None) -> Log:
    """Read an MCAP log: the angles' topic is the time grid, the voltages held on it (see align); ``held``:
    inputs not logged, held at a constant [V] (``--signal u2=0``).  Topics missing are named together."""
    path = Path(path)
    held = held or {}
    if time_source not in TIME_SOURCES:
        raise SettingsError(f"--time-source {time_source!r}: expected one of {', '.join(TIME_SOURCES)}")
    if voltage_time not in VOLTAGE_TIMES:
        raise SettingsError(f"--voltage-time {voltage_time!r}: expected one of {', '.join(VOLTAGE_TIMES)}")
    check_readable(path)
    hasher = Sha256Thread(path)
    hasher.start()
    sources = mapping(signals, _defaults_for(path) if _needs_defaults(signals) else DEFAULT_ROS2)
    wanted: dict[str, list[SignalSource]] = {}
    for name in SIGNALS:
        if name not in held:
            wanted.setdefault(sources[name].topic, []).append(sources[name])
    s = scan(path, wanted, time_source)
    topics = {ch.topic for ch in s.channels.values()}
    absent = [f"no topic {topic} (needed for {', '.join(x.signal for x in srcs)})"
              for topic, srcs in wanted.items() if topic not in topics]
    if absent:
        note = f" ({s.warnings[0]})" if s.warnings else ""
        raise LogFormatError(f"{path}: {'; '.join(absent)}; topics: {', '.join(sorted(topics)) or 'none'}; map others "
                             f"with --signal (u2=0 for a motor that was off and not logged){note}")
    for topic, srcs in wanted.items():
        if not s.series[topic].time_ns:
            raise LogFormatError(f"{path}: topic {topic} has no messages (needed for "
                                 f"{', '.join(x.signal for x in srcs)})")
    grid = sources["alpha"].topic
    if time_source == "header" and s.series[grid].clock != "header":
        raise SettingsError(f"--time-source header: topic {grid} (the angles) has no header.stamp; use log or publish")
    per_signal = {}
    for topic, srcs in wanted.items():
        t = np.concatenate(s.series[topic].time_ns)
        v = np.concatenate([x.T for x in s.series[topic].values], axis=1)  # (k, n): each field contiguous
        if t.size > 1 and np.any(t[1:] < t[:-1]):  # messages logged out of order: sort them (rare)
            order = np.argsort(t, kind="stable")
            t, v = t[order], v[:, order]
        for j, src in enumerate(srcs):
            per_signal[src.signal] = (topic, t, v[j])
    for name, value in held.items():  # on the angles' own stamps
        topic_a, t_a, _ = per_signal["alpha"]
        per_signal[name] = (topic_a, t_a, np.full(t_a.size, value))
    clocks = {topic: s.series[topic].clock for topic in wanted}
    return align(path, per_signal, angle_unit, hasher.result(), s.warnings, voltage_time, clocks, held)


def _needs_defaults(signals: list[str] | None) -> bool:
    return len(signals or []) < len(SIGNALS)


def align(path: Path, per_signal: dict, angle_unit: str, sha: str, warnings: list[str],
          voltage_time: str = "stamp", clocks: dict | None = None, held: dict | None = None) -> Log:
    """Angles' times are the grid; every other signal is held (ZOH), with gap checks.

    ``voltage_time="stamp"``: a voltage takes effect at its own message time, inside the angle interval where
    it falls (Log.u_switch_s); the value of sample k is the last message before t_k+1.  ``"next-sample"``: the
    value in force at each angle stamp, held from there (a message between two stamps acts from the next)."""
    topic_a, t_grid, alpha = per_signal["alpha"]
    warnings = list(warnings)

    def where(i: int) -> str:
        return f"{topic_a} message {i} (t = {(t_grid[i] - t_grid[0]) * 1e-9:.6g} s)"

    steps = np.diff(t_grid)
    dup = np.flatnonzero(steps <= 0)
    if dup.size:
        i = int(dup[0]) + 1
        raise LogFormatError(f"{path}: {where(i)}: time does not increase (repeats or goes back); expected strictly "
                             "increasing stamps")
    step_ns = float(np.median(steps)) if t_grid.size > 1 else 1.0
    del steps
    out = {}
    first_valid = 0
    switch = None  # voltage switch times [ns], made only when some voltage falls between two angle stamps
    offsets, merged = {}, 0
    placed: dict = {}  # per (topic, at_stamp): (index of the value each grid sample uses, switch rows or None)
    for name in SIGNALS:
        topic, t, v = per_signal[name]
        if topic == topic_a and np.array_equal(t, t_grid):
            out[name] = v
            continue
        voltage = name in ("u1", "u2")
        key = (topic, voltage and voltage_time == "stamp")
        if key not in placed:  # once per topic: u1 and u2 usually share one
            period = float(np.median(np.diff(t))) if t.size > 1 else math.inf
            take, fv, stale_i, stale_age, n_inside, n_merged = place(t_grid, t, key[1], STALE_PERIODS * period)
            if voltage:
                offsets[topic] = lead_after_grid(t_grid, t)
            if stale_i >= 0:
                raise LogFormatError(
                    f"{path}: {where(stale_i)}: {name} from {topic} is stale: its last message is "
                    f"{stale_age * 1e-9:.6g} s old (its period is {period * 1e-9:.6g} s); a gap in {topic} is not "
                    "interpolated over")
            first_valid = max(first_valid, fv)
            merged = max(merged, n_merged)
            rows = None
            if n_inside:  # the voltage switches at its own time inside these angle intervals
                rows = np.flatnonzero(t[take] > t_grid)
                rows = rows[rows >= fv]
            placed[key] = (take, rows)
        take, rows = placed[key]
        if rows is not None and rows.size:
            if switch is None:
                switch = np.repeat(t_grid[:, None].astype(np.float64), 2, axis=1)
            switch[rows, 0 if name == "u1" else 1] = t[take[rows]]
        out[name] = v[take]
    if first_valid >= t_grid.size:
        raise LogFormatError(f"{path}: no voltage message precedes any angle sample; expected voltages while the "
                             "angles are recorded")
    if first_valid:
        warnings.append(f"dropped the first {first_valid} angle samples, recorded before the first voltage message")
    if merged:
        warnings.append(f"{merged} angle interval(s) hold more than one voltage message (voltages faster than "
                        "angles): the last of each interval is used")
    t0 = int(t_grid[first_valid])
    t_s = (t_grid[first_valid:] - t0) * 1e-9
    sw = None if switch is None else (switch[first_valid:] - t0) * 1e-9
    cols = {k: v[first_valid:] for k, v in out.items()}
    if angle_unit == "deg":
        cols["alpha"] = cols["alpha"] * (math.pi / 180)
        cols["beta"] = cols["beta"] * (math.pi / 180)
    meta = {"format": "mcap", "start_time_ns": t0, "time_topic": topic_a,
            "signals": " ".join(f"{k}={v[0]}" for k, v in per_signal.items()),
            "voltage_timing": _timing_doc(voltage_time, offsets, step_ns, clocks or {})}
    if held:
        from .signals import held_note

        meta.update(held_note(held))
    if warnings:
        meta["warnings"] = "; ".join(warnings)
    return validated(t_s, cols["u1"], cols["u2"], cols["alpha"], cols["beta"], source=str(path), sha256=sha,
                     locate=lambda i: f"{topic_a} message {i + first_valid}", meta=meta, angle_unit=angle_unit,
                     time_unit="s",
                     u_switch_s=sw if voltage_time == "stamp" else None)


def _timing_doc(convention: str, offsets: dict, step_ns: float, clocks: dict) -> dict:
    """How the voltages were placed in time: the convention, each topic's clock, and the measured offset of
    voltage messages after the preceding angle stamp (median and 5-95 % spread, in ms and in samples)."""
    doc = {"convention": convention, "clocks": {k: ("header.stamp" if c == "header" else f"{c} time")
                                                 for k, c in clocks.items()}, "offset_after_angle": {}}
    for topic, off in offsets.items():
        if off.size:
            q = np.percentile(off, [5, 50, 95])
            doc["offset_after_angle"][topic] = {
                "median_ms": float(q[1] * 1e-6), "p05_ms": float(q[0] * 1e-6), "p95_ms": float(q[2] * 1e-6),
                "median_samples": float(q[1] / step_ns), "p05_samples": float(q[0] / step_ns),
                "p95_samples": float(q[2] / step_ns)}
    return doc


# ---- writing ---------------------------------------------------------------------------------

def write_mcap_log(path: str | Path, t_s, u1_v, u2_v, alpha_rad, beta_rad, encoding: str = "cdr",
                   u_t_s=None) -> None:
    """The default layout, ROS 2 CDR (``encoding="cdr"``) or JSON, zstd chunks, atomically.  ``u_t_s``: the
    voltage messages' times [s] (their log time; default: the angles' stamps)."""
    from mcap.writer import CompressionType, Writer

    if encoding not in ENCODINGS:
        raise SettingsError(f"encoding must be one of {ENCODINGS}, got {encoding!r}")
    t_ns = np.round(np.asarray(t_s) * 1e9).astype(np.int64)
    tu_ns = t_ns if u_t_s is None else np.round(np.asarray(u_t_s) * 1e9).astype(np.int64)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=1 << 20)
        w.start(profile="ros2" if encoding == "cdr" else "", library="trms-ident")
        if encoding == "cdr":
            sj = w.register_schema(JOINT_STATE, "ros2msg", JOINT_STATE_MSGDEF.encode())
            sv = w.register_schema(MULTIARRAY, "ros2msg", FLOAT64_MULTIARRAY_MSGDEF.encode())
            cj = w.register_channel("/trms/joint_states", "cdr", sj)
            cv = w.register_channel("/trms/voltage", "cdr", sv)
            ej, ev = joint_state_encoder(["pitch", "yaw"]), float64_multiarray_encoder(2)
            for i in range(t_ns.size):
                tn = int(t_ns[i])
                w.add_message(cj, tn, ej(tn, (alpha_rad[i], beta_rad[i])), tn, i)
                w.add_message(cv, int(tu_ns[i]), ev((u1_v[i], u2_v[i])), int(tu_ns[i]), i)
        else:
            obj = {"type": "object", "properties": {}}
            sj = w.register_schema("trms/Angles", "jsonschema", json.dumps(
                {**obj, "properties": {"alpha": {"type": "number"}, "beta": {"type": "number"}}}).encode())
            sv = w.register_schema("trms/Voltages", "jsonschema", json.dumps(
                {**obj, "properties": {"u1": {"type": "number"}, "u2": {"type": "number"}}}).encode())
            cj = w.register_channel("/trms/joint_states", "json", sj)
            cv = w.register_channel("/trms/voltage", "json", sv)
            for i in range(t_ns.size):
                tn = int(t_ns[i])
                w.add_message(cj, tn, json.dumps({"alpha": float(alpha_rad[i]), "beta": float(beta_rad[i])}).encode(),
                              tn, i)
                w.add_message(cv, int(tu_ns[i]), json.dumps({"u1": float(u1_v[i]), "u2": float(u2_v[i])}).encode(),
                              int(tu_ns[i]), i)
        w.finish()


# ---- inspect ---------------------------------------------------------------------------------

def inspect_mcap(path: str | Path) -> dict:
    """Topics, types, encodings, counts, rates, time span, numeric fields and a suggested mapping."""
    path = Path(path)
    s = scan(path, None)
    topics = []
    for cid, ch in sorted(s.channels.items()):
        n = s.counts.get(cid, 0)
        span = (s.last_ns.get(cid, 0) - s.first_ns.get(cid, 0)) * 1e-9 if n else 0.0
        entry = {"topic": ch.topic, "type": ch.schema_name or None, "schema_encoding": ch.schema_encoding or None,
                 "message_encoding": ch.message_encoding, "messages": n,
                 "rate_hz": (n - 1) / span if n > 1 and span > 0 else None,
                 "first_s": s.first_ns[cid] * 1e-9 if n else None, "last_s": s.last_ns[cid] * 1e-9 if n else None}
        if ch.message_encoding not in ENCODINGS:
            raise LogFormatError(f"{path}: topic {ch.topic}: message encoding {ch.message_encoding!r} is not one this "
                                 f"tool reads; expected {' or '.join(ENCODINGS)}")
        entry["numeric_fields"] = _numeric_fields(path, ch) if n else []
        topics.append(entry)
    starts = [v for v in s.first_ns.values()]
    ends = [v for v in s.last_ns.values()]
    doc = {"file": str(path), "bytes": path.stat().st_size, "chunk_compression": sorted(s.chunk_compression),
           "start_s": min(starts) * 1e-9 if starts else None, "end_s": max(ends) * 1e-9 if ends else None,
           "duration_s": (max(ends) - min(starts)) * 1e-9 if starts else 0.0, "topics": topics,
           "suggested_signals": suggest(topics), "warnings": s.warnings}
    return doc


def _first_message(path: Path, ch: Channel):
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        try:
            for _, _, msg in make_reader(f).iter_messages(topics=[ch.topic]):
                return msg.data
        except Exception:  # noqa: BLE001 - truncated files: the scan already warned
            return None
    return None


def _numeric_fields(path: Path, ch: Channel) -> list[str]:
    raw = _first_message(path, ch)
    if raw is None:
        return []
    try:
        if ch.message_encoding == "json":
            msg = json.loads(raw)
        else:
            from mcap_ros2._dynamic import generate_dynamic

            msg = generate_dynamic(ch.schema_name, ch.schema_data.decode())[ch.schema_name](raw)
    except Exception as exc:  # noqa: BLE001
        raise LogFormatError(f"{path}: topic {ch.topic}: first message cannot be decoded ({exc})") from None
    out: list[str] = []
    _walk(msg, "", out)
    return out[:64]


def _walk(obj, prefix: str, out: list[str]) -> None:
    if isinstance(obj, bool):
        return
    if isinstance(obj, (int, float)):
        out.append(prefix)
        return
    if isinstance(obj, dict):
        items = obj.items()
    elif isinstance(obj, (list, tuple)):
        if obj and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in obj):
            out.append(f"{prefix}[0..{len(obj) - 1}]")
        return
    elif hasattr(obj, "__slots__") or hasattr(obj, "__dict__"):
        names = getattr(obj, "__slots__", None) or list(vars(obj))
        items = [(k, getattr(obj, k)) for k in names if not k.startswith("_")]
        if "name" in names and isinstance(getattr(obj, "name"), list):
            joint_names = getattr(obj, "name")
            for k in ("position", "velocity", "effort"):
                arr = getattr(obj, k, None)
                if isinstance(arr, list) and len(arr) == len(joint_names):
                    out += [f"{prefix + '.' if prefix else ''}{k}[{j}]" for j in joint_names]
            items = [(k, v) for k, v in items if k not in ("position", "velocity", "effort")]
    else:
        return
    for k, v in items:
        _walk(v, f"{prefix}.{k}" if prefix else str(k), out)


def suggest(topics: list[dict]) -> dict[str, str] | None:
    """A --signal mapping when the fields make it obvious, else None."""
    found: dict[str, str] = {}
    for t in topics:
        fields = t["numeric_fields"]
        for f in fields:
            low = f.lower()
            for sig, keys in (("alpha", ("pitch", "alpha")), ("beta", ("yaw", "beta"))):
                if sig not in found and any(k in low for k in keys) and not low.startswith("header"):
                    found[sig] = f"{sig}={t['topic']}:{f}"
            for sig in ("u1", "u2"):
                if sig not in found and low == sig:
                    found[sig] = f"{sig}={t['topic']}:{f}"
        if t["type"] == MULTIARRAY and "u1" not in found:
            found["u1"] = f"u1={t['topic']}:data[0]"
            found["u2"] = f"u2={t['topic']}:data[1]"
    return found if set(found) == set(SIGNALS) else None
