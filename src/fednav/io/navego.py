"""NaveGo ``.mat`` structs (MATLAB v5) -> fednav data.

NaveGo's conventions: body x forward, y right, z down (FRD); velocities NED; Euler
``roll, pitch, yaw`` with ``C_b^n = Rz(yaw) Ry(pitch) Rx(roll)`` (NED/FRD), yaw clockwise
from north.  fednav: body right-forward-up, ENU.  The same constant matrix swaps the
first two axes and flips the third in both frames, so vectors convert with
:data:`FRD_TO_RFU` and attitudes with ``C_fednav = M C_navego M`` (``M = M' = M^-1``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core import attitude as att
from .data import (
    DataError,
    GnssData,
    ImuData,
    ImuErrors,
    Reference,
    VelocityData,
    _as_float,
    check_rows,
    check_time,
    require_file,
)

#: FRD -> RFU (and NED -> ENU): swap x and y, negate z.  A proper rotation, its own inverse.
FRD_TO_RFU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def navego_dcm(roll, pitch, yaw) -> np.ndarray:
    """NaveGo's C_b^n (body FRD -> NED) from roll, pitch, yaw [rad] (arrays broadcast)."""
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    C = np.empty(np.broadcast(roll, pitch, yaw).shape + (3, 3))
    C[..., 0, 0] = cp * cy
    C[..., 0, 1] = sr * sp * cy - cr * sy
    C[..., 0, 2] = cr * sp * cy + sr * sy
    C[..., 1, 0] = cp * sy
    C[..., 1, 1] = sr * sp * sy + cr * cy
    C[..., 1, 2] = cr * sp * sy - sr * cy
    C[..., 2, 0] = -sp
    C[..., 2, 1] = sr * cp
    C[..., 2, 2] = cr * cp
    return C


def navego_euler_to_fednav(roll, pitch, yaw) -> np.ndarray:
    """NaveGo roll, pitch, yaw [rad] -> fednav Euler ``[pitch, roll, heading]`` [rad]."""
    C = FRD_TO_RFU @ navego_dcm(roll, pitch, yaw) @ FRD_TO_RFU
    return att.dcm_to_euler(C)


