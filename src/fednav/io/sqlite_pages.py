"""A table of an SQLite database file read from its pages with numpy: every row's
columns as integers or as byte spans of the file, no Python object per row.

The file format (https://www.sqlite.org/fileformat.html): the file is pages of
``page_size`` bytes (big-endian 16-bit at byte 16 of the header; 1 means 65 536), each
with ``reserved`` bytes unused at its end (byte 20).  A table is a B-tree of pages whose
root page ``sqlite_master`` names: interior pages (type 5) point to their children, leaf
pages (type 13) hold the rows as cells — the payload's size and the rowid (varints), then
the record: a header of serial types (varints) and the values.  A payload larger than the
page can hold keeps its first bytes in the cell and the rest on overflow pages.

:func:`read_table` walks the interior pages in Python (a few dozen for a bag of some
hundred thousand messages) and every leaf page's cells with one compiled loop
(:func:`_cells`).  What it does not read — a write-ahead log beside the file (rows not yet
in it), a table without rowids — is a :class:`SqliteFormatError`; a value of a row that
lies on overflow pages is marked (:data:`ON_OVERFLOW`), for the caller to refuse.  The columns'
order is the table's (``PRAGMA table_info``); the caller checks them by name.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from .data import file_bytes

MAGIC = b"SQLite format 3\x00"
LEAF_TABLE, INTERIOR_TABLE = 13, 5
#: A value's kind in :attr:`Table.kind`: NULL, an integer, a blob, a text, another (a
#: float).
NULL, INTEGER, BLOB, TEXT, OTHER = 0, 1, 2, 3, 4
#: :attr:`Table.value` of a value that lies (partly) on overflow pages.
ON_OVERFLOW = -2


class SqliteFormatError(ValueError):
    """A database file or table this module does not read (read it with SQL instead)."""


@numba.njit(cache=True, inline="always")
def _varint(buf, p):
    """SQLite's big-endian varint at ``p``: (value, the offset after it)."""
    b = np.int64(buf[p])
    if b < 0x80:  # (most: one byte)
        return b, p + 1
    v = b & 0x7F
    for i in range(1, 8):
        b = np.int64(buf[p + i])
        v = (v << 7) | (b & 0x7F)
        if b < 0x80:
            return v, p + i + 1
    return (v << 8) | np.int64(buf[p + 8]), p + 9


@numba.njit(cache=True)
def _int_be(buf, p, n):
    """A big-endian two's-complement integer of ``n`` bytes at ``p``."""
    v = np.int64(0)
    for i in range(n):
        v = (v << 8) | np.int64(buf[p + i])
    if n < 8 and v >= (np.int64(1) << (8 * n - 1)):
        v -= np.int64(1) << (8 * n)
    return v


@numba.njit(cache=True)
def _u16(buf, p):
    return (np.int64(buf[p]) << 8) | np.int64(buf[p + 1])


@numba.njit(cache=True)
def _cells(buf, leaves, page_size, usable, ncols):
    """Every cell of the leaf pages ``leaves`` (page numbers, in order): (count, kind,
    value, size (count, ncols)) as :class:`Table` has them; or a negative count on a
    page that is not a table leaf (-1 - its index in ``leaves``) and empty arrays."""
    n = 0
    for k in range(len(leaves)):
        head = (leaves[k] - 1) * page_size + (100 if leaves[k] == 1 else 0)
        if buf[head] != LEAF_TABLE:
            return (np.int64(-1 - k), np.zeros((0, ncols), np.int8),
                    np.zeros((0, ncols), np.int64), np.zeros((0, ncols), np.int64))
        n += _u16(buf, head + 3)
    kind = np.zeros((n, ncols), np.int8)  # (NULL where a row has fewer columns)
    value = np.zeros((n, ncols), np.int64)
    size = np.zeros((n, ncols), np.int64)
    x = usable - 35  # (the largest payload kept whole in a leaf cell)
    m = (usable - 12) * 32 // 255 - 23
    first = 0
    for k in range(len(leaves)):
        base = (leaves[k] - 1) * page_size
        head = base + (100 if leaves[k] == 1 else 0)
        cells = _u16(buf, head + 3)
        for c in range(cells - 1, -1, -1):  # (a page fills from its end: addresses up)
            i = first + c
            p = base + _u16(buf, head + 8 + 2 * c)
            payload, p = _varint(buf, p)
            _, p = _varint(buf, p)  # (the rowid)
            local = payload
            if payload > x:
                local = m + (payload - m) % (usable - 4)
                if local > x:
                    local = m
            end = p + local
            hsize, q = _varint(buf, p)
            v = p + hsize
            for j in range(ncols):
                if q >= p + hsize:
                    break
                st, q = _varint(buf, q)
                if st >= 12:
                    nb = (st - 12) // 2
                    kind[i, j] = BLOB if st % 2 == 0 else TEXT
                    value[i, j] = v if v + nb <= end else ON_OVERFLOW
                    size[i, j] = nb
                elif st == 0:
                    nb = 0
                elif st == 8 or st == 9:
                    nb = 0
                    kind[i, j], value[i, j] = INTEGER, st - 8
                elif st <= 6:
                    nb = st if st <= 4 else (6 if st == 5 else 8)
                    kind[i, j] = INTEGER
                    value[i, j] = _int_be(buf, v, nb) if v + nb <= end else ON_OVERFLOW
                else:
                    nb = 8 if st == 7 else 0
                    kind[i, j] = OTHER
                v += nb
        first += cells
    return np.int64(n), kind, value, size


