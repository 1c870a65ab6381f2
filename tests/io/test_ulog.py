"""The PX4 ULog reader on the two sample logs of ../shared/data/px4-ulog (pyulog's test
logs): topics, time in seconds from the log's start, IMU rate and resampling, FRD -> RFU
and NED -> ENU row by row against the raw fields, PX4's attitude against the quaternion
by hand, ground truth in the simulator's log only, and one-line errors for bad files.
Skipped when ../shared is absent."""

from pathlib import Path

import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import units
from fednav.io import DataError, UlogRecording, read_ulog
from fednav.io.ulog import _euler_of_px4, imu_from_vehicle_imu
from fednav.sensors.mag import GAUSS, magnetic_heading

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "px4-ulog"
EVENTS = DATA / "sample_px4_events.ulg"
SIM = DATA / "sample_logging_tagged_and_default_params.ulg"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="../shared/data not available")

ZURICH = (47.3977, 8.5456)  # PX4 SITL's default home [deg]


def _raw(path, topic):
    from pyulog import ULog

    return next(d.data for d in ULog(str(path), [topic]).data_list if d.multi_id == 0)


@pytest.fixture(scope="module")
def events() -> UlogRecording:
    return read_ulog(EVENTS)


@pytest.fixture(scope="module")
def sim() -> UlogRecording:
    return read_ulog(SIM)


def test_topics_and_time_in_seconds_from_the_log_start(events, sim):
    for rec in (events, sim):
        assert {"sensor_combined", "vehicle_gps_position", "vehicle_air_data",
                "vehicle_magnetometer", "vehicle_attitude"} <= set(rec.topics)
        assert set(rec.sensors) == {"baro", "mag"}
        assert set(rec.series) == {"gnss", "baro", "mag"}  # (what process takes)
        assert rec.quality["rows_dropped"] == {}
    # this SITL log counts from the Unix epoch (2024-03-18), the other from boot
    assert events.start_s == pytest.approx(1710773350.346, abs=1e-6)
    assert sim.start_s == pytest.approx(0.28, abs=1e-9)
    raw = _raw(EVENTS, "sensor_combined")["timestamp"]
    # stamped at the start of each 4 ms integration interval
    np.testing.assert_allclose(events.imu.t[:3], (raw[:3] - 4000 - 1710773350346000) * 1e-6,
                               atol=1e-12)
    assert events.imu.t[-1] == pytest.approx(31.132, abs=1e-9)
    assert events.gnss.t[0] == pytest.approx(9.180, abs=1e-9)  # first 3D fix


def test_imu_rate_and_resampling_of_missing_samples(events, sim):
    assert events.quality["imu_rate_hz"] == pytest.approx(250.0)
    assert "imu_resampled" not in events.quality and len(events.imu.t) == 7783
    # the simulator's log lost 665 of 2693 samples (8 ms steps): integrated onto 4 ms
    assert sim.quality["imu_resampled"] == 1 and sim.quality["imu_samples_missing"] == 665
    assert len(sim.imu.t) == 2693 and sim.imu.period() == pytest.approx(0.004)
    np.testing.assert_allclose(np.diff(sim.imu.t), 0.004, atol=1e-9)
    assert 9.7 < sim.imu.accel[:, 2].mean() < 10.0


def test_imu_frd_to_rfu_row_by_row(events):
    d = _raw(EVENTS, "sensor_combined")
    for i in (0, 1000, 7000):
        g = [float(d[f"gyro_rad[{k}]"][i]) for k in range(3)]
        a = [float(d[f"accelerometer_m_s2[{k}]"][i]) for k in range(3)]
        np.testing.assert_array_equal(events.imu.gyro[i], [g[1], g[0], -g[2]])
        np.testing.assert_array_equal(events.imu.accel[i], [a[1], a[0], -a[2]])
    # at rest the specific force points up: PX4's FRD z is -9.8, fednav's RFU z +9.8
    assert d["accelerometer_m_s2[2]"][:250].mean() == pytest.approx(-9.8, abs=0.1)
    assert events.imu.accel[:250, 2].mean() == pytest.approx(9.8, abs=0.1)


def test_vehicle_imu_increments_become_rates():
    rng = np.random.default_rng(0)
    n, dt = 50, 0.004
    t_end = 1.0 + dt * np.arange(1, n + 1)
    rate_frd = rng.normal(0, 0.1, (n, 3))
    f_frd = np.tile([0.1, 0.2, -9.8], (n, 1))
    imu = imu_from_vehicle_imu("v", t_end, rate_frd * dt, f_frd * dt, np.full(n, dt),
                               np.full(n, dt))
    np.testing.assert_allclose(imu.t, t_end - dt)
    np.testing.assert_allclose(imu.gyro, rate_frd[:, [1, 0, 2]] * [1, 1, -1])
    np.testing.assert_allclose(imu.accel[0], [0.2, 0.1, 9.8])
    # the sample logs keep one vehicle_imu row in 125 (2 Hz): refused, not used as an IMU
    d = _raw(EVENTS, "vehicle_imu")
    vec = lambda k: np.column_stack([d[f"{k}[{i}]"] for i in range(3)])  # noqa: E731
    with pytest.raises(DataError, match=r"cover 0\.8% .* a subsampled log of the IMU"):
        imu_from_vehicle_imu("x", d["timestamp_sample"] * 1e-6, vec("delta_angle"),
                             vec("delta_velocity"), d["delta_angle_dt"] * 1e-6,
                             d["delta_velocity_dt"] * 1e-6)


