"""Unit helpers: convert *into* SI/radians at the edges (configs, reports) and back.

Every function takes a value (scalar or array) in the named unit and returns SI
(radians, seconds, metres, m/s^2).  The ``to_*`` functions go the other way.
"""

from __future__ import annotations

import numpy as np

#: Standard gravity used for ``g`` / ``micro_g`` style specifications [m/s^2].
G0 = 9.80665

DEG = np.pi / 180.0
ARCMIN = DEG / 60.0
ARCSEC = DEG / 3600.0
HOUR = 3600.0


def deg(x):
    """Degrees -> radians."""
    return np.multiply(x, DEG)


def arcmin(x):
    """Arc-minutes -> radians."""
    return np.multiply(x, ARCMIN)


def arcsec(x):
    """Arc-seconds -> radians."""
    return np.multiply(x, ARCSEC)


def deg_per_h(x):
    """Gyro drift in deg/h -> rad/s."""
    return np.multiply(x, DEG / HOUR)


def deg_per_sqrt_h(x):
    """Angle random walk in deg/sqrt(h) -> rad/sqrt(s)."""
    return np.multiply(x, DEG / np.sqrt(HOUR))


def g(x):
    """Acceleration in units of standard gravity -> m/s^2."""
    return np.multiply(x, G0)


def milli_g(x):
    """Acceleration in mg -> m/s^2."""
    return np.multiply(x, 1e-3 * G0)


def micro_g(x):
    """Acceleration in micro-g -> m/s^2."""
    return np.multiply(x, 1e-6 * G0)


def g_per_sqrt_hz(x):
    """Velocity random walk in g/sqrt(Hz) -> m/s^2/sqrt(Hz) = m/s/sqrt(s)."""
    return np.multiply(x, G0)


def milligal(x):
    """Acceleration in mGal -> m/s^2."""
    return np.multiply(x, 1e-5)


def ppm(x):
    """Parts per million -> a fraction."""
    return np.multiply(x, 1e-6)


def mps_per_sqrt_h(x):
    """Velocity random walk in m/s/sqrt(h) -> m/s/sqrt(s)."""
    return np.divide(x, np.sqrt(HOUR))


def to_deg(x):
    """Radians -> degrees."""
    return np.divide(x, DEG)


def to_arcmin(x):
    """Radians -> arc-minutes."""
    return np.divide(x, ARCMIN)


def to_arcsec(x):
    """Radians -> arc-seconds."""
    return np.divide(x, ARCSEC)


def to_deg_per_h(x):
    """rad/s -> deg/h."""
    return np.divide(x, DEG / HOUR)


def to_micro_g(x):
    """m/s^2 -> micro-g."""
    return np.divide(x, 1e-6 * G0)


def to_deg_per_sqrt_h(x):
    """rad/sqrt(s) -> deg/sqrt(h)."""
    return np.divide(x, DEG / np.sqrt(HOUR))


def to_milligal(x):
    """m/s^2 -> mGal."""
    return np.divide(x, 1e-5)


def to_mps_per_sqrt_h(x):
    """m/s/sqrt(s) -> m/s/sqrt(h)."""
    return np.multiply(x, np.sqrt(HOUR))


#: Names accepted in configuration files, mapped to their converter into SI.
CONVERTERS = {
    "rad": lambda x: np.asarray(x, dtype=float),
    "m": lambda x: np.asarray(x, dtype=float),
    "s": lambda x: np.asarray(x, dtype=float),
    "m/s": lambda x: np.asarray(x, dtype=float),
    "m/s^2": lambda x: np.asarray(x, dtype=float),
    "deg": deg,
    "arcmin": arcmin,
    "arcsec": arcsec,
    "deg/h": deg_per_h,
    "deg/sqrt(h)": deg_per_sqrt_h,
    "g": g,
    "mg": milli_g,
    "ug": micro_g,
    "g/sqrt(Hz)": g_per_sqrt_hz,
}