@dataclass
class Table:
    """A table's rows in rowid order: ``buf`` the file's bytes; per row and column (the
    table's order, ``columns``) its ``kind`` (:data:`INTEGER`, :data:`BLOB`, :data:`TEXT`,
    :data:`NULL` or :data:`OTHER`), ``value`` (an integer's value; a blob's or text's
    offset into ``buf``, :data:`ON_OVERFLOW` when it is not all in the cell) and
    ``size`` (a blob's or text's bytes).  A rowid alias (``INTEGER PRIMARY KEY``) is
    NULL, as stored."""

    buf: np.ndarray
    columns: list[str]
    kind: np.ndarray
    value: np.ndarray
    size: np.ndarray


def _leaves(buf: np.ndarray, root: int, page_size: int, pages: int) -> np.ndarray:
    """The leaf pages of the table B-tree at page ``root``, in rowid order (a level of
    the tree at a time: every leaf lies at the same depth)."""
    level = np.array([root], np.int64)
    while True:
        if np.any((level < 1) | (level > pages)):
            raise SqliteFormatError(f"a page number outside the file's {pages} pages")
        heads = (level - 1) * page_size + np.where(level == 1, 100, 0)
        kinds = buf[heads]
        if np.all(kinds == LEAF_TABLE):
            return level
        if not np.all(kinds == INTERIOR_TABLE):
            bad = level[np.flatnonzero(kinds != INTERIOR_TABLE)[0]]
            raise SqliteFormatError(f"page {bad} is not one of a table B-tree's level")
        children = []
        for page, head in zip(level.tolist(), heads.tolist(), strict=True):
            n = int.from_bytes(buf[head + 3:head + 5].tobytes(), "big")
            cells = buf[head + 12:head + 12 + 2 * n].view(">u2").astype(np.int64) + (
                (page - 1) * page_size)
            children += [buf[cells[:, None] + np.arange(4)].view(">u4")[:, 0],
                         [int.from_bytes(buf[head + 8:head + 12].tobytes(), "big")]]
        level = np.concatenate(children).astype(np.int64)


def read_table(path: Path, table: str) -> Table:
    """Every row of ``table`` in the SQLite database file ``path`` (:class:`Table`).

    Raises :class:`SqliteFormatError` for a file or table it does not read (not an
    SQLite file, a write-ahead log beside it, a table without rowids or not found,
    pages that do not make a table B-tree, rows that SQL counts otherwise)."""
    path = Path(path)
    wal = path.with_name(path.name + "-wal")
    if wal.exists() and wal.stat().st_size:
        raise SqliteFormatError(f"{path}: a write-ahead log beside it ({wal.name})")
    buf = file_bytes(path)
    if len(buf) < 100 or buf[:16].tobytes() != MAGIC:
        raise SqliteFormatError(f"{path}: not an SQLite database file")
    page_size = int.from_bytes(buf[16:18].tobytes(), "big")
    page_size = 65536 if page_size == 1 else page_size
    usable = page_size - int(buf[20])
    pages = len(buf) // page_size
    try:
        con = sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro&immutable=1", uri=True)
        try:
            found = con.execute("SELECT rootpage, sql FROM sqlite_master WHERE type = "
                                "'table' AND name = ?", (table,)).fetchone()
            if found is None:
                raise SqliteFormatError(f"{path}: no table {table}")
            columns = [r[1] for r in con.execute(f"PRAGMA table_info('{table}')")]
            count = con.execute(f"SELECT count(*) FROM '{table}'").fetchone()[0]
        finally:
            con.close()
    except sqlite3.Error as e:
        raise SqliteFormatError(f"{path}: {e}") from None
    if "WITHOUT ROWID" in str(found[1]).upper():
        raise SqliteFormatError(f"{path}: table {table} has no rowids")
    leaves = _leaves(buf, int(found[0]), page_size, pages)
    n, kind, value, size = _cells(buf, leaves, page_size, usable, len(columns))
    if n < 0:
        raise SqliteFormatError(f"{path}: page {leaves[-1 - n]} is not a table leaf")
    if n != count:
        raise SqliteFormatError(f"{path}: {n} cells in {table}'s pages, {count} rows")
    return Table(buf, columns, kind, value, size)
