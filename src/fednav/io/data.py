"""Containers for real sensor data in fednav's frames and units, with their checks.

Frames: body right-forward-up, navigation ENU; positions geodetic ``[lat, lon, h]``
[rad, rad, m]; Euler ``[pitch, roll, heading]`` [rad] (``docs/conventions.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import FednavError


class DataError(FednavError, ValueError):
    """A sensor data file that cannot be used (one line naming the file and the field)."""


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


def check_rows(source: str, n: int, **fields) -> None:
    """Every field has ``n`` rows (the length of the time vector)."""
    for name, a in fields.items():
        if a is not None and len(a) != n:
            raise DataError(f"{source}: field '{name}' has {len(a)} rows but 't' has {n}")


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

    def __post_init__(self):
        self.t = check_time(self.source, self.t)
        self.gyro = check_array(self.source, "gyro", self.gyro, (-1, 3))
        self.accel = check_array(self.source, "accel", self.accel, (-1, 3))
        check_rows(self.source, len(self.t), gyro=self.gyro, accel=self.accel)

    def period(self) -> float:
        """The sampling period [s]; DataError if the sampling is not uniform (a gap)."""
        d = np.diff(self.t)
        dt = float(np.median(d))
        bad = np.abs(d - dt) > 0.1 * dt
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(f"{self.source}: IMU sampling is not uniform: {d[i]:.6f} s "
                            f"between t = {self.t[i]:.6f} s and {self.t[i + 1]:.6f} s "
                            f"(median {dt:.6f} s)")
        return dt


@dataclass
class GnssData:
    """GNSS fixes: ``t`` (N,) [s], ``lla`` (N, 3), ENU ``vel`` (N, 3) [m/s] (or None for
    position-only receivers), 1-sigma ``sigma_pos`` (3,) [north, east, up] [m] and
    ``sigma_vel`` (3,) [east, north, up] [m/s], antenna ``lever`` arm (3,) from the IMU,
    body right-forward-up [m]."""

    source: str
    t: np.ndarray
    lla: np.ndarray
    vel: np.ndarray | None
    sigma_pos: np.ndarray
    sigma_vel: np.ndarray
    lever: np.ndarray

    def __post_init__(self):
        self.t = check_time(self.source, self.t)
        self.lla = check_array(self.source, "lat/lon/h", self.lla, (-1, 3))
        if self.vel is not None:
            self.vel = check_array(self.source, "vel", self.vel, (-1, 3))
        self.sigma_pos = check_array(self.source, "sigma_pos", self.sigma_pos, (3,))
        self.sigma_vel = check_array(self.source, "sigma_vel", self.sigma_vel, (3,))
        self.lever = check_array(self.source, "lever", self.lever, (3,))
        check_rows(self.source, len(self.t), lla=self.lla, vel=self.vel)
        if np.any(self.sigma_pos <= 0) or (self.vel is not None and np.any(self.sigma_vel <= 0)):
            raise DataError(f"{self.source}: GNSS standard deviations must be positive")


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

    def __post_init__(self):
        self.t = check_time(self.source, self.t)
        self.vel = check_array(self.source, "vel", self.vel, (-1, 3))
        self.cov = check_array(self.source, "cov", self.cov, (-1, 3, 3))
        self.lever = check_array(self.source, "lever", self.lever, (3,))
        check_rows(self.source, len(self.t), vel=self.vel, cov=self.cov)
        ev = np.linalg.eigvalsh(0.5 * (self.cov + np.swapaxes(self.cov, 1, 2)))
        if np.any(ev[:, 0] <= 0):
            i = int(np.argmax(ev[:, 0] <= 0))
            raise DataError(f"{self.source}: field 'cov' is not positive definite at row {i}")


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

    def __post_init__(self):
        self.t = check_time(self.source, self.t)
        self.lla = check_array(self.source, "lat/lon/h", self.lla, (-1, 3))
        self.vel = check_array(self.source, "vel", self.vel, (-1, 3))
        if self.euler is not None:
            self.euler = check_array(self.source, "roll/pitch/yaw", self.euler, (-1, 3))
        self.lever = check_array(self.source, "lever", self.lever, (3,))
        check_rows(self.source, len(self.t), lla=self.lla, vel=self.vel, euler=self.euler)
