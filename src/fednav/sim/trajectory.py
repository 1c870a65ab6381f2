"""Trajectory generator: flights described as segments, true navigation state and ideal IMU.

A flight starts from an initial position, speed and attitude and is a list of
:class:`Segment` s.  Inside a segment the along-track acceleration and the Euler-angle
rates are constant, the velocity points along the body forward axis (no angle of attack
or side-slip), so the attitude and the ENU velocity are known in closed form.  Position
(latitude, longitude, height) is integrated with an 8th-order Runge–Kutta method at
tight tolerance and the ideal IMU increments are integrals of the analytic body rate and
specific force by Gauss–Legendre quadrature, so the truth and the IMU are consistent to
far below any sensor error.

Frames and units follow ``docs/conventions.md``: ENU navigation frame, body
right-forward-up, Euler ``[pitch, roll, heading]`` [rad], SI units.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from ..core import earth
from ..core.attitude import euler_to_dcm, wrap_2pi


@dataclass(frozen=True)
class Segment:
    """One piece of a flight: constant along-track acceleration and Euler-angle rates.

    duration [s], accel [m/s^2] along track, pitch_rate, roll_rate, heading_rate [rad/s]
    (heading rate positive = turning toward east of the current heading, i.e. right).
    """

    duration: float
    accel: float = 0.0
    pitch_rate: float = 0.0
    roll_rate: float = 0.0
    heading_rate: float = 0.0
    name: str = ""


@dataclass
class Trajectory:
    """True navigation state at the IMU sample times and the ideal IMU increments.

    ``t`` (N+1,) [s]; ``lla`` (N+1, 3) latitude, longitude [rad], height [m];
    ``vel`` (N+1, 3) ENU [m/s]; ``euler`` (N+1, 3) [pitch, roll, heading] [rad];
    ``dtheta``, ``dv`` (N, 3): body angle [rad] and velocity [m/s] increments over
    ``(t[k], t[k+1]]``; ``segment_index`` (N+1,) which segment each sample lies in.
    """

    t: np.ndarray
    lla: np.ndarray
    vel: np.ndarray
    euler: np.ndarray
    dtheta: np.ndarray
    dv: np.ndarray
    dt: float
    segment_index: np.ndarray = field(repr=False)
    wind: np.ndarray | None = field(default=None, repr=False)  # (N+1, 3) ENU [m/s]

    @property
    def dcm(self) -> np.ndarray:
        return euler_to_dcm(self.euler)

    def at(self, times) -> dict[str, np.ndarray]:
        """Truth at sample times ``times`` (must lie on the IMU grid)."""
        idx = np.rint((np.asarray(times) - self.t[0]) / self.dt).astype(int)
        if np.any(idx < 0) or np.any(idx >= len(self.t)):
            raise ValueError("Trajectory.at: requested time outside the trajectory")
        wind = np.zeros((len(idx), 3)) if self.wind is None else self.wind[idx]
        return {"lla": self.lla[idx], "vel": self.vel[idx], "euler": self.euler[idx],
                "wind": wind}


def _kinematics(t, t0, seg, v0, e0):
    """Speed, Euler angles, their rates and ENU velocity/acceleration at times ``t``."""
    tau = np.asarray(t) - t0
    speed = v0 + seg.accel * tau
    rates = np.array([seg.pitch_rate, seg.roll_rate, seg.heading_rate])
    euler = e0 + tau[..., None] * rates
    th, ps = euler[..., 0], euler[..., 2]
    st, ct, sp, cp = np.sin(th), np.cos(th), np.sin(ps), np.cos(ps)
    u = np.stack([sp * ct, cp * ct, st], -1)
    du = np.stack(
        [cp * ct * seg.heading_rate - sp * st * seg.pitch_rate,
         -sp * ct * seg.heading_rate - cp * st * seg.pitch_rate,
         ct * seg.pitch_rate], -1)
    vel = speed[..., None] * u
    acc = seg.accel * u + speed[..., None] * du
    return speed, euler, vel, acc


def body_rate_from_euler_rates(euler, euler_rates):
    """omega_nb^b [rad/s] for Euler ``[pitch, roll, heading]`` and their time derivatives."""
    e = np.asarray(euler, dtype=float)
    r = np.asarray(euler_rates, dtype=float)
    th, ga = e[..., 0], e[..., 1]
    dth, dga, dps = r[..., 0], r[..., 1], r[..., 2]
    sg, cg, st, ct = np.sin(ga), np.cos(ga), np.sin(th), np.cos(th)
    return np.stack(
        [cg * dth + sg * ct * dps, dga - st * dps, sg * dth - cg * ct * dps], -1
    )


def _kinematics_wind(t, t0, seg, v0, e0, wind):
    """:func:`_kinematics` of the air-relative motion plus the wind (ground = air + wind)."""
    speed, euler, vel, acc = _kinematics(t, t0, seg, v0, e0)
    if wind is not None:
        shape = vel.shape
        w, dw = wind(np.asarray(t, dtype=float).ravel())
        vel = vel + w.reshape(shape)
        acc = acc + dw.reshape(shape)
    return speed, euler, vel, acc


def _imu_at(t, t0, seg, v0, e0, lla, wind=None):
    """Ideal gyro rate omega_ib^b and specific force f^b at times ``t`` (with ``lla``)."""
    _, euler, vel, acc = _kinematics_wind(t, t0, seg, v0, e0, wind)
    rates = np.broadcast_to([seg.pitch_rate, seg.roll_rate, seg.heading_rate], euler.shape)
    w_nb = body_rate_from_euler_rates(euler, rates)
    lat, h = lla[..., 0], lla[..., 2]
    w_ie = earth.earth_rate(lat)
    w_en = earth.transport_rate(lat, h, vel)
    C = euler_to_dcm(euler)
    Ct = np.swapaxes(C, -1, -2)
    w_ib = w_nb + np.einsum("...ij,...j->...i", Ct, w_ie + w_en)
    gvec = np.zeros_like(vel)
    gvec[..., 2] = -earth.gravity(lat, h)
    f_n = acc + np.cross(2 * w_ie + w_en, vel) - gvec
    f_b = np.einsum("...ij,...j->...i", Ct, f_n)
    return w_ib, f_b


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(4)


def generate(
    lla0,
    speed0: float,
    euler0,
    segments: list[Segment],
    dt: float,
    wind=None,
) -> Trajectory:
    """Fly ``segments`` from ``lla0`` (lat, lon [rad], h [m]) at ``speed0`` [m/s].

    ``euler0`` = initial [pitch, roll, heading] [rad]; ``dt`` = IMU sample period [s].
    Every segment duration must be a whole number of samples.  With ``wind`` (a
    :class:`~fednav.sim.wind.WindField`, or any ``t -> (w, dw/dt)`` ENU), the segments describe
    the motion *through the air mass* (speed = airspeed, body axes along the air
    velocity) and the ground velocity is air velocity + wind.
    """
    if dt <= 0:
        raise ValueError(f"trajectory: IMU period dt must be positive, got {dt}")
    if not segments:
        raise ValueError("trajectory: at least one segment is required")
    lla0 = np.asarray(lla0, dtype=float)
    e = np.asarray(euler0, dtype=float).copy()
    v = float(speed0)
    t0 = 0.0
    ts, llas, vels, eulers, dths, dvs, segidx = [], [], [], [], [], [], []
    state = lla0.copy()
    for i, seg in enumerate(segments):
        n = round(seg.duration / dt)
        if n < 1 or abs(n * dt - seg.duration) > 1e-9 * max(1.0, seg.duration):
            raise ValueError(
                f"trajectory: segment {i} ({seg.name or 'unnamed'}) duration {seg.duration} s "
                f"is not a positive multiple of dt={dt} s"
            )
        if v + seg.accel * seg.duration < 0:
            raise ValueError(f"trajectory: segment {i} ({seg.name}) makes the speed negative")

        def rhs(t, y, t0=t0, seg=seg, v=v, e=e):
            _, _, vel, _ = _kinematics_wind(np.array([t]), t0, seg, v, e, wind)
            ve, vn, vu = vel[0]
            rm, rn = earth.radii(y[0])
            return [vn / (rm + y[2]), ve / ((rn + y[2]) * np.cos(y[0])), vu]

        sol = solve_ivp(rhs, (t0, t0 + n * dt), state, method="DOP853", rtol=1e-13,
                        atol=[1e-15, 1e-15, 1e-8], dense_output=True)
        if not sol.success:
            raise RuntimeError(f"trajectory: position integration failed in segment {i}")
        tk = t0 + dt * np.arange(n + 1)
        tk[-1] = t0 + n * dt
        _, ek, vk, _ = _kinematics_wind(tk, t0, seg, v, e, wind)
        lk = sol.sol(tk).T
        # Quadrature nodes inside each sample interval.
        a, b = tk[:-1, None], tk[1:, None]
        tn = 0.5 * (a + b) + 0.5 * (b - a) * _GL_NODES[None, :]
        ln = sol.sol(tn.ravel()).T.reshape(n, len(_GL_NODES), 3)
        w_ib, f_b = _imu_at(tn, t0, seg, v, e, ln, wind)
        wts = 0.5 * dt * _GL_WEIGHTS[None, :, None]
        dths.append((w_ib * wts).sum(axis=1))
        dvs.append((f_b * wts).sum(axis=1))
        sl = slice(0, None) if i == 0 else slice(1, None)
        ts.append(tk[sl])
        llas.append(lk[sl])
        vels.append(vk[sl])
        eulers.append(ek[sl])
        segidx.append(np.full(len(tk[sl]), i))
        # Hand over exactly to the next segment.
        e = ek[-1].copy()
        v = v + seg.accel * n * dt
        state = lk[-1].copy()
        t0 = tk[-1]
    euler = np.concatenate(eulers)
    euler[:, 2] = wrap_2pi(euler[:, 2])
    t_all = np.concatenate(ts)
    return Trajectory(
        t=t_all, lla=np.concatenate(llas), vel=np.concatenate(vels),
        euler=euler, dtheta=np.concatenate(dths), dv=np.concatenate(dvs), dt=dt,
        segment_index=np.concatenate(segidx),
        wind=None if wind is None else wind(t_all)[0],
    )
