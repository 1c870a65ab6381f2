"""WGS-84 Earth model: radii of curvature, normal gravity, Earth rate, transport rate.

All functions accept scalars or numpy arrays (broadcast elementwise) and are also
compiled with numba (the ``*_nb`` names) for use inside per-sample loops.

Frames: navigation frame ENU; latitude ``lat`` and longitude ``lon`` in radians,
height ``h`` in metres above the ellipsoid, velocities ``[vE, vN, vU]`` in m/s.
"""

from __future__ import annotations

import numba
import numpy as np
from numba.extending import register_jitable

A = 6378137.0  #: semi-major axis [m]
F = 1.0 / 298.257223563  #: flattening
E2 = F * (2.0 - F)  #: first eccentricity squared
OMEGA_IE = 7.292115e-5  #: Earth rotation rate [rad/s]
GM = 3.986004418e14  #: gravitational constant [m^3/s^2]

# Somigliana normal gravity constants (WGS-84) and the free-air height terms.
_GE = 9.7803253359
_K = 0.00193185265241


def radii(lat):
    """Meridian (R_M) and prime-vertical (R_N) radii of curvature [m] at latitude ``lat``."""
    return radii_of_sin2(np.sin(lat) ** 2)


@register_jitable
def radii_of_sin2(s2):
    """:func:`radii` from the squared sine of the latitude (for compiled loops that
    already hold it; plain Python, and callable from compiled code)."""
    w = 1.0 - E2 * s2
    rn = A / np.sqrt(w)
    rm = rn * (1.0 - E2) / w
    return rm, rn


def gravity(lat, h):
    """Magnitude of normal gravity [m/s^2] (Somigliana + second-order height terms).

    The gravity vector in ENU is ``[0, 0, -gravity(lat, h)]``.
    """
    return gravity_of_sin2(np.sin(lat) ** 2, h)


def gravity_of_sin2(s2, h):
    """:func:`gravity` from the squared sine of the latitude (for compiled loops that
    already hold it)."""
    g0 = _GE * (1.0 + _K * s2) / np.sqrt(1.0 - E2 * s2)
    # Height dependence of normal gravity (free-air gradient with latitude term).
    m = OMEGA_IE**2 * A**3 * (1.0 - F) / GM  # omega^2 a^2 b / GM
    return g0 * (1.0 - 2.0 / A * (1.0 + F + m - 2.0 * F * s2) * h + 3.0 / A**2 * h * h)


def earth_rate(lat):
    """Earth rotation rate in the ENU frame, shape (..., 3) [rad/s]."""
    lat = np.asarray(lat, dtype=float)
    z = np.zeros_like(lat)
    return np.stack([z, OMEGA_IE * np.cos(lat), OMEGA_IE * np.sin(lat)], axis=-1)


def transport_rate(lat, h, vel):
    """Transport rate omega_en^n in ENU, shape (..., 3) [rad/s] for ENU velocity ``vel``."""
    rm, rn = radii(lat)
    vel = np.asarray(vel, dtype=float)
    ve, vn = vel[..., 0], vel[..., 1]
    return np.stack(
        [-vn / (rm + h), ve / (rn + h), ve * np.tan(lat) / (rn + h)], axis=-1
    )


def north_turn(t, lla, vel) -> np.ndarray:
    """How far north has turned about up since ``t[0]`` [rad], at each time ``t`` [s]:
    the trapezoidal integral of the navigation frame's rate about up, ``W sin(lat) +
    vE tan(lat) / (RN + h)``, along the positions ``lla`` (N, 3) [rad, rad, m] and ENU
    velocities ``vel`` (N, 3) [m/s].  A course measured from north turns by it while a
    gyro does not (1.3 deg/s at 89.9 deg and 250 m/s east)."""
    lla = np.asarray(lla, dtype=float)
    w = earth_rate(lla[:, 0])[:, 2] + transport_rate(lla[:, 0], lla[:, 2], vel)[:, 2]
    return np.r_[0.0, np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))]


