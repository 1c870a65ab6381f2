"""Truth and measurements for the consistency certificate, owing nothing to fednav's
simulator or sensor code (numpy only).

The certificate (:mod:`fednav.campaign.certify`) flies fednav's navigator on data made
here, so that a mistake shared by fednav's simulator and its filter (a lever arm applied
with the wrong sign in both, say) cannot cancel out.  Everything this module needs is
written out again from its definition: the WGS-84 ellipsoid and its geodetic /
Earth-centred conversions, Somigliana's normal gravity with its height terms, the
Euler-angle convention of ``docs/conventions.md`` (``C_b^n = Rz(-psi) Rx(theta)
Ry(gamma)``, body right-forward-up, ENU), the IMU's error processes, and each sensor's
measurement equation.

**Motion.**  A vehicle's reference point ``P`` moves in the Earth-fixed tangent frame
``T`` (east, north, up at the start point): the frame ``V`` of the vehicle has Euler angles
``psi(t), theta(t), gamma(t)`` in ``T`` and its reference point moves along ``V``'s
forward axis at the speed ``s(t)``, plus a constant wind (an aircraft's air-relative
velocity is along its nose).  Every one of the four signals is a constant plus quintic
smooth steps (continuous with their first two derivatives), so the angles, their rates
and accelerations, the speed and the acceleration are closed-form; the position is
their integral by Gauss-Legendre quadrature (4 nodes per IMU interval: exact to
rounding for these signals).  The body (the IMU's axes) is ``V`` turned by a fixed
mounting ``C_b^V`` and the IMU sits at ``P - C_b^T l_ref``: a land vehicle's reference
point is the wheel-ground contact point of its non-holonomic constraint, which moves
exactly along that constraint's forward axis whatever its lever arm and mounting.

**IMU.**  The ideal increments are the integrals over each IMU interval (4 Gauss-Legendre
nodes) of the body rate ``w_ib^b = C_e^b w_ie^e + w_Tb^b`` and of the specific force
``f^b = C_e^b (r'' + 2 w_ie x r' - g)`` in Earth-centred Earth-fixed axes, with the normal
gravity ``g = -gamma(lat, h) u_up``.  The errors added (:func:`corrupt_imu`): a turn-on
bias per axis (drawn per run), a first-order Gauss-Markov gyro drift (stationary,
exact discretisation) and white noise on the increments (``arw sqrt(dt)``, ``vrw
sqrt(dt)``).

**Sensors.**  :func:`measure` gives each registered sensor's values in fednav's layout
(``docs/data-formats.md``) from the truth at the sensor's point (its lever arm, body
right-forward-up) and in its axes (its mounting ``M = C_s^b``), with white noise of the
sigmas the filter is told.  Units: SI throughout (radians, metres, m/s, tesla).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# ------------------------------------------------------------------- WGS-84, gravity
A = 6378137.0  #: semi-major axis [m]
F = 1.0 / 298.257223563  #: flattening [-]
E2 = F * (2.0 - F)  #: first eccentricity squared [-]
B = A * (1.0 - F)  #: semi-minor axis [m]
W_IE = 7.292115e-5  #: Earth rotation rate [rad/s]
GM = 3.986004418e14  #: Earth's gravitational constant [m^3/s^2]
GAMMA_E = 9.7803253359  #: normal gravity at the equator [m/s^2]
K_SOMIGLIANA = 0.00193185265241  #: Somigliana's constant [-]


def radii(lat):
    """Meridian and prime-vertical radii of curvature [m] at geodetic latitude ``lat``
    [rad]."""
    w = 1.0 - E2 * np.sin(lat) ** 2
    return A * (1.0 - E2) / w**1.5, A / np.sqrt(w)


def geodetic_to_ecef(lla) -> np.ndarray:
    """Earth-centred Earth-fixed position [m] of geodetic ``lla`` (..., 3): latitude,
    longitude [rad], ellipsoidal height [m]."""
    lla = np.asarray(lla, dtype=float)
    lat, lon, h = lla[..., 0], lla[..., 1], lla[..., 2]
    _, rn = radii(lat)
    c = np.cos(lat)
    return np.stack([(rn + h) * c * np.cos(lon), (rn + h) * c * np.sin(lon),
                     (rn * (1.0 - E2) + h) * np.sin(lat)], axis=-1)


def ecef_to_geodetic(r) -> np.ndarray:
    """Geodetic latitude, longitude [rad] and height [m] of Earth-centred positions
    ``r`` (..., 3) [m]: fixed-point iteration on the latitude from Bowring's start,
    to below 1e-15 rad (8 passes; far from the poles, as the certificate's flights)."""
    r = np.asarray(r, dtype=float)
    x, y, z = r[..., 0], r[..., 1], r[..., 2]
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    u = np.arctan2(z * A, p * B)
    ep2 = E2 / (1.0 - E2)
    lat = np.arctan2(z + ep2 * B * np.sin(u) ** 3, p - E2 * A * np.cos(u) ** 3)
    for _ in range(8):
        _, rn = radii(lat)
        h = p / np.cos(lat) - rn
        lat = np.arctan2(z, p * (1.0 - E2 * rn / (rn + h)))
    _, rn = radii(lat)
    h = p / np.cos(lat) - rn
    return np.stack([lat, lon, h], axis=-1)


def c_n_e(lat, lon) -> np.ndarray:
    """``C_n^e`` (..., 3, 3): the columns are the east, north and up unit vectors of the
    local-level frame at ``lat``, ``lon`` [rad] in Earth-centred axes."""
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    z = np.zeros_like(sl)
    east = np.stack([-so, co, z], axis=-1)
    north = np.stack([-sl * co, -sl * so, cl], axis=-1)
    up = np.stack([cl * co, cl * so, sl], axis=-1)
    return np.stack([east, north, up], axis=-1)


def normal_gravity(lat, h):
    """Magnitude of WGS-84 normal gravity [m/s^2] at latitude ``lat`` [rad] and height
    ``h`` [m]: Somigliana's formula with the free-air terms to second order in ``h``
    (Groves 2013, eq. 2.134 and 2.139)."""
    s2 = np.sin(lat) ** 2
    g0 = GAMMA_E * (1.0 + K_SOMIGLIANA * s2) / np.sqrt(1.0 - E2 * s2)
    m = W_IE**2 * A**2 * B / GM
    return g0 * (1.0 - 2.0 / A * (1.0 + F + m - 2.0 * F * s2) * h + 3.0 / A**2 * h**2)


def move_metric(lla, d_enu) -> np.ndarray:
    """Positions ``lla`` (N, 3) moved by small east, north, up offsets ``d_enu`` [m]
    (radii at each position)."""
    lla = np.array(lla, dtype=float)
    rm, rn = radii(lla[:, 0])
    d = np.asarray(d_enu, dtype=float)
    lla[:, 0] += d[:, 1] / (rm + lla[:, 2])
    lla[:, 1] += d[:, 0] / ((rn + lla[:, 2]) * np.cos(lla[:, 0]))
    lla[:, 2] += d[:, 2]
    return lla


def metric_difference(lla, lla_ref) -> np.ndarray:
    """``lla - lla_ref`` as east, north, up metres (N, 3) at the reference (longitude
    difference wrapped to +-pi)."""
    lla, ref = np.asarray(lla, dtype=float), np.asarray(lla_ref, dtype=float)
    rm, rn = radii(ref[:, 0])
    dlon = (lla[:, 1] - ref[:, 1] + np.pi) % (2 * np.pi) - np.pi
    return np.column_stack([dlon * (rn + ref[:, 2]) * np.cos(ref[:, 0]),
                            (lla[:, 0] - ref[:, 0]) * (rm + ref[:, 2]),
                            lla[:, 2] - ref[:, 2]])


# ---------------------------------------------------------------------------- attitude
def _rot(axis: int, a, order: int = 0) -> np.ndarray:
    """The rotation matrix (..., 3, 3) by angle ``a`` about body axis ``axis`` (0 x, 1 y,
    2 z; vectors rotated, right-handed), or its ``order``-th derivative in ``a``."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    dc, ds = [(c, s), (-s, c), (-c, -s)][order]
    one = 1.0 if order == 0 else 0.0
    R = np.zeros(a.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R[..., axis, axis] = one
    R[..., i, i] = dc
    R[..., j, j] = dc
    R[..., i, j] = -ds
    R[..., j, i] = ds
    return R


def euler_to_dcm(euler) -> np.ndarray:
    """``C_b^n`` (..., 3, 3) of Euler angles (..., 3) ``[pitch, roll, heading]`` [rad]:
    ``Rz(-heading) Rx(pitch) Ry(roll)`` (docs/conventions.md)."""
    e = np.asarray(euler, dtype=float)
    return _rot(2, -e[..., 2]) @ _rot(0, e[..., 0]) @ _rot(1, e[..., 1])


def dcm_to_euler(C) -> np.ndarray:
    """Euler angles ``[pitch, roll, heading]`` [rad] (heading in [0, 2 pi)) of ``C_b^n``."""
    C = np.asarray(C, dtype=float)
    pitch = np.arcsin(np.clip(C[..., 2, 1], -1.0, 1.0))
    roll = np.arctan2(-C[..., 2, 0], C[..., 2, 2])
    heading = np.mod(np.arctan2(C[..., 0, 1], C[..., 1, 1]), 2 * np.pi)
    return np.stack([pitch, roll, heading], axis=-1)


def euler_dcm_rates(e, de, dde):
    """``C``, ``dC/dt`` and ``d2C/dt2`` of ``C = Rz(-psi) Rx(theta) Ry(gamma)`` for Euler
    angles ``e`` (..., 3) ``[theta, gamma, psi]`` with rates ``de`` and accelerations
    ``dde`` [rad, rad/s, rad/s^2]."""
    # the three factors as functions of time: value, first and second time derivative
    def factor(axis, a, da, dda, sign):
        R0 = _rot(axis, sign * a)
        R1 = _rot(axis, sign * a, 1) * (sign * da)[..., None, None]
        R2 = (_rot(axis, sign * a, 2) * (da * da)[..., None, None]
              + _rot(axis, sign * a, 1) * (sign * dda)[..., None, None])
        return R0, R1, R2

    Z = factor(2, e[..., 2], de[..., 2], dde[..., 2], -1.0)
    X = factor(0, e[..., 0], de[..., 0], dde[..., 0], 1.0)
    Y = factor(1, e[..., 1], de[..., 1], dde[..., 1], 1.0)
    C = Z[0] @ X[0] @ Y[0]
    C1 = Z[1] @ X[0] @ Y[0] + Z[0] @ X[1] @ Y[0] + Z[0] @ X[0] @ Y[1]
    C2 = (Z[2] @ X[0] @ Y[0] + Z[0] @ X[2] @ Y[0] + Z[0] @ X[0] @ Y[2]
          + 2.0 * (Z[1] @ X[1] @ Y[0] + Z[1] @ X[0] @ Y[1] + Z[0] @ X[1] @ Y[1]))
    return C, C1, C2


def unskew(W) -> np.ndarray:
    """The vector ``w`` of a skew-symmetric ``[w x]`` (..., 3, 3) (its antisymmetric part)."""
    return 0.5 * np.stack([W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0],
                           W[..., 1, 0] - W[..., 0, 1]], axis=-1)


def quat_to_dcm(q) -> np.ndarray:
    """``C_b^n`` (..., 3, 3) of unit quaternions ``q_b^n`` (..., 4), scalar first
    (Hamilton product)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)],
        -2)


