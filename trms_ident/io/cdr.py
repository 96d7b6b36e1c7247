"""Bulk decoding of MCAP chunk contents and of two ROS 2 CDR message types.

The mcap library reads records one Python object at a time (about 70 000 messages/s here);
a one-hour 1 kHz bench log holds 7.2 million.  So the library still opens the file, checks
CRCs, decompresses chunks and parses schemas and channels, but the message records inside a
decompressed chunk are located by a compiled scan, and the payloads of the two message types
of the default layout are decoded in bulk:

* ``sensor_msgs/msg/JointState``: header.stamp, name[], position[], velocity[], effort[]
* ``std_msgs/msg/Float64MultiArray``: layout (dim[], data_offset), data[]

Only little-endian CDR (encapsulation 0x0001) is decoded here; anything else goes through the
general ROS 2 decoder of mcap-ros2-support.  Tests check these decoders against it.
"""
from __future__ import annotations

import struct

import numpy as np
from numba import njit

from ..numerics.kernel_args import HELPER

OP_MESSAGE = 0x05

# status codes of the bulk decoders
OK, SHORT, BIG_ENDIAN, NO_SUCH_JOINT, INDEX_OUT_OF_RANGE = 0, 1, 2, 3, 4


# Byte reads as int64 arithmetic throughout: mixing numba's uint8/uint32/uint64 with int64 promotes to
# float and made the record scan 4x slower.
@njit(cache=True, nogil=True, **HELPER)
def _u16(b, p):
    return np.int64(b[p]) | (np.int64(b[p + 1]) << 8)


@njit(cache=True, nogil=True, **HELPER)
def _u32(b, p):
    return np.int64(b[p]) | (np.int64(b[p + 1]) << 8) | (np.int64(b[p + 2]) << 16) | (np.int64(b[p + 3]) << 24)


@njit(cache=True, nogil=True, **HELPER)
def _u64(b, p):
    """Little-endian 8 bytes as int64 (a length above 2**63 comes out negative: callers refuse it)."""
    r = np.int64(0)
    for i in range(8):
        r |= np.int64(b[p + i]) << (8 * i)
    return r


@njit(cache=True, nogil=True, **HELPER)
def _f64(b, p, scratch):
    """The little-endian double at b[p]; ``scratch``: an int64 array of one element (a view of it as float64
    reinterprets the bits without allocating)."""
    scratch[0] = _u64(b, p)
    return scratch.view(np.float64)[0]


@njit(cache=True, nogil=True)
def scan_chunk(buf):
    """Message records in a decompressed chunk, grouped by channel (file order within each channel).

    Returns (ids, first, count, lo, hi, log_time, publish_time, start, length, other, complete): channel ``ids[c]``
    owns records ``first[c]:first[c] + count[c]`` of the record arrays, with log times from ``lo[c]`` to ``hi[c]``;
    ``start``/``length`` locate each payload in ``buf``; ``other``: offsets of the records that are not messages
    (schemas, channels) for the caller to parse.  A record running past the end stops the scan: ``complete`` is
    False then."""
    n = buf.size
    m = 0
    n_other = 0
    top = 0
    p = 0
    complete = True
    while p < n:  # pass 1: framing, message count, largest channel id
        if p + 9 > n:
            complete = False
            break
        ln = _u64(buf, p + 1)
        if ln < 0 or p + 9 + ln > n:
            complete = False
            break
        if buf[p] == OP_MESSAGE and ln >= 22:
            m += 1
            top = max(top, _u16(buf, p + 9))
        else:
            n_other += 1
        p += 9 + ln
    end = p
    per = np.zeros(top + 1, np.int64)
    p = 0
    while p < end:  # pass 2: messages per channel
        ln = _u64(buf, p + 1)
        if buf[p] == OP_MESSAGE and ln >= 22:
            per[_u16(buf, p + 9)] += 1
        p += 9 + ln
    ids = np.flatnonzero(per)
    first = np.empty(ids.size, np.int64)
    slot = np.zeros(top + 1, np.int64)  # next free record index of each channel
    acc = 0
    for c in range(ids.size):
        first[c] = acc
        slot[ids[c]] = acc
        acc += per[ids[c]]
    logt = np.empty(m, np.int64)
    pubt = np.empty(m, np.int64)
    start = np.empty(m, np.int64)
    length = np.empty(m, np.int64)
    other = np.empty(n_other, np.int64)
    p = 0
    j = 0
    while p < end:  # pass 3: fill, grouped by channel
        ln = _u64(buf, p + 1)
        if buf[p] == OP_MESSAGE and ln >= 22:
            cid = _u16(buf, p + 9)
            k = slot[cid]
            slot[cid] += 1
            logt[k] = _u64(buf, p + 15)
            pubt[k] = _u64(buf, p + 23)
            start[k] = p + 31
            length[k] = ln - 22
        else:
            other[j] = p
            j += 1
        p += 9 + ln
    cnt = per[ids]
    lo = np.empty(ids.size, np.int64)
    hi = np.empty(ids.size, np.int64)
    for c in range(ids.size):
        seg = logt[first[c]:first[c] + cnt[c]]
        lo[c] = seg.min()
        hi[c] = seg.max()
    return ids, first, cnt, lo, hi, logt, pubt, start, length, other, complete


