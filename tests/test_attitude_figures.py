"""Issue 38: attitude errors below 0.01° print in arc-seconds (″) in every human table —
a star-sensor system's 0.0034° reads 12.2″, not 0.003 or 0.000 — while the machine
outputs (summary.json, tables.csv, runs.csv) keep degrees."""

import io

import pytest

from fednav.campaign.numbers import (
    ARCSEC_BELOW_DEG,
    attitude_unit,
    format_attitude,
    is_attitude_deg,
)
from fednav.core.console import PipeConsole


@pytest.mark.parametrize(("deg", "text"), [
    (0.0034, "12.2″"),            # 12.24″
    (-0.005, "-18.0″"),           # the magnitude decides (paper 003's signed minimum)
    (0.0001, "0.36″"),
    (0.0, "0″"),
    (0.01, "0.01"),               # from 0.01° up: degrees, the column's unit
    (0.0209, "0.0209"),
    (1.5, "1.50"),
    (None, "–"),
    (float("nan"), "–"),
])
def test_format_attitude(deg, text):
    assert format_attitude(deg) == text


def test_a_ci_takes_its_values_unit():
    assert ARCSEC_BELOW_DEG == 0.01
    assert attitude_unit(0.0034) == (pytest.approx(3600.0), "″")
    assert attitude_unit(0.05) == (1.0, "")
    assert format_attitude(0.0002, unit_of=0.0034) == "0.72″"
    assert format_attitude(0.0002, unit_of=0.05) == "0.0002"
    assert format_attitude(0.004, fmt=lambda x: f"{x:.3f}") == "14.400″"


def test_attitude_keys():
    for k in ("pitch_deg", "roll_deg", "yaw_deg", "heading_deg"):
        assert is_attitude_deg(k)
    for k in ("lat_deg", "horizontal_position_m", "phiE_arcsec", "sigma_deg", "pitch"):
        assert not is_attitude_deg(k)


def _design_summary():
    cells = {"horizontal_position_m": {"rmse": {"value": 0.004, "ci95": 0.001}},
             "pitch_deg": {"rmse": {"value": 0.0034, "ci95": 0.0002},
                           "max": {"value": 0.0209, "ci95": 0.0049}},
             "heading_deg": {"rmse": {"value": 0.0034, "ci95": None}}}
    return {"design": "d", "runs": 2, "seed": 1,
            "tables": {"flight": {"title": "Errors over the flight", "runs": 2,
                                  "rows": {"INS/GNSS/star": cells}}}}


def test_design_tables_console_markdown_html_in_arcsec_csv_in_degrees():
    from fednav.campaign.design import print_design_tables, tables_frame, tables_markdown
    from fednav.campaign.html_report import design_table_html

    s = _design_summary()
    out = io.StringIO()
    print_design_tables(s, PipeConsole(file=out))
    text = out.getvalue()
    assert "12.2″ ±0.72″" in text and "0.0209 ±0.0049" in text
    assert "0.004 ±0.0010" in text            # a position in metres is not an angle
    md = tables_markdown(s)
    assert "| 12.2″ ± 0.72″ | 0.0209 ± 0.0049 |" in md and "| 12.2″ |" in md
    html = design_table_html("flight", s["tables"]["flight"], "t", 1)
    assert "<td>12.2″ ± 0.72″</td>" in html and "<td>0.0209 ± 0.0049</td>" in html
    df = tables_frame(s)                      # tables.csv: degrees, as declared
    row = df[(df["quantity"] == "pitch_deg") & (df["statistic"] == "rmse")].iloc[0]
    assert row["value"] == 0.0034 and row["ci95"] == 0.0002


def test_reproduction_tables_console_and_html():
    """Paper 003's attitude columns (degrees): fednav's value, its CI and the paper's
    each say their unit; the ratio is unit-free."""
    from fednav.campaign.html_report import table_html
    from fednav.campaign.report import print_tables

    table = {"rows": {"FUKF": {"roll_deg": {"std": {"ours": 0.004, "ci95": 0.0005,
                                                    "paper": 0.07}}}}}
    out = io.StringIO()
    print_tables({"paper": "003", "runs": 2, "seed": 1, "tables": {"T1": table}},
                 {"T1": "Table 1"}, PipeConsole(file=out))
    assert "14.4″ ± 1.80″ | 0.07 ×0.057 better" in out.getvalue()
    html = table_html("T1", table, "Table 1", 2, 1)
    assert "14.4″ ± 1.80″<span class='p'>paper 0.07 · ×0.057" in html


def test_process_rmse_console_and_html(tmp_path, monkeypatch):
    import json

    from fednav import cli
    from fednav.campaign.html_report import render

    s = {"epochs": 10, "run_time_s": 0.1, "consistency": {},
         "rmse": {"north_m": 0.5, "pitch_deg": 0.0004, "yaw_deg": 0.25}}
    out = io.StringIO()
    monkeypatch.setattr(cli, "console", PipeConsole(file=out))
    cli._print_process(s)
    text = out.getvalue()
    assert "1.440″" in text and "0.250" in text and "0.500" in text and "0.000" not in text
    (tmp_path / "summary.json").write_text(json.dumps(s))
    html = render(tmp_path)
    assert "<td>1.44″</td>" in html and "<td>0.25</td>" in html
