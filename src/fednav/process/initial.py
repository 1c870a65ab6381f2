"""The initial state of a run on recorded data: the attitude from the alignment
(:mod:`fednav.ins.alignment`: levelling, the GNSS course, or a coarse start), the
course and velocity the GNSS gives, and the filter's initial covariance.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..core import attitude as att
from ..core import earth, units
from ..ins import error_model as em
from ..ins.alignment import Alignment, align, coarse_level
from ..io.data import DataError, FixData, ImuData
from ..navigator.system import System


def fix_course(fixes: FixData, seconds: float, min_speed: float = 0.5) -> float | None:
    """Mean course over ground [rad, from north toward east] over the first ``seconds``
    of GNSS velocity, or None when the vehicle is slower than ``min_speed`` [m/s]."""
    if fixes.vel is None:
        return None
    v = fixes.vel[fixes.t <= fixes.t[0] + seconds, :2].mean(axis=0)
    if np.hypot(*v) < min_speed:
        return None
    return float(np.arctan2(v[0], v[1]) % (2 * np.pi))


def attitude_at_start(imu: ImuData, fixes: FixData, system: System, t0: float, i0: int,
                      dt: float, noise: em.ImuNoiseModel, accel_bias_sigma: float,
                      gyro_bias_sigma: float, decorrelation_s: float = 1.0) -> Alignment:
    """The attitude at ``t0`` (IMU sample ``i0``, period ``dt`` [s]) and its 1-sigma, by
    the system's ``alignment:`` method (levelling and the GNSS course, the file's, or a
    coarse start), with the filter's IMU ``noise`` and bias 1-sigmas [m/s^2, rad/s]."""
    cfg = system.alignment
    sig = None if cfg.initial_attitude_sigma_deg is None else units.deg(
        np.asarray(cfg.initial_attitude_sigma_deg))
    heading = (None if cfg.coarse_heading_deg is None
               else float(units.deg(cfg.coarse_heading_deg)))
    if cfg.initial_attitude == "align":
        a = align(imu, fixes, t0, i0, dt, noise.gyro_arw, noise.accel_vrw, accel_bias_sigma,
                  imu.initial_euler, imu.initial_euler_sigma if sig is None else sig,
                  cfg.coarse_seconds, heading, gyro_bias_sigma=gyro_bias_sigma,
                  velocity_decorrelation_s=decorrelation_s)
        if sig is not None:  # the user's sigmas win over what the alignment claims
            a = Alignment(a.euler, sig, None, a.gyro_bias, a.gyro_bias_sigma,
                          {k: a.report[k] for k in ("levelling", "heading")}, a.warnings)
        return a
    if cfg.initial_attitude == "file" and imu.initial_euler is not None:
        euler = imu.initial_euler
        sig = imu.initial_euler_sigma if sig is None else sig
        how = "file"
    else:
        n = max(1, int(round(cfg.coarse_seconds / dt)))
        if heading is None:
            heading = fix_course(fixes, cfg.coarse_seconds) or 0.0
        euler = coarse_level(imu.accel[i0:i0 + n].mean(axis=0), heading)
        how = f"coarse {cfg.coarse_seconds:g} s"
    if sig is None:
        sig = units.deg(np.array([2.0, 2.0, 10.0]))
    return Alignment(np.asarray(euler, dtype=float), np.asarray(sig, dtype=float),
                     report={"levelling": how, "heading": how})


def start_covariance(al: Alignment, sig_vel, sig_pos_enu, gb: float, ab: float,
                     noise: em.ImuNoiseModel) -> np.ndarray:
    """P0 (filter units): diagonal from the figures, with the alignment's tilt/bias
    coupling and gyro-bias accuracy where it has them (:mod:`fednav.ins.alignment`)."""
    eps_c = gb if al.gyro_bias_sigma is None else min(gb, al.gyro_bias_sigma)
    sd0 = np.r_[al.sigma, sig_vel, sig_pos_enu, np.full(3, eps_c),
                np.full(3, noise.gyro_markov_sigma), np.full(3, ab)]
    P0 = np.diag(np.maximum(sd0, 1e-6 * em.SCALE) ** 2)
    if al.tilt_bias is not None:
        A = al.tilt_bias
        P0[0:2, 0:2] = ab**2 * A @ A.T + np.diag(al.sigma[:2] ** 2 - ab**2 * np.sum(A**2, 1))
        P0[0:2, 15:18] = ab**2 * A
        P0[15:18, 0:2] = P0[0:2, 15:18].T
    d = np.diag_indices(len(P0))  # (a figure given as 0: no state without uncertainty)
    P0[d] = np.maximum(P0[d], (1e-6 * em.SCALE) ** 2)
    return P0 / np.outer(em.SCALE, em.SCALE)


#: Half-width [s] of the window over which position-only fixes give a velocity.
VELOCITY_WINDOW_S = 2.0


def position_velocity(fixes: FixData) -> tuple[np.ndarray, np.ndarray]:
    """ENU velocity [m/s] of position-only fixes and its 1-sigma, for the alignment's
    course and the initial velocity (:meth:`GnssData.position_velocity` over +-
    :data:`VELOCITY_WINDOW_S`)."""
    return fixes.position_velocity(VELOCITY_WINDOW_S)


def start_at_first_fix(imu: ImuData, fixes: FixData, section, system: System, t0: float,
                       i0: int, dt: float, noise: em.ImuNoiseModel, accel_bias_sigma: float,
                       gyro_bias_sigma: float):
    """The start of a run without an ``initial:`` section: the first GNSS fix moved from
    the antenna to the IMU, its velocity and the alignment's attitude (the alignment sees
    the antenna lever arm and velocity 1-sigma the filter flies: ``section``, the GNSS's
    effective :class:`~fednav.sensors.GnssConfig`; position-only fixes give the course by
    their differences).  Returns (alignment, lat/lon [rad] and h [m], ENU velocity [m/s],
    P0 in filter units)."""
    lever = np.asarray(section.lever_m, dtype=float)
    sig_vel = np.asarray(section.sigma_vel_mps, dtype=float)
    fixes_v = replace(fixes, lever=lever, sigma_vel=sig_vel, quality={})
    sig_vel0, decorrelation = sig_vel, 1.0
    if fixes.vel is None:  # the alignment's course from the positions' differences
        v, s_v = position_velocity(fixes)
        if not np.isfinite(s_v[0]):
            raise DataError(f"{fixes.source}: one position-only fix: no initial "
                            f"velocity; give the initial state (initial:)")
        sig_vel0 = np.full(3, s_v[0])
        rows = np.column_stack([np.ones((len(v), 3)), np.repeat(
            np.minimum(s_v, 1e6)[:, None], 3, axis=1)])
        fixes_v = replace(fixes_v, vel=v, sigma_vel=sig_vel0, quality={}, sigma_rows=rows)
        decorrelation = 2.0 * VELOCITY_WINDOW_S  # (neighbours share their fixes)
    al = attitude_at_start(imu, fixes_v, system, t0, i0, dt, noise, accel_bias_sigma,
                           gyro_bias_sigma, decorrelation)
    lla0 = earth.move_enu(fixes.lla[0], -(att.euler_to_dcm(al.euler) @ lever))
    P0 = start_covariance(al, sig_vel0, np.asarray(section.sigma_pos_enu_m, dtype=float),
                          gyro_bias_sigma, accel_bias_sigma, noise)
    return al, lla0, fixes_v.vel[0], P0