def fednav_euler_to_navego(euler) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """fednav Euler ``[pitch, roll, heading]`` [rad] (..., 3) -> NaveGo roll, pitch, yaw
    [rad] (the inverse of :func:`navego_euler_to_fednav`)."""
    C = FRD_TO_RFU @ att.euler_to_dcm(euler) @ FRD_TO_RFU   # NaveGo's C_b^n (FRD -> NED)
    roll = np.arctan2(C[..., 2, 1], C[..., 2, 2])
    pitch = -np.arcsin(np.clip(C[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(C[..., 1, 0], C[..., 0, 0])
    return roll, pitch, yaw


def _load(path, kind: str):
    """The one struct in a NaveGo .mat file."""
    path = Path(path)
    require_file(path, kind)
    import scipy.io

    try:
        d = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)
    except Exception as e:  # scipy raises several types for non-MAT content
        raise DataError(f"{kind} file {path}: not a MATLAB v5 .mat file ({e})") from None
    structs = [k for k in d if not k.startswith("__")]
    if len(structs) != 1:
        raise DataError(f"{kind} file {path}: expected one struct, found {structs}")
    return str(path), d[structs[0]]


def _field(src: str, s, name: str, required: bool = True):
    if hasattr(s, name):
        return getattr(s, name)
    if required:
        raise DataError(f"{src}: missing field '{name}'")
    return None


def _vec3(src, s, name, required=True, default=None, nonneg=False):
    v = _field(src, s, name, required)
    if v is None:
        return default
    try:
        a = np.atleast_1d(np.asarray(v, dtype=float)).ravel()
    except (TypeError, ValueError):
        raise DataError(f"{src}: field '{name}' is not numeric") from None
    if a.size == 1:
        a = np.repeat(a, 3)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or (nonneg and np.any(a < 0)):
        what = "non-negative finite" if nonneg else "finite"
        raise DataError(f"{src}: field '{name}' must be 3 {what} numbers, got "
                        f"{np.array2string(np.atleast_1d(np.asarray(v)), precision=6)}")
    return a


def _frd(v):
    """Per-axis figures in FRD axis order -> RFU order (x and y swap)."""
    return np.asarray(v)[[1, 0, 2]]


def read_navego_imu(path, max_bridge_s: float = 0.1, mounting=None) -> ImuData:
    """NaveGo IMU struct: ``t``, ``fb``, ``wb`` (FRD) and the error figures.

    NaveGo stamps a sample at the end of the interval it integrates it over; the samples
    come back stamped where their intervals start (fednav's convention: the stamps move
    back by one period).

    Error figures (NaveGo names, SI): ``arw`` [rad/s/sqrt(Hz)], ``vrw`` [m/s^2/sqrt(Hz)],
    turn-on biases ``gb_sta``/``ab_sta``, bias instabilities ``gb_dyn``/``ab_dyn`` with
    correlation times ``gb_corr``/``ab_corr``.  fednav takes the biases as 1-sigma figures
    (their magnitudes), as a datasheet gives them; NaveGo subtracts ``*_sta`` as known
    biases.  ``ini_align`` (roll, pitch, yaw) and ``ini_align_err`` give the initial
    attitude and its 1-sigma.  ``mounting``: the file's IMU axes when they are not
    NaveGo's forward-right-down (``imu.mounting``, :meth:`fednav.io.ImuData.remount`).
    """
    src, s = _load(path, "IMU")
    t = check_time(src, _field(src, s, "t"))
    fb = _as_float(src, "fb", _field(src, s, "fb"), (-1, 3))  # faulty samples: ImuData
    wb = _as_float(src, "wb", _field(src, s, "wb"), (-1, 3))
    check_rows(src, len(t), fb=fb, wb=wb)
    errors = None
    if hasattr(s, "arw"):
        errors = ImuErrors(
            gyro_arw=_frd(_vec3(src, s, "arw", nonneg=True)),
            accel_vrw=_frd(_vec3(src, s, "vrw", nonneg=True)),
            gyro_bias=np.abs(_frd(_vec3(src, s, "gb_sta"))),
            accel_bias=np.abs(_frd(_vec3(src, s, "ab_sta"))),
            gyro_markov=_frd(_vec3(src, s, "gb_dyn", nonneg=True)),
            accel_markov=_frd(_vec3(src, s, "ab_dyn", nonneg=True)),
            gyro_tau=_frd(_vec3(src, s, "gb_corr", nonneg=True)),
            accel_tau=_frd(_vec3(src, s, "ab_corr", nonneg=True)))
    euler = sigma = None
    ini = _vec3(src, s, "ini_align", required=False)
    if ini is not None:
        euler = navego_euler_to_fednav(*ini)
        err = _vec3(src, s, "ini_align_err", required=False)
        if err is not None:
            sigma = np.abs(err[[1, 0, 2]])  # [roll, pitch, yaw] -> [pitch, roll, heading]
    imu = ImuData(src, t, wb @ FRD_TO_RFU.T, fb @ FRD_TO_RFU.T, errors, euler, sigma,
                  max_bridge_s=max_bridge_s, mounting=FRD_TO_RFU, mounting_name="FRD")
    # NaveGo integrates sample i over [t(i-1), t(i)] (ins_gnss.m: dti = t(i) - t(i-1)
    # with wb(i), fb(i)): stamped at its interval's end, where fednav holds a sample
    # from its stamp (docs/conventions.md). Moved back by one period after the checks
    # (their lines name the file's own stamps; jittered stamps: to within the jitter)
    if len(imu.t) > 1:
        imu.t = imu.t - imu.period()
    return imu if mounting is None else imu.remount(mounting)


def _lla(src, s):
    cols = []
    for name in ("lat", "lon", "h"):
        a = np.atleast_1d(np.asarray(_field(src, s, name), dtype=float))
        if a.ndim != 1:
            raise DataError(f"{src}: field '{name}' has shape {a.shape}, expected a vector")
        cols.append(a)
    if len({len(c) for c in cols}) != 1:
        raise DataError(f"{src}: fields 'lat', 'lon', 'h' have different lengths "
                        f"{[len(c) for c in cols]}")
    return np.column_stack(cols)


def _ned(src, s, name="vel", required=True):
    v = _field(src, s, name, required)
    if v is None:
        return None
    v = np.asarray(v, dtype=float)
    if v.ndim != 2 or v.shape[1] != 3:
        raise DataError(f"{src}: field '{name}' has shape {v.shape}, expected Nx3")
    return v @ FRD_TO_RFU.T  # NED -> ENU


def read_navego_gnss(path) -> GnssData:
    """NaveGo GNSS struct: ``t``, ``lat``, ``lon`` [rad], ``h`` [m], ``vel`` (NED),
    ``stdm`` [m] (north, east, down), ``stdv`` [m/s] (N, E, D), ``larm`` (FRD) [m]."""
    src, s = _load(path, "GNSS")
    stdm = _vec3(src, s, "stdm")
    stdv = _vec3(src, s, "stdv")
    larm = _vec3(src, s, "larm", required=False, default=np.zeros(3))
    return GnssData(src, _field(src, s, "t"), _lla(src, s), _ned(src, s, required=False),
                    stdm[[1, 0, 2]], stdv[[1, 0, 2]], FRD_TO_RFU @ larm)  # -> ENU


def read_navego_visual(path) -> VelocityData:
    """NaveGo visual struct: ``t``, ``vel`` (NED) and ``covv`` (N x 9, NED, row-major)."""
    src, s = _load(path, "visual")
    vel = _ned(src, s)
    covv = np.asarray(_field(src, s, "covv"), dtype=float)
    if covv.ndim != 2 or covv.shape[1] != 9:
        raise DataError(f"{src}: field 'covv' has shape {covv.shape}, expected Nx9")
    cov = FRD_TO_RFU @ covv.reshape(-1, 3, 3) @ FRD_TO_RFU
    larm = _vec3(src, s, "larm", required=False, default=np.zeros(3))
    return VelocityData(src, _field(src, s, "t"), vel, cov, FRD_TO_RFU @ larm)


def read_navego_reference(path) -> Reference:
    """NaveGo reference struct: ``t``, ``lat``, ``lon``, ``h``, ``vel`` (NED) and, where
    present, ``roll``, ``pitch``, ``yaw`` and ``larm`` (the point the positions describe,
    FRD from the IMU: NaveGo's reference files are GNSS structs)."""
    src, s = _load(path, "reference")
    euler = None
    if all(hasattr(s, k) for k in ("roll", "pitch", "yaw")):
        r, p, y = (np.atleast_1d(np.asarray(getattr(s, k), dtype=float))
                   for k in ("roll", "pitch", "yaw"))
        if not (len(r) == len(p) == len(y)):
            raise DataError(f"{src}: fields 'roll', 'pitch', 'yaw' have different lengths")
        euler = navego_euler_to_fednav(r, p, y)
    larm = _vec3(src, s, "larm", required=False, default=np.zeros(3))
    return Reference(src, _field(src, s, "t"), _lla(src, s), _ned(src, s), euler,
                     FRD_TO_RFU @ larm)
