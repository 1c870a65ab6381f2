import json
import math

import pytest
from conftest import assert_report_complete, report_tables
from typer.testing import CliRunner

from fednav.campaign.html_report import render, write_report
from fednav.cli import app

SUMMARY = {
    "paper": "003", "runs": 4, "seed": 7,
    "tables": {
        "T1": {"rows": {
            "FUKF": {"pos": {"max": {"ours": 10.0, "paper": 2.0},     # ×5: flagged
                             "std": {"ours": 1.0, "paper": 1.1}}},      # ×0.91: fine
            "FKF <b>": {"pos": {"max": {"ours": math.nan, "paper": None}}}}},
        "improvement": {"rows": {"position": {"improvement_pct": {
            "ours": 12.0, "ci95": 3.0, "paper": 40.0}}}},                # ×0.3: flagged
        "empty": {"rows": {}},
    },
    "campaign": {"runs_total": 4, "runs_computed": 1, "runs_reused": 3,
                 "engine": "dask local, 2 worker processes"},
    "extra_numbers": [1, 2],
}


def _folder(tmp_path, summary=SUMMARY):
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    (tmp_path / "campaign.json").write_text(json.dumps(
        {"paper": "003", "scenario_hash": "abc123", "seed": 7, "fednav_version": "9.9",
         "created": "2026-01-01T00:00:00+00:00"}))
    (tmp_path / "errors.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"0" * 20)
    return tmp_path


def test_report_shows_every_row_ratio_flags_and_metadata(tmp_path):
    html = (write_report(_folder(tmp_path))).read_text()
    assert_report_complete(tmp_path)
    rows = report_tables(html)
    t1 = rows["T1"]
    cells = {r[1]: r for r in reversed(t1[1:3])}  # the FUKF row
    assert cells["pos / max"][5] == "×5.00" and cells["pos / std"][5] == "×0.91"
    assert cells["pos / max"][2] == "10.0" and cells["pos / std"][4] == "1.10"
    assert "&lt;b&gt;" in html and "<b>" not in html.split("<body>")[1].split("</h1>")[1]
    for text in ("abc123", "9.9", "7 … 10", "dask local, 2 worker processes",
                 "1 computed, 3 reused", "extra_numbers"):
        assert text in html, text
    assert "http" not in html.replace("http-equiv", "")  # self-contained
    assert (tmp_path / "report.html").exists() and not list(tmp_path.glob(".*tmp"))


def test_ratio_colour_threshold(tmp_path):
    html = render(_folder(tmp_path))
    # ×5 and ×0.3 are outside ×3, ×0.91 is not
    assert html.count("class='far'") == 2 and html.count("class='near'") == 1


@pytest.mark.parametrize("content", [None, "{not json", json.dumps({"paper": "1"})])
def test_report_on_a_folder_without_a_summary_is_one_line(tmp_path, content):
    if content is not None:
        (tmp_path / "summary.json").write_text(content)
    r = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert r.output.count("\n") == 1 and str(tmp_path) in r.output
