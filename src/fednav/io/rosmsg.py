"""ROS messages of a fixed layout decoded by one compiled pass over them: each message's
fields walked in order (ROS 2 CDR's alignment, strings skipped by their length prefix),
the fields wanted copied into one record per message (:func:`records`).

One pass keeps each message in the cache while its fields are taken: the messages are
read in place in the file's bytes (a bag's storage), scattered over tens of megabytes,
in the order they lie there (an SQLite page holds its rows from its end backwards: taken
in rowid order, twice the time).
"""

from __future__ import annotations

import numba
import numpy as np

#: :func:`records`' error codes: not little-endian CDR, a message that ends before a
#: field, one longer than its fields.
NOT_CDR_LE, ENDS_BEFORE, LONGER = 1, 2, 3


@numba.njit(cache=True)
def _records(buf, starts, lens, cdr, sizes, counts, places, width, order):
    n = len(starts)
    out = np.zeros((n, width), np.uint8)
    for ii in range(n):
        i = order[ii]
        s, end = starts[i], starts[i] + lens[i]
        origin = s
        if cdr:
            if lens[i] < 4 or buf[s] != 0 or buf[s + 1] != 1:
                return out, i, NOT_CDR_LE, -1
            origin = s + 4
        off = origin
        for f in range(len(sizes)):
            size = sizes[f]
            if size == 0:  # (a string: uint32 length, then its bytes)
                if cdr:
                    off = origin + (off - origin + 3) // 4 * 4
                if off + 4 > end:
                    return out, i, ENDS_BEFORE, f
                off += 4 + (np.int64(buf[off]) | (np.int64(buf[off + 1]) << 8)
                            | (np.int64(buf[off + 2]) << 16) | (np.int64(buf[off + 3]) << 24))
                continue
            if cdr:
                off = origin + (off - origin + size - 1) // size * size
            k = size * counts[f]
            if off + k > end:
                return out, i, ENDS_BEFORE, f
            w = places[f]
            if w >= 0 and k % 8 == 0:  # (8 bytes a move: x86-64 loads them unaligned)
                src, dst = buf[off:off + k].view(np.uint64), out[i, w:w + k].view(np.uint64)
                for j in range(k // 8):
                    dst[j] = src[j]
            elif w >= 0:
                for j in range(k):
                    out[i, w + j] = buf[off + j]
            off += k
        rest = end - off  # (CDR pads the end to 4 bytes)
        if rest < 0 or rest > (3 if cdr else 0):
            return out, i, LONGER, -1
    return out, -1, 0, -1


@numba.njit(cache=True)
def _gather(buf, starts, lens):
    out = np.empty(lens.sum(), np.uint8)
    q = 0
    for i in range(len(starts)):
        out[q:q + lens[i]] = buf[starts[i]:starts[i] + lens[i]]
        q += lens[i]
    return out


def gather(buf: np.ndarray, starts: np.ndarray, lens: np.ndarray) -> np.ndarray:
    """The messages at ``starts`` (N,) of lengths ``lens`` (N,) in ``buf`` back to back
    (uint8): what several files' messages of one topic become (not the files)."""
    return _gather(buf, np.asarray(starts, np.int64), np.asarray(lens, np.int64))


def records(buf: np.ndarray, starts: np.ndarray, lens: np.ndarray, cdr: bool,
            fields: list[tuple[np.dtype | None, int, bool]]):
    """The wanted fields of the messages at ``starts`` (N,) of lengths ``lens`` (N,) in
    ``buf`` (uint8), ROS 2 CDR (``cdr``: little-endian, aligned from the byte after the
    4-byte encapsulation header) or ROS 1 (packed).  ``fields``: the message's fields in
    order, each (dtype or None for a string, count, wanted).

    Returns (views, message, code, field): ``views`` one (N, count) array per field
    (None for those not wanted and strings); on a message that does not match, ``code``
    (:data:`NOT_CDR_LE`, :data:`ENDS_BEFORE` with its ``field``, :data:`LONGER`) and its
    index ``message`` (else code 0)."""
    sizes = np.array([0 if dt is None else dt.itemsize for dt, _, _ in fields], np.int64)
    counts = np.array([c for _, c, _ in fields], np.int64)
    places, width = np.full(len(fields), -1, np.int64), 0
    for f, (dt, count, wanted) in enumerate(fields):
        if wanted and dt is not None:
            width = -(-width // dt.itemsize) * dt.itemsize  # (each view aligned)
            places[f], width = width, width + dt.itemsize * count
    width = -(-width // 8) * 8
    starts = np.asarray(starts, np.int64)
    order = (np.arange(len(starts)) if np.all(starts[1:] >= starts[:-1]) else
             np.argsort(starts, kind="stable"))
    out, message, code, field = _records(buf, starts, np.asarray(lens, np.int64),
                                         bool(cdr), sizes, counts, places, width, order)
    views = [None if places[f] < 0 else
             out[:, places[f]:places[f] + dt.itemsize * count].view(dt)
             for f, (dt, count, _) in enumerate(fields)]
    return views, int(message), int(code), int(field)
