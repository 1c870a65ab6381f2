"""u-blox UBX logs (read with ``pyubx2``): the receiver's ``NAV-PVT`` solutions as the
GNSS's series, and a dead-reckoning module's sensor data (``ESF-RAW``, ``ESF-MEAS``) as the
IMU and the odometer.

Each ``NAV-PVT`` gives a fix: latitude, longitude, the height above the ellipsoid, the
NED velocity (turned into ENU here), their accuracy estimates ``hAcc`` (the horizontal
position's 1-sigma, used for north and for east, as PX4's EKF2 uses it), ``vAcc`` (up) and
``sAcc`` (each velocity axis), the fix type and the carrier solution.  A fix is kept when
``gnssFixOK`` is set and the fix is 3-D (type 3, or 4: GNSS + dead reckoning); the others,
and the messages of other classes (NMEA mixed in, other UBX messages), are counted.

Times: by default seconds since 1970-01-01 UTC from the message's date and time (its
``nano`` correction included; a fix without a valid date and time takes its UTC from
``iTOW``, the GPS week and the leap seconds of ``NAV-TIMEGPS`` when the log has them,
else it is dropped), or ``time="week"``: the GPS time of week ``iTOW`` [s] (KF-GINS's
time base).  ``NAV-TIMEGPS`` (GPS week, leap seconds GPS - UTC) is reported in
``quality["gps_week"]``, ``quality["leap_seconds"]``: UTC = 1980-01-06 + week x 604800 s
+ time of week - leap seconds, which is how ``time="utc"`` and ``time="week"`` agree.

Dead-reckoning modules (ZED-F9R/F9K, NEO-M8U/M8L) log their inertial sensors
(:func:`read_ubx_imu`, :func:`read_ubx_odometer`).  The data fields are 24 bits, typed
by ``dataType`` (u-blox integration manuals, "sensor data types"; pyubx2's ``ESF-RAW`` and
``ESF-MEAS`` definitions): 14, 13, 5 the x, y, z gyro [deg/s x 2^-12, signed], 16, 17, 18
the x, y, z accelerometer [m/s^2 x 2^-10, signed], 12 the gyro temperature [deg C x 1e-2,
signed], 6-9 the front-left, front-right, rear-left, rear-right wheel ticks and 10 a
single tick (bits 0-22 an unsigned accumulated count, bit 23 the direction, 1 backward),
11 the speed [m/s x 1e-3, signed].

* Axes: the raw sensor data are in the IMU frame, before u-blox's IMU-mount alignment
  (``CFG-SFIMU-IMU_MNTALG_*``, ``ESF-ALG``) turns them into its vehicle frame (x forward,
  y right, z down).  Read as FRD by default (a module mounted level with its x axis to
  the front: the installation frame with zero IMU-mount angles); ``mounting`` states
  another (axis letters or ``{euler_deg: [pitch, roll, heading]}``).
* Time: each ``ESF-RAW`` sample carries the sensor time tag ``sTtag``; ``ESF-MEAS``
  carries the sensor time tag ``timeTag`` with the receiver's local time ``calibTtag``
  [ms], and ``NAV-STATUS`` the receiver's local time ``msss`` [ms since start-up] with the
  GPS time of week ``iTOW``.  The sensor time tags are mapped to the receiver's local
  time by a straight-line fit of ``calibTtag`` on ``timeTag`` (ESF-MEAS), then to GPS
  time by ``iTOW - msss`` (NAV-STATUS, interpolated): the two messages that carry both
  clocks.  A log without them (or whose ``sTtag`` do not count the ESF-MEAS clock) gives
  the sensor's own time (the tag times ``ttag_s``, default 1 ms: u-blox's default
  time-tag resolution, ``CFG-SFCORE-SEN_TTAG_FACT``), with a warning.
"""

from __future__ import annotations

import calendar
import struct
import warnings
from pathlib import Path

import numpy as np

from ..core import units
from .data import DataError, GnssData, ImuData, import_for, require_file
from .navego import FRD_TO_RFU
from .sensorfile import SensorData

