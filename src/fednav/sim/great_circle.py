"""A great-circle flight generated in ECEF: truth and ideal IMU that owe nothing to the
ENU mechanization (no latitude/longitude rate, no transport rate, no heading).

The vehicle moves at constant speed on a circle of constant geocentric radius about a
fixed ECEF axis ``n``; its body frame turns with it (right wing along ``-n``, nose along
the velocity, top along the geocentric radius), so ``C_b^e(t) = R(n, W t) C_b^e(0)`` with
``W = speed / |r|``.  Everything follows in closed form in ECEF:

* ``r(t) = R(n, W t) r0``, ``v_e = W n x r``, ``a_e = -W^2 r``;
* gyro ``omega_ib^b = C_e^b (W n + omega_ie z_e)``;
* specific force ``f^b = C_e^b (a_e + 2 omega_ie x v_e - g^e)`` with the WGS-84 normal
  gravity ``g^e = -gravity(lat, h) up^e`` (the mechanization's own gravity model);

and the increments are their integrals over each IMU interval by 8-node Gauss-Legendre
quadrature (exact to rounding for these smooth functions).  The ENU truth (``lla``,
``vel``, ``euler``) is the ECEF truth converted sample by sample
(:func:`fednav.core.earth.ecef_to_llh`, :func:`fednav.core.earth.enu_to_ecef`), so it is
defined at any latitude short of the pole itself and at any longitude: it is the oracle
for the mechanization near the poles and across +-180 deg (``tests/test_polar.py``,
``benchmarks/polar.py``).
"""

from __future__ import annotations

import numpy as np

from ..core import earth
from ..core.attitude import dcm_to_euler, wrap_2pi
from .trajectory import Trajectory

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(8)


def _rotation(axis, angle) -> np.ndarray:
    """Rodrigues: rotation matrices (..., 3, 3) by ``angle`` (...) [rad] about the unit
    ``axis`` (3,)."""
    k = np.asarray(axis, dtype=float)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    a = np.asarray(angle, dtype=float)[..., None, None]
    return np.eye(3) + np.sin(a) * K + (1.0 - np.cos(a)) * (K @ K)


def great_circle(lla_mid, heading_mid: float, speed: float, duration: float,
                 dt: float) -> Trajectory:
    """A great-circle flight of ``duration`` [s] at ``speed`` [m/s] whose midpoint is
    ``lla_mid`` (lat, lon [rad], h [m]) with course ``heading_mid`` [rad] (from north
    toward east, the geodetic horizontal there); IMU period ``dt`` [s].

    Flown east or west (heading 90 or 270 deg), the midpoint is the track's highest
    latitude: ``lla_mid`` at 89.9 deg passes 11 km from the pole.  Longitudes are
    returned in (-pi, pi] (a track over the pole or across the antimeridian jumps by
    2 pi there).  Returns a :class:`fednav.sim.trajectory.Trajectory` (``euler`` of
    ``C_b^n``: pitch and roll are the small tilt of the geocentric radius from the
    geodetic normal).
    """
    n_samp = round(duration / dt)
    if dt <= 0 or n_samp < 1 or abs(n_samp * dt - duration) > 1e-9 * max(1.0, duration):
        raise ValueError(f"great_circle: duration {duration} s is not a positive multiple "
                         f"of dt={dt} s")
    lat0, lon0, h0 = (float(v) for v in lla_mid)
    r0 = earth.llh_to_ecef(lat0, lon0, h0)
    up = r0 / np.linalg.norm(r0)
    Cne = earth.enu_to_ecef(lat0, lon0)
    fwd = Cne @ np.array([np.sin(heading_mid), np.cos(heading_mid), 0.0])
    fwd = fwd - up * (up @ fwd)
    fwd /= np.linalg.norm(fwd)
    axis = np.cross(up, fwd)
    w = speed / np.linalg.norm(r0)
    Cbe0 = np.column_stack([-axis, fwd, up])  # body right, forward, up in ECEF
    wie = np.array([0.0, 0.0, earth.OMEGA_IE])

    def at(t):
        """ECEF position, velocity, C_b^e, gyro rate and specific force (body) at ``t``
        (relative to the midpoint)."""
        R = _rotation(axis, w * t)
        r = R @ r0
        v = w * np.cross(axis, r)
        Cbe = R @ Cbe0
        lla = earth.ecef_to_llh(r)
        g = -earth.gravity(lla[..., 0], lla[..., 2])[..., None] * earth.enu_to_ecef(
            lla[..., 0], lla[..., 1])[..., :, 2]
        f_e = -w * w * r + 2.0 * np.cross(wie, v) - g
        Ceb = np.swapaxes(Cbe, -1, -2)
        omega = np.einsum("...ij,j->...i", Ceb, w * axis + wie)
        f_b = np.einsum("...ij,...j->...i", Ceb, f_e)
        return r, v, Cbe, lla, omega, f_b

    t = dt * np.arange(n_samp + 1)
    tc = t - 0.5 * duration
    _, v, Cbe, lla, _, _ = at(tc)
    Cen = np.swapaxes(earth.enu_to_ecef(lla[:, 0], lla[:, 1]), -1, -2)
    vel = np.einsum("kij,kj->ki", Cen, v)
    euler = dcm_to_euler(Cen @ Cbe)
    euler[:, 2] = wrap_2pi(euler[:, 2])
    a, b = tc[:-1, None], tc[1:, None]
    tn = 0.5 * (a + b) + 0.5 * (b - a) * _NODES[None, :]
    *_, omega, f_b = at(tn)
    wts = 0.5 * dt * _WEIGHTS[None, :, None]
    return Trajectory(t=t, lla=lla, vel=vel, euler=euler, dtheta=(omega * wts).sum(axis=1),
                      dv=(f_b * wts).sum(axis=1), dt=dt,
                      segment_index=np.zeros(len(t), dtype=int))


