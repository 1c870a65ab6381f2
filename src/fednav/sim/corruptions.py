"""Corruptions recorded data commonly suffer on their way into a navigation tool: a column
in another unit, axes in another order or sign convention, another time base, a clock
offset, a stuck sensor axis, a receiver that jumps.  Each :class:`Corruption` maps clean
``(imu, fixes)`` (:class:`~fednav.io.data.ImuData`, :class:`~fednav.io.data.GnssData`) to
corrupted copies; :func:`families` lists the ones the health monitor is measured on
(``benchmarks/health.py``, ``tests/test_health.py``, docs/reliability.md).

Data-level corruptions are what a CSV column in a wrong unit or order becomes after
loading (fednav's loaders convert degrees to radians first: a latitude column scaled by
1000 arrives as a latitude scaled by 1000).  Frames and units as everywhere in fednav: body
right-forward-up, ENU, SI inside.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from itertools import permutations

import numpy as np

from ..io.data import FixData, ImuData

#: IMU time stamps in Unix time against GNSS in GPS seconds of the week [s] (Nov 2026)
UNIX_EPOCH_OFFSET_S = 1.79e9
#: GPS - UTC [s] (a receiver's UTC stamps against an IMU on GPS time)
GPS_UTC_S = 18.0


@dataclass(frozen=True)
class Corruption:
    """One corruption: ``family`` (unit, axes, time base, time offset, stuck axis, sensor
    fault), a ``name`` saying what was done, and ``apply(imu, fixes) -> (imu, fixes)``."""

    family: str
    name: str
    apply: Callable[[ImuData, FixData], tuple[ImuData, FixData]]


def _imu(imu: ImuData, **changes) -> ImuData:
    return replace(imu, quality={}, increments=None, **changes)


def _fixes(fixes: FixData, **changes) -> FixData:
    return replace(fixes, quality={}, **changes)


def scale_imu(field: str, axis: int | None, factor: float) -> Corruption:
    """IMU ``field`` ('gyro' or 'accel'), one ``axis`` (0..2, None: all three) times
    ``factor`` (a unit: deg/s is rad/s x 57.3, g is m/s^2 / 9.81, mg x 102)."""
    def apply(imu, fixes):
        a = getattr(imu, field).copy()
        a[:, slice(None) if axis is None else axis] *= factor
        return _imu(imu, **{field: a}), fixes
    where = "xyz" if axis is None else "xyz"[axis]
    return Corruption("unit", f"{field} {where} x {factor:g}", apply)


def scale_fixes(field: str, axis: int | None, factor: float) -> Corruption:
    """GNSS ``field`` ('lla' or 'vel'), one ``axis`` (None: all) times ``factor``."""
    def apply(imu, fixes):
        a = getattr(fixes, field).copy()
        a[:, slice(None) if axis is None else axis] *= factor
        return imu, _fixes(fixes, **{field: a})
    names = {"lla": ("lat", "lon", "h"), "vel": ("vE", "vN", "vU")}[field]
    where = "all" if axis is None else names[axis]
    return Corruption("unit", f"fixes {where} x {factor:g}", apply)


def permute_imu(field: str, order: tuple[int, ...], signs=(1, 1, 1)) -> Corruption:
    """IMU ``field``'s axes in ``order`` (the file's column k holds axis ``order[k]``)
    with ``signs``."""
    def apply(imu, fixes):
        a = getattr(imu, field)[:, list(order)] * np.asarray(signs, dtype=float)
        return _imu(imu, **{field: a}), fixes
    return Corruption("axes", f"{field} axes {order} signs {tuple(signs)}", apply)


def permute_fix_velocity(order: tuple[int, ...], signs=(1, 1, 1)) -> Corruption:
    """GNSS velocity components in ``order`` with ``signs`` (e.g. N, E, D under E, N, U
    headers: order (1, 0, 2), signs (1, 1, -1))."""
    def apply(imu, fixes):
        return imu, _fixes(fixes, vel=fixes.vel[:, list(order)] * np.asarray(signs, float))
    return Corruption("axes", f"fixes velocity axes {order} signs {tuple(signs)}", apply)


def exchange_gyro_accel() -> Corruption:
    """The gyro and accelerometer blocks exchanged."""
    def apply(imu, fixes):
        return _imu(imu, gyro=imu.accel.copy(), accel=imu.gyro.copy()), fixes
    return Corruption("axes", "gyro and accel blocks exchanged", apply)


def increments_as_rates() -> Corruption:
    """Increments (dtheta, dv per sample) given where rates are expected."""
    def apply(imu, fixes):
        dt = float(np.median(np.diff(imu.t)))
        return _imu(imu, gyro=imu.gyro * dt, accel=imu.accel * dt), fixes
    return Corruption("unit", "increments given as rates", apply)


def time_base(stream: str, factor: float = 1.0, offset: float = 0.0) -> Corruption:
    """``stream`` ('imu' or 'fixes') time stamps ``t * factor + offset`` (milliseconds:
    factor 1000; Unix time against GPS time: a large offset)."""
    def apply(imu, fixes):
        if stream == "imu":
            return _imu(imu, t=imu.t * factor + offset), fixes
        return imu, _fixes(fixes, t=fixes.t * factor + offset)
    what = (f"x {factor:g}" if factor != 1.0 else "") + (f" + {offset:g} s" if offset else "")
    return Corruption("time base", f"{stream} time {what.strip()}", apply)


def time_offset(seconds: float) -> Corruption:
    """GNSS time stamps ``seconds`` late (the fixes stamped after their time of
    validity: a receiver's UTC against an IMU's GPS time is 18 s)."""
    def apply(imu, fixes):
        return imu, _fixes(fixes, t=fixes.t + seconds)
    return Corruption("time offset", f"fixes {seconds:g} s late", apply)


def stuck_axis(field: str, axis: int) -> Corruption:
    """IMU ``field``'s ``axis`` stuck at its first value."""
    def apply(imu, fixes):
        a = getattr(imu, field).copy()
        a[:, axis] = a[0, axis]
        return _imu(imu, **{field: a}), fixes
    return Corruption("stuck axis", f"{field} {'xyz'[axis]} stuck", apply)


