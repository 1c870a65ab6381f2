"""Each aiding sensor's CSV layout against its documented meaning (docs/data-formats.md):
units, frames, the sign of heading, quaternion order, per-row sigma; bad files are one
line naming the file, the column and the row."""

import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.io import read_sensor_csv
from fednav.io.csvdata import read_gnss_csv, read_imu_csv
from fednav.io.data import DataError


def _write(path, text):
    path.write_text(text)
    return path


def test_star_euler_row_with_sigma_in_arcseconds(tmp_path):
    f = _write(tmp_path / "star.csv", "t_s,pitch_deg,roll_deg,heading_deg,sigma_pitch_arcsec,"
               "sigma_roll_arcsec,sigma_heading_arcsec,t_arrival_s\n"
               "1.5,2.0,-3.0,370.0,3,4,5,1.75\n")
    d = read_sensor_csv("star", f)
    np.testing.assert_allclose(d.z[0], np.radians([2.0, -3.0, 10.0]))  # heading wrapped
    np.testing.assert_allclose(d.sigma[0], np.radians(np.array([3, 4, 5]) / 3600.0))
    assert d.t[0] == 1.5 and d.t_arrival[0] == 1.75


def test_star_quaternion_layout_is_body_to_enu_scalar_first(tmp_path):
    # heading 90 deg (body forward = east): a rotation of -90 deg about up (ENU z),
    # q = [cos(-45 deg), 0, 0, sin(-45 deg)] by hand; fednav's own quaternion agrees
    q = np.array([np.cos(np.radians(-45.0)), 0.0, 0.0, np.sin(np.radians(-45.0))])
    np.testing.assert_allclose(att.euler_to_quat([0.0, 0.0, np.pi / 2]), q, atol=1e-15)
    f = _write(tmp_path / "star.csv", "t_s,qw,qx,qy,qz\n"
               f"0.0,{float(2 * q[0])!r},0,0,{float(2 * q[3])!r}\n")  # (not normalised in the file)
    d = read_sensor_csv("star", f)
    np.testing.assert_allclose(d.z[0], [0.0, 0.0, np.pi / 2], atol=1e-12)
    assert d.sigma is None


def test_sar_fix_row_sigma_in_metres(tmp_path):
    f = _write(tmp_path / "sar.csv", "t_s,lat_deg,lon_deg,heading_deg,sigma_north_m,"
               "sigma_east_m,sigma_heading_deg\n10,39.5,-117.25,-1.0,3,4,0.5\n")
    d = read_sensor_csv("sar", f)
    np.testing.assert_allclose(d.z[0], [np.radians(39.5), np.radians(-117.25),
                                        np.radians(359.0)])
    np.testing.assert_allclose(d.sigma[0], [3.0, 4.0, np.radians(0.5)])


@pytest.mark.parametrize(("name", "header", "row", "z"), [
    ("sarvel", "vE_mps,vN_mps", "1.0,-2.0", [1.0, -2.0]),
    ("baro", "h_m", "120.5", [120.5]),
    ("odometer", "speed_mps", "12.5", [12.5]),
    ("dvl", "vR_mps,vF_mps,vU_mps", "0.1,2.0,-0.05", [0.1, 2.0, -0.05]),
    ("zupt", "vE_mps,vN_mps,vU_mps", "0,0,0", [0.0, 0.0, 0.0]),
    ("airdata", "airspeed_mps,wind_e_mps,wind_n_mps", "50,3,-4", [50.0, 3.0, -4.0]),
])
def test_metric_layouts_read_as_written(tmp_path, name, header, row, z):
    f = _write(tmp_path / f"{name}.csv", f"t_s,{header}\n0.5,{row}\n1.5,{row}\n")
    d = read_sensor_csv(name, f)
    np.testing.assert_allclose(d.z[:, :len(z)], [z, z])
    assert np.isnan(d.z[:, len(z):]).all()  # (optional columns the file leaves out)
    np.testing.assert_allclose(d.t, [0.5, 1.5])


@pytest.mark.parametrize("name", ["star", "sar", "sarvel", "baro", "airdata", "odometer",
                                  "dvl", "zupt", "mag"])
