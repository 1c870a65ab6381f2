"""Containers for real sensor data in fednav's frames and units, with their checks.

Frames: body right-forward-up, navigation ENU; positions geodetic ``[lat, lon, h]``
[rad, rad, m]; Euler ``[pitch, roll, heading]`` [rad] (``docs/conventions.md``).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from ..core.errors import DataError, FednavError  # noqa: F401  (fednav.io.data's name)
from ..sensors.gnss import reads_old_sigma_pos


def require_file(path: Path, kind: str) -> None:
    """A one-line :class:`DataError` unless ``path`` is an existing file."""
    if not path.is_file():
        raise DataError(f"{kind} file {path}: "
                        f"{'is a folder, not a file' if path.is_dir() else 'not found'}")


def file_bytes(path: Path) -> np.ndarray:
    """The bytes of the file ``path`` (uint8), mapped read-only: no copy, the pages read
    as they are touched (a fresh 50 MB copy costs 10-100 ms of page faults alone)."""
    if Path(path).stat().st_size == 0:
        return np.zeros(0, np.uint8)
    try:
        return np.asarray(np.memmap(path, np.uint8, mode="r"))
    except (OSError, ValueError):  # (a file system that cannot map files: read it)
        return np.fromfile(path, np.uint8)


def import_for(path, module: str, what: str, extra: str = "formats"):
    """``module`` imported to read ``path`` (a ``what`` file), or a one-line
    :class:`DataError` naming the extra of fednav that installs it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise DataError(f"{path}: reading {what} needs {module}: pip install "
                        f"'fednav[{extra}]'") from None


def check_array(source: str, field: str, a, shape: tuple) -> np.ndarray:
    """``a`` as a float array of ``shape`` (``-1`` = any length), finite, else DataError."""
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{source}: field '{field}' is not numeric") from None
    if arr.ndim == 1 and len(shape) == 2 and shape[1] == 1:
        arr = arr[:, None]
    if arr.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, arr.shape,
                                                                       strict=True)):
        want = "x".join("N" if s == -1 else str(s) for s in shape)
        raise DataError(f"{source}: field '{field}' has shape "
                        f"{'x'.join(map(str, arr.shape)) or 'scalar'}, expected {want}")
    bad = ~np.isfinite(arr)
    if bad.any():
        row = int(np.argwhere(bad)[0][0]) if arr.ndim else 0
        raise DataError(f"{source}: field '{field}' has NaN/inf values (first at row {row})")
    return arr


def check_time(source: str, t, field: str = "t") -> np.ndarray:
    """Strictly increasing finite time vector [s], else DataError naming the first bad row."""
    t = check_array(source, field, t, (-1,))
    if len(t) < 2:
        raise DataError(f"{source}: field '{field}' needs at least 2 samples, got {len(t)}")
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0)) + 1
        raise DataError(f"{source}: field '{field}' is not increasing at row {i} "
                        f"({t[i - 1]:.6f} s then {t[i]:.6f} s)")
    return t


#: Magnitudes no IMU reports: samples beyond them are faulty (bridged like NaN).
ABSURD_GYRO_RADPS = 100.0       # ~5 700 deg/s
ABSURD_ACCEL_MPS2 = 2000.0      # ~200 g
#: GNSS fixes beyond these fail the basic sanity check (skipped and counted).
ABSURD_HEIGHT_M = 1.0e6
ABSURD_SPEED_MPS = 1.0e4


def _as_float(source: str, field: str, a, shape: tuple) -> np.ndarray:
    """``a`` as a float array of ``shape`` (NaN allowed: screened by the caller)."""
    try:
        arr = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise DataError(f"{source}: field '{field}' is not numeric") from None
    if arr.ndim == 1 and len(shape) == 2:
        arr = arr.reshape(-1, shape[1]) if arr.size == shape[1] else arr
    if arr.ndim != len(shape) or any(s not in (-1, n) for s, n in zip(shape, arr.shape,
                                                                       strict=True)):
        want = "x".join("N" if s == -1 else str(s) for s in shape)
        raise DataError(f"{source}: field '{field}' has shape "
                        f"{'x'.join(map(str, arr.shape)) or 'scalar'}, expected {want}")
    return arr


