"""PX4 autopilot logs (ULog, ``.ulg``) -> fednav data, read with ``pyulog`` (PX4's parser).

PX4's conventions: body front-right-down (FRD), navigation NED, quaternions ``[w, x, y,
z]`` (Hamilton) rotating FRD body vectors into NED, time stamps in microseconds since
boot (SITL logs may count from the Unix epoch).  fednav: body right-forward-up, ENU:
vectors convert with :data:`~fednav.io.navego.FRD_TO_RFU` (``M``), attitudes with
``C = M C_ned_frd M`` (as NaveGo's, :mod:`fednav.io.navego`).

Times are seconds from the log's start (the ULog header's time stamp, :attr:`UlogRecording.
start_s` since boot): every stream shares that origin (a sensor's first rows may
precede it by a few milliseconds), and the small numbers keep microsecond differences
exact in double precision.  A topic's ``timestamp_sample`` (when
the sensor sampled) is used where the log fills it, else its ``timestamp``; rows stamped
0 (unset) or not later than the row before are dropped and counted.  Of a topic with
several instances (``multi_id``) the first is read.

Topics -> fednav (what each field becomes is in :func:`read_ulog`).
"""

from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import attitude as att
from ..core import units
from ..sensors.mag import GAUSS, MIN_FIELD_GAUSS
from .data import DataError, GnssData, ImuData, Reference, height_offset_to_gnss, require_file
from .navego import FRD_TO_RFU
from .sensorfile import SensorData

#: GNSS 1-sigma floors when the log does not give PX4's own (EKF2_GPS_P_NOISE [m],
#: EKF2_GPS_V_NOISE [m/s]: PX4's defaults, which EKF2 also floors eph/epv/sacc with).
GNSS_SIGMA_POS_FLOOR_M = 0.5
GNSS_SIGMA_VEL_FLOOR_MPS = 0.3
#: A vehicle_imu record whose rows integrate less than this share of the time they span
#: is a subsampled log of the IMU (PX4's logger keeps one row in many), not the IMU.
MIN_IMU_COVERAGE = 0.5


@dataclass
class UlogRecording:
    """What a PX4 log holds, in fednav's frames and units (times [s] from ``start_s``).

    ``imu`` the IMU (rates, body RFU); ``gnss`` the receiver's fixes or None; ``sensors``
    the other sensors by registered name (``baro``: height [m] shifted onto the GNSS
    ellipsoidal height; ``mag``: the field, body RFU [T]); ``px4`` PX4's own estimate and
    ``truth`` the simulator's ground truth as :class:`~fednav.io.data.Reference` (or
    None); ``start_s`` the log's start [s since boot] that every time is counted from;
    ``topics`` every topic in the log; ``quality`` what the reader did (keys in
    :func:`read_ulog`); ``notes`` what it left out or could not use, one line each."""

    source: str
    imu: ImuData
    gnss: GnssData | None
    sensors: dict[str, SensorData]
    px4: Reference | None
    truth: Reference | None
    start_s: float
    topics: list[str]
    quality: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def series(self) -> dict:
        """Every sensor's series by registered name, the GNSS among them: what
        :func:`fednav.process.process` takes."""
        return {**({"gnss": self.gnss} if self.gnss is not None else {}), **self.sensors}


class _Log:
    """The parsed log: topic data by name, the time origin, drop counts."""

    def __init__(self, path: Path):
        from pyulog import ULog  # imported here: the other readers do not need it

        self.src = str(path)
        out = io.StringIO()
        try:
            with contextlib.redirect_stdout(out):  # pyulog prints what it skips
                self.ulog = ULog(self.src)
        except Exception as e:  # pyulog raises several types for what is not a ULog
            msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise DataError(f"ULog file {path}: not a readable ULog file ({msg})") from None
        self.parser_notes = [f"pyulog: {line.strip()}" for line in out.getvalue().splitlines()
                             if line.strip()]
        self.data = {}
        for d in sorted(self.ulog.data_list, key=lambda d: d.multi_id):
            self.data.setdefault(d.name, d.data)
        self.origin = int(self.ulog.start_timestamp)
        self.params = dict(self.ulog.initial_parameters)
        self.dropped: dict[str, int] = {}

    def __contains__(self, topic: str) -> bool:
        return topic in self.data

    def rows(self, topic: str):
        """(t [s from the origin], the topic's arrays at the rows kept)."""
        d = self.data[topic]
        ts = d["timestamp"]
        if "timestamp_sample" in d and np.all(d["timestamp_sample"] > 0):
            ts = d["timestamp_sample"]
        ts = ts.astype(np.int64)
        keep = ts > 0
        running = np.maximum.accumulate(np.where(keep, ts, 0))
        keep[1:] &= ts[1:] > running[:-1]
        if (~keep).any():
            self.dropped[topic] = int((~keep).sum())
        return (ts[keep] - self.origin) * 1e-6, {k: v[keep] for k, v in d.items()}