def test_bad_files_of_each_layout_are_one_line_errors(tmp_path, name):
    from fednav.io.sensorfile import columns, sigma_columns

    head = columns(name)
    sig = sigma_columns(name)
    vals = ",".join(["1"] * (len(head) - 1))
    ones = ",".join(["1"] * len(sig))
    # a missing column (the first: the others may be optional, as a SAR fix's heading)
    f = _write(tmp_path / "a.csv", ",".join(head[:1] + head[2:]) + "\n" + "0," + ",".join(
        ["1"] * (len(head) - 2)) + "\n")
    with pytest.raises(DataError, match=rf"a.csv: missing column\(s\) {head[1]}") as e:
        read_sensor_csv(name, f)
    assert "\n" not in str(e.value)
    # a NaN row is dropped and counted
    f = _write(tmp_path / "b.csv", ",".join(head) + f"\n0,{vals}\n1,nan{',1' * (len(head) - 2)}"
               f"\n2,{vals}\n")
    d = read_sensor_csv(name, f)
    assert len(d.t) == 2 and d.quality[f"{name}_rows_dropped"] == 1
    # time going backwards
    f = _write(tmp_path / "c.csv", ",".join(head) + f"\n0,{vals}\n2,{vals}\n1,{vals}\n")
    with pytest.raises(DataError, match=r"c.csv: column 't_s' is not increasing at data row 3"):
        read_sensor_csv(name, f)
    # a sigma that is not positive
    zero = ",".join(["1"] * (len(sig) - 1) + ["0"])
    f = _write(tmp_path / "d.csv", ",".join(head + sig) + f"\n0,{vals},{ones}\n1,{vals},{zero}\n")
    with pytest.raises(DataError, match=rf"d.csv: column '{sig[-1]}' is 0 at data row 2: a "
                                        r"1-sigma must be positive"):
        read_sensor_csv(name, f)
    # some sigma columns but not all
    if len(sig) > 1:
        f = _write(tmp_path / "e.csv", ",".join(head + sig[:1]) + f"\n0,{vals},1\n")
        with pytest.raises(DataError, match="1-sigma columns are all of"):
            read_sensor_csv(name, f)


def test_gnss_position_only_velocity_only_and_per_fix_sigma(tmp_path):
    f = _write(tmp_path / "p.csv", "t_s,lat_deg,lon_deg,h_m,sigma_north_m,sigma_east_m,"
               "sigma_up_m\n0,45,-75,10,1,2,3\n1,45.00001,-75,10,1,2,3\n")
    g = read_gnss_csv(f)
    assert g.vel is None and g.lla.shape == (2, 3)
    np.testing.assert_allclose(g.sigma_rows[0, :3], [1, 2, 3])
    f = _write(tmp_path / "v.csv", "t_s,vE_mps,vN_mps,vU_mps\n0,1,2,0\n1,1,2,0\n")
    g = read_gnss_csv(f)
    assert g.lla is None and g.vel.shape == (2, 3) and g.sigma_rows is None
    f = _write(tmp_path / "h.csv", "t_s,lat_deg,lon_deg,vE_mps,vN_mps,vU_mps\n0,45,-75,1,2,0\n")
    with pytest.raises(DataError, match=r"missing column\(s\) h_m \(have"):
        read_gnss_csv(f)
    f = _write(tmp_path / "n.csv", "t_s,speed\n0,1\n")
    with pytest.raises(DataError, match="positions, velocities or both"):
        read_gnss_csv(f)
    f = _write(tmp_path / "s.csv", "t_s,lat_deg,lon_deg,h_m,sigma_north_m,sigma_east_m,"
               "sigma_up_m\n0,45,-75,10,1,2,3\n1,45,-75,10,1,-2,3\n")
    with pytest.raises(DataError, match="is not positive"):
        read_gnss_csv(f)


def test_imu_increments_are_over_the_interval_ending_at_the_stamp(tmp_path):
    # 100 Hz, a constant 0.1 rad/s about up and 9.8 m/s^2 up: increments 1e-3 rad, 0.098 m/s
    t = np.arange(1, 6) * 0.01
    rows = "\n".join(f"{float(x)!r},0,0,0.001,0,0,0.098" for x in t)
    f = _write(tmp_path / "imu.csv", "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,"
               "dv_y_mps,dv_z_mps\n" + rows + "\n")
    imu = read_imu_csv(f)
    np.testing.assert_allclose(imu.t, t - 0.01, atol=1e-15)  # stamped at the interval start
    np.testing.assert_allclose(imu.gyro[:, 2], 0.1)
    np.testing.assert_allclose(imu.accel[:, 2], 9.8)
    assert imu.quality == {"imu_samples_bridged": 0}