def bridge_imu(source: str, t, gyro, accel, max_bridge_s: float):
    """Hold the last good IMU sample over faulty ones (NaN, inf or absurd magnitude).

    A run of faulty samples longer than ``max_bridge_s`` seconds is a DataError naming
    its time span.  Returns (gyro, accel, number of samples bridged)."""
    bad = (~np.isfinite(gyro).all(axis=1) | ~np.isfinite(accel).all(axis=1))
    with np.errstate(invalid="ignore"):
        bad |= (np.abs(gyro) > ABSURD_GYRO_RADPS).any(axis=1)
        bad |= (np.abs(accel) > ABSURD_ACCEL_MPS2).any(axis=1)
    n = int(bad.sum())
    if n == 0:
        return gyro, accel, 0
    if n == len(t):
        raise DataError(f"{source}: every IMU sample is NaN/inf or absurd (|gyro| > "
                        f"{ABSURD_GYRO_RADPS:g} rad/s or |accel| > {ABSURD_ACCEL_MPS2:g} m/s^2)")
    # runs of faulty samples: [start, stop)
    edges = np.diff(np.r_[0, bad.astype(np.int8), 0])
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    span = t[stops - 1] - t[starts] + dt
    worst = int(np.argmax(span))
    if span[worst] > max_bridge_s + 1e-9:
        i, j = starts[worst], stops[worst] - 1
        raise DataError(f"{source}: {j - i + 1} faulty IMU samples in a row (NaN/inf or "
                        f"absurd) from t = {t[i]:.6f} s to {t[j]:.6f} s: {span[worst]:.3f} s, "
                        f"more than imu_max_bridge_s = {max_bridge_s:g} s")
    good = np.where(~bad, np.arange(len(t)), -1)
    last = np.maximum.accumulate(good)
    first_good = int(np.argmax(~bad))
    last[last < 0] = first_good  # leading faulty samples take the first good one
    return gyro[last], accel[last], n


def screen_rows(source: str, what: str, t, arrays: dict, extra_bad=None):
    """Rows of a measurement stream that are usable: finite time and values (and not
    ``extra_bad``).  Returns (keep mask, number skipped); DataError if none is left."""
    keep = np.isfinite(t)
    for a in arrays.values():
        if a is not None:
            keep &= np.isfinite(a.reshape(len(t), -1)).all(axis=1)
    if extra_bad is not None:
        keep &= ~extra_bad
    if not keep.any():
        raise DataError(f"{source}: no usable {what} row (all have NaN/inf or fail the "
                        f"sanity checks)")
    return keep, int((~keep).sum())


def check_rows(source: str, n: int, **fields) -> None:
    """Every field has ``n`` rows (the length of the time vector)."""
    for name, a in fields.items():
        if a is not None and len(a) != n:
            raise DataError(f"{source}: field '{name}' has {len(a)} rows but 't' has {n}")


#: Sampling intervals within this fraction of the median are uniform (taken as they are:
#: time stamps rounded to 1 us at 300 Hz differ by 3e-4).
UNIFORM_TOLERANCE = 1e-3


def lost_records(d: np.ndarray, dt: float, dv: np.ndarray) -> np.ndarray:
    """Which increments follow lost records (bool, (N,)): of the intervals ``d`` [s]
    longer than 1.5 median intervals ``dt``, those whose velocity increment ``dv``
    [m/s] (N, 3) is the size of one median interval's rather than of its own interval.
    The specific force's magnitude (near g for anything on or over the Earth, and
    smooth) is the local median of ``|dv| / d`` over 21 rows; an increment over ``T``
    seconds is ``|f| T`` long.  (In free fall or in orbit ``|f|`` is noise and the choice
    is a guess: such data should not jitter.)  Jittered stamps whose increments cover their own
    intervals (intervals 4..16 ms at 100 Hz) are then not read as lost records."""
    long = d > 1.5 * dt
    if not long.any():
        return long
    from scipy.ndimage import median_filter

    mag = np.linalg.norm(dv, axis=1)
    f = median_filter(mag / np.maximum(d, 1e-12), size=21, mode="nearest")
    cover = mag / np.maximum(f, 1e-12)  # the time the increment covers [s]
    return long & (np.abs(cover - dt) < np.abs(cover - d))


def regular_imu(source: str, t, gyro, accel, max_gap_s: float):
    """IMU samples on a uniform grid, from samples whose time stamps jitter or miss.

    Sample ``i``'s rates hold over its own interval ``[t_i, t_(i+1)]`` (the last one's: the
    median interval ``dt``); the integrated rotation and velocity increments are
    interpolated linearly at ``t_0 + k dt`` and differenced, so every increment of the
    recording is kept (nothing is dropped or counted twice), and a missing sample is
    bridged by its neighbours' rates.  A gap longer than ``max_gap_s`` plus ``dt`` is a
    :class:`DataError` naming where.  Uniform sampling (within
    :data:`UNIFORM_TOLERANCE`) is returned unchanged.

    Returns (t, gyro, accel, quality); when it resampled, quality says so:
    ``imu_resampled`` 1, ``imu_samples_missing`` (intervals longer than 1.5 ``dt``, in
    samples), ``imu_jitter_s`` (largest departure of an interval from ``dt``)."""
    d = np.diff(t)
    dt = float(np.median(d))
    dev = np.abs(d - dt)
    if not len(d) or dev.max() <= UNIFORM_TOLERANCE * dt:
        return t, gyro, accel, {}
    quality = {"imu_resampled": 1, "imu_samples_missing": 0, "imu_jitter_s": float(dev.max())}
    gap = d > max_gap_s + dt
    if gap.any():
        i = int(np.argmax(gap))
        raise DataError(f"{source}: IMU sampling has a gap of {d[i]:.6f} s between t = "
                        f"{t[i]:.6f} s and {t[i + 1]:.6f} s (median interval {dt:.6f} s; "
                        f"gaps up to imu.max_bridge_s = {max_gap_s:g} s are bridged)")
    long = d > 1.5 * dt
    quality["imu_samples_missing"] = int(np.sum(np.rint(d[long] / dt) - 1))
    dur = np.r_[d, dt]
    nodes = np.r_[t, t[-1] + dt]
    n = int(np.floor((nodes[-1] - t[0]) / dt + 1e-9)) + 1
    grid = t[0] + dt * np.arange(n)
    out = []
    for rate in (gyro, accel):
        cum = np.vstack([np.zeros(3), np.cumsum(rate * dur[:, None], axis=0)])
        at = np.column_stack([np.interp(grid, nodes, cum[:, j]) for j in range(3)])
        out.append(np.diff(at, axis=0) / dt)
    return grid[:-1], out[0], out[1], quality