def recorded(tr: Trajectory, rng: np.random.Generator, imu_errors: bool = True,
             lon_0_360: bool = False):
    """A great-circle flight ``tr`` as recorded data for :func:`fednav.process.process`:
    the IMU at ``tr``'s rate (navigation grade: 1 deg/h, 0.1 mg, 0.05 deg/sqrt(h),
    2e-4 m/s/sqrt(s); drawn from ``rng`` when ``imu_errors``, else ideal, its figures
    given either way; the initial attitude 0.05/-0.05/0.2 deg off with its sigma) and
    1 Hz GNSS fixes with 1 m noise (drawn in ECEF along the local ENU axes) and 0.05 m/s,
    the longitudes in 0..360 deg with ``lon_0_360``.  Returns ``(ImuData, FixData)``
    (the GNSS's fixes)."""
    from ..core import units
    from ..io.data import FixData, ImuData, ImuErrors
    from ..sensors import ImuErrors as SimImuErrors
    from ..sensors import corrupt_imu

    dth, dv = tr.dtheta, tr.dv
    if imu_errors:
        sim = SimImuErrors(gyro_bias=units.deg_per_h(1.0), accel_bias=units.milli_g(0.1),
                           gyro_arw=units.deg_per_sqrt_h(0.05), accel_vrw=2e-4)
        dth, dv, _ = corrupt_imu(tr.dtheta, tr.dv, tr.dt, sim, rng)
    errs = ImuErrors(*[np.full(3, v) for v in (units.deg_per_sqrt_h(0.05), 2e-4,
                                               units.deg_per_h(1.0), units.milli_g(0.1), 1e-7,
                                               1e-6, 1000.0, 1000.0)])
    imu = ImuData("sim-imu", tr.t[:-1], dth / tr.dt, dv / tr.dt, errs,  # (from the stamp)
                  tr.euler[0] + units.deg(np.array([0.05, -0.05, 0.2])),
                  units.deg(np.array([0.1, 0.1, 0.5])))
    tg = np.arange(1.0, tr.t[-1], 1.0)
    g = tr.at(tg)
    noise = rng.standard_normal((len(tg), 3))
    r = earth.llh_to_ecef(*g["lla"].T) + np.einsum(
        "kij,kj->ki", earth.enu_to_ecef(g["lla"][:, 0], g["lla"][:, 1]), noise)
    lla = earth.ecef_to_llh(r)
    if lon_0_360:
        lla[:, 1] %= 2 * np.pi
    vel = g["vel"] + 0.05 * rng.standard_normal((len(tg), 3))
    return imu, FixData("great-circle fixes", tg, lla, vel, np.ones(3), np.full(3, 0.05),
                        np.zeros(3))