@njit(cache=True, nogil=True)
def _align(q, base, k):
    r = (q - base) % k
    return q + (k - r) % k


@njit(cache=True, nogil=True, **HELPER)
def _payload(buf, p, length, min_length, status, i):
    """Start of the CDR body after the encapsulation header, or -1 (status set) if unusable."""
    status[i] = OK
    if length < min_length:
        status[i] = SHORT
        return -1
    if buf[p] != 0 or buf[p + 1] != 1:  # only little-endian CDR (0x0001) here
        status[i] = BIG_ENDIAN
        return -1
    return p + 4


@njit(cache=True, nogil=True, **HELPER)
def _f64_sequence(buf, q, base, end):
    """(start of the doubles, count) of a float64 sequence at q, or (-1, 0) if it runs past end."""
    q = _align(q, base, 4)
    if q + 4 > end:
        return -1, 0
    cnt = np.int64(_u32(buf, q))
    q += 4
    if cnt > 0:
        q = _align(q, base, 8)
    if q + 8 * cnt > end:
        return -1, 0
    return q, cnt


@njit(cache=True, nogil=True)
def decode_joint_state(buf, starts, lens, field, want_flat, want_start, want_len, want_index, values, stamp, status):
    """Per message: header stamp [ns] and ``field`` (0 position, 1 velocity, 2 effort) of each wanted joint, into
    values[j, message] ((wanted, messages), C order: one compiled kernel whatever the count).

    A wanted joint is a name (bytes in want_flat[want_start[j]:+want_len[j]]) or, when
    want_index[j] >= 0, a position in the arrays."""
    k = want_start.size
    idx = np.empty(k, np.int64)
    scratch = np.empty(1, np.int64)
    for i in range(starts.size):
        end = starts[i] + lens[i]
        base = _payload(buf, starts[i], lens[i], 24, status, i)
        if base < 0:
            continue
        q = base
        sec = np.int64(np.int32(_u32(buf, q)))
        nsec = np.int64(_u32(buf, q + 4))
        stamp[i] = sec * 1000000000 + nsec
        q += 8
        slen = np.int64(_u32(buf, q))  # frame_id
        q = _align(q + 4 + slen, base, 4)
        if q + 4 > end:
            status[i] = SHORT
            continue
        count = np.int64(_u32(buf, q))
        q += 4
        for j in range(k):
            idx[j] = want_index[j]
        for jn in range(count):
            q = _align(q, base, 4)
            if q + 4 > end:
                break
            ln = np.int64(_u32(buf, q))
            s0 = q + 4
            nl = ln - 1 if ln > 0 else 0
            for j in range(k):
                if want_index[j] < 0 and want_len[j] == nl:
                    same = True
                    for c in range(nl):
                        if buf[s0 + c] != want_flat[want_start[j] + c]:
                            same = False
                            break
                    if same:
                        idx[j] = jn
            q = s0 + ln
        for f in range(field + 1):
            q, cnt = _f64_sequence(buf, q, base, end)
            if q < 0:
                status[i] = SHORT
                break
            if f == field:
                for j in range(k):
                    if idx[j] < 0:
                        status[i] = NO_SUCH_JOINT
                    elif idx[j] >= cnt:
                        status[i] = INDEX_OUT_OF_RANGE
                    else:
                        values[j, i] = _f64(buf, q + 8 * idx[j], scratch)
            q += 8 * cnt