def _f(x) -> float:
    """A float32 log value as the decimal it was written as (0.3, not 0.30000001)."""
    return float(f"{float(x):.7g}")


def _param(log: _Log, name: str, default: float) -> float:
    return _f(log.params[name]) if name in log.params else default


def _vec(d: dict, name: str) -> np.ndarray:
    """Fields ``name[0..2]`` as (N, 3) floats."""
    return np.column_stack([d[f"{name}[{i}]"].astype(float) for i in range(3)])


def _interp(t_src, a, t) -> np.ndarray:
    """Linear interpolation of the columns of ``a`` at ``t``; NaN outside ``t_src``."""
    a = np.asarray(a, dtype=float).reshape(len(t_src), -1)
    out = np.column_stack([np.interp(t, t_src, a[:, j]) for j in range(a.shape[1])])
    out[(t < t_src[0]) | (t > t_src[-1])] = np.nan
    return out


def _quat_at(t_src, q, t) -> np.ndarray:
    """Unit quaternions ``q`` (N, 4) interpolated at ``t`` (normalised linear
    interpolation after putting consecutive ones in the same hemisphere); NaN outside."""
    q = np.asarray(q, dtype=float)
    flip = np.r_[1.0, np.cumprod(np.where(np.sum(q[1:] * q[:-1], axis=1) < 0, -1.0, 1.0))]
    qi = _interp(t_src, q * flip[:, None], t)
    return qi / np.linalg.norm(qi, axis=1, keepdims=True)


def _euler_of_px4(q) -> np.ndarray:
    """PX4 quaternions (FRD -> NED) -> fednav Euler ``[pitch, roll, heading]`` [rad]."""
    return att.dcm_to_euler(FRD_TO_RFU @ att.quat_to_dcm(q) @ FRD_TO_RFU)


# ----------------------------------------------------------------------------- IMU
def _imu_sensor_combined(log: _Log, max_bridge_s: float, quality: dict, notes: list):
    t_end, d = log.rows("sensor_combined")
    gyro, accel = _vec(d, "gyro_rad"), _vec(d, "accelerometer_m_s2")
    dt = d["gyro_integral_dt"] * 1e-6 if "gyro_integral_dt" in d else None
    if dt is None or not np.all(dt > 0):
        dt = np.full(len(t_end), np.median(np.diff(t_end)) if len(t_end) > 1 else 0.0)
    rel = d.get("accelerometer_timestamp_relative")
    if rel is not None and np.any(rel != 0):
        notes.append(f"sensor_combined: accelerometer samples up to "
                     f"{np.abs(rel).max() / 1000:g} ms from the gyro's "
                     f"(accelerometer_timestamp_relative): not corrected")
    # each row averages its rates over gyro_integral_dt ending at its time stamp; fednav
    # stamps a rate at the start of its interval
    return ImuData(f"{log.src}:sensor_combined", t_end - dt, gyro @ FRD_TO_RFU.T,
                   accel @ FRD_TO_RFU.T, max_bridge_s=max_bridge_s)