def rotvec_to_dcm(v) -> np.ndarray:
    """``exp([v x])`` (..., 3, 3) of rotation vectors ``v`` (..., 3) [rad] (Rodrigues)."""
    v = np.asarray(v, dtype=float)
    a = np.linalg.norm(v, axis=-1)[..., None, None]
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    small = a < 1e-8
    s = np.where(small, 1.0 - a * a / 6.0, np.sin(a) / np.where(small, 1.0, a))
    c = np.where(small, 0.5 - a * a / 24.0, (1.0 - np.cos(a)) / np.where(small, 1.0, a * a))
    return np.eye(3) + s * K + c * (K @ K)


def dcm_to_rotvec(R) -> np.ndarray:
    """The rotation vector (..., 3) [rad] of rotation matrices ``R`` (angles below pi)."""
    R = np.asarray(R, dtype=float)
    c = np.clip(0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0), -1.0, 1.0)
    a = np.arccos(c)
    v = unskew(R)  # sin(a) * axis
    s = np.sin(a)
    k = np.where(a < 1e-8, 1.0 + a * a / 6.0, a / np.where(a < 1e-8, 1.0, s))
    return v * k[..., None]


# ---------------------------------------------------------------------------- motion
@dataclass(frozen=True)
class Ramp:
    """A smooth step of ``delta`` (the signal's unit) from ``start_s`` lasting
    ``duration_s`` [s]: ``delta S((t - start) / duration)`` with the quintic
    ``S(x) = 10 x^3 - 15 x^4 + 6 x^5`` (0 before, 1 after; rate and acceleration zero at
    both ends)."""

    start_s: float
    duration_s: float
    delta: float


