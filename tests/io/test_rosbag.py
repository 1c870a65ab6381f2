"""ROS 1 and ROS 2 bags (``fednav.io.read_rosbag``): bags written with ``rosbags``' own
writers from a simulated drive read back to the same IMU samples, GNSS fixes and
solution as the same data in fednav's CSV files; ROS's frames (FLU body, ENU world) and
conventions (unknown covariances, no-fix status, header and bag times); one-line errors."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from fednav.core import units  # noqa: E402
from fednav.io import DataError, read_gnss_csv, read_imu_csv, read_rosbag  # noqa: E402
from fednav.io.rosbag import (  # noqa: E402
    FLU_TO_RFU,
    LAYOUTS,
    decode,
    flu_to_rfu,
    pressure_altitude,
    pressure_altitude_slope,
)

ROOT = Path(__file__).resolve().parents[2]
#: 2025-07-08 18:13:20 UTC [s]: ROS times as a robot's clock gives them
UNIX_T0 = 1_751_998_400


class Bag:
    """Messages for a bag, written with ``rosbags``' writers: a ROS 2 bag folder
    (sqlite3 or MCAP storage) or a ROS 1 ``.bag``.  Times ``t`` [s] are ROS times;
    ``late`` [s] how much later each message was received (the bag's time)."""

    def __init__(self, ros1: bool = False):
        from rosbags.typesys import Stores, get_typestore

        self.ros1 = ros1
        self.ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
        self.T = self.ts.types
        self.msgs = []  # (bag ns, topic, type, message)

    def _header(self, t: float, frame: str):
        ns = int(round(t * 1e9))
        stamp = self.T["builtin_interfaces/msg/Time"](ns // 1_000_000_000, ns % 1_000_000_000)
        h = self.T["std_msgs/msg/Header"]
        return h(0, stamp, frame) if self.ros1 else h(stamp, frame)

    def _add(self, topic, msgtype, t, late, msg):
        self.msgs.append((int(round(t * 1e9)) + int(round(late * 1e9)), topic, msgtype, msg))

    def _vec(self, v):
        return self.T["geometry_msgs/msg/Vector3"](*map(float, v))

    def imu(self, topic, t, gyro_flu, accel_flu, late=0.0, frame="imu_link",
            orientation_cov0=-1.0):
        q = self.T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)
        for i, ti in enumerate(np.atleast_1d(t)):
            m = self.T["sensor_msgs/msg/Imu"](
                self._header(ti, frame), q, np.r_[orientation_cov0, np.zeros(8)],
                self._vec(gyro_flu[i]), np.zeros(9), self._vec(accel_flu[i]), np.zeros(9))
            self._add(topic, "sensor_msgs/msg/Imu", ti, late, m)

    def fix(self, topic, t, lla, sigma_enu=None, status=0, late=0.0, frame="gps"):
        """Fixes at ``lla`` [rad, rad, m]; ``sigma_enu`` [m] (N, 3) or None (type 0)."""
        status = np.broadcast_to(status, len(t))
        for i, ti in enumerate(t):
            if sigma_enu is None:
                cov, kind = np.zeros(9), 0
            else:
                cov, kind = np.diag(np.asarray(sigma_enu)[i] ** 2).ravel(), 2
            m = self.T["sensor_msgs/msg/NavSatFix"](
                self._header(ti, frame), self.T["sensor_msgs/msg/NavSatStatus"](
                    int(status[i]), 1), float(units.to_deg(lla[i, 0])),
                float(units.to_deg(lla[i, 1])), float(lla[i, 2]), cov, kind)
            self._add(topic, "sensor_msgs/msg/NavSatFix", ti, late, m)

    def twist(self, topic, t, vel_enu, sigma=None, late=0.0, frame="odom"):
        tw = self.T
        for i, ti in enumerate(t):
            cov = np.r_[-1.0, np.zeros(35)] if sigma is None else np.diag(
                np.r_[np.full(3, sigma**2), np.ones(3)]).ravel()
            m = tw["geometry_msgs/msg/TwistWithCovarianceStamped"](
                self._header(ti, frame), tw["geometry_msgs/msg/TwistWithCovariance"](
                    tw["geometry_msgs/msg/Twist"](self._vec(vel_enu[i]),
                                                  self._vec(np.zeros(3))), cov))
            self._add(topic, "geometry_msgs/msg/TwistWithCovarianceStamped", ti, late, m)

    def odom(self, topic, t, speed, sigma=None, child="base_link"):
        T = self.T
        for i, ti in enumerate(t):
            cov = np.zeros(36) if sigma is None else np.diag(np.full(6, sigma**2)).ravel()
            pose = T["geometry_msgs/msg/PoseWithCovariance"](T["geometry_msgs/msg/Pose"](
                T["geometry_msgs/msg/Point"](1.0, 2.0, 3.0),
                T["geometry_msgs/msg/Quaternion"](0.0, 0.0, 0.0, 1.0)), np.zeros(36))
            twist = T["geometry_msgs/msg/TwistWithCovariance"](T["geometry_msgs/msg/Twist"](
                self._vec([speed[i], 0.01, 0.0]), self._vec([0.0, 0.0, 0.1])), cov)
            m = T["nav_msgs/msg/Odometry"](self._header(ti, "odom"), child, pose, twist)
            self._add(topic, "nav_msgs/msg/Odometry", ti, 0.0, m)

    def mag(self, topic, t, field_flu, frame="imu_link"):
        for i, ti in enumerate(t):
            m = self.T["sensor_msgs/msg/MagneticField"](
                self._header(ti, frame), self._vec(field_flu[i]), np.zeros(9))
            self._add(topic, "sensor_msgs/msg/MagneticField", ti, 0.0, m)

    def pressure(self, topic, t, p_pa, var, frame="baro"):
        for i, ti in enumerate(t):
            m = self.T["sensor_msgs/msg/FluidPressure"](self._header(ti, frame),
                                                        float(p_pa[i]), float(var))
            self._add(topic, "sensor_msgs/msg/FluidPressure", ti, 0.0, m)

    def write(self, path: Path, storage: str = "sqlite3") -> Path:
        """The bag at ``path`` (a ROS 2 folder, or ``path.bag`` for ROS 1); ``storage``
        ``sqlite3``, ``mcap`` or ``mcap-zstd`` (MCAP with zstd-compressed chunks); for
        ROS 1, ``bz2`` or ``lz4`` compress its chunks."""
        from rosbags.rosbag1 import Writer as Writer1
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

        if self.ros1:
            path = path.with_suffix(".bag")
            writer = Writer1(path)
            if storage in ("bz2", "lz4"):
                writer.set_compression(getattr(Writer1.CompressionFormat, storage.upper()))
        else:
            writer = Writer(path, version=9, storage_plugin={
                "sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP,
                "mcap-zstd": StoragePlugin.MCAP}[storage])
            if storage == "mcap-zstd":
                writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        ser = self.ts.serialize_ros1 if self.ros1 else self.ts.serialize_cdr
        with writer as w:
            conns = {}
            for _, topic, msgtype, _ in self.msgs:
                if topic not in conns:
                    conns[topic] = w.add_connection(topic, msgtype, typestore=self.ts)
            for ns, topic, msgtype, m in sorted(self.msgs, key=lambda x: x[0]):
                w.write(conns[topic], ns, ser(m, msgtype))
        return path


def _rest(n=400, dt=0.01, t0=float(UNIX_T0)):
    """IMU at rest (FLU: +g up) and a fix every 0.2 s: (t, gyro, accel, fix t, fix lla)."""
    t = t0 + dt * np.arange(1, n + 1)
    gyro = np.zeros((n, 3))
    accel = np.tile([0.0, 0.0, 9.8], (n, 1))
    tg = t[19::20]
    lla = np.tile([units.deg(51.05), units.deg(-114.07), 1050.0], (len(tg), 1))
    return t, gyro, accel, tg, lla


def _bag(tmp_path, name="b", storage="sqlite3", ros1=False, fixes=True, **fix):
    t, gyro, accel, tg, lla = _rest()
    b = Bag(ros1)
    b.imu("/imu/data", t, gyro, accel)
    if fixes:
        b.fix("/fix", tg, lla, **fix)
    return b, b.write(tmp_path / name, storage)


# ------------------------------------------------------------------ the CSV path's data
def _ros_seconds(t) -> np.ndarray:
    """Times [s] as a bag holds them (whole nanoseconds) and the reader gives them back:
    the CSV files get the same floats (a time one ulp apart can move a fix to the next
    filter epoch)."""
    ns = np.rint(np.asarray(t) * 1e9).astype(np.int64)
    return (ns // 1_000_000_000).astype(float) + (ns % 1_000_000_000) * 1e-9


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """60 s of the simulated car drive (200 Hz IMU, 5 Hz GNSS) as fednav CSV files (full
    precision, GNSS positions with their 1-sigma) and the system description."""
    from types import SimpleNamespace

    from fednav import load_system
    from fednav.io.csvdata import write_csv
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml").truncated(60.0)
    ds = simulate_dataset(cfg)
    d = tmp_path_factory.mktemp("drive")
    write_csv_dataset(ds, d)  # (process.yaml: the true figures)
    s = np.asarray(cfg.gnss.reported_sigma_pos_enu_m())
    t0 = 100.0  # (the simulation starts at 0: a bag's stamp 0 is an unset one, dropped)
    out = SimpleNamespace(t=_ros_seconds(t0 + ds.t), gyro=ds.gyro, accel=ds.accel,
                          gnss_t=_ros_seconds(t0 + ds.gnss_t), lla=ds.gnss_lla,
                          sigma=np.tile(s, (len(ds.gnss_t), 1)), folder=d,
                          system=load_system(d / "process.yaml"))
    write_csv(d / "imu.csv", {"t_s": out.t, **{
        f"{k}_{a}_{u}": v[:, i] for k, v, u in (("gyro", ds.gyro, "radps"),
                                                ("accel", ds.accel, "mps2"))
        for i, a in enumerate("xyz")}}, significant=17)
    write_csv(d / "gnss.csv", {
        "t_s": out.gnss_t, "lat_deg": units.to_deg(out.lla[:, 0]),
        "lon_deg": units.to_deg(out.lla[:, 1]), "h_m": out.lla[:, 2],
        "sigma_north_m": out.sigma[:, 1], "sigma_east_m": out.sigma[:, 0],
        "sigma_up_m": out.sigma[:, 2]}, significant=17)
    return out


def _drive_bag(drive, path: Path, storage="sqlite3", ros1=False) -> Path:
    b = Bag(ros1)
    b.imu("/imu/data", drive.t, drive.gyro @ FLU_TO_RFU, drive.accel @ FLU_TO_RFU)  # (FLU)
    b.fix("/fix", drive.gnss_t, drive.lla, drive.sigma)
    return b.write(path, storage)


@pytest.mark.parametrize("storage, ros1, decoding, reader", [
    ("sqlite3", False, "numpy", "sqlite3"), ("mcap", False, "numpy", "mcap"),
    ("mcap-zstd", False, "numpy", "mcap"), ("bag", True, "numpy", "ros1")])
def test_a_bag_reads_as_the_same_samples_and_fixes_as_the_csv_files(drive, tmp_path,
                                                                     storage, ros1,
                                                                     decoding, reader):
    d = drive.folder
    rec = read_rosbag(_drive_bag(drive, tmp_path / "drive", storage, ros1))
    imu, gnss = read_imu_csv(d / "imu.csv"), read_gnss_csv(d / "gnss.csv")
    np.testing.assert_array_equal(rec.imu.t, imu.t)
    np.testing.assert_allclose(rec.imu.gyro, imu.gyro, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rec.imu.accel, imu.accel, rtol=0, atol=1e-13)
    g = rec.series["gnss"]
    np.testing.assert_array_equal(g.t, gnss.t)
    np.testing.assert_allclose(g.lla[:, :2], gnss.lla[:, :2], rtol=0, atol=1e-15)
    np.testing.assert_allclose(g.lla[:, 2], gnss.lla[:, 2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(g.sigma_rows[:, :3], gnss.sigma_rows[:, :3], rtol=1e-12)
    assert g.vel is None and g.t_arrival is None  # (received at their stamps)
    assert rec.topics == {"/fix": "sensor_msgs/msg/NavSatFix",
                          "/imu/data": "sensor_msgs/msg/Imu"}
    assert rec.quality["decoding"] == {"/imu/data": decoding, "/fix": "numpy"}
    assert rec.quality["storage_reader"] == reader
    assert rec.imu.mounting_name == "FLU" and rec.quality["imu_rate_hz"] == pytest.approx(200)


def test_the_solution_is_the_csv_paths(drive, tmp_path):
    from fednav.process import process

    d, system = drive.folder, drive.system
    rec = read_rosbag(_drive_bag(drive, tmp_path / "drive"))
    a = process(rec.imu, rec.series, system).forward
    b = process(read_imu_csv(d / "imu.csv"), {"gnss": read_gnss_csv(d / "gnss.csv")},
                system).forward
    assert len(a.t) == len(b.t) > 10000
    # (the same inputs bit for bit: the same solution to a few ulps)
    np.testing.assert_array_equal(a.t, b.t)
    np.testing.assert_allclose(a.lla[:, :2], b.lla[:, :2], rtol=0, atol=1e-13)  # (< 1 mm)
    np.testing.assert_allclose(a.lla[:, 2], b.lla[:, 2], rtol=0, atol=1e-7)
    np.testing.assert_allclose(a.vel, b.vel, rtol=0, atol=1e-10)
    np.testing.assert_allclose(a.euler, b.euler, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.sigma, b.sigma, rtol=1e-10)


def test_the_cli_gives_the_csv_paths_solution(drive, tmp_path):
    from typer.testing import CliRunner

    from fednav.cli import app

    d = drive.folder
    bag = _drive_bag(drive, tmp_path / "drive")
    common = ["--config", str(d / "process.yaml"), "--output-rate", "imu"]
    r = CliRunner().invoke(app, ["process", "rosbag", str(bag), "--out",
                                 str(tmp_path / "bag"), *common])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(d / "imu.csv"), "--gnss",
                                 str(d / "gnss.csv"), "--out", str(tmp_path / "csv"),
                                 *common])
    assert r.exit_code == 0, r.output
    a, b = (np.genfromtxt(tmp_path / k / "solution.csv", delimiter=",", names=True)
            for k in ("bag", "csv"))
    assert len(a) == len(b) > 10000
    for k in ("t_s", "lat_deg", "lon_deg", "h_m", "vE_mps", "pitch_deg", "heading_deg"):
        np.testing.assert_allclose(a[k], b[k], rtol=0, atol=1e-6, err_msg=k)


def test_cli_rosbag_in_rosbag_out_on_the_ros_clock(drive, tmp_path):
    """``fednav process rosbag BAG --export rosbag``: the solution written back as a bag
    on the input's ROS clock (Unix time, header stamps; received late), one message of
    each topic per row of solution.csv."""
    from rosbags.highlevel import AnyReader
    from typer.testing import CliRunner

    from fednav.cli import app

    n = 4000  # (20 s)
    b = Bag()
    b.imu("/imu/data", UNIX_T0 + drive.t[:n], drive.gyro[:n] @ FLU_TO_RFU,
          drive.accel[:n] @ FLU_TO_RFU, late=0.002)
    g = drive.gnss_t < drive.t[n - 1]
    b.fix("/fix", UNIX_T0 + drive.gnss_t[g], drive.lla[g], drive.sigma[g], late=0.04)
    out = tmp_path / "out"
    args = ["process", "rosbag", str(b.write(tmp_path / "drive")), "--config",
            str(drive.folder / "process.yaml"), "--out", str(out), "--export", "rosbag"]
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    s = np.genfromtxt(out / "solution.csv", delimiter=",", names=True)
    got = {}
    with AnyReader([out / "solution_bag"]) as reader:
        for c, ns, raw in reader.messages():
            got.setdefault(c.topic, []).append((ns, reader.deserialize(raw, c.msgtype)))
    assert len(got["/fednav/odometry"]) == len(got["/fednav/fix"]) == len(s) > 150
    t = np.array([ns for ns, _ in got["/fednav/fix"]]) * 1e-9
    np.testing.assert_allclose(t, s["t_s"], rtol=0, atol=2e-6)
    assert UNIX_T0 < t[0] - drive.t[0] < UNIX_T0 + 1.0
    np.testing.assert_allclose([m.latitude for _, m in got["/fednav/fix"]], s["lat_deg"],
                               rtol=0, atol=1e-9)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["inputs"]["bag"] == str(tmp_path / "drive")
    assert any("/imu/data: the messages' covariances are not used" in w
               for w in summary["warnings"])


# ------------------------------------------------------------------------ frames
def test_flu_axes_are_turned_into_fednavs_rfu(tmp_path):
    """At rest the IMU reads +9.8 on z (up in FLU as in RFU); a rate about FLU x (the
    nose) is a rate about fednav's forward axis y; a specific force to the left (FLU y)
    points against fednav's right axis x."""
    t = UNIX_T0 + 0.01 * np.arange(1, 201)
    gyro = np.tile([0.1, 0.0, 0.0], (200, 1))
    accel = np.tile([0.0, 0.5, 9.8], (200, 1))
    b = Bag()
    b.imu("/imu", t, gyro, accel)
    rec = read_rosbag(b.write(tmp_path / "b"))
    np.testing.assert_allclose(rec.imu.accel[0], [-0.5, 0.0, 9.8])
    np.testing.assert_allclose(rec.imu.gyro[0], [0.0, 0.1, 0.0])
    np.testing.assert_allclose(rec.imu.t[[0, -1]], t[[0, -1]], rtol=0, atol=5e-7)  # ROS times
    assert rec.series == {} and rec.imu.mounting_name == "FLU"
    v = np.random.default_rng(1).standard_normal((5, 3))
    np.testing.assert_array_equal(flu_to_rfu(v), v @ FLU_TO_RFU.T)
    # an IMU whose axes are forward-right-down (imu.mounting: FRD): +9.8 up from -9.8 on z
    b = Bag()
    b.imu("/imu", t, np.tile([0.0, 0.2, 0.0], (200, 1)), np.tile([0.0, 0.0, -9.8], (200, 1)))
    rec = read_rosbag(b.write(tmp_path / "frd"), mounting="FRD")
    np.testing.assert_allclose(rec.imu.accel[0], [0.0, 0.0, 9.8], atol=1e-12)
    np.testing.assert_allclose(rec.imu.gyro[0], [0.2, 0.0, 0.0], atol=1e-12)  # (y: right)
    assert rec.imu.mounting_name == "FRD"


def test_header_stamps_or_bag_times(tmp_path):
    """``time="header"``: the stamps are the times of validity, the bag's (later)
    receive times the arrivals; ``time="bag"``: the receive times.  Messages come out in
    time order, a repeated stamp dropped and counted."""
    t, gyro, accel, tg, lla = _rest()
    b = Bag()
    b.imu("/imu", t, gyro, accel, late=0.001)
    b.fix("/fix", tg, lla, np.ones((len(tg), 3)), late=0.05)
    b.fix("/fix", tg[3:4], lla[3:4], np.ones((1, 3)), late=0.06)  # (the same stamp again)
    rec = read_rosbag(b.write(tmp_path / "b"))
    g = rec.gnss
    np.testing.assert_allclose(g.t, tg, rtol=0, atol=5e-7)
    np.testing.assert_allclose(g.t_arrival - g.t, 0.05, atol=1e-6)
    assert rec.quality["rows_dropped"] == {"/fix": 1}
    assert rec.quality["latency_s"]["/fix"] == pytest.approx(0.05)
    bag = read_rosbag(tmp_path / "b", time="bag")
    np.testing.assert_allclose(bag.imu.t[0], t[0] + 0.001, atol=5e-7)
    np.testing.assert_allclose(bag.gnss.t[:3], tg[:3] + 0.05, atol=5e-7)
    assert bag.gnss.t_arrival is None and bag.quality["time"] == "bag"


# ----------------------------------------------------- conventions: unknowns, no fix
def test_unknown_covariance_and_no_fix(tmp_path):
    t, gyro, accel, tg, lla = _rest()
    status = np.zeros(len(tg), dtype=int)
    status[[2, 5]] = -1  # (STATUS_NO_FIX)
    b = Bag()
    b.imu("/imu", t, gyro, accel)
    b.fix("/fix", tg, lla, None, status)  # position_covariance_type 0: unknown
    b.twist("/vel", tg, np.tile([1.0, 2.0, 0.1], (len(tg), 1)))  # covariance [0] = -1
    rec = read_rosbag(b.write(tmp_path / "b"))
    g = rec.gnss
    assert len(g.t) == len(tg) - 2 and rec.quality["gnss_epochs_no_fix"] == 2
    assert g.sigma_rows is None and np.all(g.sigma_pos_enu == 5.0)
    gnss_note = [n for n in rec.notes if n.startswith("gnss:")]
    assert len(gnss_note) == 1 and "1-sigma 5 m each axis assumed" in gnss_note[0]
    v = rec.series["velocity"]
    np.testing.assert_allclose(v.vel[0], [1.0, 2.0, 0.1])  # (ENU as it is)
    np.testing.assert_allclose(v.cov[0], np.eye(3) * 0.01)
    assert any("velocity: /vel: " in n and "(-1 or zeros): 1-sigma 0.1 m/s" in n
               for n in rec.notes)
    # every fix without a fix: one line
    b = Bag()
    b.imu("/imu", t, gyro, accel)
    b.fix("/fix", tg, lla, None, -1)
    with pytest.raises(DataError, match=r"/fix: no NavSatFix with a fix") as e:
        read_rosbag(b.write(tmp_path / "nofix"))
    assert "\n" not in str(e.value)


def test_odometer_magnetometer_and_barometer(tmp_path):
    t, gyro, accel, tg, lla = _rest()
    b = Bag()
    b.imu("/imu", t, gyro, accel)
    b.fix("/fix", tg, lla, np.ones((len(tg), 3)))
    b.odom("/wheel", tg, np.full(len(tg), 3.0), sigma=0.05)
    b.mag("/mag", tg, np.tile([2e-5, 1e-5, -4e-5], (len(tg), 1)))  # [T], FLU
    p = np.full(len(tg), 95000.0)
    b.pressure("/pressure", tg, p, 4.0)  # (2 Pa 1-sigma)
    rec = read_rosbag(b.write(tmp_path / "b"))
    odo, mag, baro = (rec.series[k] for k in ("odometer", "mag", "baro"))
    np.testing.assert_allclose(odo.z[:, 0], 3.0)
    np.testing.assert_allclose(odo.sigma[:, 0], 0.05)
    np.testing.assert_allclose(mag.z[0], [-1e-5, 2e-5, -4e-5])  # RFU [T]
    assert mag.sigma is None
    h = pressure_altitude(95000.0)
    assert h == pytest.approx(540.3, abs=0.5)  # (ISA: 950 hPa)
    np.testing.assert_allclose(baro.z[:, 0], 1050.0)  # (moved onto the GNSS height)
    assert rec.quality["baro_offset_m"] == pytest.approx(1050.0 - h)
    np.testing.assert_allclose(baro.sigma[:, 0], 2.0 * abs(pressure_altitude_slope(95000.0)))
    assert 0.08 < abs(pressure_altitude_slope(101325.0)) < 0.09  # (8.3 m per hPa)
    assert any(n.startswith("mag: /mag: the field's covariance is not used") for n in rec.notes)
    # variance 0 (unknown) and an odometer without covariance: the sections' figures
    b = Bag()
    b.imu("/imu", t, gyro, accel)
    b.odom("/wheel", tg, np.full(len(tg), 3.0))
    b.pressure("/pressure", tg, p, 0.0)
    rec = read_rosbag(b.write(tmp_path / "unknown"))
    assert rec.series["odometer"].sigma is None and rec.series["baro"].sigma is None
    assert any("sensors.odometer.sigma_mps" in n for n in rec.notes)
    assert any("sensors.baro.sigma_m" in n for n in rec.notes)
    assert any("not an ellipsoidal height" in n for n in rec.notes)  # (no GNSS)
    # a topic left out by name
    rec = read_rosbag(tmp_path / "unknown", topics={"baro": None})
    assert set(rec.series) == {"odometer"}


@pytest.mark.parametrize("ros1", [False, True])
def test_numpy_decoding_is_rosbags_deserialisation(ros1):
    """Every message type read, frame ids of several lengths (so the CDR alignment
    differs from message to message): :func:`decode` gives what ``rosbags``
    deserialises."""
    rng = np.random.default_rng(3)
    b = Bag(ros1)
    for k, frame in enumerate(["", "a", "ab", "abc", "abcde", "base_link_x"]):
        t = UNIX_T0 + 0.1 * k + np.array([0.0])
        b.imu("/imu", t, rng.standard_normal((1, 3)), rng.standard_normal((1, 3)),
              frame=frame, orientation_cov0=float(k))
        b.fix("/fix", t, np.array([[0.9, -2.0, 100.0 * k]]), rng.random((1, 3)) + 0.1,
              status=k % 3 - 1, frame=frame)
        b.twist("/vel", t, rng.standard_normal((1, 3)), sigma=0.1 * (k + 1), frame=frame)
        b.odom("/odom", t, rng.standard_normal(1), sigma=0.2, child=frame * 2)
        b.mag("/mag", t, rng.standard_normal((1, 3)), frame=frame)
        b.pressure("/p", t, [90000.0 + k], 1.0 + k, frame=frame)
    ser = b.ts.serialize_ros1 if ros1 else b.ts.serialize_cdr
    deser = b.ts.deserialize_ros1 if ros1 else b.ts.deserialize_cdr
    from fednav.io.rosbag import _deserialised

    for msgtype in LAYOUTS:
        datas = [ser(m, mt) for _, _, mt, m in b.msgs if mt == msgtype]
        lens = np.array([len(x) for x in datas])
        assert len(set(lens)) > 1  # (messages of several lengths)
        got = decode(np.frombuffer(b"".join(datas), np.uint8), lens, msgtype, not ros1)
        want = _deserialised(deser, datas, msgtype)
        for k, v in want.items():
            np.testing.assert_array_equal(got[k].astype(float), v.astype(float), err_msg=k)


def _same_messages_as_rosbags(m, path: Path) -> None:
    """The messages ``m`` (:class:`fednav.io.mcap.Messages`) are those ``rosbags``' own
    reader gives of the bag ``path``: per topic, the same bytes, bag times, order and
    message type (3000 IMU messages)."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as r:
        want = {}
        for c, ns, data in r.messages():
            want.setdefault(c.topic, []).append((ns, data))
        types = {t: i.msgtype for t, i in r.topics.items()}
    got = {}
    for cid, (topic, msgtype, _) in m.channels.items():
        assert msgtype == types[topic]
        got[topic] = [(int(m.log_ns[i]), m.buf[m.offs[i]:m.offs[i] + m.lens[i]].tobytes())
                      for i in np.flatnonzero(m.channel == cid)]
    assert got.keys() == want.keys() and all(got[k] == want[k] for k in want)
    assert len(got["/imu/data"]) == 3000


@pytest.mark.parametrize("storage", ["mcap", "mcap-zstd"])
def test_mcap_index_is_rosbags_reading(tmp_path, storage):
    """fednav.io.mcap's walk of an MCAP file (chunks plain or zstd) finds every message
    of every channel with the bytes and log time ``rosbags``' own MCAP reader gives, in
    the same order per channel."""

    from fednav.io import mcap

    t, gyro, accel, tg, lla = _rest(n=3000)
    b = Bag(False)
    b.imu("/imu/data", t, gyro, accel)
    b.fix("/fix", tg, lla, np.tile([1.0, 1.0, 2.0], (len(tg), 1)))
    path = b.write(tmp_path / "b", storage)
    m = mcap.read(next(path.glob("*.mcap")))
    assert {enc for _, _, enc in m.channels.values()} == {"cdr"}
    _same_messages_as_rosbags(m, path)


@pytest.mark.parametrize("compression", ["none", "bz2", "lz4"])
def test_ros1_walk_is_rosbags_reading(tmp_path, compression):
    """fednav.io.ros1bag's walk of a ROS 1 bag (chunks plain, bz2 or lz4) finds every
    message of every connection with the bytes and bag time ``rosbags``' own reader
    gives, in the same order per connection; the bag reads as ``rosbags`` reads it."""

    from fednav.io import ros1bag

    t, gyro, accel, tg, lla = _rest(n=3000)
    b = Bag(True)
    b.imu("/imu/data", t, gyro, accel, late=0.003)
    b.fix("/fix", tg, lla, np.tile([1.0, 1.0, 2.0], (len(tg), 1)), late=0.04)
    path = b.write(tmp_path / "b", compression)
    _same_messages_as_rosbags(ros1bag.read(path)[0], path)
    rec = read_rosbag(path)
    assert rec.quality["storage_reader"] == "ros1"
    _same_recording(rec, _any_reading(path))


def test_the_drivers_own_orientation_is_noted_not_used(tmp_path):
    """An Imu whose orientation covariance is known (its first element neither -1 nor 0)
    carries the driver's orientation: a note says it is not used; -1 says nothing."""
    t, gyro, accel, _, _ = _rest()
    for cov0, noted in ((-1.0, False), (0.0, False), (1e-4, True)):
        b = Bag()
        b.imu("/imu/data", t, gyro, accel, orientation_cov0=cov0)
        rec = read_rosbag(b.write(tmp_path / f"o{cov0}", "mcap"))
        assert any("orientation (the driver's own estimate) not used" in n
                   for n in rec.notes) == noted, cov0


def test_a_renamed_ros1_topic_is_its_record_headers(tmp_path):
    """A ROS 1 connection record holds its topic twice: in its record header and in the
    connection header it carries (the original one, when a bag was written with its
    topics renamed); the record header's is the topic, as rosbags reads it."""
    from rosbags.highlevel import AnyReader

    _, p = _bag(tmp_path, ros1=True)
    data = bytearray(p.read_bytes())
    key = b"topic=/imu/data"
    at = [i for i in range(len(data)) if data.startswith(key, i)]
    assert len(at) >= 2 and len(at) % 2 == 0
    for i in at[::2]:  # (each record's header comes before its connection header)
        data[i:i + len(key)] = b"topic=/imu/dat2"
    renamed = tmp_path / "renamed.bag"
    renamed.write_bytes(bytes(data))
    with AnyReader([renamed]) as r:
        assert "/imu/dat2" in r.topics
    rec = read_rosbag(renamed, topics={"imu": "/imu/dat2"})
    assert rec.quality["storage_reader"] == "ros1" and "/imu/dat2" in rec.topics
    assert len(rec.imu.t) == 400


def test_a_ros1_bag_the_walk_cannot_read_falls_back_to_rosbags(tmp_path):
    """A connection whose type is not the standard definition (its MD5 sum) is read by
    ``rosbags`` with the bag's own definition; a bag whose records do not add up is
    :class:`Ros1BagError` and then ``rosbags``' one-line refusal."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from fednav.io import ros1bag

    ts = get_typestore(Stores.EMPTY)  # (an Imu with a field more, under the same name)
    for name, text in (("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec"),
                       ("std_msgs/msg/Header", "uint32 seq\ntime stamp\nstring frame_id"),
                       ("geometry_msgs/msg/Vector3", "float64 x\nfloat64 y\nfloat64 z"),
                       ("geometry_msgs/msg/Quaternion",
                        "float64 x\nfloat64 y\nfloat64 z\nfloat64 w"),
                       ("sensor_msgs/msg/Imu", "std_msgs/Header header\n"
                        "geometry_msgs/Quaternion orientation\n"
                        "float64[9] orientation_covariance\n"
                        "geometry_msgs/Vector3 angular_velocity\n"
                        "float64[9] angular_velocity_covariance\n"
                        "geometry_msgs/Vector3 linear_acceleration\n"
                        "float64[9] linear_acceleration_covariance\nfloat32 temperature")):
        ts.register(get_types_from_msg(text, name))
    T = ts.types
    other = tmp_path / "other.bag"
    with Writer(other) as w:
        c = w.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=ts)
        for k in range(1, 401):
            ns = (UNIX_T0 + k // 100) * 10**9 + (k % 100) * 10**7
            m = T["sensor_msgs/msg/Imu"](
                T["std_msgs/msg/Header"](0, T["builtin_interfaces/msg/Time"](
                    ns // 10**9, ns % 10**9), "imu"), T["geometry_msgs/msg/Quaternion"](
                    0.0, 0.0, 0.0, 1.0), np.zeros(9), T["geometry_msgs/msg/Vector3"](
                    0.0, 0.0, 0.0), np.zeros(9), T["geometry_msgs/msg/Vector3"](
                    0.0, 0.0, 9.8), np.zeros(9), 20.0)
            w.write(c, ns, ts.serialize_ros1(m, "sensor_msgs/msg/Imu"))
    rec = read_rosbag(other)
    assert rec.quality["storage_reader"] == "rosbags" and len(rec.imu.t) == 400
    assert rec.quality["decoding"] == {"/imu/data": "rosbags"}
    np.testing.assert_array_equal(rec.imu.accel[:, 2], 9.8)
    _, p = _bag(tmp_path, ros1=True)
    data = p.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[:len(data) // 2])
    with pytest.raises(ros1bag.Ros1BagError, match="do not add up"):
        ros1bag.read(cut)
    with pytest.raises(DataError) as e:
        read_rosbag(cut)
    assert "\n" not in str(e.value) and str(cut) in str(e.value)


def test_an_mcap_file_the_index_cannot_read_falls_back_to_rosbags(tmp_path):
    """An MCAP file whose records do not add up is read by ``rosbags`` (said in the
    quality), or refused by it in one line; garbage is :class:`McapError`."""
    from fednav.io import mcap

    _, p = _bag(tmp_path, storage="mcap")
    f = next(p.glob("*.mcap"))
    with pytest.raises(mcap.McapError, match="not an MCAP file"):
        mcap.read(tmp_path / "x.mcap") if (tmp_path / "x.mcap").write_bytes(b"x" * 40) \
            else None
    data = bytearray(f.read_bytes())
    data[8 + 1:8 + 9] = (10**12).to_bytes(8, "little")  # (the first record's length)
    f.write_bytes(bytes(data))
    with pytest.raises(mcap.McapError, match="do not add up"):
        mcap.read(f)
    with pytest.raises(DataError) as e:
        read_rosbag(p)
    assert "\n" not in str(e.value)


def _image(b: Bag, topic: str, t, size: int) -> None:
    """Compressed images of ``size`` bytes (SQLite keeps most of each on overflow
    pages)."""
    for ti in t:
        m = b.T["sensor_msgs/msg/CompressedImage"](b._header(ti, "cam"), "jpeg",
                                                   np.full(size, 7, np.uint8))
        b._add(topic, "sensor_msgs/msg/CompressedImage", ti, 0.001, m)


def _any_reading(path: Path):
    """The bag read by ``rosbags``' AnyReader alone (no fast path)."""
    from fednav.io.rosbag import _AnyBag, _read

    bag = _AnyBag(path)
    try:
        return _read(bag, {}, "header", 0.1, None)
    finally:
        bag.close()


def _same_recording(a, b) -> None:
    np.testing.assert_array_equal(a.imu.t, b.imu.t)
    np.testing.assert_array_equal(a.imu.gyro, b.imu.gyro)
    np.testing.assert_array_equal(a.imu.accel, b.imu.accel)
    ga, gb = a.series["gnss"], b.series["gnss"]
    np.testing.assert_array_equal(ga.t, gb.t)
    np.testing.assert_array_equal(ga.lla, gb.lla)
    np.testing.assert_array_equal(ga.t_arrival, gb.t_arrival)
    assert a.quality["latency_s"] == b.quality["latency_s"]


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_bag_in_two_files_beside_images_reads_in_place(tmp_path, storage):
    """A ROS 2 bag split into two storage files, an image topic beside the IMU and the
    fixes (its 9 kB messages on SQLite's overflow pages, skipped), is read in place by the
    storage's own path to what ``rosbags`` reads."""
    import yaml

    t, gyro, accel, tg, lla = _rest(n=1200)
    halves = []
    for k, part in enumerate((t < t[600], t >= t[600])):
        b = Bag()
        b.imu("/imu/data", t[part], gyro[part], accel[part] + 0.01 * k, late=0.002)
        sel = (tg >= t[part][0]) & (tg <= t[part][-1])
        b.fix("/fix", tg[sel], lla[sel], np.ones((sel.sum(), 3)), late=0.05)
        _image(b, "/camera/compressed", t[part][::25], 9000)
        halves.append(b.write(tmp_path / f"half{k}", storage))
    split = tmp_path / "split"
    split.mkdir()
    files = [next(h.glob(f"*.{'db3' if storage == 'sqlite3' else 'mcap'}")) for h in halves]
    meta = [yaml.safe_load((h / "metadata.yaml").read_text()) for h in halves]
    info = meta[0]["rosbag2_bagfile_information"]
    info["relative_file_paths"] = []
    for k, f in enumerate(files):
        name = f"split_{k}{f.suffix}"
        (split / name).write_bytes(f.read_bytes())
        info["relative_file_paths"].append(name)
    info["files"] = []
    for x, y in zip(info["topics_with_message_count"],
                    meta[1]["rosbag2_bagfile_information"]["topics_with_message_count"],
                    strict=True):
        x["message_count"] += y["message_count"]
    (split / "metadata.yaml").write_text(yaml.safe_dump(meta[0]))
    rec = read_rosbag(split)
    assert rec.quality["storage_reader"] == storage
    assert len(rec.imu.t) == 1200 and rec.imu.accel[-1, 2] == pytest.approx(9.81, abs=0.02)
    _same_recording(rec, _any_reading(split))


def test_imu_messages_on_overflow_pages_are_read_by_rosbags(tmp_path):
    """IMU messages longer than an SQLite leaf cell keeps (a 5000-character frame id)
    leave the page reader for ``rosbags``, with the same result."""
    t, gyro, accel, tg, lla = _rest(n=100)
    b = Bag()
    b.imu("/imu/data", t, gyro, accel, frame="x" * 5000)
    b.fix("/fix", tg, lla, np.ones((len(tg), 3)))
    p = b.write(tmp_path / "long", "sqlite3")
    rec = read_rosbag(p)
    assert rec.quality["storage_reader"] == "rosbags" and len(rec.imu.t) == 100
    _same_recording(rec, read_rosbag(b.write(tmp_path / "long_mcap", "mcap")))


# ------------------------------------------------------------------------ errors
def test_a_file_that_is_not_a_bag_is_one_line(tmp_path):
    for name, data in (("log.bag", b"#ROSBAG V9\n garbage"), ("notes.txt", b"hello"),
                       ("log.db3", b"not sqlite")):
        p = tmp_path / name
        p.write_bytes(data)
        with pytest.raises(DataError, match=r"not a readable ROS 1 or ROS 2 bag") as e:
            read_rosbag(p)
        assert "\n" not in str(e.value) and str(p) in str(e.value)
    (tmp_path / "folder").mkdir()
    with pytest.raises(DataError, match=r"not a readable ROS 1 or ROS 2 bag folder"):
        read_rosbag(tmp_path / "folder")
    with pytest.raises(DataError, match=r"missing: not found"):
        read_rosbag(tmp_path / "missing")


def test_topics_missing_of_another_type_or_ambiguous(tmp_path):
    b, p = _bag(tmp_path)
    with pytest.raises(DataError, match=r"no topic /gps \(given for gnss; topics: /fix, "
                                        r"/imu/data\)"):
        read_rosbag(p, topics={"gnss": "/gps"})
    with pytest.raises(DataError, match=r"topic /fix \(given for imu\) is "
                                        r"sensor_msgs/msg/NavSatFix, not sensor_msgs/msg/Imu"):
        read_rosbag(p, topics={"imu": "/fix"})
    with pytest.raises(DataError, match=r"topics: unknown name 'lidar'"):
        read_rosbag(p, topics={"lidar": "/points"})
    with pytest.raises(DataError, match=r"time must be 'header' or 'bag', got 'gps'"):
        read_rosbag(p, time="gps")
    # two IMU topics: named, with the option that chooses
    t, gyro, accel, _, _ = _rest()
    b.imu("/imu/raw", t, gyro, accel * 1.01)
    p2 = b.write(tmp_path / "two")
    with pytest.raises(DataError, match=r"several sensor_msgs/msg/Imu topics \(/imu/data, "
                                        r"/imu/raw\): choose one with topics=\{'imu': "
                                        r"\.\.\.\} \(--imu-topic\)") as e:
        read_rosbag(p2)
    assert "\n" not in str(e.value)
    rec = read_rosbag(p2, topics={"imu": "/imu/raw"})
    assert rec.imu.accel[0, 2] == pytest.approx(9.898)
    # no IMU at all
    b = Bag()
    b.fix("/fix", *_rest()[3:], np.ones((20, 3)))
    with pytest.raises(DataError, match=r"no sensor_msgs/msg/Imu message \(no topic of that "
                                        r"type; topics: /fix\)"):
        read_rosbag(b.write(tmp_path / "noimu"))


def test_unset_header_stamps_need_the_bag_times(tmp_path):
    t, gyro, accel, _, _ = _rest()
    b = Bag()
    for ti, w, a in zip(t, gyro, accel, strict=True):
        b.imu("/imu", [0.0], [w], [a])
        b.msgs[-1] = (int(round(ti * 1e9)),) + b.msgs[-1][1:]  # (received at ti)
    p = b.write(tmp_path / "b")
    with pytest.raises(DataError, match=r"/imu: every header.stamp is 0 \(unset\): read it "
                                        r"with time='bag' \(--time bag\)"):
        read_rosbag(p)
    np.testing.assert_allclose(read_rosbag(p, time="bag").imu.t, t, rtol=0, atol=5e-7)


def test_without_rosbags_the_error_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "rosbags", None)
    with pytest.raises(DataError, match=r"reading ROS bag needs rosbags: pip install "
                                        r"'fednav\[formats\]'"):
        read_rosbag(tmp_path / "x.bag")


def test_cli_options_choose_topics(tmp_path):
    from typer.testing import CliRunner

    from fednav.cli import app

    b, _ = _bag(tmp_path, sigma_enu=np.ones((20, 3)))
    t, gyro, accel, _, _ = _rest()
    b.imu("/imu/raw", t, gyro, accel)
    p = b.write(tmp_path / "two")
    out = str(tmp_path / "out")
    r = CliRunner().invoke(app, ["process", "rosbag", str(p), "--out", out])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "several sensor_msgs/msg/Imu topics" in r.output and "--imu-topic" in r.output
    r = CliRunner().invoke(app, ["process", "rosbag", str(p), "--out", out, "--topic", "mag"])
    assert r.exit_code == 2 and "--topic mag: NAME=TOPIC" in r.output
    r = CliRunner().invoke(app, ["process", "rosbag", str(p), "--out", out, "--topic",
                                 "lidar=/x", "--imu-topic", "/imu/raw"])
    assert r.exit_code == 2 and "topics: unknown name 'lidar'" in r.output
