"""fednav on data it did not generate, beside a second implementation (issue 26 item 8).

    pip install -e '.[independent]'      # inu (Woodburn's Inertial Navigation Utilities)
    python benchmarks/independent.py [--datasets car-adis16405,car-adis16488,uav-adis16488]
                                     [--rebuild] [--label before] [--json /tmp/independent.json]
                                     [--states gyro_scale,accel_scale]

By hand, not in CI.  Each data set is built once (deterministic seeds) and cached in
``~/.cache/fednav/independent/NAME/`` (never in the repository):

* trajectory and ideal IMU signal from ``inu`` (PyPI, MIT): the path geometry from
  ``inu.waypoints`` (quadratic Bezier curves through control points), geodetic positions
  from ``r3f.curvilinear_to_geodetic``, the specific force and angular rate (WGS-84
  ellipsoid, Earth rotation, transport rate, Somigliana gravity) from ``inu.mech_inv`` on
  a 1 kHz grid; the UAV's attitude from ``inu.vne_to_rpy`` (coordinated turns).  The car's
  speed profile along the path and its attitude (heading along the path, pitch from the
  road grade, body roll out of the turn) are the script's own (a car does not bank like
  an aircraft);
* IMU errors (turn-on bias, first-order Gauss-Markov bias instability, white noise),
  time-stamp jitter and GNSS noise added here with an explicit ``numpy.random.Generator``
  per data set; the increments over each jittered IMU interval are sums of inu's 1 kHz
  signal.

Then ``fednav process csv --smooth`` runs with a config holding only what a user must give
(the IMU datasheet figures, the GNSS sigmas and lever arm), and ``benchmarks/peer_lc.py``
(a plain Groves-style loosely coupled 15-state EKF + RTS smoother, no fednav code) on the
same files.  Both are scored by the same code against the reference (10 Hz, stamped
between GNSS fixes) over the peer's span, and fednav also over its whole span.

``--states gyro_scale,accel_scale`` runs fednav with those optional error states
(``filter.states``) from a copy of the config, ``config-LABEL.yaml``, that adds them and
their 1-sigma (:data:`SCALE_PPM`); the peer and the data are unchanged.  Without it
fednav runs the config as built (the 18-state filter).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peer_lc  # noqa: E402  (benchmarks/peer_lc.py: independent of fednav)

CACHE = Path.home() / ".cache" / "fednav" / "independent"
FS = 1000.0  # the truth grid [Hz]
D2R = np.pi / 180.0

#: Datasheet-class IMU figures, per axis (1-sigma).  Turn-on bias: residual after a
#: factory calibration; bias instability simulated as a first-order Gauss-Markov process
#: of that sigma and a 100 s correlation time (the filters are told the same).
IMUS = {
    # ADIS16405: in-run bias stability 0.007 deg/s (25 deg/h), ARW 2.0 deg/sqrt(h);
    # accelerometer in-run stability 0.2 mg, VRW 0.2 m/s/sqrt(h) (= 340 ug/sqrt(Hz))
    "adis16405": {"gyro_bias_deg_h": 200.0, "gyro_markov_deg_h": 25.0,
                  "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 2.0,
                  "accel_bias_ug": 2000.0, "accel_markov_ug": 200.0,
                  "accel_markov_tau_s": 100.0, "accel_vrw_ug_sqrt_hz": 340.0},
    # ADIS16488: in-run bias stability 5.1 deg/h, ARW 0.26 deg/sqrt(h); accelerometer
    # 0.1 mg, VRW 0.029 m/s/sqrt(h) (= 49 ug/sqrt(Hz))
    "adis16488": {"gyro_bias_deg_h": 50.0, "gyro_markov_deg_h": 5.1,
                  "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 0.26,
                  "accel_bias_ug": 1000.0, "accel_markov_ug": 100.0,
                  "accel_markov_tau_s": 100.0, "accel_vrw_ug_sqrt_hz": 49.0},
}

#: Scale-factor error 1-sigma [ppm] the filter is told with ``--states`` (the data carry
#: none: the IMU signal above is simulated without a scale-factor error).  One rule for
#: every IMU: the class figure of Groves 2013 (sec. 4.4, table 4.1) as fednav's
#: ``fednav.sensors.imu.GRADE_SCALE_PPM`` holds it, the class as fednav's ``GRADES`` places
#: these units ("industrial": calibrated MEMS, ADIS16488 class) -- 3000 ppm gyro and
#: accelerometer.
SCALE_PPM = {"adis16405": {"gyro_scale_ppm": 3000.0, "accel_scale_ppm": 3000.0},
             "adis16488": {"gyro_scale_ppm": 3000.0, "accel_scale_ppm": 3000.0}}
OPTIONAL_STATES = ("gyro_scale", "accel_scale", "gnss_markov")

#: 5 Hz GNSS: white noise of these sigmas [east, north, up] m, [east, north, up] m/s
GNSS = {"period_s": 0.2, "sigma_pos_enu_m": [1.5, 1.5, 3.0],
        "sigma_vel_mps": [0.05, 0.05, 0.1]}

DATASETS = {
    "car-adis16405": {"trajectory": "car", "imu": "adis16405", "seed": 26081,
                      "jitter_ms": 2, "lever_m": [0.3, -1.0, 1.2]},
    "car-adis16488": {"trajectory": "car", "imu": "adis16488", "seed": 26082,
                      "jitter_ms": 2, "lever_m": [0.3, -1.0, 1.2]},
    "uav-adis16488": {"trajectory": "uav", "imu": "adis16488", "seed": 26083,
                      "jitter_ms": 2, "lever_m": [0.0, 0.25, 0.15]},
    # as car-adis16405 with +-3 ms stamp jitter: intervals 4..16 ms
    "car-adis16405-jitter3": {"trajectory": "car", "imu": "adis16405", "seed": 26081,
                              "jitter_ms": 3, "lever_m": [0.3, -1.0, 1.2]},
}

KEYS = ("north_m", "east_m", "down_m", "vn_mps", "ve_mps", "vd_mps", "roll_deg",
        "pitch_deg", "yaw_deg")


# --------------------------------------------------------------------------- truth

def _corners(start, legs, radius):
    """inu.waypoints control points of a route: from ``start`` (east, north), legs of
    (heading deg, length m); each corner rounded as inu.points_box does (2 sqrt 2 r)."""
    d = 2.0 * np.sqrt(2.0) * radius
    pts = [np.asarray(start, float)]
    p = pts[0].copy()
    for i, (hdg, length) in enumerate(legs):
        u = np.array([np.sin(hdg * D2R), np.cos(hdg * D2R)])
        q = p + u * length
        if i + 1 < len(legs):
            un = np.array([np.sin(legs[i + 1][0] * D2R), np.cos(legs[i + 1][0] * D2R)])
            pts += [q - u * d, q, q + un * d]
        else:
            pts.append(q)
        p = q
    return np.array(pts).T  # (2, Np), east/north


def _spline_path(points, step=2.0):
    """Smooth arc-length parametrisation of inu's Bezier path (ENU east/north)."""
    import inu
    from scipy.interpolate import CubicSpline

    path = inu.waypoints(points, seg_len=0.05, plot=False, ned=False).path  # (3, K) ENU
    xy = path[:2, :: int(round(step / 0.05))]
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=1)))]
    return CubicSpline(s, xy.T, axis=0), float(s[-1])


