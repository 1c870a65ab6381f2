"""gnss-ins-sim output folders: the fixture tests/data/gnss-ins-sim was written by
gnss-ins-sim itself (its README says how).  Rows are checked by hand against the files
(units from the headers, FRD -> RFU, NED -> ENU), and fednav's filter on the simulated
IMU and GPS against the simulator's own true trajectory: an independent check of the
navigator against another package's generator."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from fednav.io import DataError, read_gnss_ins_sim
from fednav.io.gnss_ins_sim import IMU_PROFILES
from fednav.process.gnss_ins_sim import gnss_ins_sim_system

DATA = Path(__file__).resolve().parents[1] / "data" / "gnss-ins-sim"


def _row(name: str, i: int) -> np.ndarray:
    """Data row ``i`` of a fixture file, as written (after the header)."""
    line = (DATA / name).read_text().splitlines()[i + 1]
    return np.array([float(v) for v in line.split(",")])


@pytest.fixture(scope="module")
def rec():
    return read_gnss_ins_sim(DATA)


def _copy(tmp_path: Path) -> Path:
    out = tmp_path / "sim"
    shutil.copytree(DATA, out)
    return out


def test_imu_rows_are_the_files_in_rad_per_s_and_body_rfu(rec):
    imu = rec.imu
    assert len(imu.t) == 2000 and imu.period() == pytest.approx(0.01)
    assert imu.t[1234] == pytest.approx(_row("time.csv", 1234)[0])
    for i in (0, 1234):  # at rest, and turning at 15 deg/s
        gx, gy, gz = _row("gyro-0.csv", i)  # deg/s, forward-right-down
        ax, ay, az = _row("accel-0.csv", i)  # m/s^2
        np.testing.assert_allclose(imu.gyro[i], np.radians([gy, gx, -gz]), rtol=1e-14)
        np.testing.assert_allclose(imu.accel[i], [ay, ax, -az], rtol=1e-14)
    assert imu.accel[0, 2] == pytest.approx(9.794, abs=0.01)  # (at rest: up)
    assert imu.gyro[1234, 2] == pytest.approx(-np.radians(15.0), abs=2e-3)  # right turn
    assert imu.errors is None and imu.mounting_name == "FRD"
    assert rec.quality["imu_rate_hz"] == 100.0
    assert rec.run == 0 and rec.runs == [0]
    assert any(n.startswith("imu: gnss-ins-sim writes no IMU error figures")
               for n in rec.notes)


def test_reference_converted_to_enu_and_fednav_euler(rec):
    ref, i = rec.ref, 1999
    lat, lon, h = _row("ref_pos.csv", i)
    vx, vy, vz = _row("ref_vel.csv", i)  # north, east, down
    yaw, pitch, roll = _row("ref_att_euler.csv", i)  # deg
    np.testing.assert_allclose(ref.lla[i], [np.radians(lat), np.radians(lon), h],
                               rtol=1e-14)
    np.testing.assert_allclose(ref.vel[i], [vy, vx, -vz], rtol=1e-14)  # vN -> fednav vN
    assert ref.vel[i, 1] == vx
    np.testing.assert_allclose(ref.euler[i], np.radians([pitch, roll, yaw]), atol=1e-12)
    assert np.degrees(ref.euler[i, 2]) == pytest.approx(120.0, abs=0.1)  # 30 + 90 deg
    assert np.degrees(ref.euler[i, 0]) > 0.0  # (nose up: climbing)
    assert ref.vel[i, 2] > 0.0
    np.testing.assert_allclose(ref.t, rec.imu.t)


def test_gps_fixes_their_sigma_and_the_other_sensors(rec):
    g = rec.series["gnss"]
    assert len(g.t) == 200 and g.t[10] == pytest.approx(1.0)
    lat, lon, h, vn, ve, vd = _row("gps-0.csv", 150)
    np.testing.assert_allclose(g.lla[150], [np.radians(lat), np.radians(lon), h], rtol=1e-14)
    np.testing.assert_allclose(g.vel[150], [ve, vn, -vd], rtol=1e-14)
    # the simulation's gps_opt (1, 1, 2 m; 0.05 m/s) seen in 200 fixes
    assert rec.quality["gnss_sigma_from"] == "ref_gps"
    np.testing.assert_allclose(g.sigma_pos_enu, [1.0, 1.0, 2.0], rtol=0.15)
    np.testing.assert_allclose(g.sigma_vel, 0.05, rtol=0.15)
    odo = rec.series["odometer"]
    assert odo.name == "odometer" and odo.z[1500, 0] == _row("odo-0.csv", 1500)[0]
    assert rec.quality["odometer_scale_vs_ref"] == pytest.approx(0.99, abs=0.005)
    mag = rec.series["mag"]
    bx, by, bz = _row("mag-0.csv", 700)  # uT, forward-right-down
    np.testing.assert_allclose(mag.z[700], np.array([by, bx, -bz]) * 1e-6, rtol=1e-14)
    # WMM near 32 N 120 E: a few degrees west, dipping about 50 deg
    assert -10.0 < rec.quality["mag_declination_deg"] < -3.0
    assert 45.0 < rec.quality["mag_inclination_deg"] < 55.0


def test_fednav_on_the_simulated_data_matches_the_simulators_truth(rec):
    """IMU (gnss-ins-sim's mid-accuracy profile) and GPS (1 m, 0.05 m/s) through the
    navigator: the forward solution against gnss-ins-sim's reference.  fednav gives (at
    this fixture) position RMSE east/north/up 0.24/0.11/0.35 m, velocity 0.017/0.012/0.008
    m/s, pitch/roll/heading 0.02/0.01/0.10 deg; the bounds are a GPS sigma's share."""
    from fednav.navigator.system import System
    from fednav.process.evaluation import errors_against, rmse
    from fednav.process.run import process

    cfg, series, warnings = gnss_ins_sim_system(rec, System(imu=IMU_PROFILES["mid-accuracy"]))
    assert set(series) == {"gnss"}  # (mag, odometer: not configured)
    assert any("odometer and mag read but not used" in w for w in warnings)
    assert cfg.sensors.gnss.sigma_pos_enu_m == tuple(rec.gnss.sigma_pos_enu)
    res = process(rec.imu, series, cfg)
    r = rmse(errors_against(res.forward, rec.ref))
    assert max(r["east_m"], r["north_m"]) < 0.5 and r["up_m"] < 0.8
    assert max(r["ve_mps"], r["vn_mps"], r["vu_mps"]) < 0.05
    assert max(r["pitch_deg"], r["roll_deg"]) < 0.1 and r["yaw_deg"] < 0.5
    assert 0.5 < res.consistency["gnss"]["nis_per_dof"] < 2.0