def imu_from_vehicle_imu(source: str, t_end, dtheta_frd, dv_frd, dtheta_dt, dv_dt,
                         max_bridge_s: float = 0.1) -> ImuData:
    """IMU rates from PX4 ``vehicle_imu`` increments: ``dtheta_frd`` [rad] and ``dv_frd``
    [m/s] (N, 3, body FRD) over ``dtheta_dt`` / ``dv_dt`` [s] ending at ``t_end`` [s],
    each divided by its own interval and stamped at the interval's start.  A record whose
    rows cover less than :data:`MIN_IMU_COVERAGE` of their span is refused (DataError)."""
    t_end = np.asarray(t_end, dtype=float)
    dta, dtv = np.asarray(dtheta_dt, dtype=float), np.asarray(dv_dt, dtype=float)
    if len(t_end) < 2 or np.any(dta <= 0) or np.any(dtv <= 0):
        raise DataError(f"{source}: vehicle_imu needs 2 rows or more with positive "
                        f"delta_angle_dt and delta_velocity_dt")
    span = t_end[-1] - t_end[0] + dta[0]
    cover = float(dta.sum() / span)
    if cover < MIN_IMU_COVERAGE:
        raise DataError(f"{source}: vehicle_imu rows cover {100 * cover:.1f}% of their "
                        f"{span:.3f} s (rows {np.median(np.diff(t_end)) * 1e3:.0f} ms apart, "
                        f"each integrating {np.median(dta) * 1e3:.1f} ms): a subsampled "
                        f"log of the IMU, not the IMU")
    gyro = np.asarray(dtheta_frd, dtype=float) / dta[:, None]
    accel = np.asarray(dv_frd, dtype=float) / dtv[:, None]
    return ImuData(source, t_end - dta, gyro @ FRD_TO_RFU.T, accel @ FRD_TO_RFU.T,
                   max_bridge_s=max_bridge_s)


def _imu(log: _Log, max_bridge_s: float, quality: dict, notes: list) -> ImuData:
    if "sensor_combined" in log:
        imu = _imu_sensor_combined(log, max_bridge_s, quality, notes)
        quality["imu_topic"] = "sensor_combined"
    elif "vehicle_imu" in log:
        t, d = log.rows("vehicle_imu")
        imu = imu_from_vehicle_imu(f"{log.src}:vehicle_imu", t, _vec(d, "delta_angle"),
                                   _vec(d, "delta_velocity"), d["delta_angle_dt"] * 1e-6,
                                   d["delta_velocity_dt"] * 1e-6, max_bridge_s)
        quality["imu_topic"] = "vehicle_imu"
    else:
        why = f" ({log.parser_notes[0]})" if log.parser_notes else ""
        raise DataError(f"ULog file {log.src}: no IMU topic (sensor_combined or "
                        f"vehicle_imu){why}")
    quality.update(imu.quality)
    quality["imu_rate_hz"] = round(1.0 / imu.period(), 6)
    # (the log has no IMU noise figures: PX4's own filter tuning, for the user's
    # reference; fednav process says which figures it assumes)
    for k in ("EKF2_GYR_NOISE", "EKF2_ACC_NOISE"):
        if k in log.params:
            quality[k.lower()] = _param(log, k, 0.0)
    return imu


# ---------------------------------------------------------------------------- GNSS
def _latlon_deg(d: dict, name: str) -> np.ndarray:
    """Latitude or longitude [deg]: ``<name>_deg`` (PX4 >= 1.14, degrees) or ``<name>``
    (integers of 1e-7 deg; degrees if the magnitudes say so)."""
    full = {"lat": "latitude_deg", "lon": "longitude_deg"}[name]
    if full in d:
        return d[full].astype(float)
    a = d[name]
    if np.issubdtype(a.dtype, np.integer) or np.nanmax(np.abs(a)) > 360.0:
        return a.astype(float) * 1e-7
    return a.astype(float)


def _gnss_height(d: dict):
    """(height [m], 'ellipsoid' or 'amsl'): the ellipsoidal height where the log fills it
    (``altitude_ellipsoid_m`` in m, ``alt_ellipsoid`` in mm), else AMSL."""
    for name, scale, kind in (("altitude_ellipsoid_m", 1.0, "ellipsoid"),
                              ("alt_ellipsoid", 1e-3, "ellipsoid"),
                              ("altitude_msl_m", 1.0, "amsl"), ("alt", 1e-3, "amsl")):
        if name in d and (kind == "amsl" or np.any(d[name] != 0)):
            if scale != 1.0 and not np.issubdtype(d[name].dtype, np.integer):
                scale = 1.0  # a float field holds metres
            return d[name].astype(float) * scale, kind
    return None, None