def _speed_profile(length, curv, stops, v_max=14.0, a_lat=2.5, accel=1.2, brake=1.8,
                   creep=0.02, dwell=8.0):
    """Car speed along the path: curvature and stop limits, acceleration and braking
    limits (forward/backward pass on a 0.1 m grid); starts rolling at ``creep`` m/s with a
    soft first metre.  Returns (t_nodes, s_nodes, v_nodes) for a Hermite s(t)."""
    s = np.arange(0.0, length, 0.1)
    lim = np.minimum(v_max, np.sqrt(a_lat / np.maximum(np.abs(curv(s)), 1e-6)))
    stop_idx = [int(round(x / 0.1)) for x in stops] + [len(s) - 1]
    lim[stop_idx] = 0.0
    v = lim.copy()
    v[0] = creep
    ds = 0.1
    for i in range(1, len(s)):  # acceleration limit (gentle for the first metres)
        a = accel * min(1.0, 0.1 + s[i] / 6.0)
        v[i] = min(v[i], np.sqrt(v[i - 1] ** 2 + 2 * a * ds))
    for i in range(len(s) - 2, -1, -1):  # braking limit
        v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + 2 * brake * ds))
    v[0] = creep
    dt = ds / (0.5 * (v[1:] + v[:-1]))  # constant acceleration over each 0.1 m
    t = np.r_[0.0, np.cumsum(dt)]
    tn, sn, vn, shift = [], [], [], 0.0
    for i in range(len(s)):
        tn.append(t[i] + shift), sn.append(s[i]), vn.append(v[i])
        if i in stop_idx[:-1]:  # stand still for ``dwell`` seconds
            shift += dwell
            tn.append(t[i] + shift), sn.append(s[i]), vn.append(0.0)
    return np.asarray(tn), np.asarray(sn), np.asarray(vn)


