"""Ascent trajectories in the launch inertial frame: truth and ideal IMU increments.

A powered ascent is described by

* a **pitch programme** ``phi(t)``: the elevation of the vehicle's longitudinal axis
  (body ``y``, the nose) above the LI ``x`` axis in the launch plane, 90 deg at lift-off
  (vertical rise), changed by :class:`Manoeuvre` s (pitch-over, gravity-turn-like
  programme);
* an optional **yaw programme** ``psi(t)``: the nose's angle out of the launch plane,
  positive toward LI ``+z`` (right of the firing direction);
* **burns** (:class:`Burn`): thrust acceleration along the nose,
  ``a(t) = a0 / (1 - (1 - mass_ratio) tau / duration)`` (constant thrust, linearly
  decreasing mass, ``mass_ratio`` = final / initial mass); no thrust between burns
  (coast), no aerodynamic force, no roll programme.

Attitude ``C_b^li = Rz(phi) Ry(-psi) C0`` with ``C0`` the attitude of a vehicle lying
along LI x (body x right = LI z, body y forward = LI x, body z up = LI y).  Every
manoeuvre has a cosine-bell rate (zero rate at both ends, smooth angle).

Translational motion ``r' = v``, ``v' = C_b^li f_b + g_li(r)`` is integrated with an
8th-order Runge–Kutta method at tight tolerance piece by piece between the programme's
break points (which must lie on the IMU grid); the ideal increments ``dtheta = int
omega_ib^b dt``, ``dv = int f^b dt`` are Gauss–Legendre integrals of the analytic body
rate and specific force, so truth and IMU agree far below any sensor error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from ..core import earth, units
from .frame import LaunchFrame, gravitation_li_nb

#: Attitude of a vehicle lying along LI x (columns: body x, y, z in LI).
C0 = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


@dataclass(frozen=True)
class Manoeuvre:
    """Change an angle by ``change`` [rad] between ``start`` and ``start + duration`` [s]
    with a cosine-bell rate."""

    start: float
    duration: float
    change: float

    def angle(self, t):
        tau = np.clip(np.asarray(t, dtype=float) - self.start, 0.0, self.duration)
        T = self.duration
        return self.change * (tau / T - np.sin(2 * np.pi * tau / T) / (2 * np.pi))

    def rate(self, t):
        t = np.asarray(t, dtype=float)
        tau = t - self.start
        inside = (tau > 0) & (tau < self.duration)
        return np.where(inside, self.change / self.duration
                        * (1.0 - np.cos(2 * np.pi * tau / self.duration)), 0.0)


@dataclass(frozen=True)
class Burn:
    """Constant-thrust burn: acceleration ``a0`` [m/s^2] at ignition, mass falling linearly
    to ``mass_ratio`` of its initial value at ``start + duration`` [s]."""

    start: float
    duration: float
    a0: float
    mass_ratio: float

    def accel(self, t):
        tau = np.asarray(t, dtype=float) - self.start
        inside = (tau >= 0) & (tau < self.duration)
        k = (1.0 - self.mass_ratio) / self.duration
        return np.where(inside, self.a0 / (1.0 - k * np.clip(tau, 0.0, self.duration)), 0.0)


@dataclass(frozen=True)
class AscentProfile:
    """A launch: frame, programme, duration [s] and IMU period [s]."""

    frame: LaunchFrame
    duration: float
    burns: tuple[Burn, ...]
    pitch: tuple[Manoeuvre, ...] = ()
    yaw: tuple[Manoeuvre, ...] = ()
    pitch0: float = units.deg(90.0)

    def breakpoints(self) -> list[float]:
        pts = {0.0, self.duration}
        for m in (*self.burns, *self.pitch, *self.yaw):
            pts.update((m.start, m.start + m.duration))
        return sorted(p for p in pts if 0.0 <= p <= self.duration)

    def angles(self, t):
        """(phi, psi, dphi/dt, dpsi/dt) at times ``t``."""
        t = np.asarray(t, dtype=float)
        phi = self.pitch0 + sum((m.angle(t) for m in self.pitch), np.zeros_like(t))
        psi = sum((m.angle(t) for m in self.yaw), np.zeros_like(t))
        dphi = sum((m.rate(t) for m in self.pitch), np.zeros_like(t))
        dpsi = sum((m.rate(t) for m in self.yaw), np.zeros_like(t))
        return phi, psi, dphi, dpsi

    def thrust(self, t):
        t = np.asarray(t, dtype=float)
        return sum((b.accel(t) for b in self.burns), np.zeros_like(t))

    def attitude(self, t) -> np.ndarray:
        """C_b^li (..., 3, 3) at times ``t``."""
        phi, psi, _, _ = self.angles(t)
        return _rz(phi) @ _ry(-psi) @ C0

    def body_rate(self, t) -> np.ndarray:
        """omega_ib^b (..., 3) [rad/s] (LI is inertial: omega_ib = omega_li,b)."""
        phi, psi, dphi, dpsi = self.angles(t)
        Rz = _rz(phi)
        w_li = dphi[..., None] * np.array([0.0, 0.0, 1.0]) - dpsi[..., None] * Rz[..., :, 1]
        C = Rz @ _ry(-psi) @ C0
        return np.einsum("...ji,...j->...i", C, w_li)

    def specific_force(self, t) -> np.ndarray:
        """f^b (..., 3) [m/s^2]: thrust along the nose (body y)."""
        a = self.thrust(t)
        z = np.zeros_like(a)
        return np.stack([z, a, z], -1)


def _rz(a):
    a = np.asarray(a, dtype=float)
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def _ry(a):
    a = np.asarray(a, dtype=float)
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1),
                     np.stack([-s, z, c], -1)], -2)


@dataclass
class LaunchTrajectory:
    """Truth at the IMU sample times and ideal IMU increments (all in LI, SI).

    ``t`` (N+1,); ``r``, ``v`` (N+1, 3) LI position [m] and velocity [m/s];
    ``C`` (N+1, 3, 3) C_b^li; ``dtheta``, ``dv`` (N, 3) body increments over
    ``(t[k], t[k+1]]``.
    """

    t: np.ndarray
    r: np.ndarray
    v: np.ndarray
    C: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    dt: float
    frame: LaunchFrame = field(repr=False)

    def index(self, times) -> np.ndarray:
        idx = np.rint((np.asarray(times, dtype=float) - self.t[0]) / self.dt).astype(int)
        if np.any(idx < 0) or np.any(idx >= len(self.t)):
            raise ValueError("LaunchTrajectory: requested time outside the trajectory")
        return idx

    def lla(self) -> np.ndarray:
        """Geodetic latitude, longitude [rad], height [m] at every sample."""
        return self.frame.li_to_geodetic(self.r, self.t)


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(4)


def generate(profile: AscentProfile, dt: float = 0.02) -> LaunchTrajectory:
    """Fly ``profile`` from rest on the pad (at rest on the rotating Earth) with IMU period
    ``dt`` [s]."""
    if dt <= 0:
        raise ValueError(f"launch trajectory: IMU period must be positive, got {dt}")
    n_total = round(profile.duration / dt)
    if n_total < 1 or abs(n_total * dt - profile.duration) > 1e-9 * profile.duration:
        raise ValueError(f"launch trajectory: duration {profile.duration} s is not a "
                         f"multiple of dt = {dt} s")
    bps = profile.breakpoints()
    for b in bps:
        if abs(b / dt - round(b / dt)) > 1e-6:
            raise ValueError(f"launch trajectory: programme break point {b} s is not on "
                             f"the IMU grid (dt = {dt} s)")
    fr = profile.frame
    r0_eci, C_eci_li, deg = fr.r0_eci, fr.C_eci_li, fr.degree

    def rhs(t, y):
        C = profile.attitude(t)
        f = profile.specific_force(t)
        return np.concatenate([y[3:], C @ f + gravitation_li_nb(y[:3], r0_eci, C_eci_li,
                                                                   deg)])

    # At rest on the pad: the LI velocity is the Earth-rotation velocity omega x r.
    w = np.array([0.0, 0.0, earth.OMEGA_IE])
    v0 = C_eci_li.T @ np.cross(w, r0_eci)
    y = np.concatenate([np.zeros(3), v0])
    t_all = dt * np.arange(n_total + 1)
    r = np.empty((n_total + 1, 3))
    v = np.empty((n_total + 1, 3))
    r[0], v[0] = y[:3], y[3:]
    for a, b in zip(bps[:-1], bps[1:], strict=True):
        ia, ib = round(a / dt), round(b / dt)
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-13,
                        atol=[1e-9] * 3 + [1e-12] * 3, dense_output=True)
        if not sol.success:
            raise RuntimeError(f"launch trajectory: integration failed in [{a}, {b}] s")
        tk = t_all[ia + 1:ib + 1]
        yk = sol.sol(tk)
        r[ia + 1:ib + 1], v[ia + 1:ib + 1] = yk[:3].T, yk[3:].T
        y = sol.y[:, -1]
    # Ideal increments by Gauss-Legendre quadrature inside each sample interval (every
    # interval lies inside one piece of the programme).
    ta, tb = t_all[:-1, None], t_all[1:, None]
    tn = 0.5 * (ta + tb) + 0.5 * (tb - ta) * _GL_NODES[None, :]
    wts = 0.5 * dt * _GL_WEIGHTS[None, :, None]
    dtheta = (profile.body_rate(tn) * wts).sum(axis=1)
    dvel = (profile.specific_force(tn) * wts).sum(axis=1)
    return LaunchTrajectory(t_all, r, v, profile.attitude(t_all), dtheta, dvel, dt, fr)
