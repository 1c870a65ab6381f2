"""A simulated PX4 flight written as a ULog file, with no fednav code (issue 38 item 7).

The truth is closed-form motion written here, independent of fednav's trajectory and
sensor simulators (it imports nothing from fednav):

* **Path** in the tangent plane at home (east, north, up; fixed to the Earth): 20 s at
  rest on the ground, a climb to 30 m, then a figure of eight (400 m x 160 m, 90 s a
  loop, 11-18 m/s) entered with a 15 s speed ramp, its height swinging 20 m, until
  :data:`DURATION_S`.  Every blend is a septic smoothstep, so the acceleration and its
  rate are continuous; position, velocity and acceleration are analytic.
* **Attitude** of a multicopter: the body's up axis along the thrust (acceleration plus
  9.81 m/s^2 up, no drag), its nose along the path's direction (defined at rest too:
  the figure's tangent), right-forward-up body axes.
* **Earth**: WGS-84 ellipsoid, Earth rotation, J2 gravitation (Groves 2013 eq. 2.142);
  positions are the tangent-plane points taken into ECEF exactly, so latitude, longitude
  and height, the local ENU frame and the velocity in it follow the Earth's curvature.
* **IMU** (250 Hz, ``sensor_combined``): the angular rate of the body with respect to
  inertial space and the specific force ``a + 2 w x v + w x (w x r) - gravitation``, in
  body axes, each averaged over its 4 ms interval (3-point Gauss-Legendre; rates from
  central differences of the closed-form attitude), plus the errors of :data:`IMU`
  (turn-on bias, first-order Gauss-Markov drift, white noise; an explicit
  ``numpy.random.Generator``); PX4's FRD body axes.
* **GNSS** (5 Hz, ``vehicle_gps_position``, PX4 v1.14 fields: degrees, metres, NED
  velocity) white noise of :data:`GNSS` with ``eph``/``epv``/``s_variance_m_s`` saying
  so; none in the outage window (a real outage: the fixes are not in the log).
  ``legacy_gps=True`` writes PX4 v1.13's fields instead (``lat``/``lon`` in 1e-7 deg,
  ``alt``/``alt_ellipsoid`` in mm).
* **Barometer** (20 Hz, ``vehicle_air_data.baro_alt_meter``: AMSL through a geoid
  undulation of :data:`GEOID_M`, an offset, a slow drift, white noise) and
  **magnetometer** (25 Hz, ``vehicle_magnetometer.magnetometer_ga``, FRD, gauss: a field of
  :data:`MAG` (declination, inclination, intensity) and white noise; ``EKF2_MAG_DECL`` in
  the parameters).
* **Ground truth** (50 Hz): ``vehicle_global_position_groundtruth``,
  ``vehicle_local_position_groundtruth`` (NED) and ``vehicle_attitude_groundtruth``
  (quaternion FRD -> NED, ``[w, x, y, z]``), as PX4's simulator logs them.

Times: microseconds since boot, the log starting :data:`BOOT_US` after boot; flight time
``t`` [s] is counted from the log's start.  The file is written by pyulog's own writer
(``ULog.write_ulog``, pyulog >= 1.1): the message formats (PX4's fields, the trailing
padding left out) and the data go into a ``ULog`` object, which writes the ULog format.

``truth(t)`` gives the closed-form truth at any times (for the comparison);
``errors(solution, t)`` a solution's errors against it (ECEF difference, local ENU).
Used by ``benchmarks/px4_moving.py`` and ``tests/test_px4_moving.py``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

# ----------------------------------------------------------------------------- Earth
A_WGS = 6378137.0
F_WGS = 1.0 / 298.257223563
E2 = F_WGS * (2.0 - F_WGS)
GM = 3.986004418e14
J2 = 1.082627e-3
W_IE = 7.292115e-5
OMEGA = np.array([0.0, 0.0, W_IE])

# ------------------------------------------------------------------------ the flight
HOME = (47.3977, 8.5456, 488.0)  # PX4 SITL's home [deg, deg, m ellipsoidal]
GEOID_M = 47.4  # geoid undulation at home: AMSL = ellipsoidal - 47.4 m
BOOT_US = 3_000_000  # the log starts 3 s after boot
DURATION_S = 300.0
IMU_DT_US = 4000  # 250 Hz
GNSS_DT_US = 200_000  # 5 Hz
BARO_DT_US = 50_000  # 20 Hz
MAG_DT_US = 40_000  # 25 Hz
TRUTH_DT_US = 20_000  # 50 Hz
OUTAGE_S = (120.0, 160.0)  # GNSS withheld: no fix written in [120, 160) s

REST_S = 20.0  # on the ground
CLIMB = (20.0, 12.0, 30.0)  # start [s], duration [s], height [m]
RAMP = (30.0, 15.0)  # the figure's speed ramp: start, duration [s]
FIG_A, FIG_B, FIG_W = 200.0, 80.0, 2.0 * np.pi / 90.0  # east-west, half north, rad/s
SWING_M = 20.0  # height swing over the figure (one period each two loops)
HEADING0 = np.radians(35.0)  # the nose at rest, clockwise from north
G_DESIGN = 9.81  # for the attitude's thrust direction only

#: IMU errors per axis, 1-sigma (an autopilot's MEMS after PX4's calibrations, with the
#: vibration on the white noise): turn-on bias, Gauss-Markov drift and its time
#: constant, white noise density.  The same figures in fednav's ``imu:`` keys:
#: :func:`imu_config`.
IMU = {"gyro_bias_radps": np.radians(0.2), "gyro_markov_radps": np.radians(0.02),
       "gyro_tau_s": 300.0, "gyro_arw_rad_sqrt_s": np.radians(0.3) / 60.0,
       "accel_bias_mps2": 0.05, "accel_markov_mps2": 0.005, "accel_tau_s": 300.0,
       "accel_vrw_mps_sqrt_s": 300e-6 * 9.80665}
#: GNSS white noise 1-sigma (what eph, epv and s_variance_m_s report).
GNSS = {"eph_m": 0.6, "epv_m": 1.0, "vel_mps": 0.1}
#: Barometer: offset [m], drift over the flight [m], white noise [m].
BARO = {"offset_m": 1.5, "drift_m": 0.4, "noise_m": 0.15}
#: The Earth's field at home: declination, inclination [deg], intensity [gauss]; noise.
MAG = {"declination_deg": 3.0, "inclination_deg": 63.5, "intensity_ga": 0.48,
       "noise_ga": 0.003}


def imu_config() -> dict:
    """The simulated IMU's figures as fednav's ``imu:`` section (SI keys, floats)."""
    return {k: float(v) for k, v in {"gyro_bias_radps": IMU["gyro_bias_radps"],
            "gyro_markov_radps": IMU["gyro_markov_radps"], "gyro_tau_s": IMU["gyro_tau_s"],
            "gyro_arw_rad_sqrt_s": IMU["gyro_arw_rad_sqrt_s"],
            "accel_bias_mps2": IMU["accel_bias_mps2"],
            "accel_markov_mps2": IMU["accel_markov_mps2"], "accel_tau_s": IMU["accel_tau_s"],
            "accel_vrw_mps_sqrt_s": IMU["accel_vrw_mps_sqrt_s"]}.items()}


# ------------------------------------------------------------------- Earth geometry
def geodetic_to_ecef(lat, lon, h):
    """[rad, rad, m] -> ECEF [m] (..., 3)."""
    lat, lon, h = (np.asarray(x, dtype=float) for x in (lat, lon, h))
    n = A_WGS / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
    return np.stack([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                     (n * (1.0 - E2) + h) * np.sin(lat)], axis=-1)


def ecef_to_geodetic(r):
    """ECEF [m] (..., 3) -> latitude, longitude [rad], height [m] (iterated to 1e-13)."""
    r = np.asarray(r, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    lat = np.arctan2(z, p * (1.0 - E2))
    for _ in range(8):
        n = A_WGS / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
        h = p / np.cos(lat) - n
        lat = np.arctan2(z, p * (1.0 - E2 * n / (n + h)))
    n = A_WGS / np.sqrt(1.0 - E2 * np.sin(lat) ** 2)
    return lat, lon, p / np.cos(lat) - n


def enu_to_ecef(lat, lon):
    """The rotation (..., 3, 3) whose columns are east, north, up in ECEF."""
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    z = np.zeros_like(sl)
    return np.stack([np.stack([-so, -sl * co, cl * co], axis=-1),
                     np.stack([co, -sl * so, cl * so], axis=-1),
                     np.stack([z, cl, sl], axis=-1)], axis=-2)


def gravitation(r):
    """J2 gravitational acceleration [m/s^2] at ECEF ``r`` (..., 3) (Groves eq. 2.142)."""
    r = np.asarray(r, dtype=float)
    rr = np.linalg.norm(r, axis=-1, keepdims=True)
    zr2 = (r[..., 2:3] / rr) ** 2
    k = 1.5 * J2 * (A_WGS / rr) ** 2
    fac = np.concatenate([1.0 + k * (1.0 - 5.0 * zr2)] * 2 + [1.0 + k * (3.0 - 5.0 * zr2)],
                         axis=-1)
    return -GM / rr ** 3 * r * fac


# --------------------------------------------------------------- closed-form motion
def _step(u):
    """Septic smoothstep of ``u`` and its first two derivatives (0 below 0, 1 above 1)."""
    u = np.clip(u, 0.0, 1.0)
    s = u ** 4 * (35.0 - 84.0 * u + 70.0 * u ** 2 - 20.0 * u ** 3)
    d1 = 140.0 * u ** 3 * (1.0 - u) ** 3
    d2 = 420.0 * u ** 2 * (1.0 - u) ** 2 * (1.0 - 2.0 * u)
    return s, d1, d2


def _phase(t):
    """The figure's parameter tau(t) [s] and its two derivatives: 0 before the ramp, then
    the integral of the ramp's smoothstep (tau' goes 0 -> 1)."""
    t0, d = RAMP
    u = (np.asarray(t, dtype=float) - t0) / d
    uc = np.clip(u, 0.0, 1.0)
    integral = d * uc ** 5 * (7.0 - 14.0 * uc + 10.0 * uc ** 2 - 2.5 * uc ** 3)
    tau = np.where(u > 1.0, 0.5 * d + (u - 1.0) * d, integral)
    s, d1, _ = _step(u)
    return tau, s, d1 / d


def _figure_rotation():
    """Rotation of the figure's (x, y) into (east, north) that points its tangent at the
    start (x' = A w, y' = 2 B w) along :data:`HEADING0`."""
    start = np.arctan2(FIG_A, 2.0 * FIG_B)  # heading of (x', y') = (A, 2B) as (east, north)
    a = start - HEADING0  # a rotation by +a (counter-clockwise) lowers the heading by a
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def motion(t):
    """Tangent-plane position, velocity, acceleration (east, north, up) [m, m/s, m/s^2]
    (N, 3) each, and the figure's heading [rad] (N,), at flight times ``t`` [s]."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    tau, tau1, tau2 = _phase(t)
    w = FIG_W
    x = np.stack([FIG_A * np.sin(w * tau), FIG_B * np.sin(2 * w * tau)], axis=-1)
    xt = np.stack([FIG_A * w * np.cos(w * tau), 2 * FIG_B * w * np.cos(2 * w * tau)], axis=-1)
    xtt = np.stack([-FIG_A * w ** 2 * np.sin(w * tau),
                    -4 * FIG_B * w ** 2 * np.sin(2 * w * tau)], axis=-1)
    rot = _figure_rotation()
    pos_h = x @ rot.T
    vel_h = (xt * tau1[:, None]) @ rot.T
    acc_h = (xtt * tau1[:, None] ** 2 + xt * tau2[:, None]) @ rot.T
    tang = xt @ rot.T
    heading = np.arctan2(tang[:, 0], tang[:, 1])
    # height: the climb, then a slow swing (one period every two loops)
    c0, cd, ch = CLIMB
    s, d1, d2 = _step((t - c0) / cd)
    wh = 0.5 * w
    up = ch * s + SWING_M * 0.5 * (1.0 - np.cos(wh * tau))
    vu = ch * d1 / cd + SWING_M * 0.5 * wh * np.sin(wh * tau) * tau1
    au = (ch * d2 / cd ** 2 + SWING_M * 0.5 * (wh ** 2 * np.cos(wh * tau) * tau1 ** 2
                                               + wh * np.sin(wh * tau) * tau2))
    return (np.column_stack([pos_h, up]), np.column_stack([vel_h, vu]),
            np.column_stack([acc_h, au]), heading)