@pytest.mark.parametrize("which", ["events", "sim"])
def test_gnss_degrees_or_1e7_integers_ellipsoid_height_and_ned_to_enu(which, request):
    rec, path = request.getfixturevalue(which), EVENTS if which == "events" else SIM
    g = rec.gnss
    d = _raw(path, "vehicle_gps_position")
    fix = d["fix_type"] >= 3
    assert rec.quality["gnss_epochs_no_fix"] == int((~fix).sum()) == 160
    assert len(g.t) == int(fix.sum()) and rec.quality["gnss_height"] == "ellipsoid"
    np.testing.assert_allclose(units.to_deg(g.lla[:, :2]).mean(axis=0), ZURICH, atol=1e-3)
    assert 480.0 < g.lla[:, 2].mean() < 495.0
    # the fix with the fastest climb, by hand: ENU = [vel_e, vel_n, -vel_d]
    i = int(np.argmax(np.abs(d["vel_d_m_s"][fix])))
    vn, ve, vd = (float(d[k][fix][i]) for k in ("vel_n_m_s", "vel_e_m_s", "vel_d_m_s"))
    np.testing.assert_array_equal(g.vel[i], [ve, vn, -vd])
    h = (d["altitude_ellipsoid_m"] if "altitude_ellipsoid_m" in d
         else d["alt_ellipsoid"] * 1e-3)[fix][i]
    assert g.lla[i, 2] == pytest.approx(float(h), abs=1e-9)
    np.testing.assert_array_equal(g.lever, 0.0)
    assert np.all(g.sigma_pos_enu >= 0.5) and np.all(g.sigma_vel >= 0.3)  # PX4's floors


def test_gnss_sigma_is_the_median_over_the_fixes(events, sim):
    assert events.quality["gnss_sigma_pos_enu_m"] == [0.5, 0.5, 0.5]  # eph 0.32 m: floored
    np.testing.assert_allclose(sim.gnss.sigma_pos_enu, [2.225, 2.225, 2.325], atol=1e-5)
    np.testing.assert_allclose(events.gnss.sigma_vel, 0.3)
    assert events.gnss.vel[:, 2].max() > 0.7  # the take-off (climb 1 m/s) is in it


def test_baro_is_shifted_onto_the_gnss_height(events):
    b = events.sensors["baro"]
    raw = _raw(EVENTS, "vehicle_air_data")
    assert b.z.shape == (len(raw["timestamp"]), 1)
    off = events.quality["baro_offset_m"]
    np.testing.assert_allclose(b.z[:, 0], raw["baro_alt_meter"].astype(float) + off)
    np.testing.assert_allclose(b.t, (raw["timestamp_sample"] - 1710773350346000) * 1e-6)
    g = events.gnss
    hb = np.interp(g.t, b.t, b.z[:, 0])
    assert abs(np.median(g.lla[:, 2] - hb)) < 1e-3
    assert np.abs(g.lla[:, 2] - hb).max() < 1.0


def test_magnetometer_frd_to_rfu_and_its_heading_agrees_with_px4(events):
    m = events.sensors["mag"]
    d = _raw(EVENTS, "vehicle_magnetometer")
    b = [float(d[f"magnetometer_ga[{k}]"][5]) for k in range(3)]
    np.testing.assert_allclose(m.z[5], np.array([b[1], b[0], -b[2]]) * GAUSS, rtol=1e-12)
    assert events.quality["mag_declination_deg"] == pytest.approx(3.323079, abs=1e-5)
    px = events.px4
    inside = (m.t > px.t[0]) & (m.t < px.t[-1])
    e = np.column_stack([np.interp(m.t[inside], px.t, px.euler[:, j]) for j in range(3)])
    psi = magnetic_heading(e, m.z[inside]) + units.deg(events.quality["mag_declination_deg"])
    d_psi = units.to_deg(att.wrap_pi(psi - e[:, 2]))
    assert abs(np.mean(d_psi)) < 0.5 and np.std(d_psi) < 2.0


