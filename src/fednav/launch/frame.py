"""Launch inertial frame (LI), its relation to ECI, ECEF and geodetic coordinates, and
zonal gravitation.

Frames (every array says which one it is in by its name suffix ``_li``, ``_eci``,
``_ecef``; all SI):

* **ECEF** — WGS-84 Earth-centred, Earth-fixed.
* **ECI** — Earth-centred inertial with its z axis along the Earth's rotation axis and its
  x axis toward the Earth-rotation-angle origin (a "true of date" frame frozen at the
  launch epoch; precession, nutation and polar motion are ignored, which over a 500 s
  ascent is far below any sensor error).  ``r_ecef = R3(theta(t)) r_eci`` with
  ``theta(t) = ERA(epoch) + OMEGA_IE t`` and ``R3(a)`` the frame rotation about z.
* **LI** — launch inertial frame: origin at the launch point, frozen in inertial space at
  the launch epoch.  ``x`` horizontal toward the launch azimuth (from north toward east),
  ``y`` along the geodetic vertical (up), ``z = x × y`` (to the right of the firing
  direction: south for an eastward launch).  ``r_eci = r0_eci + C_eci_li r_li``.

Gravitation (no centrifugal term: LI is inertial) is the gradient of the zonal potential
``U = GM/r [1 - J2 (a/r)^2 P2(sin phi) - J4 (a/r)^4 P4(sin phi)]`` in ECI.  With the WGS-84
normal-field J2 and J4, gravitation plus the centrifugal acceleration of the rotating
Earth equals fednav's normal gravity (:func:`fednav.core.earth.gravity`) on the ellipsoid to
about 1e-7 m/s^2 (tested); the J2-only model (``degree=2``) differs by the J4 term:
4.7e-5 m/s^2 at 32 deg latitude, up to 1.2e-4 m/s^2 near the poles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import UTC, datetime

import numba
import numpy as np

from ..core import earth

#: WGS-84 normal-field zonal coefficients (the field whose gravity is Somigliana's).
J2 = 1.082629821313e-3
J4 = -2.370912220e-6
_JD_J2000 = 2451545.0


def earth_rotation_angle(epoch: datetime) -> float:
    """Earth rotation angle [rad] at ``epoch`` (UTC taken as UT1; IERS 2003 formula)."""
    if epoch.tzinfo is None:
        epoch = epoch.replace(tzinfo=UTC)
    jd = (epoch - datetime(2000, 1, 1, 12, tzinfo=UTC)).total_seconds() / 86400.0
    era = 2.0 * math.pi * (0.7790572732640 + 1.00273781191135448 * jd)
    return era % (2.0 * math.pi)


def r3(angle):
    """Frame rotation about z by ``angle`` [rad] (scalar or (N,)): ``v' = R3 v``."""
    a = np.asarray(angle, dtype=float)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def ecef_to_geodetic(r_ecef) -> np.ndarray:
    """ECEF (..., 3) [m] -> geodetic (..., 3): latitude, longitude [rad], height [m].

    Iterates latitude on the exact relation (converges to 1e-12 rad in a few steps for
    any height from the Earth's centre region excluded to deep space)."""
    r = np.asarray(r_ecef, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    lat = np.arctan2(z, p * (1.0 - earth.E2))
    for _ in range(8):
        s = np.sin(lat)
        rn = earth.A / np.sqrt(1.0 - earth.E2 * s * s)
        lat = np.arctan2(z + earth.E2 * rn * s, p)
    s, c = np.sin(lat), np.cos(lat)
    rn = earth.A / np.sqrt(1.0 - earth.E2 * s * s)
    # Height from whichever of the two expressions is better conditioned.
    h = np.where(np.abs(c) > 0.1, p / np.where(c == 0, 1.0, c) - rn,
                 z / np.where(s == 0, 1.0, s) - rn * (1.0 - earth.E2))
    return np.stack([lat, lon, h], axis=-1)


def enu_axes_ecef(lat, lon) -> np.ndarray:
    """C_enu^ecef (..., 3, 3): columns are the east, north, up unit vectors in ECEF."""
    sl, cl = np.sin(lat), np.cos(lat)
    so, co = np.sin(lon), np.cos(lon)
    z = np.zeros_like(np.asarray(sl))
    e = np.stack([-so, co, z], -1)
    n = np.stack([-sl * co, -sl * so, cl], -1)
    u = np.stack([cl * co, cl * so, sl], -1)
    return np.stack([e, n, u], -1)


@numba.njit(cache=True, inline="always")
def gravitation_xyz(x, y, z, degree):
    """Zonal gravitation (gx, gy, gz) [m/s^2] at ECI position (x, y, z) [m] (scalars);
    ``degree`` 2 (J2) or 4 (J2 + J4)."""
    rr = math.sqrt(x * x + y * y + z * z)
    ux, uy, uz = x / rr, y / rr, z / rr
    s = uz
    mu = earth.GM
    # Central term.
    k = -mu / (rr * rr)
    gx, gy, gz = k * ux, k * uy, k * uz
    # Term -mu J a^n P(s)/r^(n+1): gradient -mu J a^n / r^(n+2) [P'(s)(e_z - s u) - (n+1) P u].
    ar = earth.A / rr
    P2, dP2 = 0.5 * (3.0 * s * s - 1.0), 3.0 * s
    c2 = -mu * J2 * ar * ar / (rr * rr)
    rad = -dP2 * s - 3.0 * P2
    gx += c2 * rad * ux
    gy += c2 * rad * uy
    gz += c2 * (dP2 + rad * uz)
    if degree >= 4:
        s2 = s * s
        P4 = (35.0 * s2 * s2 - 30.0 * s2 + 3.0) / 8.0
        dP4 = (35.0 * s2 * s - 15.0 * s) / 2.0
        c4 = -mu * J4 * ar**4 / (rr * rr)
        rad = -dP4 * s - 5.0 * P4
        gx += c4 * rad * ux
        gy += c4 * rad * uy
        gz += c4 * (dP4 + rad * uz)
    return gx, gy, gz


@numba.njit(cache=True, inline="always")
def gravitation_li_xyz(x, y, z, r0, C, degree):
    """Gravitation in LI (3 scalars) at LI position (x, y, z); ``r0`` = launch point in ECI,
    ``C`` = C_eci_li (the frame's constants)."""
    ex = r0[0] + C[0, 0] * x + C[0, 1] * y + C[0, 2] * z
    ey = r0[1] + C[1, 0] * x + C[1, 1] * y + C[1, 2] * z
    ez = r0[2] + C[2, 0] * x + C[2, 1] * y + C[2, 2] * z
    gx, gy, gz = gravitation_xyz(ex, ey, ez, degree)
    return (C[0, 0] * gx + C[1, 0] * gy + C[2, 0] * gz,
            C[0, 1] * gx + C[1, 1] * gy + C[2, 1] * gz,
            C[0, 2] * gx + C[1, 2] * gy + C[2, 2] * gz)


@numba.njit(cache=True)
def gravitation_eci(r, degree=4):
    """Zonal gravitation [m/s^2] at ECI position ``r`` (3,) [m]."""
    out = np.empty(3)
    out[0], out[1], out[2] = gravitation_xyz(r[0], r[1], r[2], degree)
    return out


@numba.njit(cache=True)
def gravitation_li_nb(r_li, r0_eci, C_eci_li, degree):
    """Gravitation in LI at LI position ``r_li`` (compiled; the frame's constants passed in)."""
    out = np.empty(3)
    out[0], out[1], out[2] = gravitation_li_xyz(r_li[0], r_li[1], r_li[2], r0_eci, C_eci_li,
                                                degree)
    return out


@dataclass(frozen=True)
class LaunchFrame:
    """The launch inertial frame of a launch at ``lla`` (lat, lon [rad], h [m]) toward
    ``azimuth`` [rad from north toward east] at ``epoch`` (UTC).

    ``degree``: zonal gravitation model, 2 (J2) or 4 (J2 + J4, the default).
    """

    lla: tuple[float, float, float]
    azimuth: float
    epoch: datetime = datetime(2014, 11, 1, tzinfo=UTC)
    degree: int = 4
    theta0: float = field(init=False)
    C_ecef_li: np.ndarray = field(init=False, repr=False)
    C_eci_li: np.ndarray = field(init=False, repr=False)
    r0_ecef: np.ndarray = field(init=False, repr=False)
    r0_eci: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if self.degree not in (2, 4):
            raise ValueError(f"LaunchFrame: gravitation degree must be 2 or 4, got "
                             f"{self.degree}")
        lat, lon, h = (float(v) for v in self.lla)
        A = enu_axes_ecef(lat, lon)
        sa, ca = math.sin(self.azimuth), math.cos(self.azimuth)
        x = sa * A[:, 0] + ca * A[:, 1]
        y = A[:, 2]
        C_ecef_li = np.column_stack([x, y, np.cross(x, y)])
        theta0 = earth_rotation_angle(self.epoch)
        R = r3(theta0)  # ECI -> ECEF at t = 0
        r0 = earth.llh_to_ecef(lat, lon, h)
        object.__setattr__(self, "theta0", theta0)
        object.__setattr__(self, "C_ecef_li", C_ecef_li)
        object.__setattr__(self, "C_eci_li", R.T @ C_ecef_li)
        object.__setattr__(self, "r0_ecef", r0)
        object.__setattr__(self, "r0_eci", R.T @ r0)

    # --- rotations ------------------------------------------------------------------
    def C_ecef_eci(self, t) -> np.ndarray:
        """ECI -> ECEF rotation at time ``t`` [s since launch] (scalar or (N,))."""
        return r3(self.theta0 + earth.OMEGA_IE * np.asarray(t, dtype=float))

    def C_ecef_li_at(self, t) -> np.ndarray:
        """LI -> ECEF rotation at ``t``: ``v_ecef = C @ v_li``."""
        return self.C_ecef_eci(t) @ self.C_eci_li

    # --- positions --------------------------------------------------------------------
    def li_to_eci(self, r_li) -> np.ndarray:
        return self.r0_eci + np.asarray(r_li, dtype=float) @ self.C_eci_li.T

    def li_to_ecef(self, r_li, t) -> np.ndarray:
        R = self.C_ecef_eci(t)
        return (np.einsum("...ij,...j->...i", R @ self.C_eci_li, r_li)
                + np.einsum("...ij,j->...i", R, self.r0_eci))

    def ecef_to_li(self, r_ecef, t) -> np.ndarray:
        R = self.C_ecef_eci(t)
        d = np.asarray(r_ecef, dtype=float) - np.einsum("...ij,j->...i", R, self.r0_eci)
        return np.einsum("...ji,...j->...i", R @ self.C_eci_li, d)

    def li_to_geodetic(self, r_li, t) -> np.ndarray:
        return ecef_to_geodetic(self.li_to_ecef(r_li, t))

    def geodetic_to_li(self, lla, t) -> np.ndarray:
        lla = np.asarray(lla, dtype=float)
        return self.ecef_to_li(earth.llh_to_ecef(lla[..., 0], lla[..., 1], lla[..., 2]), t)

    # --- gravitation ----------------------------------------------------------------------
    def gravity_li(self, r_li) -> np.ndarray:
        """Gravitation [m/s^2] in LI at LI positions ``r_li`` (..., 3)."""
        r = np.asarray(r_li, dtype=float)
        flat = r.reshape(-1, 3)
        out = np.array([gravitation_li_nb(np.ascontiguousarray(p), self.r0_eci,
                                          self.C_eci_li, self.degree) for p in flat])
        return out.reshape(r.shape)
