"""A plain loosely coupled INS/GNSS EKF, written apart from fednav (no fednav import).

The peer of ``benchmarks/independent.py``: Groves, *Principles of GNSS, Inertial and
Multisensor Integrated Navigation Systems* (2nd ed.), ch. 5 (local-navigation-frame
mechanization) and ch. 14 (loosely coupled, closed loop), as a textbook would write it.

Frames: navigation NED, body forward-right-down; the fednav CSV files (ENU, body
right-forward-up) are converted on reading.  Error state (15), "estimate minus truth":
attitude misalignment phi (C_est = (I - [phi x]) C_true), velocity, position (NED metres),
accelerometer and gyro biases; the biases are random walks (PSD 2 sigma^2 / tau from the
Gauss-Markov figures, initial variance turn-on^2 + instability^2).  Propagation at every
IMU row: first-order attitude (Rodrigues) and velocity/position update with Earth rate,
transport rate, Coriolis and Somigliana gravity; Phi = I + F dt, Qd = Q dt.  GNSS position
and velocity at the antenna (lever arm in H, including the gyro-bias term of the lever
velocity), applied at the GNSS time stamp (the IMU row straddling it is split), Joseph
update, errors fed back after every update.  RTS smoother over the GNSS epochs on the
error states, its corrections interpolated in time between epochs.

Alignment: roll and pitch by levelling the first second of specific force, carried by
the gyros (heading unknown); the filter starts at the first GNSS fix with horizontal
speed above 2 m/s, heading = that fix's course (nothing carried back): the peer has no
solution before then.
"""

from __future__ import annotations

import numpy as np

A_E, E2, W_IE, MU = 6378137.0, 6.69437999014e-3, 7.292115e-5, 3.986004418e14
F_E = 1.0 / 298.257223563
D2R = np.pi / 180.0
M = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])  # RFU<->FRD, ENU<->NED


def skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rodrigues(a):
    th2 = a @ a
    k = skew(a)
    if th2 < 1e-12:
        return np.eye(3) + k + 0.5 * k @ k
    th = np.sqrt(th2)
    return np.eye(3) + np.sin(th) / th * k + (1 - np.cos(th)) / th2 * k @ k


def radii(lat):
    s2 = np.sin(lat) ** 2
    return A_E * (1 - E2) / (1 - E2 * s2) ** 1.5, A_E / np.sqrt(1 - E2 * s2)


def gravity_down(lat, h):
    """Somigliana on the ellipsoid, with Groves' (2.140) height terms."""
    s2 = np.sin(lat) ** 2
    g0 = 9.7803253359 * (1 + 0.001931853 * s2) / np.sqrt(1 - E2 * s2)
    m = W_IE ** 2 * A_E ** 2 * A_E * (1 - F_E) / MU
    return g0 * (1 - 2 / A_E * (1 + F_E + m - 2 * F_E * s2) * h + 3 * h * h / A_E ** 2)


def dcm_to_rpy(c):
    """Roll, pitch, yaw [rad] of C_b^n (NED, FRD), arrays (K, 3, 3) -> (K, 3)."""
    return np.column_stack((np.arctan2(c[:, 2, 1], c[:, 2, 2]),
                            -np.arcsin(np.clip(c[:, 2, 0], -1, 1)),
                            np.arctan2(c[:, 1, 0], c[:, 0, 0])))