def _gnss(log: _Log, quality: dict, notes: list) -> GnssData | None:
    topic = next((t for t in ("vehicle_gps_position", "sensor_gps") if t in log), None)
    if topic is None:
        notes.append("gnss: no vehicle_gps_position or sensor_gps topic")
        return None
    t, d = log.rows(topic)
    h, kind = _gnss_height(d)
    if h is None:
        notes.append(f"gnss: {topic} has no altitude field")
        return None
    fix = d["fix_type"] >= 3 if "fix_type" in d else np.ones(len(t), dtype=bool)
    quality.update(gnss_topic=topic, gnss_epochs_no_fix=int((~fix).sum()), gnss_height=kind)
    if kind == "amsl":
        notes.append(f"gnss: {topic} gives no ellipsoidal height: heights are AMSL")
    if fix.sum() < 2:
        notes.append(f"gnss: {topic} has {int(fix.sum())} rows with a 3D fix: not used")
        return None
    lla = np.column_stack([units.deg(_latlon_deg(d, "lat")), units.deg(_latlon_deg(d, "lon")),
                           h])
    ned = np.column_stack([d[k].astype(float) for k in ("vel_n_m_s", "vel_e_m_s",
                                                         "vel_d_m_s")])
    if "vel_ned_valid" in d:
        ned[d["vel_ned_valid"] == 0] = np.nan  # screened (gnss_epochs_skipped)
    fl_p = _param(log, "EKF2_GPS_P_NOISE", GNSS_SIGMA_POS_FLOOR_M)
    fl_v = _param(log, "EKF2_GPS_V_NOISE", GNSS_SIGMA_VEL_FLOOR_MPS)
    eph, epv = (max(_f(np.median(d[k][fix])), fl_p) for k in ("eph", "epv"))
    sv = max(_f(np.median(d["s_variance_m_s"][fix])), fl_v)
    quality.update(gnss_sigma_pos_enu_m=[eph, eph, epv], gnss_sigma_vel_mps=sv)
    g = GnssData(f"{log.src}:{topic}", t[fix], lla[fix], (ned @ FRD_TO_RFU.T)[fix],
                 np.array([eph, eph, epv]), np.full(3, sv), np.zeros(3))
    quality.update(g.quality)
    if "EKF2_GPS_DELAY" in log.params:
        notes.append(f"gnss: stamped when received; PX4 assumes a delay of "
                     f"{_param(log, 'EKF2_GPS_DELAY', 0.0):g} ms (EKF2_GPS_DELAY): "
                     f"not applied")
    return g


# ---------------------------------------------------------------------- other sensors
def _baro(log: _Log, gnss: GnssData | None, quality: dict, notes: list):
    if "vehicle_air_data" not in log:
        return None
    t, d = log.rows("vehicle_air_data")
    h = d["baro_alt_meter"].astype(float)
    ok = np.isfinite(h)
    t, h = t[ok], h[ok]
    if len(t) < 2:
        return None
    off = height_offset_to_gnss(t, h, gnss)
    if np.isfinite(off):
        quality["baro_offset_m"] = off
        h = h + off
    else:
        notes.append("baro: no GNSS height over its span: baro_alt_meter (AMSL from "
                     "standard atmosphere) kept as it is, not ellipsoidal")
    return SensorData("baro", f"{log.src}:vehicle_air_data", t, h[:, None],
                      quality={"baro_rows_dropped": int((~ok).sum())})


def _mag(log: _Log, quality: dict, notes: list):
    if "vehicle_magnetometer" in log:
        topic = "vehicle_magnetometer"
        t, d = log.rows(topic)
        b = _vec(d, "magnetometer_ga")
    elif "sensor_mag" in log:
        topic = "sensor_mag"
        t, d = log.rows(topic)
        b = np.column_stack([d[k].astype(float) for k in "xyz"])
        notes.append("mag: from sensor_mag (no calibration applied: hard and soft iron)")
    else:
        return None
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(b).all(axis=1) & (np.linalg.norm(b, axis=1) > MIN_FIELD_GAUSS)
    quality["mag_topic"] = topic
    if "EKF2_MAG_DECL" in log.params:
        quality["mag_declination_deg"] = _param(log, "EKF2_MAG_DECL", 0.0)
    return SensorData("mag", f"{log.src}:{topic}", t[ok], (b[ok] @ FRD_TO_RFU.T) * GAUSS,
                      quality={"mag_rows_dropped": int((~ok).sum())})


