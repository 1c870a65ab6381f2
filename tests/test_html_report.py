import json
import math
import re
import shutil
import subprocess
from pathlib import Path

import pytest
from conftest import assert_report_complete, report_tables
from typer.testing import CliRunner

from fednav.campaign import explain
from fednav.campaign.html_report import render, write_report
from fednav.cli import app

DOCS = Path(__file__).resolve().parents[1] / "docs"

SUMMARY = {
    "paper": "003", "runs": 4, "seed": 7,
    "tables": {
        "T1": {"rows": {
            "FUKF": {"lon_m": {"max": {"ours": 20.0, "paper": 5.06},     # ×4: worse
                               "std": {"ours": 1.5, "paper": 1.57}},     # ×0.96: fine
                     "roll_deg": {"max": {"ours": 0.02, "paper": 0.26},  # better
                                  "std": {"ours": 0.005, "paper": 0.07}}},
            "FKF <b>": {"lon_m": {"max": {"ours": math.nan, "paper": None},
                                  "std": {"ours": 2.0, "paper": 2.46}},
                        "roll_deg": {"max": {"ours": 0.03, "paper": 0.35},
                                     "std": {"ours": 0.01, "paper": 0.09}}}}},
        "improvement": {"rows": {"position": {"improvement_pct": {
            "ours": -0.001, "ci95": 3.0, "paper": 25.8,                 # worse, not ×-0.00
            "paper_table_same_rule": 37.1}}}},
        "timing": {"rows": {"UKF": {"ms_per_cycle": {"ours": 30.0, "paper": 2.1},
                                    "pos_m": {"ours": 0.7, "paper": 0.85}}}},
        "empty": {"rows": {}},
    },
    "campaign": {"runs_total": 4, "runs_computed": 1, "runs_reused": 3,
                 "engine": "dask local, 2 worker processes"},
    "extra_numbers": [1, 2],
    "observability_phases": {"si": {"climb": {"phiE": 3400.0, "dVE": 1.0},
                                    "dive": {"phiE": 3300.0, "dVE": 1.0}}},
    "failures": [],
    "null_values": [{"why": "no run gave a finite value", "was": "NaN",
                     "paths": ["/tables/T1/rows/FKF <b>/lon_m/max/ours"]}],
}