def test_px4_attitude_against_the_quaternion_by_hand(events):
    d = _raw(EVENTS, "vehicle_attitude")
    i = 300
    w, x, y, z = (float(d[f"q[{k}]"][i]) for k in range(4))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))  # from north, clockwise
    pitch = np.arcsin(2 * (w * y - z * x))                          # nose up
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))  # right wing down
    e = _euler_of_px4(np.array([w, x, y, z]))
    np.testing.assert_allclose(e, [pitch, roll, yaw % (2 * np.pi)], atol=1e-7)
    # a synthetic attitude: yaw 30, pitch 10, roll -5 deg (PX4's z-y-x order)
    half = units.deg(np.array([30.0, 10.0, -5.0])) / 2
    cy, sy, cp, sp, cr, sr = (f(a) for a in half for f in (np.cos, np.sin))
    q = [cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
         cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy]
    np.testing.assert_allclose(units.to_deg(_euler_of_px4(np.array(q))), [10.0, -5.0, 30.0],
                               atol=1e-9)
    # the reader's heading at a position's time: the quaternion interpolated by hand
    px = events.px4
    t_att = (d["timestamp_sample"] - 1710773350346000) * 1e-6
    k = 50
    j = int(np.searchsorted(t_att, px.t[k])) - 1
    f = (px.t[k] - t_att[j]) / (t_att[j + 1] - t_att[j])
    q0, q1 = (np.array([float(d[f"q[{m}]"][r]) for m in range(4)]) for r in (j, j + 1))
    qi = q0 + f * (q1 * np.sign(q0 @ q1) - q0)
    w, x, y, z = qi / np.linalg.norm(qi)
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    assert px.euler[k, 2] == pytest.approx(yaw % (2 * np.pi), abs=1e-7)


def test_px4_estimate_velocity_is_ned_to_enu_interpolated(events):
    px = events.px4
    d = _raw(EVENTS, "vehicle_local_position")
    t = (d["timestamp_sample"] - 1710773350346000) * 1e-6
    vn, ve, vd = (np.interp(px.t, t, d[k].astype(float)) for k in ("vx", "vy", "vz"))
    np.testing.assert_allclose(px.vel, np.column_stack([ve, vn, -vd]), atol=1e-12)
    assert events.quality["px4_height"] == "ellipsoid"
    np.testing.assert_allclose(units.to_deg(px.lla[:, :2]).mean(axis=0), ZURICH, atol=1e-3)


def test_ground_truth_only_in_the_simulator_log(events, sim):
    assert events.truth is None
    tr = sim.truth
    assert tr is not None and len(tr.t) == 109 and tr.euler is not None
    np.testing.assert_allclose(units.to_deg(tr.lla[:, :2]).mean(axis=0), ZURICH, atol=1e-3)
    np.testing.assert_allclose(tr.euler, 0.0, atol=1e-12)  # level, facing north, at rest
    # the simulator left the truth's altitude at 0: flagged, not invented
    assert sim.quality["truth_height"] == "unset"
    assert any("altitude is 0 in every row" in n for n in sim.notes)
    # and this log has no PX4 global position
    assert sim.px4 is None and any("no vehicle_global_position" in n for n in sim.notes)


def test_bad_files_are_one_line_errors_naming_the_file(tmp_path):
    cases = [(tmp_path / "missing.ulg", "not found"),
             (tmp_path, "is a folder")]
    text = tmp_path / "notes.ulg"
    text.write_text("this is not a ULog file\n")
    cases.append((text, "not a readable ULog file"))
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(EVENTS.read_bytes()[:20000])  # definitions only: no data
    cases.append((cut, "no IMU topic"))
    for path, what in cases:
        with pytest.raises(DataError) as e:
            read_ulog(path)
        msg = str(e.value)
        assert "\n" not in msg and str(path) in msg and what in msg, msg


def test_the_log_runs_through_process_and_agrees_with_px4(events):
    """GNSS + magnetometer + baro from the log through fednav's navigator, against PX4's
    own estimate (IMU figures guessed for a PX4 SITL IMU: the log has none)."""
    from fednav import load_system
    from fednav.process import errors_against, process, rmse

    imu = {"gyro_arw_rad_sqrt_s": 3e-3, "accel_vrw_mps_sqrt_s": 3e-2, "gyro_bias_radps": 0.01,
           "accel_bias_mps2": 0.2, "gyro_markov_radps": 1e-4, "gyro_tau_s": 100,
           "accel_markov_mps2": 1e-3, "accel_tau_s": 100}
    g = events.gnss
    sec = {"gnss": {"sigma_pos_enu_m": g.sigma_pos_enu.tolist(),
                    "sigma_vel_mps": g.sigma_vel.tolist()},
           "mag": {"sigma_heading_deg": 2.0, "inclination_deg": 64.0,
                   "declination_deg": events.quality["mag_declination_deg"]},
           "baro": {"sigma_m": 0.5, "damping_loop": False}}
    res = process(events.imu, {"gnss": g, **events.sensors}, load_system({"imu": imu,
                                                                          "sensors": sec}))
    r = rmse(errors_against(res.forward, events.px4))
    assert max(r["east_m"], r["north_m"], r["up_m"]) < 0.5
    assert max(r["ve_mps"], r["vn_mps"], r["vu_mps"]) < 0.2
    assert max(r["roll_deg"], r["pitch_deg"]) < 0.5 and r["yaw_deg"] < 1.0