def test_magnetometer_and_odometer_aid_when_configured(rec):
    from fednav.navigator.system import System
    from fednav.process.evaluation import errors_against, rmse
    from fednav.process.run import process

    cfg = System(imu=IMU_PROFILES["mid-accuracy"],
                 sensors={"mag": {"sigma_heading_deg": 0.5},
                          "odometer": {"sigma_mps": 0.1, "scale": 0.99}})
    cfg, series, _ = gnss_ins_sim_system(rec, cfg)
    assert set(series) == {"gnss", "mag", "odometer"}
    assert cfg.sensors.mag.declination_deg == rec.quality["mag_declination_deg"]
    res = process(rec.imu, series, cfg)
    r = rmse(errors_against(res.forward, rec.ref))
    assert r["yaw_deg"] < 0.1
    assert 0.5 < res.consistency["odometer"]["nis_per_dof"] < 2.0


def test_run_selection_mounting_and_visibility(tmp_path):
    d = _copy(tmp_path)
    lines = (d / "gyro-0.csv").read_text().splitlines(keepends=True)
    lines[1] = "1.0,2.0,3.0\n"  # deg/s
    (d / "gyro-1.csv").write_text("".join(lines))
    shutil.copy(d / "accel-0.csv", d / "accel-1.csv")
    vis = (d / "gps_visibility.csv").read_text().splitlines(keepends=True)
    for i in range(1, 21):  # the first 2 s of GPS hidden
        vis[i] = "0.000000000000000000e+00\n"
    (d / "gps_visibility.csv").write_text("".join(vis))
    r1 = read_gnss_ins_sim(d, run=1)
    assert r1.runs == [0, 1] and r1.run == 1
    np.testing.assert_allclose(r1.imu.gyro[0], np.radians([2.0, 1.0, -3.0]))
    assert "gnss" not in r1.series and any("no gps-1.csv" in n for n in r1.notes)
    r0 = read_gnss_ins_sim(d, mounting="RFU")  # the file's axes said to be the body's
    np.testing.assert_allclose(r0.imu.gyro[5], np.radians(_row("gyro-0.csv", 5)))
    assert r0.quality["gnss_epochs_invisible"] == 20 and r0.gnss.t[0] == pytest.approx(2.0)
    with pytest.raises(DataError, match=r"no accel-2.csv and gyro-2.csv \(run 2; the "
                                        r"folder holds runs 0, 1\)"):
        read_gnss_ins_sim(d, run=2)