def llh_to_ecef(lat, lon, h):
    """Geodetic latitude, longitude [rad], height [m] -> ECEF coordinates, shape (..., 3) [m]."""
    _, rn = radii(lat)
    cl, sl = np.cos(lat), np.sin(lat)
    xyz = [(rn + h) * cl * np.cos(lon), (rn + h) * cl * np.sin(lon), (rn * (1 - E2) + h) * sl]
    if np.ndim(xyz[0]) == 0 and np.ndim(xyz[2]) == 0:  # one point (the same values, quicker)
        return np.array(xyz, dtype=float)
    return np.stack(xyz, axis=-1)


@register_jitable
def wrap_lon(a):
    """A longitude or longitude difference [rad] wrapped to (-pi, pi]: returned unchanged,
    bit for bit, when it lies there already (scalar; plain Python, and callable from
    compiled code; arrays: :func:`wrap_lon_array`)."""
    if -np.pi < a <= np.pi:
        return a
    r = (a + np.pi) % (2.0 * np.pi) - np.pi
    return r + 2.0 * np.pi if r <= -np.pi else r


def wrap_lon_array(a) -> np.ndarray:
    """:func:`wrap_lon` elementwise on an array [rad]."""
    a = np.asarray(a, dtype=float)
    r = (a + np.pi) % (2.0 * np.pi) - np.pi
    r = np.where(r <= -np.pi, r + 2.0 * np.pi, r)
    return np.where((a > -np.pi) & (a <= np.pi), a, r)


