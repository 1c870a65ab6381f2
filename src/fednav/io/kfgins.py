"""KF-GINS's text files (i2Nav-WHU's C++ loosely coupled GNSS/INS) in and out.

Every file is plain text, one row per epoch, columns separated by spaces; times are GPS
seconds of the week [s].

* **IMU** (``imupath``, ``imudatalen`` columns, 7 or more): ``t, dθx, dθy, dθz [rad],
  dvx, dvy, dvz [m/s]`` — increments over the interval that *ends* at ``t``, in the IMU's
  forward-right-down axes; an eighth column, where there is one, is an odometer speed
  [m/s] (:func:`read_kfgins_odometer`; KF-GINS itself reads it and does not use it).
* **GNSS** (``gnsspath``, 7 or 13 columns): ``t, lat [deg], lon [deg], h [m]`` above the
  ellipsoid, then either ``σN, σE, σD`` [m] (7) or ``vN, vE, vD`` [m/s], ``σN, σE, σD``
  [m], ``σvN, σvE, σvD`` [m/s] (13).  KF-GINS uses the positions only; fednav uses the
  velocities of a 13-column file too (``velocity=False`` leaves them out).
* **Navigation result** (``KF_GINS_Navresult.nav``, and the ``truth.nav`` of its
  dataset): ``week, t, lat [deg], lon [deg], h [m], vN, vE, vD [m/s], roll, pitch, yaw
  [deg]`` (Euler angles of the body forward-right-down in north-east-down, ZYX, yaw
  clockwise from north: NaveGo's).  :func:`read_kfgins_nav` reads one as a
  :class:`~fednav.io.data.Reference`, :func:`write_kfgins_nav` writes fednav's solution
  so that KF-GINS's ``plot_navresult.py`` reads it.

The configuration ``kf-gins.yaml`` is translated by :mod:`fednav.process.kfgins`.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..core import units
from .data import (
    DataError,
    GnssData,
    ImuData,
    Reference,
    SensorData,
    check_time,
    require_file,
)
from .navego import FRD_TO_RFU, fednav_euler_to_navego, navego_euler_to_fednav

#: the columns of each file (the first ``n`` of each layout)
IMU_COLUMNS = ("t", "dtheta_x", "dtheta_y", "dtheta_z", "dv_x", "dv_y", "dv_z")
NAV_COLUMNS = 11


def read_table(path, kind: str, columns: tuple[int, ...]) -> tuple[str, np.ndarray]:
    """A KF-GINS text file as a float array (rows x columns): every row with the same
    number of columns, one of ``columns``; one-line :class:`DataError` s naming the file
    and the first bad row."""
    path = Path(path)
    require_file(path, f"KF-GINS {kind}")
    src = str(path)
    a = _plain_table(path)
    if a is not None and (a.shape[1] in columns
                          or columns[-1] is None and a.shape[1] >= columns[0]):
        return src, a
    import pandas as pd  # (here only, to explain a file numpy's parser does not take:
    # 0.2-0.7 s of a command's start)

    try:
        df = pd.read_csv(path, sep=r"\s+", header=None, comment="#", dtype=float,
                         engine="c")
    except pd.errors.EmptyDataError:
        raise DataError(f"{src}: empty file (a KF-GINS {kind} file has "
                        f"{' or '.join(map(str, columns))} numbers per row)") from None
    except (ValueError, pd.errors.ParserError) as e:
        first = str(e).strip().splitlines()[-1] if str(e).strip() else type(e).__name__
        raise DataError(f"{src}: not a KF-GINS {kind} file: rows of "
                        f"{' or '.join(map(str, columns))} numbers separated by spaces "
                        f"({first})") from None
    a = df.to_numpy(dtype=float)
    if a.shape[1] not in columns and not (columns[-1] is None and a.shape[1] >= columns[0]):
        raise DataError(f"{src}: {a.shape[1]} columns; a KF-GINS {kind} file has "
                        f"{' or '.join(str(c) for c in columns if c)}")
    short = np.isnan(a).any(axis=1)
    if short.any():
        i = int(np.argmax(short))
        raise DataError(f"{src}: row {i + 1} has fewer numbers than the first row "
                        f"({a.shape[1]})")
    return src, a


def _plain_table(path: Path) -> np.ndarray | None:
    """A file of rows of finite numbers, every row as wide as the first, separated by
    white space (``#`` comments and blank lines skipped), as a (rows, columns) float
    array read by numpy's C parser (no pandas import); None for any other file
    (:func:`read_table` then reads it with pandas, which names what is wrong)."""
    import warnings

    try:
        with warnings.catch_warnings():  # (an empty file warns)
            warnings.simplefilter("ignore", UserWarning)
            a = np.loadtxt(path, ndmin=2, comments="#")
    except (ValueError, UnicodeDecodeError, OSError):
        return None
    if not a.size or not np.isfinite(a).all():
        return None
    return a


def _window(t: np.ndarray, start_s: float | None, end_s: float | None) -> np.ndarray:
    keep = np.ones(len(t), dtype=bool)
    if start_s is not None:
        keep &= t >= start_s
    if end_s is not None and end_s >= 0:
        keep &= t <= end_s
    return keep


def read_kfgins_imu(path, *, start_s: float | None = None, end_s: float | None = None,
                    rate_hz: float | None = None, max_bridge_s: float = 0.1,
                    mounting=None, known_errors: dict | None = None) -> ImuData:
    """KF-GINS's IMU file (module docstring) as IMU data, body right-forward-up.

    Parameters
    ----------
    path : str or Path
        The text file.
    start_s, end_s : float, optional
        The processing window (GPS seconds of the week; ``end_s`` -1: to the end), as
        ``starttime``/``endtime`` choose it.
    rate_hz : float, optional
        ``imudatarate``: checked against the stamps (a mismatch of more than 10 % is
        warned about: the stamps are used).
    max_bridge_s : float
        Longest faulty stretch bridged (:class:`~fednav.io.data.ImuData`).
    mounting : str or dict, optional
        The file's axes when they are not KF-GINS's forward-right-down
        (``imu.mounting``).
    known_errors : dict, optional
        Errors to take out of the increments as KF-GINS takes out its initial estimate
        (``initgyrbias`` ...), in the file's forward-right-down axes, SI: ``gyro_bias``
        [rad/s], ``accel_bias`` [m/s^2], ``gyro_scale``, ``accel_scale`` [fraction]:
        ``(d - b dt) / (1 + s)`` per axis.
    """
    src, a = read_table(path, "IMU", (7, None))
    keep = _window(a[:, 0], start_s, end_s)
    if keep.sum() < 2:
        raise DataError(f"{src}: fewer than 2 IMU rows between starttime {start_s} and "
                        f"endtime {end_s} (the file spans {a[0, 0]:.3f} to {a[-1, 0]:.3f} s)")
    a = a[keep]
    t = check_time(src, a[:, 0])
    if rate_hz:
        dt = float(np.median(np.diff(t)))
        if abs(dt * rate_hz - 1.0) > 0.1:  # (KF-GINS uses it only across a gap)
            warnings.warn(f"{src}: the stamps are {1.0 / dt:.1f} Hz apart, imudatarate says "
                          f"{rate_hz:g} Hz: the stamps are used (is it the file the "
                          f"configuration describes?)", stacklevel=2)
    dth, dv = a[:, 1:4], a[:, 4:7]
    if known_errors:
        d = np.diff(t)
        dt = np.r_[np.median(d), d][:, None]
        k = {n: np.broadcast_to(np.asarray(known_errors.get(n, 0.0), dtype=float), (3,))
             for n in ("gyro_bias", "accel_bias", "gyro_scale", "accel_scale")}
        dth = (dth - k["gyro_bias"] * dt) / (1.0 + k["gyro_scale"])
        dv = (dv - k["accel_bias"] * dt) / (1.0 + k["accel_scale"])
    imu = ImuData.from_increments(src, t, dth @ FRD_TO_RFU.T, dv @ FRD_TO_RFU.T,
                                  max_bridge_s=max_bridge_s, mounting=FRD_TO_RFU,
                                  mounting_name="FRD")
    return imu if mounting is None else imu.remount(mounting)


def read_kfgins_odometer(path, *, start_s: float | None = None,
                         end_s: float | None = None) -> SensorData | None:
    """The eighth column of a KF-GINS IMU file (an odometer's forward speed [m/s], at the
    row's time) as the ``odometer`` sensor's series; None when the file has 7 columns."""
    src, a = read_table(path, "IMU", (7, None))
    if a.shape[1] < 8:
        return None
    a = a[_window(a[:, 0], start_s, end_s)]
    return SensorData("odometer", src, a[:, 0], a[:, 7:8])


def read_kfgins_gnss(path, *, lever=(0.0, 0.0, 0.0), start_s: float | None = None,
                     end_s: float | None = None, velocity: bool = True) -> GnssData:
    """KF-GINS's GNSS file (module docstring) as GNSS fixes with each row's 1-sigma.

    ``lever``: the antenna lever arm, body right-forward-up [m] (KF-GINS's ``antlever``
    is forward-right-down: :func:`fednav.process.kfgins.translate` turns it).
    ``start_s``/``end_s``: the processing window (fixes after ``start_s``, as KF-GINS).
    """
    src, a = read_table(path, "GNSS", (7, 13))
    keep = _window(a[:, 0], None, end_s) & (a[:, 0] > (start_s if start_s is not None
                                                         else -np.inf))
    a = a[keep]
    if len(a) == 0:
        raise DataError(f"{src}: no GNSS fix after starttime {start_s}")
    lla = np.column_stack([units.deg(a[:, 1]), units.deg(a[:, 2]), a[:, 3]])
    vel = None
    sig = np.ones((len(a), 6))
    if a.shape[1] == 7:
        sig[:, :3] = a[:, 4:7]
    else:
        sig[:, :3] = a[:, 7:10]
        if velocity:
            vel = a[:, [5, 4, 6]] * [1.0, 1.0, -1.0]  # NED -> ENU
            sig[:, 3:] = a[:, [11, 10, 12]]
    med = np.median(sig[:, :3], axis=0)[[1, 0, 2]]
    out = GnssData(src, a[:, 0], lla, vel, np.maximum(med, 1e-3),
                   np.maximum(np.median(sig[:, 3:], axis=0), 1e-3),
                   np.asarray(lever, dtype=float), sigma_rows=sig)
    return out


def read_kfgins_nav(path) -> Reference:
    """A KF-GINS navigation result (``truth.nav`` of its dataset, or its own output) as a
    reference trajectory: positions, ENU velocity, fednav Euler angles."""
    src, a = read_table(path, "navigation result", (NAV_COLUMNS,))
    lla = np.column_stack([units.deg(a[:, 2]), units.deg(a[:, 3]), a[:, 4]])
    vel = a[:, [6, 5, 7]] * [1.0, 1.0, -1.0]
    euler = navego_euler_to_fednav(*units.deg(a[:, 8:11]).T)
    return Reference(src, a[:, 1], lla, vel, euler)


def write_kfgins_nav(path, t, lla, vel_enu, euler) -> Path:
    """Write a solution in KF-GINS's ``.nav`` layout (module docstring): times ``t`` [s]
    (written as they are: KF-GINS's are GPS seconds of the week), ``lla`` (N, 3) [rad, rad,
    m], ENU velocity [m/s] and fednav Euler ``[pitch, roll, heading]`` [rad]; the week
    column is 0, as KF-GINS writes it.  The file is written whole (a temporary file
    renamed)."""
    from ..core.atomic import replacing

    roll, pitch, yaw = fednav_euler_to_navego(np.asarray(euler, dtype=float))
    yaw = np.mod(yaw, 2 * np.pi)
    v = np.asarray(vel_enu, dtype=float)
    rows = np.column_stack([np.zeros(len(t)), t, units.to_deg(lla[:, 0]),
                            units.to_deg(lla[:, 1]), lla[:, 2], v[:, 1], v[:, 0], -v[:, 2],
                            units.to_deg(roll), units.to_deg(pitch), units.to_deg(yaw)])
    path = Path(path)
    with replacing(path) as tmp:
        np.savetxt(tmp, rows, fmt=["%d", "%.9f", "%.10f", "%.10f", "%.4f", "%.4f", "%.4f",
                                   "%.4f", "%.8f", "%.8f", "%.8f"])
    return path