def height_offset_to_gnss(t: np.ndarray, h: np.ndarray, gnss) -> float:
    """The median of the GNSS's ellipsoidal heights minus heights ``h`` [m] (at times
    ``t`` [s], interpolated to the fixes inside their span): what moves a barometric
    altitude onto the GNSS's ellipsoidal height; NaN without GNSS heights over ``t``."""
    if gnss is None or gnss.lla is None or len(t) < 2:
        return float("nan")
    hb = np.interp(gnss.t, t, h, left=np.nan, right=np.nan)
    both = np.isfinite(hb)
    return float(np.median(gnss.lla[both, 2] - hb[both])) if both.any() else float("nan")


def check_arrival(source: str, t: np.ndarray, ta) -> np.ndarray | None:
    """Arrival times ``ta`` [s] of measurements valid at ``t`` (None: on time); a
    measurement arriving before the time it describes is a DataError naming it."""
    if ta is None:
        return None
    ta = check_array(source, "t_arrival", ta, (-1,))
    early = ta < t - 1e-9
    if early.any():
        i = int(np.argmax(early))
        raise DataError(f"{source}: row {i} arrives at {ta[i]:.6f} s, before the time it "
                        f"describes ({t[i]:.6f} s)")
    return ta


@dataclass
class ImuErrors:
    """IMU error figures (SI, per body axis, right-forward-up).

    ``gyro_arw`` [rad/sqrt(s)], ``accel_vrw`` [m/s/sqrt(s)]; turn-on biases ``gyro_bias``
    [rad/s] and ``accel_bias`` [m/s^2] (1-sigma of a constant bias); first-order
    Gauss–Markov bias instability ``gyro_markov`` [rad/s], ``accel_markov`` [m/s^2] with
    correlation times ``gyro_tau``, ``accel_tau`` [s].
    """

    gyro_arw: np.ndarray
    accel_vrw: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    gyro_markov: np.ndarray
    accel_markov: np.ndarray
    gyro_tau: np.ndarray
    accel_tau: np.ndarray