def attitude_tangent(t):
    """C (N, 3, 3): body right-forward-up -> tangent plane ENU (columns right, forward,
    up): up along the thrust, the nose along the figure's heading."""
    _, _, acc, heading = motion(t)
    thrust = acc + np.array([0.0, 0.0, G_DESIGN])
    up = thrust / np.linalg.norm(thrust, axis=1, keepdims=True)
    nose = np.column_stack([np.sin(heading), np.cos(heading), np.zeros_like(heading)])
    fwd = nose - np.sum(nose * up, axis=1, keepdims=True) * up
    fwd /= np.linalg.norm(fwd, axis=1, keepdims=True)
    right = np.cross(fwd, up)
    return np.stack([right, fwd, up], axis=-1)


def _home():
    lat0, lon0, h0 = np.radians(HOME[0]), np.radians(HOME[1]), HOME[2]
    return geodetic_to_ecef(lat0, lon0, h0), enu_to_ecef(lat0, lon0)


@dataclass
class Truth:
    """The closed-form truth at times ``t`` [s]: ``lla`` (rad, rad, m ellipsoidal),
    ``vel_enu`` [m/s] in the local ENU frame, ``c_bn`` body RFU -> local ENU, ``r_e``
    ECEF [m]."""

    t: np.ndarray
    lla: np.ndarray
    vel_enu: np.ndarray
    c_bn: np.ndarray
    r_e: np.ndarray

    @property
    def euler(self) -> np.ndarray:
        """``[pitch, roll, heading]`` [rad]: the nose's elevation, the bank
        ``atan2(-C[2,0], C[2,2])`` and the nose's azimuth clockwise from north."""
        c = self.c_bn
        return np.column_stack([np.arcsin(np.clip(c[:, 2, 1], -1, 1)),
                                np.arctan2(-c[:, 2, 0], c[:, 2, 2]),
                                np.arctan2(c[:, 0, 1], c[:, 1, 1]) % (2 * np.pi)])


