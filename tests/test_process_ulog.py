"""`fednav process ulog FLIGHT.ulg`: a PX4 log through the navigator, compared with PX4's
own estimate (the sample logs of ../shared/data/px4-ulog; skipped without them)."""

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fednav.cli import app

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "px4-ulog"
EVENTS = DATA / "sample_px4_events.ulg"
SIM = DATA / "sample_logging_tagged_and_default_params.ulg"


@pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not available")
def test_a_px4_log_against_px4s_own_estimate(tmp_path):
    r = CliRunner().invoke(app, ["process", "ulog", str(EVENTS), "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "summary.json").read_text())
    assert set(s["consistency"]) == {"gnss", "baro", "mag"}
    px4 = s["against"]["px4"]["rmse"]
    # 31 s of a simulated vehicle at rest, both filters fed the same GNSS: fednav within a
    # few cm and tenths of a degree of PX4's EKF2 (measured east/north/up
    # 0.005/0.005/0.044 m, pitch/roll/yaw 0.04/0.05/0.30 deg).  This shows the reader and
    # the conventions, not accuracy: tests/test_px4_moving.py flies a moving vehicle.
    assert max(px4["east_m"], px4["north_m"], px4["up_m"]) < 0.2
    assert max(px4["roll_deg"], px4["pitch_deg"]) < 0.3 and px4["yaw_deg"] < 1.0
    assert any("'consumer' MEMS preset is assumed" in w for w in s["warnings"])
    assert s["alignment"]["heading"] == "config"  # the magnetometer's, over the first second
    for f in ("solution.csv", "errors_px4.csv", "errors_px4.png", "track.png"):
        assert (tmp_path / f).is_file()


@pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not available")
def test_a_log_whose_truth_has_no_height_says_so(tmp_path):
    r = CliRunner().invoke(app, ["process", "ulog", str(SIM), "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "summary.json").read_text())
    assert "rmse" not in s and "against" not in s  # no usable truth, no PX4 estimate
    assert any("ground truth has no height" in w for w in s["warnings"])
    assert s["data_quality"]["imu_samples_missing"] == 665


def test_bad_log_files_are_one_line_errors(tmp_path):
    bad = tmp_path / "notes.ulg"
    bad.write_text("not a log\n")
    for path, msg in ((tmp_path / "missing.ulg", "not found"), (bad, "notes.ulg")):
        r = CliRunner().invoke(app, ["process", "ulog", str(path), "--out",
                                     str(tmp_path / "out")])
        assert r.exit_code == 2 and msg in r.output, r.output
        assert len(r.output.strip().splitlines()) == 1