@dataclass
class ImuData:
    """IMU samples: ``t`` (N,) [s], ``gyro`` (N, 3) angular rate [rad/s] and ``accel``
    (N, 3) specific force [m/s^2] in body right-forward-up axes; optional error figures,
    initial Euler ``[pitch, roll, heading]`` [rad] and its 1-sigma [rad]."""

    source: str
    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    errors: ImuErrors | None = None
    initial_euler: np.ndarray | None = None
    initial_euler_sigma: np.ndarray | None = None
    #: longest run of faulty samples (NaN/inf/absurd) bridged by holding the last good
    #: sample, and longest gap in the time stamps bridged by the neighbours' rates [s];
    #: longer ones are a DataError naming their time
    max_bridge_s: float = 0.1
    #: what the checks did: {"imu_samples_bridged": n} and, when the time stamps were
    #: not uniform, "imu_resampled", "imu_samples_missing", "imu_jitter_s"
    #: (:func:`regular_imu`)
    quality: dict = field(default_factory=dict)
    #: the file's own increments ``(dtheta [rad], dv [m/s])`` (N, 3) each, kept when the
    #: file held increments that needed no bridging or regridding: the navigator
    #: integrates them as they are (no rate round trip; a sigma-point filter with a
    #: small ``alpha`` magnifies even one-ulp differences)
    increments: tuple | None = None
    #: the mounting the reader applied, ``C_file^b`` (:mod:`fednav.core.mounting`): its
    #: format's axes (CSV right-forward-up, NaveGo and PX4 forward-right-down) or the
    #: ``imu.mounting`` it was given; :func:`remount` turns the data to another
    mounting: np.ndarray | None = None
    #: how that mounting was written (axis letters or ``{euler_deg: ...}``), for messages
    mounting_name: str = "RFU"

    def __post_init__(self):
        self.t = check_time(self.source, self.t)
        self.gyro = _as_float(self.source, "gyro", self.gyro, (-1, 3))
        self.accel = _as_float(self.source, "accel", self.accel, (-1, 3))
        check_rows(self.source, len(self.t), gyro=self.gyro, accel=self.accel)
        self.gyro, self.accel, n = bridge_imu(self.source, self.t, self.gyro, self.accel,
                                              self.max_bridge_s)
        self.quality["imu_samples_bridged"] = n
        self.t, self.gyro, self.accel, q = regular_imu(self.source, self.t, self.gyro,
                                                       self.accel, self.max_bridge_s)
        self.quality.update(q)
        if n or q:
            self.increments = None

    @classmethod
    def from_increments(cls, source: str, t_end, dtheta, dv, **kw) -> ImuData:
        """IMU data from increments ``dtheta`` [rad] and ``dv`` [m/s] (N, 3) over the
        intervals that end at ``t_end`` [s] (how loggers stamp them); the first
        interval is taken as long as the median one.  Each increment becomes a rate over
        its own interval, stamped at the interval's start (fednav's convention).  An
        interval longer than 1.5 median intervals is either jitter (the increment covers
        it) or lost records (the increment covers one median interval, and its rate
        bridges the lost ones): :func:`lost_records` tells them apart by the size of the
        velocity increment."""
        t_end = check_time(source, t_end)
        d = np.diff(t_end)
        dt = float(np.median(d)) if len(d) else 0.0
        d = np.r_[dt, d]
        dth = _as_float(source, "dtheta", dtheta, (-1, 3))
        dvv = _as_float(source, "dv", dv, (-1, 3))
        check_rows(source, len(t_end), dtheta=dth, dv=dvv)
        t_start = np.r_[t_end[0] - d[0], t_end[:-1]]
        lost = lost_records(d, dt, dvv)
        over = np.where(lost, dt, d)[:, None]  # the time each increment covers
        imu = cls(source, t_start, dth / over, dvv / over, increments=(dth, dvv), **kw)
        if "imu_samples_missing" in imu.quality:
            imu.quality["imu_samples_missing"] = int(np.sum(np.rint(d[lost] / dt) - 1))
        return imu

    def remount(self, mounting) -> ImuData:
        """These samples with the file's axes taken as ``mounting`` (axis letters such as
        ``FRD`` or ``{euler_deg: [pitch, roll, heading]}``, :mod:`fednav.core.mounting`)
        instead of the mounting the reader applied: rates, specific forces, increments
        and the per-axis error figures turned by ``C_new C_applied^T`` (a copy; the data
        themselves when nothing changes)."""
        from ..core import mounting as mt

        M_new = mt.parse(mounting)
        M_new = np.eye(3) if M_new is None else M_new
        M_old = np.eye(3) if self.mounting is None else self.mounting
        R = M_new @ M_old.T
        name = mounting if isinstance(mounting, str) else str(mounting)
        if mt.is_identity(R):
            out = copy.copy(self)
            out.mounting, out.mounting_name = M_new, name
            return out
        out = copy.copy(self)
        out.gyro, out.accel = mt.rotate_rows(self.gyro, R), mt.rotate_rows(self.accel, R)
        if self.increments is not None:
            out.increments = tuple(mt.rotate_rows(a, R) for a in self.increments)
        if self.errors is not None:  # per-axis figures: the variance carried to each axis
            # (a correlation time goes with the axis that contributes most)
            major = np.argmax(np.abs(R), axis=1)
            out.errors = ImuErrors(**{f: np.sqrt((R**2) @ np.asarray(v, dtype=float) ** 2)
                                      if "tau" not in f else np.asarray(v)[major]
                                      for f, v in vars(self.errors).items()})
        out.mounting, out.mounting_name = M_new, name
        out.quality = {**self.quality, "imu_mounting": name}
        return out

    def period(self) -> float:
        """The sampling period [s]: the mean interval (uniform: :func:`regular_imu` made it
        so; the mean carries the time stamps' full precision, one difference of two large
        stamps does not)."""
        return float((self.t[-1] - self.t[0]) / (len(self.t) - 1))


@runtime_checkable
class Series(Protocol):
    """What every sensor's recording is, whichever reader made it: the sensor's
    registered ``name``, its ``source`` (file and record), times of validity ``t`` (N,)
    [s], values ``z`` (N, m) in the sensor's SI layout (NaN in the ``absent``
    components), each row's 1-sigma ``sigma`` (N, m) [units of the sensor's series] or
    its covariance ``cov`` (N, m, m) or neither (the system description's figures),
    arrival times ``t_arrival`` (N,) [s] or None, and ``quality`` (what the reader did).
    :class:`SensorData` is the plain one; :class:`GnssData` and :class:`VelocityData`
    are the GNSS's and velocity sensor's with their own fields beside; a simulated
    sensor's :class:`~fednav.sensors.base.MeasurementSeries` is one too (one ``sigma``
    (m,) for every row).  :meth:`fednav.navigator.Navigator.add_series` takes any."""

    name: str
    source: str
    t: np.ndarray
    t_arrival: np.ndarray | None
    quality: dict

    @property
    def z(self) -> np.ndarray: ...

    @property
    def sigma(self) -> np.ndarray | None: ...

    @property
    def cov(self) -> np.ndarray | None: ...

    @property
    def absent(self) -> tuple[int, ...]: ...