def test_without_ref_gps_the_builtin_profile_is_assumed_with_a_note(tmp_path):
    d = _copy(tmp_path)
    (d / "ref_gps.csv").unlink()
    r = read_gnss_ins_sim(d)
    assert r.quality["gnss_sigma_from"] == "assumed"
    np.testing.assert_allclose(r.gnss.sigma_pos_enu, [5.0, 5.0, 7.0])
    assert any("built-in profile assumed" in n for n in r.notes)


def _one_line(match, folder, **kw):
    with pytest.raises(DataError, match=match) as e:
        read_gnss_ins_sim(folder, **kw)
    assert "\n" not in str(e.value)
    return str(e.value)


def test_a_folder_that_is_not_gnss_ins_sim_output_is_one_line(tmp_path):
    """Each refusal is one line (``_one_line`` asserts it) that names the path given."""
    msg = _one_line(r"gnss-ins-sim folder .*nowhere: not found", tmp_path / "nowhere")
    assert str(tmp_path / "nowhere") in msg
    (tmp_path / "f.csv").write_text("x\n")
    msg = _one_line(r"is a file, not a folder", tmp_path / "f.csv")
    assert str(tmp_path / "f.csv") in msg
    empty = tmp_path / "empty"
    empty.mkdir()
    msg = _one_line(r"not a gnss-ins-sim output folder: no time.csv, accel-0.csv, "
                    r"gyro-0.csv", empty)
    assert str(empty) in msg
    d = _copy(tmp_path)
    (d / "gyro-0.csv").unlink()
    msg = _one_line(r"not a gnss-ins-sim output folder: no gyro-0.csv \(gnss-ins-sim "
                    r"writes", d)
    assert str(d) in msg


def test_units_rows_and_frames_are_checked(tmp_path):
    d = _copy(tmp_path)
    text = (d / "gyro-0.csv").read_text()
    (d / "gyro-0.csv").write_text(text.replace("gyro_z (deg/s)", "gyro_z (rpm)", 1))
    _one_line(r"gyro-0.csv: column 'gyro_z' has the unit 'rpm', unknown for a rate "
              r"\(known: 'deg/s', 'rad/s'", d)
    (d / "gyro-0.csv").write_text(text.replace("gyro_x (deg/s)", "gyro_x", 1))
    _one_line(r"column 'gyro_x' has no unit", d)
    (d / "gyro-0.csv").write_text(text.replace(" (deg/s)", " (rad/s)"))
    r = read_gnss_ins_sim(d)  # rad/s is taken as it is
    np.testing.assert_allclose(r.imu.gyro[3], _row("gyro-0.csv", 3)[[1, 0, 2]] * [1, 1, -1])
    (d / "gyro-0.csv").write_text("".join(text.splitlines(keepends=True)[:-5]))
    _one_line(r"gyro-0.csv: 1995 rows but time.csv has 2000", d)
    (d / "gyro-0.csv").write_text(text)
    summary = (d / "summary.txt").read_text()
    (d / "summary.txt").write_text(summary.replace("Reference frame: 0", "Reference frame: 1"))
    _one_line(r"virtual inertial frame \(ref_frame=1", d)


def test_cli_process_gnss_ins_sim(tmp_path):
    import json

    from typer.testing import CliRunner

    from fednav.cli import app

    cfg = tmp_path / "system.yaml"
    cfg.write_text("imu: " + json.dumps(IMU_PROFILES["mid-accuracy"]) + "\n")
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["process", "gnss-ins-sim", str(DATA), "--config", str(cfg),
                                 "--out", str(out)])
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())
    assert s["rmse"]["east_m"] < 0.5 and s["rmse"]["yaw_deg"] < 0.5
    assert any("ref_gps.csv" in w for w in s["warnings"])
    r = CliRunner().invoke(app, ["process", "gnss-ins-sim", str(DATA), "--run", "3",
                                 "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and "no accel-3.csv and gyro-3.csv" in r.output
