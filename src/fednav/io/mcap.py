"""MCAP files (ROS 2's default bag storage since Iron) read whole, their messages indexed
with numpy: no Python object per message.

An MCAP file is ``MAGIC``, then records — an opcode (uint8), the content's length (uint64,
little-endian), the content — then ``MAGIC`` again (the MCAP specification,
https://mcap.dev/spec).  Messages sit in Chunk records (their records back to back,
uncompressed, zstd or lz4) or at the top level; Schema and Channel records say each
channel's topic and message type.  :func:`read` walks the records with one compiled loop
(:func:`_walk`) per chunk — the only sequential step — and reads each message's channel,
log time and data span with numpy (the bag reader decodes the messages wanted in place).
``rosbags`` reads the same file at ~3 us a message in Python generators
(``benchmarks/rosbag_read.py --all-storages``).  What this module does not know (a
compression other than zstd and lz4, records that do not add up) is a :class:`McapError`:
the bag reader then falls back to ``rosbags``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from .data import file_bytes

MAGIC = b"\x89MCAP0\r\n"
OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x03, 0x04, 0x05, 0x06
#: a Message record's content before its data: channel id (uint16), sequence (uint32),
#: log time (uint64 ns), publish time (uint64 ns)
MESSAGE_HEADER = 22


class McapError(ValueError):
    """An MCAP file this module cannot read (read with ``rosbags`` instead)."""


@numba.njit(cache=True)
def _u64(buf, p):
    v = np.int64(0)
    for k in range(8):
        v |= np.int64(buf[p + k]) << (8 * k)
    return v


@numba.njit(cache=True)
def _walk(buf, start, stop):
    """The records of ``buf[start:stop]``: (opcodes, content offsets, content lengths,
    and for Message records their channel ids and log times [ns] (0 for the others),
    where the walk stopped — ``stop`` when the records fill the span exactly)."""
    n, p = 0, start
    while p + 9 <= stop:
        length = _u64(buf, p + 1)
        if length < 0 or length > stop - p - 9:
            break
        p += 9 + length
        n += 1
    ops = np.empty(n, np.uint8)
    offs = np.empty(n, np.int64)
    lens = np.empty(n, np.int64)
    channel = np.zeros(n, np.int64)
    log_ns = np.zeros(n, np.int64)
    p = start
    for i in range(n):
        length = _u64(buf, p + 1)
        ops[i], offs[i], lens[i] = buf[p], p + 9, length
        if buf[p] == OP_MESSAGE and length >= MESSAGE_HEADER:
            channel[i] = np.int64(buf[p + 9]) | (np.int64(buf[p + 10]) << 8)
            log_ns[i] = _u64(buf, p + 9 + 6)
        p += 9 + length
    return ops, offs, lens, channel, log_ns, p


@dataclass
class Messages:
    """An MCAP file's messages: ``buf`` the records' bytes (chunks decompressed) and, per
    message in file order, its ``channel`` id, ``log_ns`` (the bag time [ns]) and data span
    (``offs``, ``lens`` into ``buf``); ``channels`` {id: (topic, schema name, message
    encoding)}."""

    buf: np.ndarray
    channel: np.ndarray
    log_ns: np.ndarray
    offs: np.ndarray
    lens: np.ndarray
    channels: dict[int, tuple[str, str, str]]


def _u16(b: bytes, p: int) -> int:
    return int.from_bytes(b[p:p + 2], "little")


def _string(b: bytes, p: int) -> tuple[str, int]:
    """A length-prefixed (uint32) string at ``p`` and the offset after it."""
    n = int.from_bytes(b[p:p + 4], "little")
    return b[p + 4:p + 4 + n].decode("utf-8", "replace"), p + 4 + n


def _decompressor(name: str):
    if name == "":
        return None
    try:  # (rosbags reads MCAP with these: installed with it)
        from rosbags.rosbag2.storage_mcap import DECOMPRESSORS
    except ImportError as e:
        raise McapError(f"chunk compression {name!r}: {e}") from None
    if name not in DECOMPRESSORS:
        raise McapError(f"chunk compression {name!r}")
    return DECOMPRESSORS[name]


def chunk_regions(path: Path, data: np.ndarray, top: tuple, chunks: list, walk, error):
    """The records of a file of chunks (MCAP, ROS 1 bags) by region: the top level's
    (``top``, ``walk``'s result on ``data`` without its end) and each chunk's ``(start,
    length, decompress or None, size)`` walked by ``walk(buf, start, stop)``; an
    uncompressed chunk's records stay in ``data`` (no copy), decompressed ones follow it.
    Returns ``[(buffer, where it starts in the joined buffer, *walked)]`` and the joined
    buffer (``data``, then each decompressed chunk); a chunk whose records do not add up
    is ``error``."""
    regions, extra, size_so_far = [(data, 0, *top)], [], len(data)
    for start, n, unpack, size in chunks:
        if unpack is None:
            *walked, r_end = walk(data, start, start + n)
            if r_end != start + n:
                raise error(f"{path}: a chunk's records do not add up")
            regions.append((data, 0, *walked))
            continue
        records = np.frombuffer(unpack(data[start:start + n].tobytes()), np.uint8)
        if len(records) != size:
            raise error(f"{path}: a chunk decompressed to {len(records)} bytes, not {size}")
        *walked, r_end = walk(records, 0, len(records))
        if r_end != len(records):
            raise error(f"{path}: a chunk's records do not add up")
        regions.append((records, size_so_far, *walked))
        extra.append(records)
        size_so_far += len(records)
    return regions, np.concatenate([data, *extra]) if extra else data


def read(path: Path) -> Messages:
    """Every message of the MCAP file ``path`` (:class:`Messages`)."""
    data = file_bytes(path)
    if len(data) < 2 * len(MAGIC) or data[:8].tobytes() != MAGIC:
        raise McapError(f"{path}: not an MCAP file")
    closed = data[-8:].tobytes() == MAGIC
    stop = len(data) - len(MAGIC) if closed else len(data)
    *top, end = _walk(data, len(MAGIC), stop)
    if end != stop and closed:
        raise McapError(f"{path}: records do not add up to the file")
    ops, offs, lens = top[0], top[1], top[2]
    chunks = []
    for o, n in zip(offs[ops == OP_CHUNK].tolist(), lens[ops == OP_CHUNK].tolist(),
                    strict=True):
        head = data[o:o + min(n, 4096)].tobytes()
        size = int.from_bytes(head[16:24], "little")
        compression, p = _string(head, 28)
        rlen = int.from_bytes(head[p:p + 8], "little")
        start = o + p + 8
        if start + rlen > o + n:
            raise McapError(f"{path}: a chunk's records run past it")
        unpack = _decompressor(compression)
        chunks.append((start, rlen, None if unpack is None else
                       (lambda b, f=unpack, size=size: f(b, size)), size))
    regions, joined = chunk_regions(path, data, top, chunks, _walk, McapError)
    schemas, channels = {}, {}
    for buf, _, r_ops, r_offs, *_ in regions:
        for o in r_offs[r_ops == OP_SCHEMA].tolist():
            b = buf[o:o + 4096].tobytes()
            schemas[_u16(b, 0)] = _string(b, 2)[0]
        for o in r_offs[r_ops == OP_CHANNEL].tolist():
            b = buf[o:o + 4096].tobytes()
            topic, p = _string(b, 4)
            channels[_u16(b, 0)] = (topic, _u16(b, 2), _string(b, p)[0])
    msg = [(base, r_ops == OP_MESSAGE, r_offs, r_lens, r_ch, r_ns)
           for _, base, r_ops, r_offs, r_lens, r_ch, r_ns in regions]
    m_offs = np.concatenate([o[m] + base for base, m, o, *_ in msg])
    m_lens = np.concatenate([ln[m] for _, m, _, ln, *_ in msg])
    if np.any(m_lens < MESSAGE_HEADER):
        raise McapError(f"{path}: a message record shorter than its header")
    return Messages(joined,
                    np.concatenate([c[m] for _, m, _, _, c, _ in msg]),
                    np.concatenate([t[m] for _, m, _, _, _, t in msg]),
                    m_offs + MESSAGE_HEADER, m_lens - MESSAGE_HEADER,
                    {c: (t, schemas.get(s, ""), enc) for c, (t, s, enc) in channels.items()})