@dataclass
class SensorData:
    """One sensor's recorded measurements: ``name`` (registered), ``source`` (the file),
    times of validity ``t`` (N,) [s], values ``z`` (N, m) in SI units (radians, metres,
    m/s) in the layout of the sensor's measurement model, each row's 1-sigma ``sigma``
    (N, m) in the units of the sensor's series (metres north/east for latitude and
    longitude, radians, m/s) or None (the system description's figure), arrival times
    ``t_arrival`` (N,) [s] or None, and what the reader found (``quality``: rows
    dropped).  The one series type every sensor's recording is (:class:`Series`)."""

    name: str
    source: str
    t: np.ndarray
    z: np.ndarray
    t_arrival: np.ndarray | None = None
    quality: dict = field(default_factory=dict)
    sigma: np.ndarray | None = None
    #: components of ``z`` the file does not have (optional columns; NaN in ``z``)
    absent: tuple[int, ...] = ()
    #: each row's covariance (N, m, m) instead of ``sigma``, for a sensor whose errors
    #: correlate between components (a velocity sensor's), in the units of ``sigma``
    #: squared; None: ``sigma``
    cov: np.ndarray | None = None

    def with_sigma(self, sigma) -> SensorData:
        """The recording with each row's 1-sigma ``sigma`` (N, m) [units of the series]."""
        return replace(self, sigma=sigma)

    def adjusted(self, section) -> SensorData:
        """The recording as its section corrects it: the section's ``time_offset_s`` [s]
        (where it has one: the raw GNSS's) added to the time stamps; more corrections (the
        GNSS's, the velocity sensor's) need a data class of their own
        (:data:`RECORDINGS`)."""
        dt = float(getattr(section, "time_offset_s", 0.0) or 0.0)
        if not dt:
            return self
        return replace(self, t=self.t + dt, t_arrival=_shifted(self.t_arrival, dt))