#: NAV-PVT fix types and carrier solutions.
FIX_TYPE = {0: "no_fix", 1: "dead_reckoning", 2: "2d", 3: "3d", 4: "gnss_dr", 5: "time_only"}
CARRIER = {0: "none", 1: "float", 2: "fixed"}

#: GPS time's origin, 1980-01-06 00:00:00 UTC, in seconds since 1970-01-01 UTC; a week [s].
GPS_EPOCH_UNIX = 315964800
WEEK_S = 604800
#: ESF data types: gyro x, y, z [deg/s x 2^-12], accelerometer x, y, z [m/s^2 x 2^-10],
#: gyro temperature [deg C x 1e-2], wheel ticks, speed [m/s x 1e-3].
ESF_GYRO = (14, 13, 5)
ESF_ACCEL = (16, 17, 18)
ESF_TEMPERATURE = 12
ESF_TICKS = {6: "front-left", 7: "front-right", 8: "rear-left", 9: "rear-right",
             10: "single tick"}
ESF_SPEED = 11
GYRO_LSB_DEG_S = 2.0**-12
ACCEL_LSB_MPS2 = 2.0**-10
TEMPERATURE_LSB_C = 1e-2
SPEED_LSB_MPS = 1e-3
#: The sensor time tag's unit assumed when nothing in the log gives it [s] (u-blox's
#: default time-tag resolution, CFG-SFCORE-SEN_TTAG_FACT = 1000 us).
DEFAULT_TTAG_S = 1e-3
_TIMES = ("week", "utc", "sensor")


def _signed24(v):
    """24-bit two's complement fields as signed integers."""
    v = np.asarray(v, dtype=np.int64)
    return np.where(v & 0x800000, v - (1 << 24), v)