def profile(t, x0: float, ramps) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value, rate and acceleration at times ``t`` [s] of ``x0`` plus the smooth steps
    ``ramps``."""
    t = np.asarray(t, dtype=float)
    x, dx, ddx = np.full(t.shape, float(x0)), np.zeros(t.shape), np.zeros(t.shape)
    for r in ramps:
        u = np.clip((t - r.start_s) / r.duration_s, 0.0, 1.0)
        inside = (u > 0.0) & (u < 1.0)
        x = x + r.delta * u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
        dx = dx + np.where(inside, r.delta * 30.0 * u * u * (1.0 - u) ** 2 / r.duration_s,
                           0.0)
        ddx = ddx + np.where(inside, r.delta * 60.0 * u * (1.0 - u) * (1.0 - 2.0 * u)
                             / r.duration_s**2, 0.0)
    return x, dx, ddx


@dataclass(frozen=True)
class Motion:
    """A vehicle's motion (see the module docstring): start point (``lat_deg``,
    ``lon_deg``, ``h_m``), ``duration_s`` [s], initial speed [m/s] and Euler angles [deg]
    of the vehicle frame in the tangent frame, the smooth steps of each (``speed`` in
    m/s, the angles in deg), and a constant ``wind_enu_mps`` (tangent-frame east, north,
    up [m/s]; the speed is then the air-relative one).  ``kind``: ``land`` or ``air``."""

    name: str
    kind: str
    duration_s: float
    lat_deg: float
    lon_deg: float
    h_m: float
    speed_mps: float
    heading_deg: float
    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    speed: tuple = ()
    heading: tuple = ()
    pitch: tuple = ()
    roll: tuple = ()
    wind_enu_mps: tuple = (0.0, 0.0, 0.0)

    def signals(self, t):
        """Euler angles ``[pitch, roll, heading]`` of the vehicle frame [rad], their rates
        and accelerations (each (N, 3)); speed [m/s] and its rate (N,)."""
        d = np.pi / 180.0
        p = profile(t, self.pitch_deg * d, [Ramp(r.start_s, r.duration_s, r.delta * d)
                                            for r in self.pitch])
        g = profile(t, self.roll_deg * d, [Ramp(r.start_s, r.duration_s, r.delta * d)
                                           for r in self.roll])
        h = profile(t, self.heading_deg * d, [Ramp(r.start_s, r.duration_s, r.delta * d)
                                              for r in self.heading])
        s, ds, _ = profile(t, self.speed_mps, self.speed)
        e = [np.stack([p[i], g[i], h[i]], axis=-1) for i in range(3)]
        return e[0], e[1], e[2], np.maximum(s, 0.0), ds

    def stopped(self, t) -> np.ndarray:
        """Whether the vehicle stands still at ``t`` [s] (speed exactly zero, no wind)."""
        s = self.signals(t)[3]
        return (s == 0.0) & (not np.any(self.wind_enu_mps))


#: Gauss-Legendre nodes on [0, 1] and weights (4 points).
_GL_X, _GL_W = np.polynomial.legendre.leggauss(4)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


@dataclass
class Truth:
    """The true trajectory on the IMU grid ``t`` (N + 1,) [s] and the ideal IMU
    increments of its N intervals.

    ``lla`` IMU position [rad, rad, m]; ``vel`` ENU velocity [m/s]; ``C`` ``C_b^n``;
    ``euler`` ``[pitch, roll, heading]`` [rad]; ``r_e``, ``v_e`` Earth-centred position
    [m] and velocity [m/s]; ``C_be`` ``C_b^e``; ``w_eb`` body rate relative to the Earth,
    body axes [rad/s]; ``w_ib`` body rate (what a gyro reads) [rad/s]; ``stopped`` the
    vehicle stands still; ``wind`` ENU wind at the IMU [m/s]; ``dtheta``, ``dv`` (N, 3)
    ideal angle [rad] and velocity [m/s] increments, body right-forward-up.
    """

    motion: Motion
    dt: float
    t: np.ndarray
    lla: np.ndarray
    vel: np.ndarray
    C: np.ndarray
    euler: np.ndarray
    r_e: np.ndarray
    v_e: np.ndarray
    C_be: np.ndarray
    w_eb: np.ndarray
    w_ib: np.ndarray
    stopped: np.ndarray
    wind: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    cache: dict = field(default_factory=dict, repr=False)

    def point(self, lever) -> dict[str, np.ndarray]:
        """The point at ``lever`` (body right-forward-up [m]) at every grid time: ``lla``
        [rad, rad, m] and ENU velocity ``vel`` [m/s] in the local-level frame at that
        point (``r + C_b^e l`` and ``v + C_b^e (w_eb x l)``)."""
        lever = np.asarray(lever, dtype=float)
        key = tuple(lever)
        if key not in self.cache:
            r = self.r_e + self.C_be @ lever
            v = self.v_e + np.einsum("nij,nj->ni", self.C_be, np.cross(self.w_eb, lever))
            lla = ecef_to_geodetic(r)
            Cne = c_n_e(lla[:, 0], lla[:, 1])
            self.cache[key] = {"lla": lla, "vel": np.einsum("nji,nj->ni", Cne, v)}
        return self.cache[key]


def _kinematics(motion: Motion, t, M_v, l_ref):
    """At times ``t``: the vehicle frame's attitude and rates, the reference point's
    tangent-frame velocity and acceleration, and the IMU's offset from the reference
    point with its first two derivatives (tangent frame)."""
    e, de, dde, s, ds = motion.signals(t)
    CV, CV1, CV2 = euler_dcm_rates(e, de, dde)
    fwd = CV[..., :, 1]  # the vehicle frame's forward axis in T
    wind = np.asarray(motion.wind_enu_mps, dtype=float)
    vP = s[:, None] * fwd + wind
    aP = ds[:, None] * fwd + s[:, None] * CV1[..., :, 1]
    lb = M_v @ l_ref  # the reference point's lever in V axes
    off = -(CV @ lb)  # IMU - P
    off1, off2 = -(CV1 @ lb), -(CV2 @ lb)
    w_TV = unskew(np.swapaxes(CV, -1, -2) @ CV1)  # vehicle-frame rate in V axes
    return CV, w_TV, vP, aP, off, off1, off2


def make_truth(motion: Motion, dt: float, M_v=None, l_ref=(0.0, 0.0, 0.0)) -> Truth:
    """The truth of ``motion`` on the IMU grid of period ``dt`` [s]: the body is the
    vehicle frame turned by ``M_v = C_b^V`` (None: the vehicle frame itself) and the IMU
    sits at ``l_ref`` [m] (body axes) from the reference point (see the module
    docstring)."""
    M_v = np.eye(3) if M_v is None else np.asarray(M_v, dtype=float)
    l_ref = np.asarray(l_ref, dtype=float)
    n = int(round(motion.duration_s / dt))
    t = dt * np.arange(n + 1)
    d = np.pi / 180.0
    origin = np.array([motion.lat_deg * d, motion.lon_deg * d, motion.h_m])
    r0 = geodetic_to_ecef(origin)
    C_Te = c_n_e(origin[0], origin[1])
    w_ie_e = np.array([0.0, 0.0, W_IE])

    # the reference point's position: its velocity integrated by Gauss-Legendre
    tn = (t[:-1, None] + dt * _GL_X[None, :]).ravel()
    kn = _kinematics(motion, tn, M_v, l_ref)
    steps = dt * (kn[2].reshape(n, 4, 3) * _GL_W[None, :, None]).sum(axis=1)
    P = np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])

    # the grid
    CV, w_TV, vP, aP, off, off1, off2 = _kinematics(motion, t, M_v, l_ref)
    r_T = P + off
    r_e = r0 + r_T @ C_Te.T
    v_e = (vP + off1) @ C_Te.T
    lla = ecef_to_geodetic(r_e)
    Cne = c_n_e(lla[:, 0], lla[:, 1])
    C_be = C_Te @ CV @ M_v
    C = np.swapaxes(Cne, -1, -2) @ C_be
    w_eb = w_TV @ M_v  # M_v^T w (rows)
    w_ib = w_eb + np.einsum("nji,j->ni", C_be, w_ie_e)
    vel = np.einsum("nji,nj->ni", Cne, v_e)
    wind = np.einsum("nji,j->ni", Cne, C_Te @ np.asarray(motion.wind_enu_mps, dtype=float))

    # the IMU at the quadrature nodes: position by a second-order expansion from the grid
    # point before (its error, jerk dt^3 / 6, is far below what gravity notices)
    CVn, w_TVn, vPn, aPn, offn, off1n, off2n = kn
    tau = (dt * _GL_X)[None, :, None]
    i0 = np.arange(n)
    rT_n = (r_T[i0][:, None, :] + (vP[i0] + off1[i0])[:, None, :] * tau
            + 0.5 * (aP[i0] + off2[i0])[:, None, :] * tau**2).reshape(-1, 3)
    re_n = r0 + rT_n @ C_Te.T
    ve_n = (vPn + off1n) @ C_Te.T
    ae_n = (aPn + off2n) @ C_Te.T
    lla_n = ecef_to_geodetic(re_n)
    up_n = c_n_e(lla_n[:, 0], lla_n[:, 1])[..., :, 2]
    g_e = -normal_gravity(lla_n[:, 0], lla_n[:, 2])[:, None] * up_n
    f_e = ae_n + 2.0 * np.cross(w_ie_e, ve_n) - g_e
    Cbe_n = C_Te @ CVn @ M_v
    f_b = np.einsum("nji,nj->ni", Cbe_n, f_e)
    wib_n = w_TVn @ M_v + np.einsum("nji,j->ni", Cbe_n, w_ie_e)
    w4 = (dt * _GL_W)[None, :, None]
    dtheta = (wib_n.reshape(n, 4, 3) * w4).sum(axis=1)
    dv = (f_b.reshape(n, 4, 3) * w4).sum(axis=1)
    return Truth(motion, dt, t, lla, vel, C, dcm_to_euler(C), r_e, v_e, C_be, w_eb, w_ib,
                 motion.stopped(t), wind, dtheta, dv)


# ------------------------------------------------------------------------------- IMU
@dataclass(frozen=True)
class ImuSpec:
    """The certificate's IMU, per axis, SI: turn-on bias 1-sigma (drawn per run), gyro
    Gauss-Markov drift (1-sigma, correlation time) and white noise densities."""

    gyro_bias: float
    gyro_markov: float
    gyro_tau: float
    gyro_arw: float
    accel_bias: float
    accel_vrw: float


def corrupt_imu(truth: Truth, imu: ImuSpec, rng: np.random.Generator):
    """Measured increments (N, 3) each: ideal + (turn-on bias + Gauss-Markov drift) dt +
    white noise (``arw sqrt(dt)``, ``vrw sqrt(dt)``); the drawn turn-on biases too."""
    n, dt = len(truth.dtheta), truth.dt
    gb = rng.standard_normal(3) * imu.gyro_bias
    ab = rng.standard_normal(3) * imu.accel_bias
    a = np.exp(-dt / imu.gyro_tau)
    w = rng.standard_normal((n, 3)) * imu.gyro_markov * np.sqrt(1.0 - a * a)
    m = np.empty((n, 3))
    x = rng.standard_normal(3) * imu.gyro_markov  # stationary start
    for k in range(n):
        m[k] = x
        x = a * x + w[k]
    dth = (truth.dtheta + (gb + m) * dt
           + rng.standard_normal((n, 3)) * imu.gyro_arw * np.sqrt(dt))
    dv = truth.dv + ab * dt + rng.standard_normal((n, 3)) * imu.accel_vrw * np.sqrt(dt)
    return dth, dv, gb, ab


# --------------------------------------------------------------------------- sensors
#: Field strength [T] of the magnetometer's simulated field (0.5 gauss).
FIELD_T = 0.5e-4


def field_enu(inclination: float, declination: float) -> np.ndarray:
    """The Earth's field direction in ENU for dip ``inclination`` (below the horizon)
    and ``declination`` (east of north) [rad], times :data:`FIELD_T`."""
    ci = np.cos(inclination)
    return FIELD_T * np.array([ci * np.sin(declination), ci * np.cos(declination),
                               -np.sin(inclination)])


def measure(name: str, truth: Truth, idx, lever, M, sigma: dict,
            rng: np.random.Generator) -> np.ndarray:
    """Values ``z`` (len(idx), m) of sensor ``name`` at grid indices ``idx`` in fednav's
    layout for that sensor, from the truth at its point ``lever`` (body right-forward-up
    [m]) and in its axes ``M = C_s^b`` (None: the body's), with white noise of
    ``sigma`` (the sensor's figures, SI, by key as :func:`fednav.campaign.certify`
    names them).

    ``gnss`` lat, lon, h, vE, vN, vU; ``star`` the sensor frame's pitch, roll, heading;
    ``sar`` lat, lon and the sensor frame's heading; ``baro`` h; ``sarvel`` vE, vN;
    ``velocity`` vE, vN, vU; ``odometer`` the point's velocity along the sensor's forward
    axis; ``dvl`` the point's velocity in the sensor's axes; ``zupt`` zero (plus noise);
    ``mag`` the field in the sensor's axes [T]; ``nhc`` zero right and up velocity (plus
    noise: the truth keeps the constraint exactly); ``zaru`` zero (the gyro's own noise is
    the measurement noise); ``airdata`` horizontal airspeed, wind east, north.
    """
    idx = np.asarray(idx, dtype=int)
    k = len(idx)
    M = np.eye(3) if M is None else np.asarray(M, dtype=float)
    pt = truth.point(lever)
    lla, vel = pt["lla"][idx], pt["vel"][idx]
    Cs = truth.C[idx] @ M  # the sensor's axes in ENU

    def noise(*s):
        return rng.standard_normal((k, len(s))) * np.asarray(s, dtype=float)

    if name == "gnss":
        sp, sv = sigma["pos_enu"], sigma["vel_enu"]
        return np.column_stack([move_metric(lla, noise(*sp)), vel + noise(*sv)])
    if name in ("star", "sar"):
        e = dcm_to_euler(Cs)
        if name == "star":
            z = e + noise(*[sigma["angle"]] * 3)
            z[:, 2] = np.mod(z[:, 2], 2 * np.pi)
            return z
        n = noise(sigma["pos"], sigma["pos"], sigma["heading"])
        pos = move_metric(lla, np.column_stack([n[:, 0], n[:, 1], np.zeros(k)]))
        return np.column_stack([pos[:, :2], np.mod(e[:, 2] + n[:, 2], 2 * np.pi)])
    if name == "baro":
        return (lla[:, 2] + noise(sigma["h"])[:, 0])[:, None]
    if name == "sarvel":
        return vel[:, :2] + noise(sigma["vel"], sigma["vel"])
    if name == "velocity":
        return vel + noise(*sigma["vel_enu"])
    if name in ("odometer", "dvl", "nhc"):
        vs = np.einsum("nji,nj->ni", Cs, vel)  # the point's velocity in the sensor's axes
        if name == "odometer":
            return vs[:, 1:2] + noise(sigma["vel"])
        if name == "dvl":
            return vs + noise(*sigma["vel_rfu"])
        return vs[:, [0, 2]] + noise(*sigma["vel_ru"])
    if name == "zupt":
        return vel + noise(*[sigma["vel"]] * 3)  # (vel is zero: the vehicle is stopped)
    if name == "zaru":
        return np.zeros((k, 3))
    if name == "mag":
        b = field_enu(sigma["inclination"], sigma["declination"])
        z = np.einsum("nji,j->ni", Cs, b)
        sb = sigma["heading"] * FIELD_T * np.cos(sigma["inclination"])
        return z + noise(sb, sb, sb)
    if name == "airdata":
        air = truth.vel[idx, :2] - truth.wind[idx, :2]
        n = noise(sigma["airspeed"], sigma["wind"], sigma["wind"])
        return np.column_stack([np.linalg.norm(air, axis=1) + n[:, 0],
                                truth.wind[idx, :2] + n[:, 1:]])
    if name == "gnss_raw":
        return raw_gnss(truth, idx, lever, sigma, rng)
    raise ValueError(f"certificate: no measurement equation for sensor '{name}'")


#: The raw GNSS sky of the certificate: satellites at these azimuths and elevations
#: [deg] seen from the trajectory's start, 20 200 km away, each moving at 3 km/s along
#: its own fixed direction (straight lines: the model takes each satellite's position and
#: velocity from the measurement, so any motion serves; none of fednav's orbit code).
RAW_SKY_DEG = ((10.0, 75.0), (70.0, 35.0), (135.0, 20.0), (190.0, 50.0), (250.0, 15.0),
               (300.0, 40.0), (340.0, 25.0), (100.0, 60.0))
RAW_FIELDS = 11  # number, x, y, z, vx, vy, vz, pseudorange, range rate, their 1-sigma
RAW_SLOTS = 14


def raw_gnss(truth: Truth, idx, lever, sigma: dict, rng) -> np.ndarray:
    """fednav's raw GNSS layout (:mod:`fednav.sensors.gnss_raw`: slots of number, ECEF
    position and velocity, pseudorange, range rate, 1-sigma of both; NaN slots after)
    from the truth at the antenna ``lever``: ``|r_s - r| + cb`` and ``u . (v_s - v) +
    cd`` with the receiver clock's two-state random walk (densities ``sigma["clock"]``
    = (S_f, S_g); start drawn from ``sigma["clock0"]`` (bias [m], drift [m/s])) and
    white noise ``sigma["pr"]`` [m], ``sigma["rr"]`` [m/s]."""
    pt = truth.point(lever)
    lla, vel = pt["lla"][idx], pt["vel"][idx]
    t = truth.t[idx]
    r = geodetic_to_ecef(lla)
    v = np.einsum("nij,nj->ni", c_n_e(lla[:, 0], lla[:, 1]), vel)
    r0 = geodetic_to_ecef(truth.lla[:1])[0]
    C0 = c_n_e(truth.lla[0, 0], truth.lla[0, 1])
    az, el = np.radians(np.array(RAW_SKY_DEG)).T
    los = np.column_stack([np.sin(az) * np.cos(el), np.cos(az) * np.cos(el), np.sin(el)])
    p0 = r0 + 2.02e7 * los @ C0.T
    along = np.cross(los, [0.0, 0.0, 1.0]) + 0.3 * np.cross(los, [1.0, 0.0, 0.0])
    vs = 3000.0 * (along / np.linalg.norm(along, axis=1)[:, None]) @ C0.T
    sf, sg = sigma["clock"]
    x = rng.standard_normal(2) * np.asarray(sigma["clock0"], dtype=float)
    clk = np.empty((len(t), 2))
    for i in range(len(t)):
        d = t[i] - (t[i - 1] if i else t[0])
        if d > 0.0:
            Q = np.array([[sf * d + sg * d**3 / 3, sg * d**2 / 2], [sg * d**2 / 2, sg * d]])
            x = np.array([x[0] + d * x[1], x[1]]) + np.linalg.cholesky(Q) @ \
                rng.standard_normal(2)
        clk[i] = x
    z = np.full((len(t), RAW_SLOTS, RAW_FIELDS), np.nan)
    n = len(RAW_SKY_DEG)
    for i in range(len(t)):
        ps = p0 + vs * (t[i] - truth.t[0])
        d = ps - r[i]
        rho = np.linalg.norm(d, axis=1)
        u = d / rho[:, None]
        z[i, :n, 0] = np.arange(1, n + 1)
        z[i, :n, 1:4], z[i, :n, 4:7] = ps, vs
        z[i, :n, 7] = rho + clk[i, 0] + rng.standard_normal(n) * sigma["pr"]
        z[i, :n, 8] = (np.einsum("ij,ij->i", u, vs - v[i]) + clk[i, 1]
                       + rng.standard_normal(n) * sigma["rr"])
        z[i, :n, 9], z[i, :n, 10] = sigma["pr"], sigma["rr"]
    return z.reshape(len(t), -1)