def truth(t) -> Truth:
    """The truth at flight times ``t`` [s] (see :class:`Truth`)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    r0, c_te = _home()
    pos, vel, _, _ = motion(t)
    r_e = r0 + pos @ c_te.T
    lat, lon, h = ecef_to_geodetic(r_e)
    c_ne = enu_to_ecef(lat, lon)
    c_ne_t = np.swapaxes(c_ne, -1, -2)
    vel_enu = np.einsum("nij,nj->ni", c_ne_t, vel @ c_te.T)
    c_bn = c_ne_t @ (c_te @ attitude_tangent(t))
    return Truth(t, np.column_stack([lat, lon, h]), vel_enu, c_bn, r_e)


def _vee(m):
    return np.stack([m[..., 2, 1], m[..., 0, 2], m[..., 1, 0]], axis=-1)


def ideal_imu(t_nodes, h=1e-4):
    """Angular rate w.r.t. inertial space [rad/s] and specific force [m/s^2], body RFU,
    at flight times ``t_nodes`` (N,)."""
    r0, c_te = _home()
    pos, vel, acc, _ = motion(t_nodes)
    r_e = r0 + pos @ c_te.T
    v_e, a_e = vel @ c_te.T, acc @ c_te.T
    c = attitude_tangent(t_nodes)  # body -> tangent plane (fixed to the Earth)
    cdot = (attitude_tangent(t_nodes + h) - attitude_tangent(t_nodes - h)) / (2 * h)
    skew = np.swapaxes(c, -1, -2) @ cdot
    w_eb = _vee(0.5 * (skew - np.swapaxes(skew, -1, -2)))
    c_be = c_te @ c  # body -> ECEF
    c_eb = np.swapaxes(c_be, -1, -2)
    w_ib = w_eb + np.einsum("nij,j->ni", c_eb, OMEGA)
    f_e = (a_e + 2.0 * np.cross(OMEGA, v_e) + np.cross(OMEGA, np.cross(OMEGA, r_e))
           - gravitation(r_e))
    return w_ib, np.einsum("nij,nj->ni", c_eb, f_e)


def imu_averages(t_end, dt):
    """Averages of :func:`ideal_imu` over ``[t_end - dt, t_end]`` (3-point Gauss-Legendre)."""
    nodes = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
    weights = np.array([5.0, 8.0, 5.0]) / 18.0
    mid = t_end - 0.5 * dt
    gyro = np.zeros((len(t_end), 3))
    accel = np.zeros((len(t_end), 3))
    for x, wgt in zip(nodes, weights, strict=True):
        g, a = ideal_imu(mid + 0.5 * dt * x)
        gyro += wgt * g
        accel += wgt * a
    return gyro, accel


def _markov(rng, n, dt, sigma, tau):
    """First-order Gauss-Markov (N, 3) of steady-state ``sigma``, starting in steady state."""
    phi = np.exp(-dt / tau)
    q = sigma * np.sqrt(1.0 - phi ** 2)
    x = np.empty((n, 3))
    x[0] = rng.normal(0.0, sigma, 3)
    e = rng.normal(0.0, q, (n, 3))
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    return x


# ------------------------------------------------------------------ frames, quaternions
def rfu_to_frd(v):
    """Body right-forward-up -> front-right-down (also ENU -> NED): swap x and y, negate z."""
    v = np.asarray(v, dtype=float)
    return np.stack([v[..., 1], v[..., 0], -v[..., 2]], axis=-1)


_P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def quat_frd_ned(c_bn):
    """Hamilton ``[w, x, y, z]`` (N, 4) rotating FRD body vectors into NED, from C (RFU ->
    ENU): C_frd->ned = P C P (Shepperd's method, w >= 0)."""
    m = _P @ c_bn @ _P
    tr = np.trace(m, axis1=-2, axis2=-1)
    q = np.empty((len(m), 4))
    for i, (c, t) in enumerate(zip(m, tr, strict=True)):
        k = int(np.argmax([t, c[0, 0], c[1, 1], c[2, 2]]))
        if k == 0:
            s = 2.0 * np.sqrt(1.0 + t)
            q[i] = [0.25 * s, (c[2, 1] - c[1, 2]) / s, (c[0, 2] - c[2, 0]) / s,
                    (c[1, 0] - c[0, 1]) / s]
        elif k == 1:
            s = 2.0 * np.sqrt(1.0 + c[0, 0] - c[1, 1] - c[2, 2])
            q[i] = [(c[2, 1] - c[1, 2]) / s, 0.25 * s, (c[0, 1] + c[1, 0]) / s,
                    (c[0, 2] + c[2, 0]) / s]
        elif k == 2:
            s = 2.0 * np.sqrt(1.0 + c[1, 1] - c[0, 0] - c[2, 2])
            q[i] = [(c[0, 2] - c[2, 0]) / s, (c[0, 1] + c[1, 0]) / s, 0.25 * s,
                    (c[1, 2] + c[2, 1]) / s]
        else:
            s = 2.0 * np.sqrt(1.0 + c[2, 2] - c[0, 0] - c[1, 1])
            q[i] = [(c[1, 0] - c[0, 1]) / s, (c[0, 2] + c[2, 0]) / s,
                    (c[1, 2] + c[2, 1]) / s, 0.25 * s]
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


# ------------------------------------------------------------------------- the ULog
#: PX4's message formats (v1.14; ``legacy`` GPS fields of v1.13), trailing padding out.
FORMATS = {
    "sensor_combined": "uint64_t timestamp;float[3] gyro_rad;uint32_t gyro_integral_dt;"
    "int32_t accelerometer_timestamp_relative;float[3] accelerometer_m_s2;"
    "uint32_t accelerometer_integral_dt;uint8_t accelerometer_clipping;"
    "uint8_t gyro_clipping;uint8_t accel_calibration_count;uint8_t gyro_calibration_count;",
    "vehicle_gps_position": "uint64_t timestamp;uint64_t timestamp_sample;"
    "double latitude_deg;double longitude_deg;double altitude_msl_m;"
    "double altitude_ellipsoid_m;uint64_t time_utc_usec;uint32_t device_id;"
    "float s_variance_m_s;float c_variance_rad;float eph;float epv;float hdop;float vdop;"
    "int32_t noise_per_ms;int32_t jamming_indicator;float vel_m_s;float vel_n_m_s;"
    "float vel_e_m_s;float vel_d_m_s;float cog_rad;int32_t timestamp_time_relative;"
    "float heading;float heading_offset;float heading_accuracy;float rtcm_injection_rate;"
    "uint16_t automatic_gain_control;uint8_t fix_type;uint8_t jamming_state;"
    "uint8_t spoofing_state;bool vel_ned_valid;uint8_t satellites_used;"
    "uint8_t selected_rtcm_instance;bool rtcm_crc_failed;uint8_t rtcm_msg_used;",
    "vehicle_gps_position_legacy": "uint64_t timestamp;uint64_t time_utc_usec;int32_t lat;"
    "int32_t lon;int32_t alt;int32_t alt_ellipsoid;float s_variance_m_s;"
    "float c_variance_rad;float eph;float epv;float hdop;float vdop;int32_t noise_per_ms;"
    "int32_t jamming_indicator;float vel_m_s;float vel_n_m_s;float vel_e_m_s;"
    "float vel_d_m_s;float cog_rad;int32_t timestamp_time_relative;float heading;"
    "float heading_offset;uint8_t fix_type;uint8_t jamming_state;bool vel_ned_valid;"
    "uint8_t satellites_used;uint8_t selected;",
    "vehicle_air_data": "uint64_t timestamp;uint64_t timestamp_sample;"
    "uint32_t baro_device_id;float baro_alt_meter;float baro_temp_celcius;"
    "float baro_pressure_pa;float rho;float eas2tas;uint8_t calibration_count;",
    "vehicle_magnetometer": "uint64_t timestamp;uint64_t timestamp_sample;"
    "uint32_t device_id;float[3] magnetometer_ga;uint8_t calibration_count;",
    "vehicle_global_position_groundtruth": "uint64_t timestamp;uint64_t timestamp_sample;"
    "double lat;double lon;float alt;float alt_ellipsoid;float delta_alt;float eph;"
    "float epv;float terrain_alt;uint8_t lat_lon_reset_counter;uint8_t alt_reset_counter;"
    "bool terrain_alt_valid;bool dead_reckoning;",
    "vehicle_local_position_groundtruth": "uint64_t timestamp;uint64_t timestamp_sample;"
    "uint64_t ref_timestamp;double ref_lat;double ref_lon;float x;float y;float z;"
    "float vx;float vy;float vz;float ref_alt;bool xy_valid;bool z_valid;bool v_xy_valid;"
    "bool v_z_valid;bool xy_global;bool z_global;",
    "vehicle_attitude_groundtruth": "uint64_t timestamp;uint64_t timestamp_sample;"
    "float[4] q;float[4] delta_q_reset;uint8_t quat_reset_counter;",
}


def write_ulog(path, start_us: int, topics: dict, params: dict, info: dict) -> None:
    """Write a ULog file with pyulog's writer: ``topics`` {name: (format name, {field:
    array})} (fields as the format flattens them, ``x[0]``...; missing ones are zero),
    ``params`` {name: int or float}, ``info`` {key: str}."""
    from pyulog import ULog

    if not hasattr(ULog, "write_ulog"):
        raise RuntimeError("pyulog >= 1.1 is needed (ULog.write_ulog)")
    log = ULog(None)
    log._file_version = 1
    log._start_timestamp = int(start_us)
    log._msg_info_dict = dict(info)
    log._msg_info_dict_types = {k: f"char[{len(v)}]" for k, v in info.items()}
    log._initial_parameters = dict(params)
    for msg_id, (name, (fmt, fields)) in enumerate(topics.items()):
        spec = FORMATS[fmt]
        log._message_formats[name] = ULog.MessageFormat(f"{name}:{spec}".encode(), None)
        add = ULog._MessageAddLogged(struct.pack("<BH", 0, msg_id) + name.encode(), None,
                                     log._message_formats)
        n = len(fields["timestamp"])
        rows = np.zeros(n, dtype=add.dtype)
        for k, v in fields.items():
            rows[k] = v
        add.buffer = bytearray(rows.tobytes())
        log._data_list.append(ULog.Data(add))
    log.write_ulog(str(path))


def _grid(first_us: int, step_us: int, duration_s: float) -> np.ndarray:
    """Times [s] of a stream: ``first_us + k * step_us`` microseconds, before the end."""
    return np.arange(first_us, int(round(duration_s * 1e6)), step_us) * 1e-6


def _us(t):
    return BOOT_US + np.round(np.asarray(t) * 1e6).astype(np.int64)


def build(path, seed: int = 38, duration_s: float = DURATION_S,
          outage_s: tuple[float, float] | None = OUTAGE_S, legacy_gps: bool = False,
          imu_errors: bool = True) -> dict:
    """Write the flight to ``path`` (a ``.ulg``); returns what went into it: the IMU's
    drawn errors, the GNSS fixes' times [s], the outage."""
    rng = np.random.default_rng(seed)
    # IMU: rows end at k * 4 ms (k >= 1), each the average over the 4 ms before
    dt = IMU_DT_US * 1e-6
    n_imu = int(round(duration_s / dt))
    t_end = np.arange(1, n_imu + 1) * dt
    gyro, accel = imu_averages(t_end, dt)
    drawn = {}
    if imu_errors:
        gb = rng.normal(0.0, IMU["gyro_bias_radps"], 3)
        ab = rng.normal(0.0, IMU["accel_bias_mps2"], 3)
        gm = _markov(rng, n_imu, dt, IMU["gyro_markov_radps"], IMU["gyro_tau_s"])
        am = _markov(rng, n_imu, dt, IMU["accel_markov_mps2"], IMU["accel_tau_s"])
        gyro = gyro + gb + gm + rng.normal(0.0, IMU["gyro_arw_rad_sqrt_s"] / np.sqrt(dt),
                                           (n_imu, 3))
        accel = accel + ab + am + rng.normal(0.0, IMU["accel_vrw_mps_sqrt_s"] / np.sqrt(dt),
                                             (n_imu, 3))
        drawn = {"gyro_bias_radps": gb, "accel_bias_mps2": ab}
    ts = _us(t_end)
    g_frd, a_frd = rfu_to_frd(gyro), rfu_to_frd(accel)
    sc = {"timestamp": ts, "gyro_integral_dt": IMU_DT_US, "accelerometer_integral_dt": IMU_DT_US}
    for i in range(3):
        sc[f"gyro_rad[{i}]"] = g_frd[:, i]
        sc[f"accelerometer_m_s2[{i}]"] = a_frd[:, i]
    topics = {"sensor_combined": ("sensor_combined", sc)}

    # GNSS at 5 Hz from 1 s, none in the outage
    t_g = _grid(1_000_000, GNSS_DT_US, duration_s)
    if outage_s is not None:
        t_g = t_g[(t_g < outage_s[0]) | (t_g >= outage_s[1])]
    tr = truth(t_g)
    lat0 = tr.lla[:, 0]
    rm = A_WGS * (1 - E2) / (1 - E2 * np.sin(lat0) ** 2) ** 1.5
    rn = A_WGS / np.sqrt(1 - E2 * np.sin(lat0) ** 2)
    ne = rng.normal(0.0, GNSS["eph_m"], (len(t_g), 2))
    lat = np.degrees(tr.lla[:, 0] + ne[:, 1] / (rm + tr.lla[:, 2]))
    lon = np.degrees(tr.lla[:, 1] + ne[:, 0] / ((rn + tr.lla[:, 2]) * np.cos(lat0)))
    hgt = tr.lla[:, 2] + rng.normal(0.0, GNSS["epv_m"], len(t_g))
    v_ned = rfu_to_frd(tr.vel_enu + rng.normal(0.0, GNSS["vel_mps"], (len(t_g), 3)))
    tg_us = _us(t_g)
    gps = {"timestamp": tg_us, "eph": GNSS["eph_m"], "epv": GNSS["epv_m"],
           "s_variance_m_s": GNSS["vel_mps"], "hdop": 0.8, "vdop": 1.2,
           "vel_n_m_s": v_ned[:, 0], "vel_e_m_s": v_ned[:, 1], "vel_d_m_s": v_ned[:, 2],
           "vel_m_s": np.hypot(v_ned[:, 0], v_ned[:, 1]),
           "cog_rad": np.arctan2(v_ned[:, 1], v_ned[:, 0]), "fix_type": 3,
           "vel_ned_valid": 1, "satellites_used": 14,
           "time_utc_usec": 1_700_000_000_000_000 + tg_us}
    if legacy_gps:
        gps.update(lat=np.round(lat * 1e7).astype(np.int32),
                   lon=np.round(lon * 1e7).astype(np.int32),
                   alt=np.round((hgt - GEOID_M) * 1e3).astype(np.int32),
                   alt_ellipsoid=np.round(hgt * 1e3).astype(np.int32))
        topics["vehicle_gps_position"] = ("vehicle_gps_position_legacy", gps)
    else:
        gps.update(timestamp_sample=tg_us, latitude_deg=lat, longitude_deg=lon,
                   altitude_msl_m=hgt - GEOID_M, altitude_ellipsoid_m=hgt, device_id=1)
        topics["vehicle_gps_position"] = ("vehicle_gps_position", gps)

    # barometer, 20 Hz: AMSL + offset + drift + noise
    t_b = _grid(20_000, BARO_DT_US, duration_s)
    hb = (truth(t_b).lla[:, 2] - GEOID_M + BARO["offset_m"]
          + BARO["drift_m"] * t_b / duration_s + rng.normal(0.0, BARO["noise_m"], len(t_b)))
    topics["vehicle_air_data"] = ("vehicle_air_data", {
        "timestamp": _us(t_b), "timestamp_sample": _us(t_b), "baro_alt_meter": hb,
        "baro_temp_celcius": 20.0, "baro_pressure_pa": 101325.0 * (1 - 2.25577e-5 * hb)
        ** 5.25588, "rho": 1.2, "eas2tas": 1.0, "baro_device_id": 2})

    # magnetometer, 25 Hz: the field in FRD body axes [gauss]
    t_m = _grid(30_000, MAG_DT_US, duration_s)
    d, i = np.radians(MAG["declination_deg"]), np.radians(MAG["inclination_deg"])
    b_enu = MAG["intensity_ga"] * np.array([np.cos(i) * np.sin(d), np.cos(i) * np.cos(d),
                                            -np.sin(i)])
    b_body = np.einsum("nji,j->ni", truth(t_m).c_bn, b_enu)  # C^T b (RFU)
    b_frd = rfu_to_frd(b_body + rng.normal(0.0, MAG["noise_ga"], (len(t_m), 3)))
    mag = {"timestamp": _us(t_m), "timestamp_sample": _us(t_m), "device_id": 3}
    for k in range(3):
        mag[f"magnetometer_ga[{k}]"] = b_frd[:, k]
    topics["vehicle_magnetometer"] = ("vehicle_magnetometer", mag)

    # ground truth, 50 Hz
    t_t = _grid(0, TRUTH_DT_US, duration_s + 1e-6)
    tt = truth(t_t)
    r0, c_te = _home()
    local = np.einsum("ij,nj->ni", c_te.T, tt.r_e - r0)  # tangent plane ENU at home
    ned, vned = rfu_to_frd(local), rfu_to_frd(tt.vel_enu)
    q = quat_frd_ned(tt.c_bn)
    us = _us(t_t)
    topics["vehicle_global_position_groundtruth"] = (
        "vehicle_global_position_groundtruth", {
            "timestamp": us, "timestamp_sample": us, "lat": np.degrees(tt.lla[:, 0]),
            "lon": np.degrees(tt.lla[:, 1]), "alt": tt.lla[:, 2] - GEOID_M,
            "alt_ellipsoid": tt.lla[:, 2]})
    lp = {"timestamp": us, "timestamp_sample": us, "ref_timestamp": BOOT_US,
          "ref_lat": HOME[0], "ref_lon": HOME[1], "ref_alt": HOME[2] - GEOID_M,
          "xy_valid": 1, "z_valid": 1, "v_xy_valid": 1, "v_z_valid": 1, "xy_global": 1,
          "z_global": 1}
    for k, name in enumerate(("x", "y", "z")):
        lp[name] = ned[:, k]
        lp[f"v{name}"] = vned[:, k]
    topics["vehicle_local_position_groundtruth"] = ("vehicle_local_position_groundtruth", lp)
    att = {"timestamp": us, "timestamp_sample": us}
    for k in range(4):
        att[f"q[{k}]"] = q[:, k]
    topics["vehicle_attitude_groundtruth"] = ("vehicle_attitude_groundtruth", att)

    params = {"EKF2_MAG_DECL": float(MAG["declination_deg"]), "EKF2_GPS_P_NOISE": 0.5,
              "EKF2_GPS_V_NOISE": 0.3, "SYS_AUTOSTART": 4001}
    info = {"sys_name": "PX4", "ver_hw": "fednav benchmarks/px4_flight.py",
            "sys_toolchain": "none (closed-form simulation)"}
    write_ulog(path, BOOT_US, topics, params, info)
    return {"gnss_t": t_g, "outage_s": outage_s, **drawn}


# -------------------------------------------------------------------- the comparison
def errors(t, lla_deg, vel_enu, euler_deg) -> dict:
    """A solution's errors against the closed-form truth at its times ``t`` [s]:
    ``pos`` [m] and ``vel`` [m/s] (N, 3) local ENU at the truth (ECEF difference rotated),
    ``att`` [deg] (N, 3) ``[pitch, roll, heading]`` differences (heading wrapped to
    +-180)."""
    tr = truth(t)
    lla = np.asarray(lla_deg, dtype=float)
    r = geodetic_to_ecef(np.radians(lla[:, 0]), np.radians(lla[:, 1]), lla[:, 2])
    c_en = np.swapaxes(enu_to_ecef(tr.lla[:, 0], tr.lla[:, 1]), -1, -2)
    pos = np.einsum("nij,nj->ni", c_en, r - tr.r_e)
    att = np.asarray(euler_deg, dtype=float) - np.degrees(tr.euler)
    att[:, 2] = (att[:, 2] + 180.0) % 360.0 - 180.0
    return {"pos": pos, "vel": np.asarray(vel_enu, dtype=float) - tr.vel_enu, "att": att}