def position_jump(at_s: float, north_m: float) -> Corruption:
    """GNSS positions ``north_m`` off from ``at_s`` on (a receiver back from an outage on
    a wrong fix, staying there)."""
    def apply(imu, fixes):
        lla = fixes.lla.copy()
        m = fixes.t >= at_s
        lla[m, 0] += north_m / 6.371e6
        return imu, _fixes(fixes, lla=lla)
    return Corruption("sensor fault", f"fixes {north_m:g} m north from {at_s:g} s", apply)


#: unit factors a column meets: 1e-3 .. 1e3, and the usual suspects (deg <-> rad, g, mg)
FACTORS = (1e-3, 1e-2, 0.1, 1 / 9.80665, 10.0, 180 / np.pi, 100.0, 1e3)


def families(t_jump: float = 50.0) -> list[Corruption]:
    """The corruptions the health monitor is measured on: every IMU column and GNSS
    velocity column (and every GNSS position column) scaled by each of :data:`FACTORS`,
    every axis permutation of gyro, accelerometer and GNSS velocity, front-right-down axes,
    the blocks exchanged, increments as rates, time in milliseconds, Unix vs GPS time,
    UTC vs GPS time, GNSS clock offsets, stuck axes, and a 200 m receiver jump at
    ``t_jump`` [s]."""
    out = []
    for field in ("gyro", "accel"):
        for axis in (None, 0, 1, 2):
            out += [scale_imu(field, axis, f) for f in FACTORS]
    for axis in (None, 0, 1, 2):
        out += [scale_fixes("vel", axis, f) for f in FACTORS]
    for axis in (0, 1, 2):
        out += [scale_fixes("lla", axis, f) for f in (1e-3, 0.1, 10.0, 1e3)]
    perms = [p for p in permutations(range(3)) if p != (0, 1, 2)]
    for field in ("gyro", "accel"):
        out += [permute_imu(field, p) for p in perms]
    out += [permute_imu("gyro", (1, 0, 2), (1, 1, -1)), permute_imu("accel", (1, 0, 2),
                                                                        (1, 1, -1))]
    out += [Corruption("axes", "front-right-down axes (NaveGo) in a right-forward-up file",
                       lambda i, g: (_imu(i, gyro=i.gyro[:, [1, 0, 2]] * [1, 1, -1],
                                          accel=i.accel[:, [1, 0, 2]] * [1, 1, -1]), g))]
    out += [permute_fix_velocity(p) for p in perms]
    out += [permute_fix_velocity((1, 0, 2), (1, 1, -1))]
    out += [exchange_gyro_accel(), increments_as_rates()]
    out += [time_base("imu", 1e3), time_base("fixes", 1e3),
            time_base("imu", offset=UNIX_EPOCH_OFFSET_S), time_base("fixes", offset=3e5)]
    out += [time_offset(s) for s in (-GPS_UTC_S, -1.0, -0.2, 0.2, 1.0, GPS_UTC_S)]
    out += [stuck_axis(f, a) for f in ("gyro", "accel") for a in range(3)]
    out += [position_jump(t_jump, 200.0)]
    return out


__all__ = ["Corruption", "FACTORS", "GPS_UTC_S", "UNIX_EPOCH_OFFSET_S", "exchange_gyro_accel",
           "families", "increments_as_rates", "permute_fix_velocity", "permute_imu",
           "position_jump", "scale_fixes", "scale_imu", "stuck_axis", "time_base",
           "time_offset"]