@reads_old_sigma_pos
@dataclass
class GnssData:
    """GNSS fixes: ``t`` (N,) [s], ``lla`` (N, 3) (or None for velocity-only data), ENU
    ``vel`` (N, 3) [m/s] (or None for position-only receivers), 1-sigma
    ``sigma_pos_enu`` (3,) [east, north, up] [m] and ``sigma_vel`` (3,) [east, north, up]
    [m/s], antenna ``lever`` arm (3,) from the IMU, body right-forward-up [m]; optionally
    each fix's own 1-sigma ``sigma_rows`` (N, 6) in the order of the fix's values
    ``[lat, lon, h, vE, vN, vU]``: [north, east, up m, vE, vN, vU m/s] (the file's).

    The old keyword ``sigma_pos`` ([north, east, up]) is read, reordered, with a
    ``FutureWarning`` for one more release; the attribute ``sigma_pos`` gives that
    order until then (:func:`fednav.sensors.gnss.reads_old_sigma_pos`)."""

    source: str
    t: np.ndarray
    lla: np.ndarray | None
    vel: np.ndarray | None
    sigma_pos_enu: np.ndarray
    sigma_vel: np.ndarray
    lever: np.ndarray
    #: what the checks did: {"gnss_epochs_skipped": n}
    quality: dict = field(default_factory=dict)
    sigma_rows: np.ndarray | None = None
    #: when each fix reached the navigator [s] (None: at its time of validity)
    t_arrival: np.ndarray | None = None
    #: its registered sensor (:class:`Series`): the GNSS, or another sensor whose
    #: fixes start a recording (``SensorSpec.fixes``)
    name: str = "gnss"

    def __post_init__(self):
        t = _as_float(self.source, "t", self.t, (-1,))
        if self.lla is None and self.vel is None:
            raise DataError(f"{self.source}: GNSS data without positions and velocities")
        lla = None if self.lla is None else _as_float(self.source, "lat/lon/h", self.lla,
                                                      (-1, 3))
        vel = None if self.vel is None else _as_float(self.source, "vel", self.vel, (-1, 3))
        sig = (None if self.sigma_rows is None
               else _as_float(self.source, "sigma", self.sigma_rows, (-1, 6)))
        check_rows(self.source, len(t), lla=lla, vel=vel, sigma=sig)
        insane = np.zeros(len(t), dtype=bool)
        with np.errstate(invalid="ignore"):
            if lla is not None:
                insane |= ((np.abs(lla[:, 0]) > np.pi / 2) | (np.abs(lla[:, 1]) > 2 * np.pi)
                           | (np.abs(lla[:, 2]) > ABSURD_HEIGHT_M))
            if vel is not None:
                insane |= np.linalg.norm(vel, axis=1) > ABSURD_SPEED_MPS
        ta = (None if self.t_arrival is None
              else _as_float(self.source, "t_arrival", self.t_arrival, (-1,)))
        check_rows(self.source, len(t), t_arrival=ta)
        keep, n = screen_rows(self.source, "GNSS", t, {"lla": lla, "vel": vel, "sigma": sig,
                                                       "t_arrival": ta}, insane)
        self.quality[f"{self.name}_epochs_skipped"] = n
        self.t = check_time(self.source, t[keep])
        self.t_arrival = check_arrival(self.source, self.t, None if ta is None else ta[keep])
        self.lla = None if lla is None else lla[keep]
        self.vel = None if vel is None else vel[keep]
        if sig is not None:
            sig = sig[keep]
            used = np.r_[np.full(3, lla is not None), np.full(3, vel is not None)]
            if np.any(sig[:, used] <= 0):
                i = int(np.argmax((sig[:, used] <= 0).any(axis=1)))
                raise DataError(f"{self.source}: a 1-sigma of fix {i} (at {self.t[i]:.6f} s) "
                                f"is not positive")
        self.sigma_rows = sig
        self.sigma_pos_enu = check_array(self.source, "sigma_pos_enu", self.sigma_pos_enu,
                                         (3,))
        self.sigma_vel = check_array(self.source, "sigma_vel", self.sigma_vel, (3,))
        self.lever = check_array(self.source, "lever", self.lever, (3,))
        if (self.lla is not None and np.any(self.sigma_pos_enu <= 0)) or (
                self.vel is not None and np.any(self.sigma_vel <= 0)):
            raise DataError(f"{self.source}: GNSS standard deviations must be positive")

    cov: ClassVar[None] = None

    @property
    def z(self) -> np.ndarray:
        """The fixes as the sensor's series ``[lat, lon, h, vE, vN, vU]`` (N, 6) [rad, m,
        m/s], NaN where the receiver gives no position or no velocity."""
        n = len(self.t)
        return np.column_stack([np.full((n, 3), np.nan) if self.lla is None else self.lla,
                                np.full((n, 3), np.nan) if self.vel is None else self.vel])

    @property
    def sigma(self) -> np.ndarray | None:
        """Each fix's 1-sigma in the series' order (``sigma_rows``) or None."""
        return self.sigma_rows

    @property
    def absent(self) -> tuple[int, ...]:
        """The components the receiver does not give (position or velocity)."""
        return ((0, 1, 2) if self.lla is None else ()) + ((3, 4, 5) if self.vel is None
                                                          else ())

    @classmethod
    def from_series(cls, d: Series, sigma_pos_enu=5.0, sigma_vel=0.1,
                    lever=(0.0, 0.0, 0.0)) -> GnssData:
        """A GNSS series of any reader (``read_sensor_csv("gnss", ...)``) as GNSS fixes,
        with the figures for fixes without a 1-sigma (position [east, north, up] m,
        velocity m/s; one value for three) and the antenna lever arm (body
        right-forward-up, m)."""
        if isinstance(d, cls):
            return d
        z = np.asarray(d.z, dtype=float)
        absent = set(d.absent)
        lla = None if {0, 1, 2} <= absent else z[:, :3]
        vel = None if z.shape[1] < 6 or {3, 4, 5} <= absent else z[:, 3:6]
        sig = None if d.sigma is None else np.asarray(d.sigma, dtype=float)
        if sig is not None and sig.shape[1] < 6:
            sig = np.column_stack([sig, np.ones((len(sig), 6 - sig.shape[1]))])
        out = cls(d.source, d.t, lla, vel, np.broadcast_to(np.asarray(
            sigma_pos_enu, dtype=float), (3,)).copy(), np.broadcast_to(np.asarray(
                sigma_vel, dtype=float), (3,)).copy(), np.asarray(lever, dtype=float),
            sigma_rows=sig, t_arrival=d.t_arrival, name=d.name)
        out.quality = {**d.quality, **out.quality}
        return out

    @classmethod
    def for_section(cls, d: Series, section) -> GnssData:
        """:meth:`from_series` with the figures of ``section`` (a
        :class:`~fednav.sensors.GnssConfig`; 5 m and 0.1 m/s where it has none)."""
        return cls.from_series(
            d, 5.0 if section.sigma_pos_enu_m is None else section.sigma_pos_enu_m,
            0.1 if section.sigma_vel_mps is None else section.sigma_vel_mps,
            section.lever())

    def adjusted(self, section) -> GnssData:
        """The fixes as ``section`` corrects them: its ``time_offset_s`` added to the
        stamps (and arrival times) and its ``velocity_latency_s`` taken out of the
        velocities (the velocity stamped ``t`` is the one of ``t - L``: the velocity of
        ``t`` is the one stamped ``t + L``, interpolated between fixes, held at the
        last)."""
        out = self
        if section.time_offset_s:
            out = _again(out, t=out.t + section.time_offset_s,
                         t_arrival=_shifted(out.t_arrival, section.time_offset_s))
        if out.vel is not None and section.velocity_latency_s:
            L = section.velocity_latency_s
            out = _again(out, vel=np.column_stack([np.interp(out.t + L, out.t, out.vel[:, j])
                                                   for j in range(3)]))
        return out

    def with_sigma(self, sigma) -> GnssData:
        """The fixes with each one's 1-sigma ``sigma`` (N, 6) (``sigma_rows``' order)."""
        return _again(self, sigma_rows=sigma)

    def flown(self, section) -> GnssData:
        """The fixes as the navigator flies them with ``section`` (its effective settings,
        :meth:`~fednav.sensors.spec.SensorConfig.for_recording`): corrected
        (:meth:`adjusted`), with its lever arm and 1-sigma."""
        return replace(self.adjusted(section), quality={},
                       lever=np.asarray(section.lever_m, dtype=float),
                       sigma_pos_enu=np.asarray(section.sigma_pos_enu_m, dtype=float),
                       sigma_vel=np.asarray(section.sigma_vel_mps, dtype=float))

    def position_velocity(self, window_s: float) -> tuple[np.ndarray, np.ndarray]:
        """ENU velocity [m/s] at each fix from the positions alone: their difference
        across +-``window_s`` around it (one-sided at the ends), and its 1-sigma [m/s]
        from the two fixes' horizontal position noise over the span they are apart (inf
        where the window holds one fix)."""
        from ..core import earth

        lla, t = self.lla, self.t
        d = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], lla[0, 0], lla[0, 1],
                                     lla[0, 2])
        lo = np.searchsorted(t, t - window_s)
        hi = np.minimum(np.searchsorted(t, t + window_s, side="right") - 1, len(t) - 1)
        span = t[hi] - t[lo]
        vel = np.zeros((len(t), 3))
        ok = span > 0
        vel[ok] = (d[hi[ok]] - d[lo[ok]]) / span[ok, None]
        sp = (np.broadcast_to(self.sigma_pos_enu, (len(t), 3)) if self.sigma_rows is None
              else self.sigma_rows[:, :3])
        s = np.max(sp[:, :2], axis=1)  # (horizontal, east and north: the course's)
        sigma = np.full(len(t), np.inf)
        sigma[ok] = np.hypot(s[hi[ok]], s[lo[ok]]) / span[ok]
        return vel, sigma


