"""The peer EKF of benchmarks/independent.py (benchmarks/peer_lc.py, no fednav code):
its mechanization holds a static IMU, and the filter runs on a small straight drive."""

import importlib.util
from pathlib import Path

import numpy as np

_SPEC = importlib.util.spec_from_file_location(
    "peer_lc", Path(__file__).resolve().parents[1] / "benchmarks" / "peer_lc.py")
peer = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(peer)

LAT, H = np.radians(45.0), 100.0


def _ideal(v_north, c):
    """Specific force and angular rate (body FRD) holding NED velocity (v_north, 0, 0)."""
    rn, re = peer.radii(LAT)
    w_ie = np.array([peer.W_IE * np.cos(LAT), 0.0, -peer.W_IE * np.sin(LAT)])
    w_en = np.array([0.0, -v_north / (rn + H), 0.0])
    v = np.array([v_north, 0.0, 0.0])
    f_n = -np.array([0.0, 0.0, peer.gravity_down(LAT, H)]) + np.cross(2 * w_ie + w_en, v)
    return c.T @ f_n, c.T @ (w_ie + w_en)


def test_static_imu_is_held():
    c = peer.rpy_to_dcm(0.01, -0.02, 0.7)
    f, w = _ideal(0.0, c)
    nav = peer.Nav(LAT, 0.2, H, np.zeros(3), c, np.eye(15), np.zeros(15))
    for _ in range(6000):  # 60 s at 100 Hz
        nav.step(w * 0.01, f * 0.01, 0.01)
    rn, _ = peer.radii(LAT)
    assert abs(nav.lat - LAT) * rn < 0.01
    assert abs(nav.h - H) < 0.01
    assert np.abs(nav.v).max() < 1e-3
    assert np.abs(nav.c - c).max() < 1e-6


def test_filter_on_a_straight_drive(tmp_path):
    rng = np.random.default_rng(5)
    c = peer.rpy_to_dcm(0.0, 0.0, 0.0)
    v = 5.0
    f, w = _ideal(v, c)
    t = np.arange(1, 4001) * 0.01  # 40 s at 100 Hz
    m = peer.M
    dth = np.tile(w * 0.01, (len(t), 1)) + rng.normal(0, 1e-5, (len(t), 3))
    dv = np.tile(f * 0.01, (len(t), 1)) + rng.normal(0, 1e-4, (len(t), 3))
    np.savetxt(tmp_path / "imu.csv", np.column_stack((t, dth @ m, dv @ m)), delimiter=",",
               comments="", header="t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,"
                                   "dv_y_mps,dv_z_mps")
    tg = np.arange(1, 200) * 0.2
    rn, _ = peer.radii(LAT)
    lat = LAT + v * tg / (rn + H) + rng.normal(0, 1.0, len(tg)) / rn
    np.savetxt(tmp_path / "gnss.csv", np.column_stack((
        tg, np.degrees(lat), np.full(len(tg), 10.0), H + rng.normal(0, 1.0, len(tg)),
        rng.normal(0, 0.05, len(tg)), v + rng.normal(0, 0.05, len(tg)),
        rng.normal(0, 0.05, len(tg)))), delimiter=",", comments="",
        header="t_s,lat_deg,lon_deg,h_m,vE_mps,vN_mps,vU_mps")
    fig = {"gyro_bias_deg_h": 10.0, "gyro_markov_deg_h": 1.0, "gyro_markov_tau_s": 100.0,
           "gyro_arw_deg_sqrt_h": 0.1, "accel_bias_ug": 500.0, "accel_markov_ug": 50.0,
           "accel_markov_tau_s": 100.0, "accel_vrw_ug_sqrt_hz": 50.0}
    r = peer.run(tmp_path / "imu.csv", tmp_path / "gnss.csv", fig, [1.0, 1.0, 1.0],
                 [0.05, 0.05, 0.05], [0.0, 0.0, 0.0])
    assert r["start_t_s"] == 0.2
    assert 0.3 < r["nis_per_dof"] < 3.0
    s = r["smoothed"]
    assert np.abs(s["vN_mps"][-100:] - v).max() < 0.05
    assert np.abs(((r["forward"]["heading_deg"] + 180) % 360) - 180).max() < 5.0