def rpy_to_dcm(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([[cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
                     [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
                     [-sp, sr * cp, cr * cp]])


def _read(path):
    with open(path) as fh:
        names = fh.readline().strip().lstrip("\ufeff").split(",")
    d = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {k.strip(): d[:, i] for i, k in enumerate(names)}


class Nav:
    """The mechanization state and the 15-state error covariance."""

    def __init__(self, lat, lon, h, v, c, p0, q):
        self.lat, self.lon, self.h = lat, lon, h
        self.v, self.c = v.astype(float), c
        self.ba, self.bg = np.zeros(3), np.zeros(3)
        self.p = p0
        self.q = q  # continuous PSD diagonal (15,)
        self.phi_acc = np.eye(15)
        self.w_b = np.zeros(3)  # last corrected angular rate (lever arm velocity)

    def step(self, dth, dv, dt):
        """One mechanization step over dt with increments dth, dv (FRD), and P."""
        lat, h, v = self.lat, self.h, self.v
        rn, re = radii(lat)
        cl, sl = np.cos(lat), np.sin(lat)
        w_ie = np.array([W_IE * cl, 0.0, -W_IE * sl])
        w_en = np.array([v[1] / (re + h), -v[0] / (rn + h), -v[1] * sl / cl / (re + h)])
        a = dth - self.bg * dt
        dvb = dv - self.ba * dt
        self.w_b = a / dt
        c_mid = self.c @ (np.eye(3) + 0.5 * skew(a))
        dvn = c_mid @ dvb
        g = np.array([0.0, 0.0, gravity_down(lat, h)])
        v_new = v + dvn + (g - np.cross(2 * w_ie + w_en, v)) * dt
        self.c = rodrigues(-(w_ie + w_en) * dt) @ self.c @ rodrigues(a)
        vm = 0.5 * (v + v_new)
        self.lat = lat + vm[0] / (rn + h) * dt
        self.h = h - vm[2] * dt
        self.lon += vm[1] / ((re + h) * np.cos(0.5 * (lat + self.lat))) * dt
        self.v = v_new
        # error dynamics
        f = np.zeros((15, 15))
        f[0:3, 0:3] = -skew(w_ie + w_en)
        f[0:3, 12:15] = self.c
        f[3:6, 0:3] = skew(dvn / dt)
        f[3:6, 3:6] = -skew(2 * w_ie + w_en)
        f[3:6, 9:12] = -self.c
        f[5, 8] = 2 * g[2] / np.sqrt(rn * re)
        f[6:9, 3:6] = np.eye(3)
        phi = np.eye(15) + f * dt
        self.p = phi @ self.p @ phi.T + np.diag(self.q * dt)
        self.phi_acc = phi @ self.phi_acc

    def update(self, z_llh, z_vel, r_diag, lever):
        """GNSS position (lat, lon, h) and NED velocity of the antenna; returns the
        estimated error state, the NIS, and P before the update."""
        rn, re = radii(self.lat)
        cl = self.c @ lever
        wl = self.c @ np.cross(self.w_b, lever)
        dz = np.r_[(self.lat - z_llh[0]) * (rn + self.h) + cl[0],
                   (self.lon - z_llh[1]) * (re + self.h) * np.cos(self.lat) + cl[1],
                   -(self.h - z_llh[2]) + cl[2],
                   self.v + wl - z_vel]
        hm = np.zeros((6, 15))
        hm[0:3, 0:3] = skew(cl)
        hm[0:3, 6:9] = np.eye(3)
        hm[3:6, 0:3] = skew(wl)
        hm[3:6, 3:6] = np.eye(3)
        hm[3:6, 12:15] = self.c @ skew(lever)
        p_minus = self.p
        s = hm @ p_minus @ hm.T + np.diag(r_diag)
        k = np.linalg.solve(s, hm @ p_minus).T
        x = k @ dz
        ikh = np.eye(15) - k @ hm
        self.p = ikh @ p_minus @ ikh.T + k @ np.diag(r_diag) @ k.T
        self.correct(x)
        return x, float(dz @ np.linalg.solve(s, dz)), p_minus

    def correct(self, x):
        rn, re = radii(self.lat)
        self.c = rodrigues(x[0:3]) @ self.c
        self.v = self.v - x[3:6]
        self.lat -= x[6] / (rn + self.h)
        self.lon -= x[7] / ((re + self.h) * np.cos(self.lat))
        self.h += x[8]
        self.ba -= x[9:12]
        self.bg -= x[12:15]


def run(imu_csv, gnss_csv, figures, sigma_pos_m, sigma_vel_mps, lever_rfu, smooth=True,
        start_speed_mps=2.0):
    """Run the peer on fednav CSV files (IMU increments, GNSS positions and velocities).

    ``figures``: fednav-style IMU figure keys (gyro_bias_deg_h, gyro_markov_deg_h,
    gyro_markov_tau_s, gyro_arw_deg_sqrt_h, accel_bias_ug, accel_markov_ug,
    accel_markov_tau_s, accel_vrw_ug_sqrt_hz); GNSS sigmas [N, E, U] m and [E, N, U] m/s;
    lever arm body right-forward-up.  Returns the forward and smoothed solutions as
    columns (fednav's names: ENU velocity, [pitch, roll, heading] deg,
    sigma_heading_deg), the GNSS mean NIS per degree of freedom and the start time."""
    imu = _read(imu_csv)
    gn = _read(gnss_csv)
    t = imu["t_s"]
    dth = np.column_stack([imu[f"dtheta_{a}_rad"] for a in "xyz"]) @ M
    dvs = np.column_stack([imu[f"dv_{a}_mps"] for a in "xyz"]) @ M
    lever = M @ np.asarray(lever_rfu, float)
    tg = gn["t_s"]
    g_llh = np.column_stack((np.radians(gn["lat_deg"]), np.radians(gn["lon_deg"]), gn["h_m"]))
    g_vel = np.column_stack((gn["vN_mps"], gn["vE_mps"], -gn["vU_mps"]))
    sp = np.asarray(sigma_pos_m, float)
    sv = np.asarray(sigma_vel_mps, float)
    r_diag = np.r_[sp[0] ** 2, sp[1] ** 2, sp[2] ** 2, sv[1] ** 2, sv[0] ** 2, sv[2] ** 2]
    dt = np.diff(np.r_[t[0] - np.median(np.diff(t)), t])

    # --- alignment: level over the first second, carry roll/pitch with the gyros
    first = t <= t[0] + 1.0
    fb = dvs[first].sum(0) / dt[first].sum()
    roll, pitch = np.arctan2(-fb[1], -fb[2]), np.arctan(fb[0] / np.hypot(fb[1], fb[2]))
    j0 = int(np.argmax(np.hypot(g_vel[:, 0], g_vel[:, 1]) > start_speed_mps))
    t_start = tg[j0]
    c = rpy_to_dcm(roll, pitch, 0.0)
    k = 0
    while t[k] <= t_start:
        c = c @ rodrigues(dth[k])
        k += 1
    frac = (t[k] - t_start) / dt[k]  # the part of row k after t_start
    r0, p0_, _ = dcm_to_rpy(c[None])[0]
    yaw = np.arctan2(g_vel[j0, 1], g_vel[j0, 0])
    c = rpy_to_dcm(r0, p0_, yaw)
    rn, re = radii(g_llh[j0, 0])
    cl = c @ lever
    lat = g_llh[j0, 0] - cl[0] / (rn + g_llh[j0, 2])
    lon = g_llh[j0, 1] - cl[1] / ((re + g_llh[j0, 2]) * np.cos(lat))
    h = g_llh[j0, 2] + cl[2]

    f = figures
    gb2 = ((f["gyro_bias_deg_h"] ** 2 + f["gyro_markov_deg_h"] ** 2) * (D2R / 3600) ** 2)
    ab2 = (f["accel_bias_ug"] ** 2 + f["accel_markov_ug"] ** 2) * 9.80665e-6 ** 2
    p0 = np.diag(np.r_[(2 * D2R) ** 2, (2 * D2R) ** 2, (3 * D2R) ** 2,
                       [0.1 ** 2] * 3, sp[0] ** 2, sp[1] ** 2, sp[2] ** 2,
                       [ab2] * 3, [gb2] * 3])
    arw = f["gyro_arw_deg_sqrt_h"] * D2R / 60.0
    vrw = f["accel_vrw_ug_sqrt_hz"] * 9.80665e-6
    qg = 2 * (f["gyro_markov_deg_h"] * D2R / 3600) ** 2 / f["gyro_markov_tau_s"]
    qa = 2 * (f["accel_markov_ug"] * 9.80665e-6) ** 2 / f["accel_markov_tau_s"]
    q = np.r_[[arw ** 2] * 3, [vrw ** 2] * 3, [0.0] * 3, [qa] * 3, [qg] * 3]
    nav = Nav(lat, lon, h, g_vel[j0], c, p0, q)

    n = len(t) - k
    out_t = np.empty(n)
    out_x = np.empty((n, 6))  # lat, lon, h, vN, vE, vD
    out_c = np.empty((n, 3, 3))
    out_sig = np.empty(n)
    epochs = []  # (row index, time, P-, P+, Phi since the last epoch, x)
    nis = []
    j = j0 + 1
    for i in range(n):
        kk = k + i
        fr = frac if i == 0 else 1.0
        ta = t[kk] - fr * dt[kk]
        rem = fr
        while j < len(tg) and tg[j] <= t[kk] + 1e-9:
            part = (tg[j] - ta) / dt[kk]
            if part > 0:
                nav.step(dth[kk] * part, dvs[kk] * part, dt[kk] * part)
            x, nis_j, p_minus = nav.update(g_llh[j], g_vel[j], r_diag, lever)
            epochs.append((i, tg[j], p_minus, nav.p.copy(), nav.phi_acc.copy(), x))
            nav.phi_acc = np.eye(15)
            nis.append(nis_j / 6.0)
            rem -= part
            ta = tg[j]
            j += 1
        if rem > 1e-12:
            nav.step(dth[kk] * rem, dvs[kk] * rem, dt[kk] * rem)
        out_t[i] = t[kk]
        out_x[i] = (nav.lat, nav.lon, nav.h, *nav.v)
        out_c[i] = nav.c
        out_sig[i] = np.sqrt(nav.p[2, 2])

    fwd = _columns(out_t, out_x, out_c, out_sig)
    res = {"forward": fwd, "nis_per_dof": float(np.mean(nis)), "start_t_s": float(t_start),
           "gnss_epochs": len(nis)}
    if smooth:
        res["smoothed"] = _smooth(out_t, out_x, out_c, epochs)
    return res


def _columns(t, x, c, sig):
    rpy = np.degrees(dcm_to_rpy(c))
    return {"t_s": t, "lat_deg": np.degrees(x[:, 0]), "lon_deg": np.degrees(x[:, 1]),
            "h_m": x[:, 2], "vE_mps": x[:, 4], "vN_mps": x[:, 3], "vU_mps": -x[:, 5],
            "pitch_deg": rpy[:, 1], "roll_deg": rpy[:, 0], "heading_deg": rpy[:, 2] % 360,
            "sigma_heading_deg": np.degrees(sig)}


def _smooth(t, x, c, epochs):
    """RTS on the error states at the GNSS epochs: d_k = A_k (d_{k+1} + x_{k+1}),
    A_k = P+_k Phi_k+1^T (P-_k+1)^-1; d is the error of the forward (post-update)
    solution, interpolated in time between epochs (before the next update's correction:
    d_{k+1} + x_{k+1})."""
    ne = len(epochs)
    d = np.zeros((ne, 15))
    ps = [None] * ne
    ps[-1] = epochs[-1][3]
    for e in range(ne - 2, -1, -1):
        p_plus = epochs[e][3]
        _, _, p_minus1, _, phi1, x1 = epochs[e + 1]
        a = np.linalg.solve(p_minus1, phi1 @ p_plus).T
        d[e] = a @ (d[e + 1] + x1)
        ps[e] = p_plus + a @ (ps[e + 1] - p_minus1) @ a.T
    te = np.array([ep[1] for ep in epochs])
    ie = np.array([ep[0] for ep in epochs])
    xe = np.array([ep[5] for ep in epochs])
    # per row: the correction at the previous epoch (d) and just before the next (d + x)
    err = np.zeros((len(t), 15))
    sig = np.zeros(len(t))
    for e in range(ne):
        rows = np.arange(ie[e], ie[e + 1] if e + 1 < ne else len(t))
        if e + 1 < ne:
            w = ((t[rows] - te[e]) / (te[e + 1] - te[e]))[:, None]
            err[rows] = (1 - w) * d[e] + w * (d[e + 1] + xe[e + 1])
        else:
            err[rows] = d[e]
        sig[rows] = np.sqrt(ps[e][2, 2])
    rows = np.arange(0, ie[0])
    err[rows] = d[0] + xe[0]
    rn, re = radii(x[:, 0])
    xs = x.copy()
    xs[:, 3:6] -= err[:, 3:6]
    xs[:, 0] -= err[:, 6] / (rn + x[:, 2])
    xs[:, 1] -= err[:, 7] / ((re + x[:, 2]) * np.cos(x[:, 0]))
    xs[:, 2] += err[:, 8]
    ph = err[:, 0:3]
    k = np.zeros((len(t), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -ph[:, 2], ph[:, 1], -ph[:, 0]
    k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = ph[:, 2], -ph[:, 1], ph[:, 0]
    cs = (np.eye(3) + k + 0.5 * k @ k) @ c
    u, _, vt = np.linalg.svd(cs)
    return _columns(t, xs, u @ vt, sig)
