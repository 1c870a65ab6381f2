"""Shared test helpers."""

import json
from html.parser import HTMLParser
from pathlib import Path

import pytest


class _Cells(HTMLParser):
    """Text of every <td> of every <table id='table-NAME'>: {NAME: [[cells of a row]]}."""

    def __init__(self):
        super().__init__()
        self.tables, self.table, self.row, self.cell = {}, None, None, None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table" and a.get("id", "").startswith("table-"):
            self.table = self.tables.setdefault(a["id"][6:], [])
        elif tag == "tr" and self.table is not None:
            self.row = []
            self.table.append(self.row)
        elif tag == "td" and self.row is not None:
            self.cell = ""

    def handle_endtag(self, tag):
        if tag == "td" and self.cell is not None:
            self.row.append(self.cell)
            self.cell = None
        elif tag == "table":
            self.table = self.row = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell += data


def report_tables(html: str) -> dict:
    p = _Cells()
    p.feed(html)
    return p.tables


def assert_report_complete(folder: Path) -> None:
    """report.html of a reproduce folder shows every table row of summary.json (by its
    human label: ``curve_fit`` -> "curve fit")."""
    from fednav.campaign.explain import row_label

    s = json.loads((folder / "summary.json").read_text())
    html = (folder / "report.html").read_text()
    tables = report_tables(html)
    for name, t in s["tables"].items():
        if not t.get("rows"):
            continue
        assert name in tables, f"table {name} missing from report.html"
        shown = {r[0] for r in tables[name] if r and r[0]}
        assert shown == {row_label(r) for r in t["rows"]}, name
    assert "<img" in html and "data:image/png;base64," in html


@pytest.fixture
def report_complete():
    """The check above, for tests in sub-folders (which cannot import conftest)."""
    return assert_report_complete
