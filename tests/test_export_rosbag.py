"""The solution as a ROS 2 bag (``--export rosbag``): ``nav_msgs/msg/Odometry`` and
``sensor_msgs/msg/NavSatFix`` read back with ``rosbags`` and compared with the solution
they came from, in ROS's frames (map = ENU at the first row, body FLU)."""

import numpy as np
import pytest

pytest.importorskip("rosbags")

from test_process import make_flight  # noqa: E402

from fednav import load_system  # noqa: E402
from fednav.core import attitude as att  # noqa: E402
from fednav.core import earth, units  # noqa: E402
from fednav.navigator.solution import Solution  # noqa: E402
from fednav.process import process  # noqa: E402
from fednav.process.export import (  # noqa: E402
    FIX_TOPIC,
    ODOMETRY_TOPIC,
    check_exports,
    write_exports,
    write_rosbag,
)
from fednav.process.output import decimate  # noqa: E402

T0 = 1_751_998_400.0  # 2025-07-08 18:13:20 UTC [s]


def _messages(path) -> dict:
    """{topic: [(bag ns, message)]} of a bag."""
    from rosbags.highlevel import AnyReader

    out = {}
    with AnyReader([path]) as r:
        for c, ns, raw in r.messages():
            out.setdefault(c.topic, []).append((ns, r.deserialize(raw, c.msgtype)))
    return out


def _quat_dcm(q) -> np.ndarray:
    """A ROS quaternion (x, y, z, w) as the DCM it turns vectors with."""
    return att.quat_to_dcm(np.array([q.w, q.x, q.y, q.z]))


@pytest.fixture(scope="module")
def run():
    imu, gnss, _ = make_flight()
    res = process(imu, {"gnss": gnss}, load_system({}))
    sol = decimate(res.forward, 1.0)
    return Solution(sol.t + T0, sol.lla, sol.vel, sol.euler, sol.sigma, sol.sigma_euler,
                    sol.omega)  # (on a ROS clock)