def truth_car():
    """A 6 min urban drive: rolls off at 0.02 m/s (no static period) heading 62 deg,
    ten corners both ways, two stops, gentle grades (inu path, own speed profile)."""
    from scipy.interpolate import CubicHermiteSpline

    legs = [(62, 420), (152, 380), (62, 300), (332, 520), (242, 260), (332, 300),
            (242, 520), (152, 420), (197, 240), (242, 420), (152, 300)]
    spl, length = _spline_path(_corners([0.0, 0.0], legs, 18.0))

    def curv(s):
        d1, d2 = spl(s, 1), spl(s, 2)
        return (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.hypot(*d1.T) ** 3

    stops = [1500.0, 3100.0]
    tn, sn, vn = _speed_profile(length - 30.0, curv, stops)
    st = CubicHermiteSpline(tn, sn, vn)
    t = np.arange(0.0, tn[-1] - 1.0, 1.0 / FS)
    s = np.clip(st(t), 0.0, length - 30.0)
    s = np.maximum.accumulate(s)
    v = np.maximum(st(t, 1), 0.0)
    xy = spl(s)
    d1 = spl(s, 1)
    yaw = np.unwrap(np.arctan2(d1[:, 0], d1[:, 1]))  # course: from north toward east
    h = 3.0 * np.sin(2 * np.pi * s / 1300.0) + 2.0 * np.sin(2 * np.pi * s / 470.0 + 1.0)
    grade = 3.0 * 2 * np.pi / 1300.0 * np.cos(2 * np.pi * s / 1300.0) \
        + 2.0 * 2 * np.pi / 470.0 * np.cos(2 * np.pi * s / 470.0 + 1.0)
    k = curv(s)  # > 0 turning left (counter-clockwise, ENU)
    a_lat_right = -v ** 2 * k
    roll = -0.4 * D2R * a_lat_right  # body rolls out of the turn, 0.4 deg per m/s^2
    pitch = np.arctan(grade)
    ned = np.vstack((xy[:, 1], xy[:, 0], -h))
    rpy = np.vstack((roll, pitch, yaw))
    return t, ned, rpy, np.array([48.137 * D2R, 11.575 * D2R, 520.0])


def truth_uav():
    """A 5.4 min fixed-wing flight at 22 m/s (flying start) heading 215 deg: inu Bezier
    path, gentle climbs, attitude from inu.vne_to_rpy (coordinated turns, 0.06 rad angle
    of attack)."""
    legs = [(215, 1400), (305, 900), (35, 1300), (125, 700), (215, 1200), (170, 900),
            (80, 1100)]
    spl, length = _spline_path(_corners([0.0, 0.0], legs, 120.0))
    v = 22.0
    t = np.arange(0.0, (length - 50.0) / v, 1.0 / FS)
    s = v * t
    xy = spl(s)
    h = 120.0 + 25.0 * np.sin(2 * np.pi * s / 4000.0) ** 2
    return t, np.vstack((xy[:, 1], xy[:, 0], -h)), None, np.array(
        [37.41 * D2R, -122.05 * D2R, 40.0])


def build_truth(kind):
    """1 kHz truth: t, llh [rad, rad, m], NED velocity, rpy [rad] (NED, body FRD), and
    inu.mech_inv's specific force and angular rate (body FRD)."""
    import inu
    import r3f

    t, ned, rpy, llh0 = truth_car() if kind == "car" else truth_uav()
    llh = r3f.curvilinear_to_geodetic(ned, llh0)
    T = 1.0 / FS
    if rpy is None:
        vne = inu.llh_to_vne(llh, T)
        rpy = inu.vne_to_rpy(vne, inu.somigliana(llh)[2], T)
        rpy[2] = np.unwrap(rpy[2])
    f, w = inu.mech_inv(llh, rpy, T)
    # velocity by central differences of the geodetic positions (for the reference)
    vne = inu.llh_to_vne(llh, T)
    vne = np.column_stack((vne[:, :1], 0.5 * (vne[:, 1:] + vne[:, :-1])))
    return {"t": t, "llh": llh.T, "vne": vne.T, "rpy": rpy.T, "f": f.T, "w": w.T}


# ----------------------------------------------------------------------- data files

def _rpy_to_dcm(rpy):
    """C_b^n (NED, body FRD) of roll, pitch, yaw (z-y-x), shape (K, 3, 3)."""
    r, p, y = rpy.T
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack([
        np.stack([cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy], -1),
        np.stack([cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy], -1),
        np.stack([-sp, sr * cp, cr * cp], -1)], -2)


#: FRD <-> RFU and NED <-> ENU (its own inverse)
M = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _fednav_euler(rpy):
    """fednav's [pitch, roll, heading] deg (docs/conventions.md) of NED/FRD roll, pitch,
    yaw: C_enu_rfu = M C M, theta = asin C32, gamma = atan2(-C31, C33), psi = atan2(C12,
    C22)."""
    c = M @ _rpy_to_dcm(rpy) @ M
    pitch = np.arcsin(np.clip(c[:, 2, 1], -1, 1))
    roll = np.arctan2(-c[:, 2, 0], c[:, 2, 2])
    hdg = np.mod(np.arctan2(c[:, 0, 1], c[:, 1, 1]), 2 * np.pi)
    return np.degrees(np.column_stack((pitch, roll, hdg)))


def _ned_offset_llh(llh, d_ned):
    """Geodetic position moved by a small NED offset [m] (WGS-84 radii)."""
    a, e2 = 6378137.0, 6.69437999014e-3
    s = np.sin(llh[:, 0])
    rn = a * (1 - e2) / (1 - e2 * s * s) ** 1.5
    re = a / np.sqrt(1 - e2 * s * s)
    out = llh.copy()
    out[:, 0] += d_ned[:, 0] / (rn + llh[:, 2])
    out[:, 1] += d_ned[:, 1] / ((re + llh[:, 2]) * np.cos(llh[:, 0]))
    out[:, 2] -= d_ned[:, 2]
    return out


def _gauss_markov(rng, n, dt, sigma, tau):
    """First-order Gauss-Markov sequence (3 axes) at intervals dt (array), stationary."""
    x = np.empty((n, 3))
    x[0] = rng.normal(0.0, sigma, 3)
    phi = np.exp(-dt / tau)
    w = rng.normal(0.0, 1.0, (n, 3)) * (sigma * np.sqrt(1 - phi ** 2))[:, None]
    for k in range(1, n):
        x[k] = phi[k] * x[k - 1] + w[k]
    return x


def _write_csv(path, cols, fmt):
    names = list(cols)
    data = np.column_stack([cols[k] for k in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)


def build_dataset(name, folder):
    """Write imu.csv (increments, jittered stamps), gnss.csv, ref.csv, config.yaml and
    meta.json of data set ``name`` into ``folder``."""
    spec = DATASETS[name]
    rng = np.random.default_rng(spec["seed"])
    tr_cache = CACHE / f"truth-{spec['trajectory']}.npz"
    if tr_cache.exists():
        tr = dict(np.load(tr_cache))
    else:
        tr = build_truth(spec["trajectory"])
        np.savez(tr_cache, **tr)
    t, llh, vne, rpy = tr["t"], tr["llh"], tr["vne"], tr["rpy"]
    n = len(t)
    # IMU stamps: nominal 100 Hz, each jittered uniformly by +-jitter_ms on the 1 ms grid
    nom = np.arange(10, n - 10, 10)
    jit = spec["jitter_ms"]
    idx = np.unique(nom + rng.integers(-jit, jit + 1, len(nom)))
    idx = np.r_[0, idx]
    dt = np.diff(t[idx])
    # increments over each interval: sums of inu's 1 kHz rates (the sample k holds over
    # [t_k, t_k+1] in inu's forward-Euler mechanization)
    cw = np.vstack((np.zeros(3), np.cumsum(tr["w"], axis=0) / FS))
    cf = np.vstack((np.zeros(3), np.cumsum(tr["f"], axis=0) / FS))
    dth = np.diff(cw[idx], axis=0)
    dv = np.diff(cf[idx], axis=0)
    fig = IMUS[spec["imu"]]
    gb0 = rng.normal(0.0, fig["gyro_bias_deg_h"] * D2R / 3600, 3)
    ab0 = rng.normal(0.0, fig["accel_bias_ug"] * 9.80665e-6, 3)
    gbm = _gauss_markov(rng, len(dt), dt, fig["gyro_markov_deg_h"] * D2R / 3600,
                        fig["gyro_markov_tau_s"])
    abm = _gauss_markov(rng, len(dt), dt, fig["accel_markov_ug"] * 9.80665e-6,
                        fig["accel_markov_tau_s"])
    arw = fig["gyro_arw_deg_sqrt_h"] * D2R / 60.0  # rad/sqrt(s)
    vrw = fig["accel_vrw_ug_sqrt_hz"] * 9.80665e-6  # m/s/sqrt(s)
    sq = np.sqrt(dt)[:, None]
    dth = dth + (gb0 + gbm) * dt[:, None] + arw * sq * rng.normal(0.0, 1.0, dth.shape)
    dv = dv + (ab0 + abm) * dt[:, None] + vrw * sq * rng.normal(0.0, 1.0, dv.shape)
    dth, dv = dth @ M, dv @ M  # FRD -> RFU
    folder.mkdir(parents=True, exist_ok=True)
    _write_csv(folder / "imu.csv", {
        "t_s": t[idx[1:]], "dtheta_x_rad": dth[:, 0], "dtheta_y_rad": dth[:, 1],
        "dtheta_z_rad": dth[:, 2], "dv_x_mps": dv[:, 0], "dv_y_mps": dv[:, 1],
        "dv_z_mps": dv[:, 2]}, "%.12g")
    # GNSS at the antenna (lever arm, body RFU), 5 Hz from 0.2 s
    lever_frd = M @ np.asarray(spec["lever_m"])
    cbn = _rpy_to_dcm(rpy)
    ant = _ned_offset_llh(llh, cbn @ lever_frd)
    vant = vne + np.gradient(cbn @ lever_frd, 1.0 / FS, axis=0)
    g = np.arange(int(round(GNSS["period_s"] * FS)), n - 10, int(round(GNSS["period_s"] * FS)))
    sp, sv = np.array(GNSS["sigma_pos_enu_m"])[[1, 0, 2]], np.array(GNSS["sigma_vel_mps"])
    npos = rng.normal(0.0, 1.0, (len(g), 3)) * sp  # north, east, up
    nvel = rng.normal(0.0, 1.0, (len(g), 3)) * sv  # east, north, up
    gl = _ned_offset_llh(ant[g], np.column_stack((npos[:, 0], npos[:, 1], -npos[:, 2])))
    _write_csv(folder / "gnss.csv", {
        "t_s": t[g], "lat_deg": np.degrees(gl[:, 0]), "lon_deg": np.degrees(gl[:, 1]),
        "h_m": gl[:, 2], "vE_mps": vant[g, 1] + nvel[:, 0], "vN_mps": vant[g, 0] + nvel[:, 1],
        "vU_mps": -vant[g, 2] + nvel[:, 2]}, "%.12f")
    # reference (the IMU's point), 10 Hz, stamped between the GNSS fixes
    r = np.arange(50, n - 10, 100)
    e = _fednav_euler(rpy[r])
    _write_csv(folder / "ref.csv", {
        "t_s": t[r], "lat_deg": np.degrees(llh[r, 0]), "lon_deg": np.degrees(llh[r, 1]),
        "h_m": llh[r, 2], "vE_mps": vne[r, 1], "vN_mps": vne[r, 0], "vU_mps": -vne[r, 2],
        "pitch_deg": e[:, 0], "roll_deg": e[:, 1], "heading_deg": e[:, 2]}, "%.12f")
    cfg = ["# only what a user must give: the IMU datasheet figures, the GNSS receiver's",
           "# sigmas and the antenna lever arm (body right-forward-up)", "imu:"]
    cfg += [f"  {k}: {v}" for k, v in fig.items()]
    cfg += ["sensors:", "  gnss:", f"    sigma_pos_enu_m: {GNSS['sigma_pos_enu_m']}",
            f"    sigma_vel_mps: {GNSS['sigma_vel_mps']}", f"    lever_m: {spec['lever_m']}"]
    (folder / "config.yaml").write_text("\n".join(cfg) + "\n")
    speed = np.hypot(vne[:, 0], vne[:, 1])
    meta = {"dataset": name, **spec, "imu_figures": fig, "gnss": GNSS,
            "duration_s": float(t[-1]), "imu_rows": int(len(dt)),
            "imu_interval_ms": [float(dt.min() * 1e3), float(dt.max() * 1e3)],
            "start_speed_mps": float(speed[0]), "speed_at_1s_mps": float(speed[1000]),
            "max_speed_mps": float(speed.max()),
            "path_length_m": float(np.sum(speed) / FS),
            "start_heading_deg": float(np.degrees(rpy[0, 2]) % 360),
            "turn_on_gyro_bias_deg_h": (gb0 * 3600 / D2R).tolist(),
            "turn_on_accel_bias_ug": (ab0 / 9.80665e-6).tolist()}
    (folder / "meta.json").write_text(json.dumps(meta, indent=1))
    return meta


# -------------------------------------------------------------------------- scoring

def _read_csv(path):
    with open(path) as fh:
        names = fh.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {k: data[:, i] for i, k in enumerate(names)}


def _wrap180(a):
    return (a + 180.0) % 360.0 - 180.0


def score(sol, ref, t0=None):
    """RMSE N/E/D m, vN/vE/vD m/s, roll/pitch/yaw deg of ``sol`` (fednav solution
    columns: t_s, lat_deg, lon_deg, h_m, vE/vN/vU_mps, pitch/roll/heading_deg,
    sigma_heading_deg) against ``ref`` at the reference stamps within the solution's span
    (and after ``t0``); heading 3-sigma containment [% of those epochs].  The same code
    scores fednav and the peer."""
    ts = sol["t_s"]
    m = (ref["t_s"] >= ts[0]) & (ref["t_s"] <= ts[-1])
    if t0 is not None:
        m &= ref["t_s"] >= t0
    tr = ref["t_s"][m]

    def at(k, unwrap=False):
        x = sol[k]
        if unwrap:
            x = np.degrees(np.unwrap(np.radians(x)))
        return np.interp(tr, ts, x)

    lat0 = np.radians(ref["lat_deg"][m])
    a, e2 = 6378137.0, 6.69437999014e-3
    s = np.sin(lat0)
    rn = a * (1 - e2) / (1 - e2 * s * s) ** 1.5 + ref["h_m"][m]
    re = (a / np.sqrt(1 - e2 * s * s) + ref["h_m"][m]) * np.cos(lat0)
    err = {
        "north_m": np.radians(at("lat_deg") - ref["lat_deg"][m]) * rn,
        "east_m": np.radians(at("lon_deg") - ref["lon_deg"][m]) * re,
        "down_m": -(at("h_m") - ref["h_m"][m]),
        "vn_mps": at("vN_mps") - ref["vN_mps"][m],
        "ve_mps": at("vE_mps") - ref["vE_mps"][m],
        "vd_mps": -(at("vU_mps") - ref["vU_mps"][m]),
        "roll_deg": _wrap180(at("roll_deg", True) - ref["roll_deg"][m]),
        "pitch_deg": _wrap180(at("pitch_deg") - ref["pitch_deg"][m]),
        "yaw_deg": _wrap180(at("heading_deg", True) - ref["heading_deg"][m]),
    }
    out = {k: float(np.sqrt(np.mean(err[k] ** 2))) for k in KEYS}
    if "sigma_heading_deg" in sol:
        sig = at("sigma_heading_deg")
        out["heading_3sigma_pct"] = float(100.0 * np.mean(np.abs(err["yaw_deg"]) <= 3 * sig))
        out["heading_err_t0_deg"] = float(err["yaw_deg"][0])
        out["heading_sigma_t0_deg"] = float(sig[0])
    out["epochs"] = int(m.sum())
    out["t_from_s"] = float(tr[0])
    return out


# -------------------------------------------------------------------------- running

def states_config(folder, imu, states, label):
    """``config-LABEL.yaml``: the data set's config with ``filter.states`` = ``states``
    and the scale-factor 1-sigma of :data:`SCALE_PPM` for the scale states selected."""
    import yaml

    cfg = yaml.safe_load((folder / "config.yaml").read_text())
    for which in ("gyro", "accel"):
        if f"{which}_scale" in states:
            cfg.setdefault("imu", {})[f"{which}_scale_ppm"] = SCALE_PPM[imu][f"{which}_scale_ppm"]
    cfg.setdefault("filter", {})["states"] = list(states)
    path = folder / f"config-{label}.yaml"
    path.write_text("# config.yaml with optional error states (independent.py --states)\n"
                    + yaml.safe_dump(cfg, sort_keys=False))
    return path


def run_fednav(folder, out, src=None, config=None):
    """``fednav process csv --smooth`` on the data set; ``src``: a fednav source tree to
    run instead of the installed one (e.g. ``git archive HEAD src | tar -x -C DIR``);
    ``config``: a config file instead of the data set's ``config.yaml``."""
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(src), env.get("PYTHONPATH"))))
    cmd = ["fednav", "process", "csv", "--imu", str(folder / "imu.csv"),
           "--gnss", str(folder / "gnss.csv"), "--ref", str(folder / "ref.csv"),
           "--config", str(config or folder / "config.yaml"), "--smooth", "--out", str(out),
           # every IMU sample, as the peer writes: the reference is scored between
           # samples, and a 10 Hz file (the default) adds its interpolation error (UAV
           # roll 0.038 -> 0.122 deg in turns)
           "--output-rate", "imu"]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if p.returncode != 0 and "output-rate" in p.stderr + p.stdout:  # an older fednav
        cmd = cmd[:-2]  # (wrote every IMU sample by default)
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}\n{p.stdout}\n{p.stderr}")
    return " ".join(cmd), wall