#: The data of a sensor whose fixes start a recording (``SensorSpec.fixes``: the
#: GNSS), as the processing layers name them.
FixData = GnssData


def _again(data, **changes):
    """``data`` with ``changes``, re-checked by its constructor, keeping its first
    counts (``quality``)."""
    quality = dict(data.quality)
    out = replace(data, quality={}, **changes)
    out.quality = quality
    return out


def _shifted(ta, dt):
    return None if ta is None else ta + dt


@dataclass
class VelocityData:
    """Velocity measurements (visual odometry, DVL ...): ``t`` (N,) [s], ENU ``vel``
    (N, 3) [m/s], covariance ``cov`` (N, 3, 3) [m^2/s^2] (ENU), sensor ``lever`` arm (3,),
    body right-forward-up [m]."""

    source: str
    t: np.ndarray
    vel: np.ndarray
    cov: np.ndarray
    lever: np.ndarray
    #: what the checks did: {"velocity_epochs_skipped": n}
    quality: dict = field(default_factory=dict)
    #: when each measurement reached the navigator [s] (None: at its time of validity)
    t_arrival: np.ndarray | None = None
    #: its registered sensor (:class:`Series`); its noise is ``cov``
    name: ClassVar[str] = "velocity"
    sigma: ClassVar[None] = None
    absent: ClassVar[tuple] = ()

    @property
    def z(self) -> np.ndarray:
        """The series' values: ``vel``."""
        return self.vel

    @classmethod
    def from_series(cls, d: Series, lever=(0.0, 0.0, 0.0)) -> VelocityData:
        """A velocity series of any reader (``read_sensor_csv("velocity", ...)``, which
        must give each row's 1-sigma or covariance) as velocity data, with the sensor's
        lever arm (body right-forward-up, m)."""
        if isinstance(d, cls):
            return d
        cov = d.cov
        if cov is None:
            if d.sigma is None:
                raise DataError(f"{d.source}: velocity data without each row's 1-sigma "
                                f"(sigma_vE_mps, sigma_vN_mps, sigma_vU_mps) or covariance")
            s = np.asarray(d.sigma, dtype=float)
            cov = np.zeros((len(s), 3, 3))
            cov[:, np.arange(3), np.arange(3)] = s**2
        out = cls(d.source, d.t, d.z, cov, np.asarray(lever, dtype=float),
                  t_arrival=d.t_arrival)
        out.quality = {**d.quality, **out.quality}
        return out

    @classmethod
    def for_section(cls, d: Series, section) -> VelocityData:
        """:meth:`from_series` with the lever arm of ``section`` (a
        :class:`~fednav.sensors.VelocityConfig`)."""
        return cls.from_series(d, section.lever())

    def adjusted(self, section) -> VelocityData:
        """The measurements as ``section`` corrects them: its axis order (``axes``: file
        column ``i`` holds the ENU component ``axes[i]``, sign included), its 1-sigma
        ``sigma_mps`` for every row, its ``time_offset_s`` added to the stamps."""
        vel, cov = self.vel, self.cov
        if tuple(section.axes) != ("E", "N", "U"):  # v_enu = M v_file
            M = np.zeros((3, 3))
            for i, a in enumerate(section.axes):
                M["ENU".index(a.lstrip("+-").upper()), i] = -1.0 if a.startswith("-") else 1.0
            vel = vel @ M.T
            cov = M @ cov @ M.T
        if section.sigma_mps is not None:
            cov = np.broadcast_to(np.diag(np.square(section.sigma_mps)), cov.shape).copy()
        if section.time_offset_s or vel is not self.vel or cov is not self.cov:
            return _again(self, t=self.t + section.time_offset_s, vel=vel, cov=cov,
                          t_arrival=_shifted(self.t_arrival, section.time_offset_s))
        return self

    def __post_init__(self):
        t = _as_float(self.source, "t", self.t, (-1,))
        vel = _as_float(self.source, "vel", self.vel, (-1, 3))
        cov = _as_float(self.source, "cov", self.cov, (-1, 3, 3))
        self.lever = check_array(self.source, "lever", self.lever, (3,))
        check_rows(self.source, len(t), vel=vel, cov=cov)
        sym = 0.5 * (cov + np.swapaxes(cov, 1, 2))
        finite = np.isfinite(sym).all(axis=(1, 2))
        not_pd = np.zeros(len(t), dtype=bool)
        if finite.any():
            not_pd[finite] = np.linalg.eigvalsh(sym[finite])[:, 0] <= 0
        with np.errstate(invalid="ignore"):
            insane = not_pd | (np.linalg.norm(vel, axis=1) > ABSURD_SPEED_MPS)
        ta = (None if self.t_arrival is None
              else _as_float(self.source, "t_arrival", self.t_arrival, (-1,)))
        check_rows(self.source, len(t), t_arrival=ta)
        keep, n = screen_rows(self.source, "velocity", t, {"vel": vel, "cov": cov,
                                                           "t_arrival": ta}, insane)
        self.quality["velocity_epochs_skipped"] = n
        self.t = check_time(self.source, t[keep])
        self.vel, self.cov = vel[keep], cov[keep]
        self.t_arrival = check_arrival(self.source, self.t, None if ta is None else ta[keep])