def test_odometry_and_fixes_of_every_row(run, tmp_path):
    sol = run
    (p,) = write_exports(tmp_path, sol, ("rosbag",))
    assert p == tmp_path / "solution_bag" and (p / "metadata.yaml").is_file()
    m = _messages(p)
    odo, fix = m[ODOMETRY_TOPIC], m[FIX_TOPIC]
    assert len(odo) == len(fix) == len(sol.t) > 200
    ns = np.array([n for n, _ in fix])
    np.testing.assert_array_equal(ns, np.rint(sol.t * 1e9).astype(np.int64))
    stamp = odo[7][1].header.stamp
    assert stamp.sec + stamp.nanosec * 1e-9 == pytest.approx(sol.t[7], abs=1e-6)
    f = np.array([[x.latitude, x.longitude, x.altitude] for _, x in fix])
    np.testing.assert_allclose(f[:, :2], units.to_deg(sol.lla[:, :2]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(f[:, 2], sol.lla[:, 2], rtol=0, atol=1e-9)
    x = fix[5][1]
    assert x.position_covariance_type == 2 and x.status.status == 0
    assert x.header.frame_id == "base_link"
    np.testing.assert_allclose(np.reshape(x.position_covariance, (3, 3)),
                               np.diag(sol.sigma[5, 6:9] ** 2))  # (ENU)
    # the pose: metres in the ENU tangent frame at the first row
    o = odo[-1][1]
    assert o.header.frame_id == "map" and o.child_frame_id == "base_link"
    pos = np.array([[y.pose.pose.position.x, y.pose.pose.position.y,
                     y.pose.pose.position.z] for _, y in odo])
    np.testing.assert_allclose(pos[0], 0.0, atol=1e-9)
    assert np.abs(pos[:, :2]).max() > 1000.0
    # (a tangent plane: back through ECEF to the solution's latitude, longitude, height)
    r0 = earth.llh_to_ecef(*sol.lla[0])
    back = earth.ecef_to_llh(r0 + pos @ earth.enu_to_ecef(*sol.lla[0, :2]).T)
    np.testing.assert_allclose(back[:, :2], sol.lla[:, :2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(back[:, 2], sol.lla[:, 2], rtol=0, atol=1e-6)
    # (near the local ENU differences: within the plane's departure from the ellipsoid,
    # d^2 / 2R, 0.5 m at 2.6 km)
    enu = earth.llh_difference_enu(*sol.lla.T, *sol.lla[0])
    d = np.hypot(enu[:, 0], enu[:, 1])
    assert np.all(np.abs(pos - enu).max(axis=1) <= 1.1 * d**2 / (2 * 6.36e6) + 1e-6)
    # its covariance: the position 1-sigmas (map frame, turned by the ENU frames' angle)
    cov = np.reshape(o.pose.covariance, (6, 6))
    np.testing.assert_allclose(np.sqrt(np.diag(cov)[:3]), sol.sigma[-1, 6:9], rtol=1e-3)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)[3:]), sol.sigma[-1, 0:3], rtol=1e-3)
    # its orientation: C_flu^map, the solution's attitude with FLU body axes
    # (in the map frame: the row's own ENU frame turned by the 4e-4 rad the tangent
    # frames 2.6 km apart differ by)
    C = _quat_dcm(o.pose.pose.orientation)
    R = earth.enu_to_ecef(*sol.lla[0, :2]).T @ earth.enu_to_ecef(*sol.lla[-1, :2])
    C_rfu = R @ att.euler_to_dcm(sol.euler[-1])
    np.testing.assert_allclose(C[:, 0], C_rfu[:, 1], atol=1e-12)   # x: forward
    np.testing.assert_allclose(C[:, 1], -C_rfu[:, 0], atol=1e-12)  # y: left
    np.testing.assert_allclose(C[:, 2], C_rfu[:, 2], atol=1e-12)   # z: up
    assert np.abs(R - np.eye(3)).max() > 1e-4
    # the twist: body FLU
    v = o.twist.twist.linear
    np.testing.assert_allclose(R.T @ C_rfu @ np.array([-v.y, v.x, v.z]), sol.vel[-1],
                               atol=1e-9)
    assert v.x > 5.0  # (driving forward)


def test_heading_east_nose_up():
    """A vehicle heading east, 10 deg nose up, driving forward and yawing left: the
    quaternion turns FLU x (the nose) to east and up, FLU y (left) to north; the twist
    is forward with the yaw rate about FLU z and a pitch rate about FLU y (left)."""
    import tempfile
    from pathlib import Path

    n = 3
    pitch = units.deg(10.0)
    sol = Solution(T0 + 0.1 * np.arange(n),
                   np.tile([units.deg(51.05), units.deg(-114.07), 1050.0], (n, 1)),
                   np.tile([10.0 * np.cos(pitch), 0.0, 10.0 * np.sin(pitch)], (n, 1)),
                   np.tile([pitch, 0.0, units.deg(90.0)], (n, 1)),
                   np.tile([1e-3, 2e-3, 3e-3, 0.1, 0.2, 0.3, 1.0, 2.0, 3.0], (n, 1)),
                   np.zeros((n, 3)), np.tile([0.2, 0.0, 0.1], (n, 1)))  # RFU: pitch up, yaw left
    with tempfile.TemporaryDirectory() as d:
        p = write_rosbag(Path(d) / "solution_bag", sol)
        o = _messages(p)[ODOMETRY_TOPIC][0][1]
    C = _quat_dcm(o.pose.pose.orientation)
    np.testing.assert_allclose(C @ [1, 0, 0], [np.cos(pitch), 0.0, np.sin(pitch)],
                               atol=1e-12)  # the nose: east, up
    np.testing.assert_allclose(C @ [0, 1, 0], [0.0, 1.0, 0.0], atol=1e-12)  # left: north
    assert C[2] @ [1, 0, 0] > 0  # (pitch up: positive z)
    tw = o.twist.twist
    np.testing.assert_allclose([tw.linear.x, tw.linear.y, tw.linear.z], [10.0, 0.0, 0.0],
                               atol=1e-12)
    np.testing.assert_allclose([tw.angular.x, tw.angular.y, tw.angular.z], [0.0, -0.2, 0.1],
                               atol=1e-15)
    c, s = np.cos(pitch), np.sin(pitch)  # (ENU 1-sigmas 0.1, 0.2, 0.3 m/s seen from FLU)
    np.testing.assert_allclose(np.diag(np.reshape(o.twist.covariance, (6, 6))),
                               [0.01 * c**2 + 0.09 * s**2, 0.04, 0.01 * s**2 + 0.09 * c**2,
                                0.0, 0.0, 0.0], rtol=1e-12, atol=1e-18)


def test_a_folder_fednav_did_not_write_is_not_replaced(run, tmp_path):
    from rosbags.rosbag2 import Writer

    sol = run.rows(slice(0, 20))
    mine = tmp_path / "solution_bag"
    write_rosbag(mine, sol)
    write_rosbag(mine, run.rows(slice(0, 30)))  # (its own: replaced)
    assert len(_messages(mine)[FIX_TOPIC]) == 30
    assert sorted(x.name for x in tmp_path.iterdir()) == ["solution_bag"]  # (nothing left)
    other = tmp_path / "other" / "solution_bag"
    other.parent.mkdir()
    with Writer(other, version=8):  # a bag someone else wrote
        pass
    (tmp_path / "notes" / "solution_bag").mkdir(parents=True)
    for out in (other.parent, tmp_path / "notes"):
        with pytest.raises(ValueError, match=r"solution_bag: exists and is not a bag fednav "
                                             r"wrote") as e:
            write_exports(out, sol, ("rosbag",))
        assert "\n" not in str(e.value)
    assert (other / "metadata.yaml").is_file()  # (left as it was)


def test_the_kind_is_checked_with_its_extra(monkeypatch):
    import sys

    assert check_exports("kml,rosbag") == ("kml", "rosbag")
    monkeypatch.setitem(sys.modules, "rosbags", None)
    with pytest.raises(ValueError, match=r"--export rosbag needs rosbags: pip install "
                                         r"'fednav\[formats\]'"):
        check_exports("rosbag")


def test_cli_export_rosbag_beside_the_solution(tmp_path):
    """``fednav process csv ... --export rosbag``: ``solution_bag/`` beside solution.csv,
    one message of each topic per row."""
    from test_export import write_short_flight
    from typer.testing import CliRunner

    from fednav.cli import app

    write_short_flight(tmp_path, velocity=False)
    out = tmp_path / "out"
    args = ["process", "csv", "--imu", str(tmp_path / "imu.csv"), "--gnss",
            str(tmp_path / "gnss.csv"), "--out", str(out), "--export", "rosbag,geojson"]
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    assert "solution_bag" in r.output and (out / "solution.geojson").is_file()
    s = np.genfromtxt(out / "solution.csv", delimiter=",", names=True)
    m = _messages(out / "solution_bag")
    assert len(m[ODOMETRY_TOPIC]) == len(m[FIX_TOPIC]) == len(s) > 250
    np.testing.assert_allclose([ns * 1e-9 for ns, _ in m[FIX_TOPIC]], s["t_s"], atol=1e-6)
    np.testing.assert_allclose([x.latitude for _, x in m[FIX_TOPIC]], s["lat_deg"],
                               atol=1e-9)
    assert CliRunner().invoke(app, args).exit_code == 0  # (its own bag: replaced)