def run_dataset(name, rebuild, label, src=None, states=()):
    folder = CACHE / name
    if rebuild or not (folder / "meta.json").exists():
        print(f"[{name}] building ...", flush=True)
        build_dataset(name, folder)
    meta = json.loads((folder / "meta.json").read_text())
    ref = _read_csv(folder / "ref.csv")
    out = folder / f"out-{label}"
    config = states_config(folder, DATASETS[name]["imu"], states, label) if states else None
    cmd, wall = run_fednav(folder, out, src, config)
    summ = json.loads((out / "summary.json").read_text())
    fwd = _read_csv(out / "solution.csv")
    smo = _read_csv(out / "solution_smoothed.csv")
    # the peer: same files, the same figures
    t0 = time.perf_counter()
    peer = peer_lc.run(folder / "imu.csv", folder / "gnss.csv", meta["imu_figures"],
                       np.array(GNSS["sigma_pos_enu_m"])[[1, 0, 2]],  # (the peer: N, E, U)
                       GNSS["sigma_vel_mps"], meta["lever_m"],
                       smooth=True)
    peer_wall = time.perf_counter() - t0
    tp = float(peer["start_t_s"])
    rows = {
        "fednav forward": score(fwd, ref, tp),
        "fednav smoothed": score(smo, ref, tp),
        "peer forward": score(peer["forward"], ref, tp),
        "peer smoothed": score(peer["smoothed"], ref, tp),
        "fednav forward, whole run": score(fwd, ref),
        "fednav smoothed, whole run": score(smo, ref),
    }
    nis = {"fednav": {k: v["nis_per_dof"] for k, v in summ.get("consistency", {}).items()},
           "peer": {"gnss": peer["nis_per_dof"]}}
    return {"dataset": name, "meta": meta, "command": cmd, "fednav_wall_s": wall,
            "states": list(states), "error_states": summ.get("error_states"),
            "peer_wall_s": peer_wall, "peer_start_t_s": tp, "rows": rows, "nis_per_dof": nis,
            "fednav_summary_rmse": summ.get("rmse"),
            "fednav_summary_rmse_smoothed": summ.get("rmse_smoothed"),
            "fednav_alignment": summ.get("alignment"), "fednav_warnings": summ.get("warnings")}