# ------------------------------------------------------------------ PX4's estimate, truth
def _reference(log: _Log, what: str, suffix: str, quality: dict,
               notes: list) -> Reference | None:
    """PX4's estimate (``suffix`` '') or the simulator's truth ('_groundtruth'):
    positions from vehicle_global_position, ENU velocity from vehicle_local_position and
    Euler angles from vehicle_attitude, both interpolated at the positions' times."""
    gp, lp, va = (f"vehicle_{k}{suffix}" for k in ("global_position", "local_position",
                                                    "attitude"))
    if gp not in log or lp not in log:
        missing = " and ".join(k for k in (gp, lp) if k not in log)
        notes.append(f"{what}: no {missing} in the log")
        return None
    t, d = log.rows(gp)
    ell = "alt_ellipsoid" in d and np.any(d["alt_ellipsoid"] != 0)
    alt = d["alt_ellipsoid"] if ell else d["alt"]
    quality[f"{what}_height"] = "ellipsoid" if ell else "amsl"
    if np.all(alt == 0):
        quality[f"{what}_height"] = "unset"
        notes.append(f"{what}: {gp} altitude is 0 in every row (not filled by the log's "
                     f"source): its height is not usable")
    elif not ell:
        notes.append(f"{what}: {gp} has no ellipsoidal altitude: heights are AMSL")
    lla = np.column_stack([units.deg(d["lat"].astype(float)),
                           units.deg(d["lon"].astype(float)), alt.astype(float)])
    tl, dl = log.rows(lp)
    ned = np.column_stack([dl[k].astype(float) for k in ("vx", "vy", "vz")])
    vel = _interp(tl, ned @ FRD_TO_RFU.T, t)
    euler = None
    if va in log:
        tq, dq = log.rows(va)
        q = np.column_stack([dq[f"q[{i}]"].astype(float) for i in range(4)])
        euler = _euler_of_px4(_quat_at(tq, q, t))
    else:
        notes.append(f"{what}: no {va}: no attitude")
    ref = Reference(f"{log.src}:{gp}", t, lla, vel, euler)
    quality[f"{what}_rows_skipped"] = ref.quality["reference_rows_skipped"]
    return ref


# ---------------------------------------------------------------------------- reader
def _optional(read, notes: list, *args):
    """``read(*args)``; a stream that fails its checks is left out with a note (the IMU's
    failures are the reader's)."""
    try:
        return read(*args)
    except DataError as e:
        notes.append(f"not used: {e}")
        return None
    except KeyError as e:  # a firmware whose topic lacks a field
        notes.append(f"not used: {getattr(read, '__name__', 'stream').strip('_')}: the log "
                     f"has no field {e}")
        return None