def test_jittered_and_missing_imu_stamps_keep_every_increment(tmp_path):
    """Stamps jittering 8-11 ms and one record lost: every kept increment is integrated
    over its own interval, the lost record's time is bridged by its neighbour's rate."""
    rng = np.random.default_rng(5)
    d = rng.uniform(0.008, 0.011, 401)
    t = np.cumsum(d)
    w = np.column_stack([np.sin(t), np.cos(2 * t), 0.3 * t])  # rad/s
    dth_all = w * d[:, None]
    keep = np.r_[0:100, 101:401]  # record 100 is lost (its increment with it)
    t, dth, d = t[keep], dth_all[keep], np.r_[d[:100], d[100] + d[101], d[102:]]
    rows = "\n".join(",".join(repr(float(v)) for v in (a, *b)) + ",0,0,0.1"
                     for a, b in zip(t, dth, strict=True))
    f = _write(tmp_path / "imu.csv", "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,"
               "dv_y_mps,dv_z_mps\n" + rows + "\n")
    imu = read_imu_csv(f)
    dt = imu.period()
    np.testing.assert_allclose(np.diff(imu.t), dt, rtol=1e-9)
    q = imu.quality
    assert q["imu_resampled"] == 1 and q["imu_samples_missing"] == 1
    assert 0.0005 < q["imu_jitter_s"] < 0.015  # (the lost record's interval included)
    # every kept increment is there, and the lost one is bridged: the integral over the
    # grid equals the true total (to about one increment: the grid's ends, the bridge)
    n_full = len(imu.t)
    np.testing.assert_allclose((imu.gyro * dt).sum(axis=0)[:2],
                               dth_all.sum(axis=0)[:2], rtol=0,
                               atol=2 * np.abs(w).max() * dt)
    assert n_full == int(np.floor((t[-1] - (t[0] - d[0])) / dt + 1e-9))
    # a gap beyond imu.max_bridge_s is refused where it is
    t2 = t.copy()
    t2[200:] += 0.5
    rows = "\n".join(f"{float(a)!r},0,0,0,0,0,0.1" for a in t2)
    f = _write(tmp_path / "gap.csv", "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,"
               "dv_y_mps,dv_z_mps\n" + rows + "\n")
    where = rf"between t = {t2[199]:.6f} s and {t2[200]:.6f} s"
    with pytest.raises(DataError, match=rf"gap of 0\.5\d+ s {where}"):
        read_imu_csv(f)


def test_stamps_jittering_beyond_half_a_period_are_not_lost_records(tmp_path):
    """Stamps jittering +-3 ms at 100 Hz (intervals 4..16 ms: some beyond 1.5 periods)
    whose increments cover their own intervals, and one record truly lost: only that one
    is read as lost (its velocity increment is one period's, the others' their own
    interval's: gravity makes |dv| = |f| T), and the integral keeps every increment."""
    rng = np.random.default_rng(8)
    stamps = np.arange(1, 2002) * 0.01 + rng.uniform(-0.003, 0.003, 2001)
    d = np.diff(np.r_[0.0, stamps])
    w = np.column_stack([np.sin(stamps), np.cos(2 * stamps), 0.3 + 0 * stamps])
    f = np.column_stack([0.3 * np.sin(stamps), 0.5 + 0 * stamps, 9.8 + 0 * stamps])
    dth_all, dv_all = w * d[:, None], f * d[:, None]
    keep = np.r_[0:1000, 1001:2001]  # record 1000 lost, its increment with it
    rows = "\n".join(",".join(repr(float(v)) for v in (stamps[k], *dth_all[k], *dv_all[k]))
                     for k in keep)
    path = _write(tmp_path / "imu.csv", "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,"
                  "dv_x_mps,dv_y_mps,dv_z_mps\n" + rows + "\n")
    imu = read_imu_csv(path)
    assert np.sum(d[keep][1:] > 0.015) > 20  # jitter beyond 1.5 periods, often
    assert imu.quality["imu_samples_missing"] == 1
    dt = imu.period()
    total = (imu.accel * dt).sum(axis=0)
    np.testing.assert_allclose(total, dv_all.sum(axis=0), rtol=0, atol=3 * 9.8 * 0.01)


def test_a_sar_fix_without_heading_and_a_magnetometer_reporting_zeros(tmp_path):
    f = _write(tmp_path / "sar.csv", "t_s,lat_deg,lon_deg,sigma_north_m,sigma_east_m\n"
               "10,39.5,-117.25,3,4\n11,39.5,-117.25,3,4\n")
    d = read_sensor_csv("sar", f)
    assert d.absent == (2,) and np.isnan(d.z[:, 2]).all()
    np.testing.assert_allclose(d.sigma[:, :2], [[3, 4], [3, 4]])
    from fednav.sensors.registry import spec

    cfg = spec("sar").config(sigma_pos_m=3.0, use_heading=False)
    assert cfg.model().dim == 2 and cfg.model().R(cfg.sigma()).shape == (2, 2)
    f = _write(tmp_path / "mag.csv", "t_s,magR_gauss,magF_gauss,magU_gauss\n"
               "1,0.2,0.1,-0.4\n2,0,0,0\n3,0.2,0.1,-0.4\n")
    d = read_sensor_csv("mag", f)
    assert list(d.t) == [1.0, 3.0] and d.quality["mag_rows_dropped"] == 1


def test_air_data_angles_in_degrees(tmp_path):
    f = _write(tmp_path / "air.csv", "t_s,airspeed_mps,wind_e_mps,wind_n_mps,aoa_deg,"
               "sideslip_deg\n1,30,2,-1,4,-3\n")
    d = read_sensor_csv("airdata", f)
    np.testing.assert_allclose(d.z[0], [30, 2, -1, np.radians(4), np.radians(-3)])
    assert d.absent == ()
