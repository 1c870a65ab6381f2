"""``fednav run SCENARIO.yaml``: a user's design as a Monte Carlo campaign, end to end on
both example designs; the confidence intervals; one-line errors."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_report_complete
from typer.testing import CliRunner

from fednav.campaign.design import ci95, json_safe, summarize_rows
from fednav.cli import app

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: (file, --max-time): truncated flights that still hold what makes each design (the UAV
#: flies into its GNSS outage at 900 s; the car makes its first stop at 150-180 s, so
#: ZUPT has measurements).
DESIGNS = [("uav-gnss-baro-star.yaml", "960"), ("land-vehicle-odometer-zupt.yaml", "200")]


def _no_nan(text: str):
    def refuse(name):
        raise AssertionError(f"summary.json holds {name}")
    return json.loads(text, parse_constant=refuse)


def _run(path, out, *extra):
    return CliRunner().invoke(app, ["run", str(path), "--jobs", "1", "--out", str(out),
                                    *extra])


@pytest.mark.slow
@pytest.mark.parametrize(("name", "max_time"), DESIGNS)
def test_run_example_end_to_end_and_resume(tmp_path, name, max_time):
    out = tmp_path / "out"
    r = _run(EXAMPLES / name, out, "--runs", "2", "--max-time", max_time)
    assert r.exit_code == 0, r.output
    s = _no_nan((out / "summary.json").read_text())
    import yaml

    scn = yaml.safe_load((EXAMPLES / name).read_text())
    modes = [m["name"] for m in scn["modes"]]
    assert s["design"] == scn["name"] and s["runs"] == 2 and s["seed"] == 1
    flight = s["tables"]["flight"]
    assert list(flight["rows"]) == modes
    for mode in modes:
        for q in ("horizontal_position_m", "height_m", "velocity_mps", "pitch_deg",
                  "roll_deg", "heading_deg"):
            for stat in ("rmse", "mean", "max"):
                cell = flight["rows"][mode][q][stat]
                assert cell["value"] > 0 and cell["ci95"] >= 0, (mode, q, stat, cell)
        c = flight["rows"][mode]["horizontal_position_m"]
        assert c["mean"]["value"] <= c["rmse"]["value"] <= c["max"]["value"]
    # every local filter of every mode has its consistency, and none diverged (NIS/dof
    # far above 1); ZUPT's simulated zeros are exact, hence its NIS/dof well below 1
    nis = s["tables"]["consistency"]["rows"]
    assert {m: set(v) for m, v in nis.items()} == {
        m["name"]: set(m["aiding"]) for m in scn["modes"]}
    for mode, locals_ in nis.items():
        for local, cell in locals_.items():
            assert 0.005 < cell["nis_per_dof"]["value"] < 2.0, (mode, local, cell)
    for f in ("runs.csv", "tables.csv", "tables.md", "errors.png", "report.html",
              "campaign.json"):
        assert (out / f).is_file(), f
    assert len((out / "runs.csv").read_text().strip().splitlines()) == 1 + 2 * len(modes)
    assert json.loads((out / "campaign.json").read_text())["paper"] == f"design:{scn['name']}"
    assert_report_complete(out)
    html = (out / "report.html").read_text()
    assert "fednav design" in html and "paper" not in html.split("<h2>")[0].lower()
    # resumed: both runs read back, the same tables
    r = _run(EXAMPLES / name, out, "--runs", "2", "--max-time", max_time)
    assert r.exit_code == 0, r.output
    s2 = _no_nan((out / "summary.json").read_text())
    assert (s2["campaign"]["runs_computed"], s2["campaign"]["runs_reused"]) == (0, 2)
    assert s2["tables"] == s["tables"]


@pytest.mark.slow
def test_outage_windows_and_more_runs_reuse_the_stored_ones(tmp_path):
    out = tmp_path / "uav"
    path = EXAMPLES / "uav-gnss-baro-star.yaml"
    assert _run(path, out, "--runs", "1", "--max-time", "960").exit_code == 0
    s = _no_nan((out / "summary.json").read_text())
    # one run: the values, no interval (null, never NaN)
    cell = s["tables"]["flight"]["rows"]["INS/GNSS"]["height_m"]["rmse"]
    assert cell["value"] > 0 and cell["ci95"] is None
    # the GNSS outage inside the truncated flight, clipped to it
    assert s["outage_windows"] == [{"key": "outage_900_1200s", "sensors": ["gnss"],
                                    "start_s": 900.0, "end_s": 960.0}]
    out_t = s["tables"]["outage_900_1200s"]["rows"]
    # without GNSS the star sensor bounds the attitude, hence the position drift
    assert (out_t["INS/GNSS/baro/star"]["heading_deg"]["max"]["value"]
            < out_t["INS/GNSS"]["heading_deg"]["max"]["value"])
    r = _run(path, out, "--runs", "3", "--max-time", "960")
    assert r.exit_code == 0, r.output
    c = _no_nan((out / "summary.json").read_text())["campaign"]
    assert (c["runs_computed"], c["runs_reused"]) == (2, 1)


def _one_line_error(r, *words):
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), r.output
    for w in words:
        assert w in lines[0], lines[0]


def test_bad_scenarios_are_one_line_errors(tmp_path):
    text = (EXAMPLES / "uav-gnss-baro-star.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("sigma_arcsec: 20.0", "sigma_arcsec: -20.0"))
    _one_line_error(_run(bad, tmp_path / "o1"), "bad.yaml", "sigma_arcsec")
    bad.write_text(text.replace("aiding: [gnss, baro, star]", "aiding: [gnss, lidar]"))
    _one_line_error(_run(bad, tmp_path / "o2"), "lidar")
    bad.write_text(text.replace("duration_s: 120}", "duration_s: 120.005}"))
    _one_line_error(_run(bad, tmp_path / "o2"), "segments", "120.005")
    bad.write_text(text.replace("accel_mps2: -0.5}", "accel_mps2: -5.0}", 1))
    _one_line_error(_run(bad, tmp_path / "o2"), "segments", "speed negative")
    bad.write_text(text.replace("name: INS/GNSS/baro,", "name: INS/GNSS,"))
    _one_line_error(_run(bad, tmp_path / "o2"), "modes", "INS/GNSS")
    bad.write_text("name: x\nsegments: [\n")
    _one_line_error(_run(bad, tmp_path / "o3"), "bad.yaml")
    _one_line_error(_run(tmp_path / "missing.yaml", tmp_path / "o4"), "missing.yaml")
    _one_line_error(_run(EXAMPLES / "uav-gnss-baro-star.yaml", tmp_path / "o5", "--runs",
                         "0"), "--runs")
    assert not (tmp_path / "o1" / "summary.json").exists()


# ------------------------------------------------------------------- the statistics
def test_ci95_is_the_student_t_interval_of_the_mean():
    m, h = ci95([1.0, 2.0, 3.0])
    assert m == pytest.approx(2.0)
    # t(0.975, 2 dof) = 4.302653; sample std 1
    assert h == pytest.approx(4.302652729749464 / math.sqrt(3.0), rel=1e-12)
    assert ci95([2.5]) == (2.5, None)                # one run: no interval
    assert ci95([]) == (None, None)
    assert ci95([1.0, np.nan, 3.0])[0] == pytest.approx(2.0)   # NaN left out
    # coverage: the interval holds the true mean in about 95 % of experiments
    rng = np.random.default_rng(7)
    hits = 0
    for _ in range(4000):
        m, h = ci95(rng.normal(10.0, 2.0, 5))
        hits += abs(m - 10.0) <= h
    assert 0.94 < hits / 4000 < 0.96


def test_tables_with_missing_statistics_hold_null_not_nan():
    rows = [{"seed": 1, "mode": "A", "flight.height_m.rmse": 1.0,
             "flight.height_m.max": float("nan"), "nis_per_dof.gnss": 0.9}]
    t = summarize_rows(rows, ["A"], [], 1)
    cell = t["flight"]["rows"]["A"]["height_m"]
    assert cell["rmse"] == {"value": 1.0, "ci95": None}
    assert cell["max"] == {"value": None, "ci95": None}
    assert t["flight"]["rows"]["A"]["pitch_deg"]["rmse"] == {"value": None, "ci95": None}
    assert t["consistency"]["rows"]["A"]["gnss"]["nis_per_dof"]["value"] == 0.9
    json.dumps(json_safe({"x": [np.float64("nan"), np.inf, 1.0]}), allow_nan=False)
    assert json_safe({"x": [np.float64("nan"), np.inf, 1.0]}) == {"x": [None, None, 1.0]}


def test_table_titles_do_not_wrap_when_piped():
    """A title is its own lines above the table (a rich title wraps to the table's
    width, ~46 columns, piped or not)."""
    import io

    from fednav.campaign.design import print_design_tables
    from fednav.core.console import PipeConsole

    title = ("Navigation errors over the whole flight, every mode of the design compared "
             "side by side")
    summary = {"seed": 3, "tables": {"errors": {"title": title, "runs": 12, "rows": {
        "INS/GNSS": {"horizontal_position_m": {"rmse": {"value": 1.23, "ci95": 0.1}}}}}}}
    out = io.StringIO()
    print_design_tables(summary, PipeConsole(file=out))
    lines = out.getvalue().splitlines()
    assert lines[:2] == [title, "Monte Carlo mean ±95% CI over 12 runs (seed 3)"]


def test_a_designs_nis_is_the_centralized_filters():
    """In a federation (GNSS, baro, star sharing their information) each local filter's
    ``nis_per_dof`` is against the centralized filter's innovation covariance — about 1
    for a consistent filter — and the local filter's own, which its gate tests, is beside
    it as ``gate_nis_per_dof`` (the star's: about 0.6)."""
    from fednav.campaign.design import one_run
    from fednav.sim.scenario import load_scenario

    scn = load_scenario(EXAMPLES / "uav-gnss-baro-star.yaml")
    rows = [r for seed in (1, 2) for r in one_run((scn, seed, 200.0))[0]
            if r["mode"] == "INS/GNSS/baro/star"]
    for local in ("gnss", "baro", "star"):
        central = np.mean([r[f"nis_per_dof.{local}"] for r in rows])
        gate = np.mean([r[f"gate_nis_per_dof.{local}"] for r in rows])
        assert 0.75 < central < 1.35, (local, central)
        assert gate <= central + 1e-9, (local, gate, central)
    star_gate = np.mean([r["gate_nis_per_dof.star"] for r in rows])
    assert star_gate < 0.8


def test_a_design_naming_a_recording_only_key_is_told(tmp_path):
    """noise and output_rate_hz act on fednav process's recordings: a design that sets
    them is told, in one line, that fednav run does not use them."""
    import yaml

    from fednav.campaign.design import Design

    scn = yaml.safe_load((EXAMPLES / DESIGNS[1][0]).read_text())
    path = tmp_path / "design.yaml"
    path.write_text(yaml.safe_dump({**scn, "noise": "as-given", "output_rate_hz": 5}))
    with pytest.warns(UserWarning, match=r"noise \(fednav process's noise identification"
                                         r".*output_rate_hz .*not used by fednav run"):
        Design().load_scenario(path)
    plain = tmp_path / "plain.yaml"
    plain.write_text(yaml.safe_dump(scn))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Design().load_scenario(plain)