#: The sensors whose recordings have a data class of their own (the figures and lever
#: arm of their section for rows without their own, their section's corrections:
#: ``for_section``, ``adjusted``); any other sensor's recording is a :class:`SensorData`.
RECORDINGS: dict[str, type] = {"gnss": GnssData, "velocity": VelocityData}


def as_recording(d: Series, section) -> Series:
    """``d`` as its sensor's recording (:data:`RECORDINGS`; a sensor whose fixes start a
    recording, ``SensorSpec.fixes``, as :data:`FixData`) with the figures of its
    ``section`` (the system's, or the section's defaults) where its rows have none."""
    from ..sensors import registry

    cls = RECORDINGS.get(d.name) or (FixData if registry.spec(d.name).fixes else None)
    return d if cls is None else cls.for_section(d, section)


@dataclass
class Reference:
    """Reference trajectory: ``t``, ``lla`` (N, 3), ENU ``vel`` (N, 3), optionally Euler
    ``[pitch, roll, heading]`` (N, 3) [rad], and the ``lever`` arm (body
    right-forward-up, m) of the point it describes, from the IMU (zero: the IMU)."""

    source: str
    t: np.ndarray
    lla: np.ndarray
    vel: np.ndarray
    euler: np.ndarray | None = None
    lever: np.ndarray = field(default_factory=lambda: np.zeros(3))
    #: what the checks did: {"reference_rows_skipped": n}
    quality: dict = field(default_factory=dict)

    def __post_init__(self):
        t = _as_float(self.source, "t", self.t, (-1,))
        lla = _as_float(self.source, "lat/lon/h", self.lla, (-1, 3))
        vel = _as_float(self.source, "vel", self.vel, (-1, 3))
        euler = (None if self.euler is None
                 else _as_float(self.source, "roll/pitch/yaw", self.euler, (-1, 3)))
        self.lever = check_array(self.source, "lever", self.lever, (3,))
        check_rows(self.source, len(t), lla=lla, vel=vel, euler=euler)
        keep, n = screen_rows(self.source, "reference", t,
                              {"lla": lla, "vel": vel, "euler": euler})
        self.quality["reference_rows_skipped"] = n
        self.t = check_time(self.source, t[keep])
        self.lla, self.vel = lla[keep], vel[keep]
        self.euler = None if euler is None else euler[keep]