def ecef_to_llh(r) -> np.ndarray:
    """ECEF coordinates (..., 3) [m] -> geodetic latitude, longitude [rad] in (-pi, pi],
    height [m] above the ellipsoid, shape (..., 3) (inverse of :func:`llh_to_ecef`).

    Bowring's iteration on the reduced latitude (five steps: the round trip with
    :func:`llh_to_ecef` at rounding level from below the surface to 30 km up, the poles
    included, ``tests/test_polar.py``)."""
    r = np.asarray(r, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    b = A * (1.0 - F)
    ep2 = E2 / (1.0 - E2)
    beta = np.arctan2(z, (1.0 - F) * p)
    for _ in range(5):
        lat = np.arctan2(z + ep2 * b * np.sin(beta) ** 3, p - E2 * A * np.cos(beta) ** 3)
        beta = np.arctan2((1.0 - F) * np.sin(lat), np.cos(lat))
    sl, cl = np.sin(lat), np.cos(lat)
    rn = A / np.sqrt(1.0 - E2 * sl * sl)
    h = p * cl + z * sl - rn * (1.0 - E2 * sl * sl)  # exact at any latitude
    return np.stack([lat, np.arctan2(y, x), h], axis=-1)


def enu_to_ecef(lat, lon) -> np.ndarray:
    """C_n^e (..., 3, 3): the columns are the east, north and up unit vectors in ECEF."""
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    if np.ndim(sl) == 0 and np.ndim(co) == 0:  # one point (the same values, quicker)
        return np.array([[-so, -sl * co, cl * co], [co, -sl * so, cl * so], [0.0, cl, sl]],
                        dtype=float)
    z = np.zeros_like(sl)
    return np.stack([np.stack([-so, -sl * co, cl * co], -1),
                     np.stack([co, -sl * so, cl * so], -1),
                     np.stack([z, cl, sl], -1)], -2)


@register_jitable
def moved(lat, lon, h, de, dn, du):
    """Latitude, longitude, height moved by ``de``, ``dn``, ``du`` metres east, north, up
    (radii of curvature at the start; scalars or arrays; compiled: :func:`moved_nb`)."""
    rm, rn = radii_of_sin2(np.sin(lat) ** 2)
    return lat + dn / (rm + h), lon + de / ((rn + h) * np.cos(lat)), h + du


def move_enu(lla, d_enu) -> np.ndarray:
    """Positions ``lla`` (..., 3) moved by ``d_enu`` (..., 3) metres east, north, up (the
    inverse of :func:`llh_difference_enu`, radii of curvature at ``lla``)."""
    lla = np.asarray(lla, dtype=float)
    d = np.asarray(d_enu, dtype=float)
    return np.stack(moved(lla[..., 0], lla[..., 1], lla[..., 2], d[..., 0], d[..., 1],
                          d[..., 2]), axis=-1)


def lever_arm_point(lla, vel, C, omega, lever):
    """Position and ENU velocity of a point at ``lever`` (body right-forward-up, m) from
    the IMU at ``lla`` (..., 3) with ENU velocity ``vel``, attitude ``C`` = C_b^n
    (..., 3, 3) and body rate ``omega`` (..., 3) [rad/s]: ``move_enu(lla, C l)`` and
    ``vel + C (omega x l)``."""
    lever = np.asarray(lever, dtype=float)
    return move_enu(lla, C @ lever), lever_arm_velocity(vel, C, omega, lever)


def lever_arm_velocity(vel, C, omega, lever) -> np.ndarray:
    """ENU velocity of a point at ``lever`` (body right-forward-up, m) from the IMU with
    ENU velocity ``vel`` (..., 3), attitude ``C`` = C_b^n (..., 3, 3) and body rate
    ``omega`` (..., 3) [rad/s]: ``vel + C (omega x l)``."""
    return vel + np.einsum("...ij,...j->...i", C, np.cross(omega, np.asarray(lever,
                                                                         dtype=float)))


def llh_difference_enu(lat, lon, h, lat_ref, lon_ref, h_ref):
    """Small position difference (lat, lon, h) - reference, expressed in metres ENU.

    Uses the local radii of curvature at the reference; exact to first order, which is
    what error statistics over kilometre-scale errors need.  The longitude difference is
    wrapped to +-180 deg (a track crossing the antimeridian; longitudes in 0..360 against
    -180..180).
    """
    rm, rn = radii(lat_ref)
    dlon = wrap_lon_array(np.asarray(lon) - lon_ref)
    de = dlon * (rn + h_ref) * np.cos(lat_ref)
    dn = (np.asarray(lat) - lat_ref) * (rm + h_ref)
    du = np.asarray(h) - h_ref
    return np.stack(np.broadcast_arrays(de, dn, du), axis=-1)




def gravity_gradient(lat, h):
    """-d(gravity)/dh [1/s^2]: the vertical-channel instability coefficient (~2g/R)."""
    s2 = np.sin(lat) ** 2
    g0 = _GE * (1.0 + _K * s2) / np.sqrt(1.0 - E2 * s2)
    m = OMEGA_IE**2 * A**3 * (1.0 - F) / GM
    return g0 * (2.0 / A * (1.0 + F + m - 2.0 * F * s2) - 6.0 / A**2 * h)


def gravity_dlat(lat):
    """d(gravity)/d(latitude) at the ellipsoid surface [m/s^2 per rad]."""
    s = np.sin(lat)
    w = 1.0 - E2 * s * s
    return _GE * np.sin(2 * lat) * (_K / np.sqrt(w) + (1.0 + _K * s * s) * E2 / (2.0 * w**1.5))


radii_of_sin2_nb = numba.njit(cache=True)(radii_of_sin2)


@numba.njit(cache=True)
def radii_nb(lat):
    """Compiled :func:`radii`."""
    return radii_of_sin2_nb(np.sin(lat) ** 2)


gravity_of_sin2_nb = numba.njit(cache=True)(gravity_of_sin2)


@numba.njit(cache=True)
def gravity_nb(lat, h):
    """Compiled :func:`gravity`."""
    return gravity_of_sin2_nb(np.sin(lat) ** 2, h)


moved_nb = numba.njit(cache=True)(moved)
gravity_gradient_nb = numba.njit(cache=True)(gravity_gradient)
gravity_dlat_nb = numba.njit(cache=True)(gravity_dlat)