def _folder(tmp_path, summary=SUMMARY):
    (tmp_path / "summary.json").write_text(json.dumps(summary))
    (tmp_path / "campaign.json").write_text(json.dumps(
        {"paper": "003", "scenario_hash": "abc123", "seed": 7, "fednav_version": "9.9",
         "created": "2026-01-01T00:00:00+00:00"}))
    (tmp_path / "errors.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"0" * 20)
    return tmp_path


def _cells(html: str, table: str) -> dict:
    """{(row, statistic): [cell texts]} of a report table (a row's name only on its first
    line, as shown)."""
    rows, last = {}, None
    for r in report_tables(html)[table]:
        if not r:
            continue
        last = r[0] or last
        rows[(last, r[1])] = r
    return rows


def test_report_shows_every_row_ratio_flags_and_metadata(tmp_path):
    html = (write_report(_folder(tmp_path))).read_text()
    assert_report_complete(tmp_path)
    t1 = _cells(html, "T1")
    # columns: row, statistic, east position [m], roll [°]
    assert t1[("FUKF", "max")][2].startswith("20.0") and "×3.95" in t1[("FUKF", "max")][2]
    assert "×0.96" in t1[("FUKF", "std")][2] and "paper 1.57" in t1[("FUKF", "std")][2]
    assert "&lt;b&gt;" in html and "<b>" not in html.split("<body>")[1].split("</h1>")[1]
    for text in ("abc123", "9.9", "7 … 10", "dask local, 2 worker processes",
                 "1 computed, 3 reused"):
        assert text in html, text
    assert "http" not in html.replace("http-equiv", "")  # self-contained
    assert (tmp_path / "report.html").exists() and not list(tmp_path.glob(".*tmp"))


def test_human_titles_and_labels_not_raw_keys(tmp_path):
    """Issue 29: paper 003's headings were the raw keys "T1", "improvement", "fault";
    the paper's own titles are used (as ``fednav report`` passes them: the campaign layer
    does not import the scenarios), and every measure has a label."""
    from fednav.scenarios import paper_module

    html = render(_folder(tmp_path), paper_module("003").EXPERIMENT.titles)
    heads = re.findall(r"<h2[^>]*>(.*?)</h2>", html)
    assert "Table 1 — error max / min / std over the flight" in heads
    assert "Improvement of FUKF over FKF" in heads
    assert not {"T1", "improvement", "timing"} & set(heads)
    assert "east position [m]" in html and "roll [°]" in html and "improvement [%]" in html
    assert ">lon_m<" not in html and ">improvement_pct<" not in html


def test_red_only_for_worse_with_a_reason_green_for_better_timings_not_judged(tmp_path):
    html = render(_folder(tmp_path))
    t1 = _cells(html, "T1")
    # a larger error: red, with a link to its reason
    assert re.search(r"<td class='worse'[^>]*>20\.0", html)
    assert "worse: why [" in t1[("FUKF", "max")][2]
    # smaller attitude errors than the paper's: green, said in words, not red
    assert "better than the paper" in t1[("FUKF", "max")][3]
    assert re.search(r"<td class='better'[^>]*>0\.02<", html)
    # an improvement of -0.001 % against 25.8 %: worse, as a difference in points
    assert "×-0.00" not in html and "-25.8 points" in html
    assert re.search(r"<td class='worse'[^>]*>-0\.001", html)
    assert "own Table 1, same rule: 37.1" in html  # a cell's further figure is shown
    # a timing on another machine is shown, not judged
    timing = report_tables(html)["timing"][1]  # UKF: time per filter cycle, position
    assert "timing: not compared" in timing[1] and "×14.29" in timing[1]
    assert re.search(r"<td class='timing'[^>]*>30\.0", html)
    assert html.count("<td class='worse'") == 2 and html.count("<td class='better'") == 4
    # every link to a reason lands on a reason, which names its doc section
    links = set(re.findall(r"href='#(why-\d+)'", html))
    assert links and all(f"id='{w}'" in html for w in links)
    assert "docs/paper003.md#" in html


def test_every_explanation_points_at_an_anchor_of_its_doc():
    for paper, rules in explain.EXPLAINED.items():
        text = (DOCS / f"paper{paper}.md").read_text()
        for *_, anchor, _why in rules:
            assert f'<a id="{anchor}"></a>' in text, (paper, anchor)
        # a catch-all, so that no flagged cell is left without a reason
        assert rules[-1][:3] == ("*", "*", "*"), paper
    r = explain.reason("002", "T2", "SINS", "dVx_mps")
    assert r.anchor == "beyond-x3" and "swapped" in explain.doc_excerpt(r) + r.text


@pytest.mark.parametrize("ours, paper, q, kind", [
    (10.0, 2.0, "pos_m", "worse"), (0.5, 2.0, "pos_m", "better"),
    (-0.5, -2.0, "lon_m / min", "better"), (-9.0, -2.0, "lon_m / min", "worse"),
    (1.0, 1.1, "pos_m", "near"), (3437.0, 8.67, "degree", "differs"),
    (90.0, 25.8, "improvement_pct", "better"), (30.0, 2.0, "ms_per_cycle", "timing"),
    (None, 2.0, "pos_m", ""), (1.0, None, "pos_m", ""), (2.0, -2.0, "h_m / max", "differs"),
])
def test_verdicts(ours, paper, q, kind):
    assert explain.compare(ours, paper, q).kind == kind


def test_confidence_interval_said_only_where_there_is_one(tmp_path):
    """Issue 29: "mean ± 95 % CI over 10 runs" over a table whose every CI is "–"."""
    one = {"paper": "002", "runs": 1, "seed": 1, "tables": {"T2": {"rows": {
        "SINS": {"dlambda_m": {"ours": 280.0, "ci95": None, "paper": 267.0}}}}}}
    html = render(_folder(tmp_path, one))
    assert "one Monte Carlo run (seed 1) — no confidence interval" in html
    assert "95 % confidence interval over" not in html and "±" not in html.split(
        "<table id='table-T2'>")[1]
    analysis = {**one, "runs": 10}
    html = render(_folder(tmp_path, analysis))
    assert "one computation" in html and "95 % confidence interval over" not in html


def test_measures_not_computed_are_left_out_and_said(tmp_path):
    s = {"paper": "003", "runs": 2, "seed": 1, "tables": {"fault": {"rows": {
        c: {"detect_delay_s": {"ours": None, "ci95": None, "paper": None},
            "false_alarm_rate": {"ours": 0.0, "ci95": 0.0, "paper": None}}
        for c in ("isolated", "not_isolated")}}}}
    html = render(_folder(tmp_path, s))
    header = html.split("<table id='table-fault'>")[1].split("</tr>")[0]
    assert "false alarms outside the window" in header and "detection delay" not in header
    assert "Not computed in this run (no value in any row): detection delay [s]" in html


def test_other_results_are_labelled_tables_not_a_json_dump(tmp_path):
    html = render(_folder(tmp_path))
    assert "<pre>" not in html and "{&quot;" not in html and '{"' not in html
    tables = report_tables(html)
    assert "other-observability_phases-si" in tables and "other-null_values" in tables
    assert "Observability degree per flight phase" in html and "φE" in html
    nulls = tables["other-null_values"][1]
    assert nulls[0] == "no run gave a finite value" and "east position [m], max" in nulls[2]
    assert "Runs that failed" in html and "extra numbers" in html


def _process_folder(tmp_path):
    s = {"inputs": {"imu": "imu.csv", "gnss": "gnss.csv", "config": None},
         "run_time_s": 0.9, "epochs": 494,
         "data_quality": {"imu_samples_bridged": 2, "gnss_epochs_skipped": 0},
         "warnings": ["imu.csv: no IMU error figures <assumed>", "gnss.csv: 3 fixes late"],
         "consistency": {"gnss": {"nis_per_dof": 0.35, "isolated_fraction": 0.0,
                                  "measurements": 494},
                         "velocity": {"nis_per_dof": 0.85, "isolated_fraction": 0.01,
                                      "measurements": 988}},
         "alignment": {"levelling": "static 14.2 s", "euler_deg": [-0.25, -0.08, 30.1]},
         "rmse": {"north_m": 1.08, "east_m": 0.58, "vn_mps": 0.028},
         "against": {"px4": {"source": "PX4 EKF2", "rmse": {"north_m": 2.0}}},
         "health": {"stuck_axes": []}}
    (tmp_path / "summary.json").write_text(json.dumps(s))
    (tmp_path / "solution.csv").write_text(
        "t_s,lat_deg,lon_deg,h_m,vE_mps,vN_mps,vU_mps,sigma_E_m,sigma_N_m,sigma_U_m\n"
        "0.0,51.0,-114.0,1000.0,10.0,0.0,0.0,5.0,5.0,5.0\n"
        "1.0,51.0,-113.99986,1000.0,10.0,0.0,0.0,0.5,0.5,0.9\n")
    (tmp_path / "track.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"0" * 20)
    return s


def test_report_on_a_process_folder_shows_every_table_and_warning(tmp_path):
    s = _process_folder(tmp_path)
    r = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert r.exit_code == 0, r.output
    html = (tmp_path / "report.html").read_text()
    for w in s["warnings"]:
        assert w.replace("<", "&lt;").replace(">", "&gt;") in html, w
    assert "Warnings (2)" in html
    tables = report_tables(html)
    for t in ("solution", "consistency", "alignment", "data-quality", "rmse", "rmse-px4"):
        assert t in tables, t
    assert "RMSE against PX4 EKF2" in html and "north position [m]" in html
    sol = {r[0]: r[1] for r in tables["solution"] if r}
    assert sol["rows"] == "2" and sol["horizontal distance [m]"] == "9.81"
    assert "(outside 0.5 … 2)" in html  # gnss NIS/dof 0.35
    assert "data:image/png;base64," in html and "Health checks" in html


def test_report_renders_in_headless_chromium(tmp_path):
    """The page as a browser shows it: every table there, nothing fetched."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        pytest.skip("no headless Chromium here")
    html_path = write_report(_folder(tmp_path))
    r = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu",
                        "--dump-dom", html_path.resolve().as_uri()],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-500:]
    dom = r.stdout
    for t in ("T1", "improvement", "timing", "other-null_values"):
        assert f'id="table-{t}"' in dom, t
    assert "better than the paper" in dom and "Why cells differ from the paper" in dom


@pytest.mark.parametrize("content", [None, "{not json", json.dumps({"paper": "1"})])
def test_report_on_a_folder_without_a_summary_is_one_line(tmp_path, content):
    if content is not None:
        (tmp_path / "summary.json").write_text(content)
    r = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert r.output.count("\n") == 1 and str(tmp_path) in r.output