@njit(cache=True, nogil=True)
def decode_float64_multiarray(buf, starts, lens, want_index, values, status):
    """Per message: data[want_index[j]] of a Float64MultiArray, into values[j, message] ((wanted, messages), C order:
    one compiled kernel whatever the count)."""
    k = want_index.size
    scratch = np.empty(1, np.int64)
    for i in range(starts.size):
        end = starts[i] + lens[i]
        base = _payload(buf, starts[i], lens[i], 16, status, i)
        if base < 0:
            continue
        q = base
        ndim = np.int64(_u32(buf, q))
        q += 4
        for d in range(ndim):
            q = _align(q, base, 4)
            ln = np.int64(_u32(buf, q))
            q = _align(q + 4 + ln, base, 4) + 8  # label, size, stride
        q = _align(q, base, 4) + 4  # data_offset
        q, cnt = _f64_sequence(buf, q, base, end)
        if q < 0:
            status[i] = SHORT
            continue
        for j in range(k):
            if want_index[j] >= cnt:
                status[i] = INDEX_OUT_OF_RANGE
            else:
                values[j, i] = _f64(buf, q + 8 * want_index[j], scratch)


# ---- encoders (simulate --format mcap): fixed layouts, struct-packed ----------------------------

def _cdr_string(s: str, offset: int) -> tuple[bytes, int]:
    raw = s.encode() + b"\x00"
    out = struct.pack("<I", len(raw)) + raw
    end = offset + len(out)
    pad = (-end) % 4
    return out + b"\x00" * pad, end + pad


def joint_state_encoder(names: list[str], frame_id: str = ""):
    """Return encode(stamp_ns, positions) -> CDR bytes of a JointState with these joints."""
    head = bytearray()
    body_off = 0  # offsets relative to the CDR payload start (after the 4-byte encapsulation)
    body_off += 8  # stamp
    frame, body_off = _cdr_string(frame_id, body_off)
    parts = [frame, struct.pack("<I", len(names))]
    body_off += 4
    for n in names:
        enc, body_off = _cdr_string(n, body_off)
        parts.append(enc)
    parts.append(struct.pack("<I", len(names)))
    body_off += 4
    pad = (-body_off) % 8
    parts.append(b"\x00" * pad)
    head += b"".join(parts)
    middle = bytes(head)
    tail = struct.pack("<II", 0, 0)  # empty velocity, effort
    fmt = struct.Struct("<iI")
    vec = struct.Struct("<%dd" % len(names))

    def encode(stamp_ns: int, positions) -> bytes:
        sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
        return b"\x00\x01\x00\x00" + fmt.pack(sec, nsec) + middle + vec.pack(*positions) + tail

    return encode


def float64_multiarray_encoder(size: int):
    """Return encode(values) -> CDR bytes of a Float64MultiArray with no dimensions."""
    prefix = b"\x00\x01\x00\x00" + struct.pack("<III", 0, 0, size) + b"\x00" * 4  # dims, data_offset, count, pad
    vec = struct.Struct("<%dd" % size)

    def encode(values) -> bytes:
        return prefix + vec.pack(*values)

    return encode


JOINT_STATE_MSGDEF = """# This is a message that holds data to describe the state of a set of torque controlled joints.
std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""

FLOAT64_MULTIARRAY_MSGDEF = """MultiArrayLayout layout
float64[] data
================================================================================
MSG: std_msgs/MultiArrayLayout
MultiArrayDimension[] dim
uint32 data_offset
================================================================================
MSG: std_msgs/MultiArrayDimension
string label
uint32 size
uint32 stride
"""
