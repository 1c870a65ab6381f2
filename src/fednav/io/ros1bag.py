"""ROS 1 bag files (format 2.0) read whole, their messages indexed with numpy: no Python
object per message.

A ROS 1 bag is ``#ROSBAG V2.0\\n``, then records — the header's length (uint32,
little-endian), the header (fields ``length name=value``), the data's length and the
data (http://wiki.ros.org/Bags/Format/2.0).  The header's ``op`` says the record's kind:
message data (``conn``, ``time``), a chunk (``compression``, ``size``; its data the
records of its messages and connections, uncompressed, bz2 or lz4), a connection
(``conn``, ``topic``; its data the connection header: ``type``, ``md5sum``...), the bag
header and the indexes.  :func:`read` walks the records with one compiled loop
(:func:`_walk`) per chunk, reading each record's ``op``, ``conn`` and ``time`` from its
header; the connections' few records are read in Python.  The indexes are not needed:
the walk finds every message (a bag closed without its index, but whole, too).
``rosbags`` reads the same file at ~6 us a message.  What this module does not know (a
compression it has no decompressor for, records that do not add up) is a
:class:`Ros1BagError`: the bag reader then falls back to ``rosbags``.
"""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np

from .data import file_bytes
from .mcap import Messages, chunk_regions

MAGIC = b"#ROSBAG V2.0\n"
OP_MESSAGE, OP_CHUNK, OP_CONNECTION = 0x02, 0x05, 0x07


class Ros1BagError(ValueError):
    """A ROS 1 bag this module cannot read (read with ``rosbags`` instead)."""


@numba.njit(cache=True)
def _u32(buf, p):
    return (np.int64(buf[p]) | (np.int64(buf[p + 1]) << 8) | (np.int64(buf[p + 2]) << 16)
            | (np.int64(buf[p + 3]) << 24))


@numba.njit(cache=True)
def _is(buf, p, n, name):
    """Whether the ``n`` bytes at ``p`` are ``name`` (uint8 array)."""
    if n != len(name):
        return False
    for k in range(n):
        if buf[p + k] != name[k]:
            return False
    return True


@numba.njit(cache=True)
def _walk(buf, start, stop):
    """The records of ``buf[start:stop]``: (op (-1 where the header has none), conn (-1),
    time [ns] (0), header offset and length, data offset and length, where the walk
    stopped — ``stop`` when the records fill the span exactly)."""
    op_, conn_, time_ = np.array([111, 112]), np.array([99, 111, 110, 110]), np.array(
        [116, 105, 109, 101])
    n, p = 0, start
    while p + 8 <= stop:
        hl = _u32(buf, p)
        if p + 8 + hl > stop:
            break
        dl = _u32(buf, p + 4 + hl)
        if p + 8 + hl + dl > stop:
            break
        p += 8 + hl + dl
        n += 1
    ops = np.full(n, -1, np.int64)
    conns = np.full(n, -1, np.int64)
    times = np.zeros(n, np.int64)
    hoffs, hlens = np.empty(n, np.int64), np.empty(n, np.int64)
    doffs, dlens = np.empty(n, np.int64), np.empty(n, np.int64)
    p = start
    for i in range(n):
        hl = _u32(buf, p)
        q, hend = p + 4, p + 4 + hl
        hoffs[i], hlens[i] = q, hl
        while q + 4 <= hend:
            fe = q + 4 + _u32(buf, q)
            if fe > hend:
                break
            e = q + 4
            while e < fe and buf[e] != 61:  # ('=')
                e += 1
            v = e + 1
            if _is(buf, q + 4, e - q - 4, op_) and fe - v >= 1:
                ops[i] = buf[v]
            elif _is(buf, q + 4, e - q - 4, conn_) and fe - v >= 4:
                conns[i] = _u32(buf, v)
            elif _is(buf, q + 4, e - q - 4, time_) and fe - v >= 8:
                times[i] = _u32(buf, v) * np.int64(1_000_000_000) + _u32(buf, v + 4)
            q = fe
        doffs[i], dlens[i] = hend + 4, _u32(buf, hend)
        p = hend + 4 + dlens[i]
    return ops, conns, times, hoffs, hlens, doffs, dlens, p


def fields(b: bytes) -> dict[str, bytes]:
    """A record header's or connection header's fields (``length name=value``...)."""
    out, p = {}, 0
    while p + 4 <= len(b):
        n = int.from_bytes(b[p:p + 4], "little")
        name, _, value = b[p + 4:p + 4 + n].partition(b"=")
        out[name.decode("ascii", "replace")] = value
        p += 4 + n
    return out


def _decompressor(name: str):
    if name == "none":
        return None
    if name == "bz2":
        import bz2

        return bz2.decompress
    try:  # (rosbags reads ROS 1 bags with these: installed with it)
        from rosbags.rosbag1.reader import decompressors
    except ImportError as e:
        raise Ros1BagError(f"chunk compression {name!r}: {e}") from None
    if name not in decompressors:
        raise Ros1BagError(f"chunk compression {name!r}")
    return decompressors[name]


def read(path: Path) -> tuple[Messages, dict[int, dict[str, bytes]]]:
    """Every message of the ROS 1 bag ``path``, as :class:`fednav.io.mcap.Messages`
    (``channel`` the connection id; ``channels`` {conn: (topic, message type as ROS 2
    names it, "ros1")}), and each connection's header fields."""
    from rosbags.typesys.msg import normalize_msgtype

    data = file_bytes(path)
    if data[:len(MAGIC)].tobytes() != MAGIC:
        raise Ros1BagError(f"{path}: not a ROS 1 bag (format 2.0)")
    *top, end = _walk(data, len(MAGIC), len(data))
    if end != len(data):
        raise Ros1BagError(f"{path}: records do not add up to the file")
    ops, _, _, hoffs, hlens, doffs, dlens = top
    chunks = []
    for i in np.flatnonzero(ops == OP_CHUNK).tolist():
        head = fields(data[hoffs[i]:hoffs[i] + hlens[i]].tobytes())
        chunks.append((int(doffs[i]), int(dlens[i]), _decompressor(
            head.get("compression", b"none").decode("ascii", "replace")),
            int.from_bytes(head.get("size", b"\0\0\0\0")[:4], "little")))
    regions, joined = chunk_regions(path, data, top, chunks, _walk, Ros1BagError)
    connections: dict[int, dict[str, bytes]] = {}
    for buf, _, r_ops, r_conns, _, r_hoffs, r_hlens, r_doffs, r_dlens in regions:
        for i in np.flatnonzero(r_ops == OP_CONNECTION).tolist():
            head = fields(buf[r_hoffs[i]:r_hoffs[i] + r_hlens[i]].tobytes())
            conn = fields(buf[r_doffs[i]:r_doffs[i] + r_dlens[i]].tobytes())
            # (the record header's topic: the connection header's may be the original
            # of a renamed topic)
            connections[int(r_conns[i])] = {**conn, "topic": head.get("topic", b"")}
    channels = {c: (f["topic"].decode("utf-8", "replace"),
                    normalize_msgtype(f.get("type", b"").decode("ascii", "replace")), "ros1")
                for c, f in connections.items()}
    msg = [(base, r[0] == OP_MESSAGE, *r) for _, base, *r in regions]
    return Messages(joined,
                    np.concatenate([c[m] for _, m, _, c, *_ in msg]),
                    np.concatenate([t[m] for _, m, _, _, t, *_ in msg]),
                    np.concatenate([o[m] + base for base, m, *_, o, _ in msg]),
                    np.concatenate([ln[m] for _, m, *_, ln in msg]),
                    channels), connections