def read_ulog(path, max_bridge_s: float = 0.1, mounting=None) -> UlogRecording:
    """A PX4 ULog file as fednav data (:class:`UlogRecording`); a missing file, a file
    that is not a ULog, or a log without a usable IMU: one-line :class:`DataError`.  A
    GNSS, PX4-estimate or truth stream that fails fednav's checks (fewer than two rows,
    say) is left out with a note.

    * ``imu`` from ``sensor_combined`` (``gyro_rad`` [rad/s], ``accelerometer_m_s2``
      [m/s^2], averaged over ``gyro_integral_dt`` ending at ``timestamp``: stamped at the
      interval's start), else from ``vehicle_imu`` increments (:func:`imu_from_vehicle_imu`);
      FRD -> RFU (``mounting``: the IMU's axes when they are not PX4's FRD,
      ``imu.mounting``, :meth:`fednav.io.ImuData.remount`).  Missing or jittered
      samples are integrated onto a uniform grid by :class:`~fednav.io.data.ImuData`
      (:func:`~fednav.io.data.regular_imu`).
    * ``gnss`` from ``vehicle_gps_position`` (else ``sensor_gps``): rows with
      ``fix_type`` >= 3; latitude/longitude in degrees (``latitude_deg``) or 1e-7 deg
      integers (``lat``); the ellipsoidal height (``altitude_ellipsoid_m`` m or
      ``alt_ellipsoid`` mm) where filled, else AMSL; ``vel_n/e/d_m_s`` NED -> ENU (rows
      with ``vel_ned_valid`` 0 skipped); 1-sigma the median over the fixes of ``eph``
      (north, east), ``epv`` (up), ``s_variance_m_s`` (a speed 1-sigma despite its name),
      floored by PX4's EKF2_GPS_P_NOISE / EKF2_GPS_V_NOISE (the log's, else 0.5 m,
      0.3 m/s); lever arm zero.
    * ``sensors["baro"]`` from ``vehicle_air_data.baro_alt_meter`` [m]: a pressure
      altitude (AMSL in the standard atmosphere), **shifted by the median of the GNSS
      ellipsoidal height minus it** over their overlap so that it is a height like
      fednav's (``quality["baro_offset_m"]``; unshifted without GNSS, with a note).
    * ``sensors["mag"]`` from ``vehicle_magnetometer.magnetometer_ga`` (else
      ``sensor_mag``), FRD -> RFU, gauss -> tesla (the ``mag`` sensor's ``z``).
    * Airspeed (``airspeed``, ``airspeed_validated``) is not read: the ``airdata``
      sensor's measurement holds the wind estimate with the airspeed (a note says so).
    * ``px4``: ``vehicle_global_position`` (lat, lon, ``alt_ellipsoid`` else AMSL
      ``alt``), ``vehicle_local_position`` ``vx, vy, vz`` NED -> ENU and
      ``vehicle_attitude`` ``q`` -> ``[pitch, roll, heading]`` (``C = M C_ned_frd M``),
      both interpolated at the positions' times (NaN rows outside their span are
      skipped, ``reference_rows_skipped``).  ``truth``: the same from the
      ``*_groundtruth`` topics (a simulator's log), else None.

    ``quality``: ``imu_topic``, ``imu_rate_hz``, ImuData's ``imu_samples_bridged`` (and,
    when it resampled, ``imu_resampled``, ``imu_samples_missing``, ``imu_jitter_s``),
    ``ekf2_gyr_noise`` / ``ekf2_acc_noise`` (PX4's own filter tuning: the log has no
    IMU noise figures);
    ``gnss_topic``, ``gnss_epochs_no_fix`` (``fix_type`` < 3), ``gnss_epochs_skipped``,
    ``gnss_height`` ('ellipsoid' or 'amsl'), ``gnss_sigma_pos_enu_m``, ``gnss_sigma_vel_mps``;
    ``baro_offset_m``; ``mag_topic``, ``mag_declination_deg`` (PX4's EKF2_MAG_DECL, for
    ``sensors.mag.declination_deg``); ``px4_height`` / ``truth_height`` ('ellipsoid',
    'amsl' or 'unset': 0 in every row) and ``px4_rows_skipped`` / ``truth_rows_skipped``
    (outside the velocity's or attitude's span); ``rows_dropped`` {topic: rows with a
    zero or non-increasing time stamp}.
    """
    path = Path(path)
    require_file(path, "ULog")
    log = _Log(path)
    quality: dict = {}
    notes: list[str] = list(log.parser_notes)
    try:
        imu = _imu(log, max_bridge_s, quality, notes)
    except KeyError as e:
        raise DataError(f"{path}: the IMU topic has no field {e}") from None
    imu.mounting, imu.mounting_name = FRD_TO_RFU, "FRD"
    if mounting is not None:
        imu = imu.remount(mounting)
    gnss = _optional(_gnss, notes, log, quality, notes)
    sensors = {}
    for name, s in (("baro", _optional(_baro, notes, log, gnss, quality, notes)),
                    ("mag", _optional(_mag, notes, log, quality, notes))):
        if s is not None:
            sensors[name] = s
    air = [t for t in ("airspeed_validated", "airspeed") if t in log]
    if air:
        notes.append(f"airdata: {air[0]} not read: fednav's airdata sensor needs the wind "
                     f"estimate [east, north] with the airspeed, which the log does not "
                     f"give independently of PX4's own estimator")
    px4 = _optional(_reference, notes, log, "px4", "", quality, notes)
    truth = (_optional(_reference, notes, log, "truth", "_groundtruth", quality, notes)
             if any(t.endswith("_groundtruth") for t in log.data) else None)
    quality["rows_dropped"] = dict(log.dropped)
    return UlogRecording(str(path), imu, gnss, sensors, px4, truth, log.origin * 1e-6,
                         sorted(log.data), quality, notes)