def _unwrap(tag) -> np.ndarray:
    """Time tags that wrap (24 or 32 bits) made increasing across a wrap."""
    tag = np.asarray(tag, dtype=np.int64)
    if len(tag) < 2:
        return tag
    mod = 1 << 24 if tag.max() < (1 << 24) else 1 << 32
    back = np.diff(tag) < -(mod // 2)
    return tag + mod * np.r_[0, np.cumsum(back)]


class _UbxLog:
    """One pass over a UBX log: the raw ESF samples, the clocks' pairs, NAV-TIMEGPS."""

    def __init__(self, path: Path):
        pyubx2 = import_for(path, "pyubx2", "UBX")
        self.src = str(path)
        self.raw: list[tuple[int, int, int]] = []        # (sTtag, dataType, field)
        self.meas: list[tuple[int, int, int, int]] = []  # (timeTag, calibTtag|-1, type, field)
        self.status: list[tuple[int, int]] = []          # (iTOW, msss) [ms]
        self.timegps: list[tuple[int, int, int]] = []    # (iTOW [ms], week, leapS)
        self.counts = {"ESF-RAW": 0, "ESF-MEAS": 0, "NAV-STATUS": 0, "NAV-TIMEGPS": 0,
                       "other_messages": 0, "errors": 0}
        with path.open("rb") as f:
            reader = pyubx2.UBXReader(f, protfilter=pyubx2.UBX_PROTOCOL, quitonerror=1,
                                      errorhandler=self._error)
            for _, m in reader:
                name = getattr(m, "identity", "")
                if name in self.counts:
                    self.counts[name] += 1
                    getattr(self, "_" + name.replace("-", "_").lower())(m)
                else:
                    self.counts["other_messages"] += 1

    def _error(self, e) -> None:
        self.counts["errors"] += 1

    def _esf_raw(self, m) -> None:
        pl = m.payload
        for k in range(4, len(pl) - 7, 8):  # (4 reserved bytes, then data U4, sTtag U4)
            data, tag = struct.unpack_from("<II", pl, k)
            self.raw.append((tag, data >> 24, data & 0xFFFFFF))

    def _esf_meas(self, m) -> None:
        pl = m.payload
        if len(pl) < 8:
            return
        tag, flags = struct.unpack_from("<IH", pl, 0)
        n = (flags >> 11) & 0x1F
        n = min(n, (len(pl) - 8) // 4)
        calib = -1
        if flags & 0x8 and len(pl) >= 8 + 4 * n + 4:  # calibTtagValid: receiver time [ms]
            calib = struct.unpack_from("<I", pl, 8 + 4 * n)[0]
        for k in range(n):
            data = struct.unpack_from("<I", pl, 8 + 4 * k)[0]
            self.meas.append((tag, calib, (data >> 24) & 0x3F, data & 0xFFFFFF))

    def _nav_status(self, m) -> None:
        if m.towSet:
            self.status.append((int(m.iTOW), int(m.msss)))

    def _nav_timegps(self, m) -> None:
        if m.towValid and m.weekValid and m.leapSValid:
            self.timegps.append((int(m.iTOW), int(m.week), int(m.leapS)))


def _week_and_leap(timegps: list, quality: dict):
    """(GPS week, leap seconds, its iTOW [ms]) of the log's first valid NAV-TIMEGPS, into
    ``quality``; Nones without one."""
    if not timegps:
        return None, None, None
    itow, week, leap = timegps[0]
    quality["gps_week"] = week
    quality["leap_seconds"] = leap
    if len({lp for _, _, lp in timegps}) > 1:
        quality["leap_seconds_changed"] = 1
    return week, leap, itow


class _Clock:
    """Sensor time tags -> GPS time of week [s] (module docstring), or None."""

    def __init__(self, log: _UbxLog):
        self.how = None
        st = np.array(log.status, dtype=np.int64).reshape(-1, 2)
        pairs = np.array([(t, c) for t, c, _, _ in log.meas if c >= 0],
                         dtype=np.int64).reshape(-1, 2)
        self.why = ("no NAV-STATUS with a set time of week" if not len(st) else
                    "no ESF-MEAS with a receiver time tag (calibTtag)" if not len(pairs)
                    else None)
        if self.why:
            return
        # GPS time of week continues across week rollovers within the log
        itow = st[:, 0].astype(float)
        itow += WEEK_S * 1e3 * np.r_[0, np.cumsum(np.diff(itow) < -WEEK_S * 500.0)]
        order = np.argsort(st[:, 1], kind="stable")
        self.msss, self.offset = st[order, 1].astype(float), (itow - st[:, 1])[order]
        self.itow0 = float(itow[0])
        tag = _unwrap(pairs[:, 0]).astype(float)
        calib = _unwrap(pairs[:, 1]).astype(float)
        if np.ptp(tag) > 0:
            self.scale, self.zero = np.polyfit(tag - tag[0], calib, 1)
        else:
            self.scale, self.zero = 1.0, float(np.median(calib - tag[0]))
        self.tag0, self.tag_range = tag[0], (tag.min(), tag.max())
        self.how = ("sensor time tag -> receiver time: ESF-MEAS timeTag/calibTtag "
                    f"({len(pairs)} pairs, {self.scale:.6g} ms per tick); receiver time -> "
                    f"GPS time of week: NAV-STATUS msss/iTOW ({len(st)} epochs)")

    def covers(self, tag: np.ndarray) -> bool:
        """Whether ``tag`` lies in the span the ESF-MEAS time tags cover (a tenth of it
        either side): the same sensor clock."""
        lo, hi = self.tag_range
        pad = 0.1 * (hi - lo) + 1000.0 / max(self.scale, 1e-9)
        return bool(np.all((tag >= lo - pad) & (tag <= hi + pad)))

    def gps_tow(self, tag: np.ndarray) -> np.ndarray:
        """GPS time of week [s] of sensor time tags ``tag`` (unwrapped)."""
        ms = self.zero + self.scale * (tag - self.tag0)
        return (ms + np.interp(ms, self.msss, self.offset)) * 1e-3

    def receiver_tow(self, ms: np.ndarray) -> np.ndarray:
        """GPS time of week [s] of receiver times ``ms`` (calibTtag)."""
        ms = np.asarray(ms, dtype=float)
        return (ms + np.interp(ms, self.msss, self.offset)) * 1e-3


def _times(src: str, what: str, time: str, clock: _Clock, tag: np.ndarray, ttag_s,
           gps_time: tuple, quality: dict, receiver_ms=None) -> np.ndarray:
    """The ``time`` base's times [s] of sensor time tags ``tag`` (or of receiver times
    ``receiver_ms``), with a warning when the GPS time cannot be had; ``gps_time``:
    NAV-TIMEGPS's (week, leap seconds, iTOW [ms])."""
    week, leap, itow_tg = gps_time
    if time == "utc" and week is None:
        raise DataError(f"{src}: time='utc' needs NAV-TIMEGPS with a valid week and leap "
                        f"seconds (none in the log); use time='week' or 'sensor'")
    why = None
    if time != "sensor":
        if clock.how is None:
            why = clock.why
        elif receiver_ms is None and not clock.covers(tag):
            why = "its sensor time tags do not count the ESF-MEAS clock"
    if time == "sensor" or why:
        unit = DEFAULT_TTAG_S if ttag_s is None else float(ttag_s)
        quality[f"{what}_time_base"] = "sensor"
        if why:
            warnings.warn(f"{src}: {what} times are the sensor's time tags x {unit:g} s "
                          f"({'assumed: ' if ttag_s is None else ''}ttag_s), not GPS time: "
                          f"{why}", stacklevel=3)
        return tag * unit
    quality[f"{what}_time_base"] = "gps"
    quality[f"{what}_time_mapping"] = clock.how
    tow = clock.receiver_tow(receiver_ms) if receiver_ms is not None else clock.gps_tow(tag)
    if time == "utc":
        # (the times of week count from the first NAV-STATUS's week: a rollover between
        # it and the NAV-TIMEGPS read puts that one in the next week)
        week0 = week - (1 if clock.itow0 - itow_tg > 1e3 * WEEK_S / 2 else 0)
        return GPS_EPOCH_UNIX + WEEK_S * week0 + tow - leap
    return tow


def _check_time(src: str, time: str) -> None:
    if time not in _TIMES:
        raise DataError(f"{src}: time must be 'week', 'utc' or 'sensor', got '{time}'")


def read_ubx_imu(path, *, max_bridge_s: float = 0.1, mounting=None, time: str = "week",
                 ttag_s: float | None = None) -> ImuData:
    """The IMU of a u-blox dead-reckoning module from the ``ESF-RAW`` messages of a UBX
    log (module docstring: data types, axes, time).

    Parameters
    ----------
    path : str or Path
        The binary log (``.ubx``).
    max_bridge_s : float
        The longest run of faulty samples bridged [s] (:class:`~fednav.io.ImuData`).
    mounting : str or dict, optional
        The IMU frame in the body when it is not FRD (u-blox's vehicle frame), e.g. the
        IMU-mount angles of ``ESF-ALG`` as ``{euler_deg: [pitch, roll, heading]}``.
    time : {"week", "utc", "sensor"}
        GPS time of week [s] (as ``read_ubx(time="week")``), seconds since 1970-01-01 UTC
        (as ``read_ubx()``: needs ``NAV-TIMEGPS``), or the sensor's own time tags [s].
    ttag_s : float, optional
        The sensor time tag's unit [s] when the log cannot map it to GPS time (default 1
        ms, :data:`DEFAULT_TTAG_S`).

    Returns
    -------
    ImuData
        Rates [rad/s] and specific force [m/s^2], body right-forward-up, at the samples'
        times; ``quality``: ``imu_time_base`` ('gps' or 'sensor') and
        ``imu_time_mapping`` (the messages used), ``imu_rate_hz``,
        ``imu_samples_incomplete`` (sensor times missing one of the six axes: dropped),
        ``imu_temperature_c`` (median of type 12), ``gps_week``, ``leap_seconds``
        (NAV-TIMEGPS), ``ubx_messages`` (counts) and ImuData's checks.

    Raises
    ------
    DataError
        One line: no ``ESF-RAW`` message (naming the message class), no complete sample,
        ``time='utc'`` without ``NAV-TIMEGPS``.
    """
    path = Path(path)
    require_file(path, "UBX log")
    src = str(path)
    _check_time(src, time)
    log = _UbxLog(path)
    if not log.raw:
        raise DataError(f"{src}: no ESF-RAW message (UBX class ESF 0x10, id 0x03: the "
                        f"module's raw IMU data; enable CFG-MSGOUT-UBX_ESF_RAW) "
                        f"(messages: {log.counts})")
    a = np.array(log.raw, dtype=np.int64)
    tag = _unwrap(a[:, 0])
    kinds = ESF_GYRO + ESF_ACCEL
    times = np.unique(tag)
    vals = np.full((len(times), 6), np.nan)
    idx = np.searchsorted(times, tag)
    for j, k in enumerate(kinds):
        m = a[:, 1] == k
        vals[idx[m], j] = _signed24(a[m, 2])
    complete = np.isfinite(vals).all(axis=1)
    if complete.sum() < 2:
        raise DataError(f"{src}: ESF-RAW has {int(complete.sum())} complete samples (gyro "
                        f"types 14, 13, 5 and accelerometer 16, 17, 18 at one sensor time)")
    quality: dict = {"imu_samples_incomplete": int((~complete).sum()),
                     "ubx_messages": dict(log.counts)}
    gps_time = _week_and_leap(log.timegps, quality)
    temp = a[a[:, 1] == ESF_TEMPERATURE, 2]
    if len(temp):
        quality["imu_temperature_c"] = float(np.median(_signed24(temp)) * TEMPERATURE_LSB_C)
    clock = _Clock(log)
    t = _times(src, "imu", time, clock, times[complete].astype(float), ttag_s, gps_time,
               quality)
    gyro = units.deg(vals[complete, :3] * GYRO_LSB_DEG_S)
    accel = vals[complete, 3:] * ACCEL_LSB_MPS2
    imu = ImuData(f"{src}:ESF-RAW", t, gyro @ FRD_TO_RFU.T, accel @ FRD_TO_RFU.T,
                  max_bridge_s=max_bridge_s)
    imu.quality.update(quality)
    imu.quality["imu_rate_hz"] = round(1.0 / imu.period(), 6)
    imu.mounting, imu.mounting_name = FRD_TO_RFU, "FRD"
    if mounting is not None:
        imu = imu.remount(mounting)
    return imu


def read_ubx_odometer(path, *, time: str = "week", tick_m: float | None = None,
                      ttag_s: float | None = None) -> SensorData:
    """The forward speed of a u-blox dead-reckoning log's wheel data (``ESF-MEAS``) as the
    ``odometer`` series (module docstring: data types, time).

    The speed (type 11, m/s, signed: backward negative) where the log has it; otherwise
    wheel ticks turned into speed with ``tick_m`` (metres per tick): the single tick
    (type 10), else the rear wheels' mean (8, 9: the rear axle's middle), else the front
    wheels' (6, 7); each count's change over the interval since the one before (bit 23:
    backward), stamped at the interval's middle.  ESF-MEAS times: ``calibTtag`` mapped to
    GPS time by NAV-STATUS where the log has both, else ``timeTag`` x ``ttag_s`` with a
    warning.

    Returns
    -------
    SensorData
        ``odometer``: ``z`` (N, 1) forward speed [m/s] (its noise is the system
        description's ``sensors.odometer.sigma_mps``); ``quality``: ``odometer_source``
        ('speed' or the wheels), ``odometer_time_base``, ``odometer_rows``.

    Raises
    ------
    DataError
        One line: no ESF-MEAS speed or wheel ticks, ticks without ``tick_m``.
    """
    path = Path(path)
    require_file(path, "UBX log")
    src = str(path)
    _check_time(src, time)
    log = _UbxLog(path)
    quality: dict = {}
    gps_time = _week_and_leap(log.timegps, quality)
    m = np.array(log.meas, dtype=np.int64).reshape(-1, 4)
    types = set(m[:, 2].tolist()) if len(m) else set()
    clock = _Clock(log)

    def stamped(rows):
        tag = _unwrap(rows[:, 0]).astype(float)
        calib = rows[:, 1]
        rec = _unwrap(calib).astype(float) if np.all(calib >= 0) else None
        return _times(src, "odometer", time, clock, tag, ttag_s, gps_time, quality,
                      receiver_ms=rec if clock.how is not None else None)

    if ESF_SPEED in types:
        rows = m[m[:, 2] == ESF_SPEED]
        t, v = stamped(rows), _signed24(rows[:, 3]) * SPEED_LSB_MPS
        quality["odometer_source"] = "speed"
        if types & set(ESF_TICKS):
            warnings.warn(f"{src}: wheel ticks in ESF-MEAS not used (the speed, type 11, is)",
                          stacklevel=2)
    else:
        ticks = [k for k in (10, 8, 9, 6, 7) if k in types]
        if not ticks:
            raise DataError(f"{src}: no ESF-MEAS speed or wheel ticks (data types 6-11) "
                            f"(messages: {log.counts})")
        if tick_m is None:
            raise DataError(f"{src}: ESF-MEAS has wheel ticks "
                            f"({', '.join(ESF_TICKS[k] for k in ticks)}) but no speed: "
                            f"give tick_m, the distance per tick [m] (u-blox: "
                            f"CFG-SFODO-FACTOR)")
        use = [10] if 10 in ticks else [8, 9] if {8, 9} <= types else [6, 7] \
            if {6, 7} <= types else ticks[:1]
        per = []
        for k in use:
            rows = m[m[:, 2] == k]
            t_k = stamped(rows)
            count = rows[:, 3] & 0x7FFFFF
            d = np.diff(count) % (1 << 23)  # (an accumulated count wraps at 23 bits)
            sign = np.where(rows[1:, 3] & 0x800000, -1.0, 1.0)
            dt = np.diff(t_k)
            ok = dt > 0
            per.append((0.5 * (t_k[1:] + t_k[:-1])[ok], (sign * d * tick_m)[ok] / dt[ok]))
        t = per[0][0]
        v = np.mean([np.interp(t, tk, vk) for tk, vk in per], axis=0)
        quality["odometer_source"] = " + ".join(ESF_TICKS[k] for k in use) + " ticks"
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    keep = np.r_[True, np.diff(t) > 0]
    quality["odometer_rows"] = int(keep.sum())
    return SensorData("odometer", f"{src}:ESF-MEAS", t[keep], v[keep, None],
                      quality=quality)


def read_ubx(path, *, time: str = "utc", lever=(0.0, 0.0, 0.0)) -> GnssData:
    """Read the ``NAV-PVT`` fixes of a u-blox UBX log (module docstring).

    Parameters
    ----------
    path : str or Path
        The binary log (``.ubx``).
    time : {"utc", "week"}
        The time base of ``t``: seconds since 1970-01-01 UTC, or the GPS time of week.
    lever : sequence of float
        The antenna lever arm, body right-forward-up [m].

    Returns
    -------
    GnssData
        ``t`` [s], lat/lon [rad], h above the ellipsoid [m], ENU velocity [m/s], each fix's
        1-sigma from its accuracy estimates; ``quality`` counts the fixes by fix type and
        carrier solution and what was left out, and gives ``gps_week`` and
        ``leap_seconds`` when the log has ``NAV-TIMEGPS`` (``utc_from_week``: fixes
        whose UTC came from them).

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    pyubx2 = import_for(path, "pyubx2", "UBX")
    path = Path(path)
    require_file(path, "UBX log")
    src = str(path)
    if time not in ("utc", "week"):
        raise DataError(f"{src}: time must be 'utc' or 'week', got '{time}'")
    rows, keys, left = [], [], {"not_3d_or_no_fix_ok": 0, "no_valid_utc": 0,
                                "other_messages": 0, "errors": 0}
    timegps = []
    with path.open("rb") as f:
        reader = pyubx2.UBXReader(f, protfilter=pyubx2.UBX_PROTOCOL, quitonerror=1,
                           errorhandler=lambda e: left.__setitem__("errors",
                                                                   left["errors"] + 1))
        for _, m in reader:
            name = getattr(m, "identity", "") if m is not None else ""
            if name == "NAV-TIMEGPS":
                if m.towValid and m.weekValid and m.leapSValid:
                    timegps.append((int(m.iTOW), int(m.week), int(m.leapS)))
                continue
            if name != "NAV-PVT":
                left["other_messages"] += 1
                continue
            if not m.gnssFixOk or m.fixType not in (3, 4):
                left["not_3d_or_no_fix_ok"] += 1
                continue
            utc = np.nan  # (from NAV-TIMEGPS at the end, if the log has it)
            if m.validDate and m.validTime:
                utc = calendar.timegm((m.year, m.month, m.day, m.hour, m.min, m.second)) \
                    + m.nano * 1e-9
            rows.append((utc, m.lat, m.lon, m.height * 1e-3, m.velE * 1e-3, m.velN * 1e-3,
                         -m.velD * 1e-3, m.hAcc * 1e-3, m.vAcc * 1e-3, m.sAcc * 1e-3,
                         m.iTOW * 1e-3))
            keys.append(f"{FIX_TYPE.get(m.fixType, m.fixType)}/"
                        f"{CARRIER.get(m.carrSoln, m.carrSoln)}")
    quality: dict = {}
    week, leap, _ = _week_and_leap(timegps, quality)
    if rows and time == "utc":
        a = np.array(rows, dtype=float)
        bad = ~np.isfinite(a[:, 0])
        if bad.any() and week is not None:
            # UTC = GPS epoch + week + time of week - leap seconds (a week rollover
            # between a fix and the NAV-TIMEGPS read: the fix's own week)
            w = week - (a[bad, 10] > timegps[0][0] * 1e-3 + WEEK_S / 2) \
                + (a[bad, 10] < timegps[0][0] * 1e-3 - WEEK_S / 2)
            a[bad, 0] = GPS_EPOCH_UNIX + WEEK_S * w + a[bad, 10] - leap
            quality["utc_from_week"] = int(bad.sum())
            bad[:] = False
        left["no_valid_utc"] = int(bad.sum())
        rows = list(a[~bad])
        keys = [k for k, b in zip(keys, bad, strict=True) if not b]
    if not rows:
        raise DataError(f"{src}: no NAV-PVT message with a 3-D fix (what was left out: "
                        f"{left})")
    kinds: dict = {}
    for k in keys:
        kinds[k] = kinds.get(k, 0) + 1
    a = np.array(rows, dtype=float)
    if time == "week":
        a[:, 0] = a[:, 10]
    order = np.argsort(a[:, 0], kind="stable")
    a = a[order]
    dup = np.r_[False, np.diff(a[:, 0]) <= 0]  # (a repeated epoch: the first kept)
    left["repeated_epochs"] = int(dup.sum())
    a = a[~dup]
    h, v, s = a[:, 7], a[:, 8], a[:, 9]
    sig = np.column_stack([h, h, v, s, s, s])  # north, east, up [m], vE, vN, vU [m/s]
    sig = np.maximum(sig, 1e-3)  # (an accuracy estimate of 0: a millimetre, mm/s)
    lla = np.column_stack([units.deg(a[:, 1]), units.deg(a[:, 2]), a[:, 3]])
    out = GnssData(src, a[:, 0], lla, a[:, 4:7], np.full(3, 5.0), np.full(3, 0.1),
                   np.asarray(lever, dtype=float), sigma_rows=sig)
    out.quality.update({"gnss_ubx_fixes": kinds, "gnss_ubx_left_out": left, **quality})
    return out