def print_table(r):
    print(f"\n## {r['dataset']}  (scored from t = {r['peer_start_t_s']:.1f} s, the peer's "
          f"start; fednav {r['fednav_wall_s']:.1f} s, peer {r['peer_wall_s']:.1f} s)")
    head = ["run", "N m", "E m", "D m", "vN", "vE", "vD", "roll", "pitch", "yaw", "hdg 3σ %"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for row, s in r["rows"].items():
        cells = [f"{s[k]:.3f}" for k in KEYS]
        print(f"| {row} | " + " | ".join(cells) + f" | {s.get('heading_3sigma_pct', 0):.1f} |")
    nis = r["nis_per_dof"]
    print("NIS/dof: fednav " + ", ".join(f"{k} {v:.2f}" for k, v in nis["fednav"].items())
          + f"; peer gnss {nis['peer']['gnss']:.2f}")
    for name, v in (r.get("error_states") or {}).items():  # (--states)
        print(f"fednav {name} at the end: " + ", ".join(
            f"{e:+.0f} ± {sd:.0f}" for e, sd in zip(v["estimate"], v["sigma"], strict=True)))
    f = r["rows"]["fednav forward, whole run"]
    print(f"fednav heading error at its first reference epoch {f['heading_err_t0_deg']:+.2f} "
          f"deg, sigma {f['heading_sigma_t0_deg']:.2f} deg")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", default=",".join(DATASETS))
    ap.add_argument("--rebuild", action="store_true")
    ap.add_argument("--label", default="current")
    ap.add_argument("--json", default="/tmp/independent.json")
    ap.add_argument("--src", default=None,
                    help="fednav source folder to run (on PYTHONPATH) instead of the installed "
                         "package, e.g. a clean export of a commit's src/")
    ap.add_argument("--states", default="",
                    help="optional error states for fednav (filter.states), comma-separated, "
                         f"of {', '.join(OPTIONAL_STATES)}; the scale-factor 1-sigma from "
                         "SCALE_PPM (default: none, the config as built)")
    a = ap.parse_args(argv)
    states = tuple(filter(None, a.states.split(",")))
    for st in states:
        if st not in OPTIONAL_STATES:
            ap.error(f"unknown state {st!r}: {', '.join(OPTIONAL_STATES)}")
        if st == "gnss_markov":
            ap.error("gnss_markov: the data sets' GNSS error is white (nothing to estimate)")
    CACHE.mkdir(parents=True, exist_ok=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=Path(__file__).resolve().parent).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--", "src"], capture_output=True,
                           text=True, cwd=Path(__file__).resolve().parent).stdout.strip()
    if dirty and not a.src:
        print("note: src/ has uncommitted changes; the installed fednav runs them, not HEAD "
              "(--src runs a clean export)")
    if a.rebuild:
        for f in CACHE.glob("truth-*.npz"):
            f.unlink()
    results = []
    for name in a.datasets.split(","):
        if name not in DATASETS:
            ap.error(f"unknown data set {name!r}: {', '.join(DATASETS)}")
        r = run_dataset(name, a.rebuild, a.label, a.src, states)
        print_table(r)
        results.append(r)
    Path(a.json).write_text(json.dumps({"label": a.label, "commit": commit, "src": a.src,
                                        "states": list(states),
                                        "src_dirty": bool(dirty) and not a.src,
                                        "results": results}, indent=1))
    print(f"\nwrote {a.json} (label {a.label}, HEAD {commit})")


if __name__ == "__main__":
    main()
