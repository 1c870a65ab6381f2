"""``fednav.io.sqlite_pages``: a table read from an SQLite file's pages gives every row
that SQLite's own SQL gives — integers of every serial type, blobs and texts of every
size (those on overflow pages marked), page sizes from 512 to 65 536 bytes, a B-tree
several levels deep, rows written before a column was added — and what it does not read
(a write-ahead log beside the file, a table without rowids, not an SQLite file) is one
:class:`SqliteFormatError`."""

import sqlite3

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fednav.io.sqlite_pages import (
    BLOB,
    INTEGER,
    NULL,
    ON_OVERFLOW,
    OTHER,
    TEXT,
    SqliteFormatError,
    read_table,
)

#: integers at the edges of every serial type's size (1, 2, 3, 4, 6, 8 bytes; 0 and 1)
EDGES = [0, 1, -1, 127, -128, 128, 32767, -32768, 32768, 2**23 - 1, -(2**23), 2**23,
         2**31 - 1, -(2**31), 2**31, 2**47 - 1, -(2**47), 2**47, 2**63 - 1, -(2**63)]


def _db(path, rows, page_size=4096, vacuum=False):
    con = sqlite3.connect(path)
    con.execute(f"PRAGMA page_size = {page_size}")
    con.execute("CREATE TABLE t (id INTEGER PRIMARY KEY, a INTEGER, b BLOB)")
    con.executemany("INSERT INTO t (a, b) VALUES (?, ?)", rows)
    con.commit()
    if vacuum:
        con.execute("VACUUM")
    con.close()
    return path


def _check(path, table="t", cols=("a", "b")):
    got = read_table(path, table)
    con = sqlite3.connect(path)
    want = con.execute(f"SELECT {', '.join(cols)} FROM {table} ORDER BY rowid").fetchall()
    con.close()
    assert len(got.kind) == len(want)
    for i, row in enumerate(want):
        for j, x in enumerate(row, start=1):
            k, v = got.kind[i, j], got.value[i, j]
            if x is None:
                assert k == NULL
            elif isinstance(x, int):
                assert k == INTEGER and v == x
            elif isinstance(x, float):
                assert k == OTHER
            else:
                data = x.encode() if isinstance(x, str) else x
                assert k == (TEXT if isinstance(x, str) else BLOB)
                assert got.size[i, j] == len(data)
                if v != ON_OVERFLOW:
                    assert got.buf[v:v + len(data)].tobytes() == data
    return got


def test_every_integer_serial_type_and_small_blobs(tmp_path):
    rows = [(x, bytes([i % 256]) * (i % 40)) for i, x in enumerate(EDGES * 3)]
    rows += [(None, b"x"), (5, None), (7, "text"), (8, 2.5)]
    got = _check(_db(tmp_path / "a.db", rows))
    assert got.columns == ["id", "a", "b"] and np.all(got.kind[:, 0] == NULL)


@pytest.mark.parametrize("page_size", [512, 1024, 4096, 65536])
def test_a_tree_several_levels_deep_with_overflowing_blobs(tmp_path, page_size):
    """Thousands of rows (interior pages above the leaves at 512 bytes), blobs below,
    at and above what a leaf cell keeps (the rest on overflow pages: marked, never read
    wrong)."""
    rng = np.random.default_rng(1)
    sizes = np.r_[rng.integers(0, 300, 3000), [page_size - 36, page_size - 35,
                                               page_size - 34, 3 * page_size]]
    rows = [(int(rng.integers(-2**40, 2**40)), rng.bytes(int(n))) for n in sizes]
    got = _check(_db(tmp_path / "a.db", rows, page_size, vacuum=True))
    over = got.value[:, 2] == ON_OVERFLOW
    assert over[-2:].all() and not over[:3000].any()  # (a payload of more than
    assert np.all(got.size[over, 2] >= page_size - 50)  # page_size - 35 overflows)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.one_of(st.none(), st.integers(-2**63, 2**63 - 1)),
                          st.one_of(st.none(), st.binary(max_size=600),
                                    st.text(max_size=200))),
                max_size=300),
       st.sampled_from([512, 4096]))
def test_any_rows_read_as_sql_reads_them(tmp_path_factory, rows, page_size):
    got = _check(_db(tmp_path_factory.mktemp("h") / "a.db", rows, page_size))
    assert len(got.kind) == len(rows)
    assert [int(got.value[i, 1]) if got.kind[i, 1] == INTEGER else None
            for i in range(len(rows))] == [a for a, _ in rows]
    assert [NULL if b is None else (TEXT if isinstance(b, str) else BLOB)
            for _, b in rows] == got.kind[:, 2].tolist()


def test_rows_from_before_a_column_was_added_are_null_there(tmp_path):
    p = _db(tmp_path / "a.db", [(1, b"a"), (2, b"b")])
    con = sqlite3.connect(p)
    con.execute("ALTER TABLE t ADD COLUMN c INTEGER")
    con.execute("INSERT INTO t (a, b, c) VALUES (3, x'63', 9)")
    con.commit()
    con.close()
    got = _check(p, cols=("a", "b", "c"))
    assert got.kind[:, 3].tolist() == [NULL, NULL, INTEGER] and got.value[2, 3] == 9


def test_what_it_does_not_read_is_one_error(tmp_path):
    p = _db(tmp_path / "a.db", [(1, b"a")])
    with pytest.raises(SqliteFormatError, match="no table nothere"):
        read_table(p, "nothere")
    (tmp_path / "a.db-wal").write_bytes(b"x" * 100)
    with pytest.raises(SqliteFormatError, match="write-ahead log"):
        read_table(p, "t")
    (tmp_path / "n.db").write_bytes(b"not a database at all" * 10)
    with pytest.raises(SqliteFormatError, match="not an SQLite database"):
        read_table(tmp_path / "n.db", "t")
    con = sqlite3.connect(tmp_path / "w.db")
    con.execute("CREATE TABLE w (k TEXT PRIMARY KEY, v INTEGER) WITHOUT ROWID")
    con.commit()
    con.close()
    with pytest.raises(SqliteFormatError, match="no rowids"):
        read_table(tmp_path / "w.db", "w")
