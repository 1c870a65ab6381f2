"""Initial alignment for post-processing: levelling while static, heading from the GNSS
course once moving, and an initial covariance that says what the alignment achieved.

A MEMS IMU cannot find north by gyrocompassing (its gyro bias, ~200 deg/h, dwarfs the
Earth rate, 15 deg/h), and a vehicle standing still gives no heading information at all.
Post-processing may look ahead, so fednav aligns as a surveyor would:

* **Levelling.** Over the static period at the start (GNSS horizontal speed below
  ``0.5 m/s``, less a 1 s margin before motion) the mean specific force is the reaction
  to gravity: pitch and roll follow (:func:`coarse_level`).  The mean accelerometer bias
  is inseparable from the tilt here: levelling makes the computed horizontal specific
  force zero, so the tilt error is ``phiE = -(C nabla)_N / g``, ``phiN = (C nabla)_E / g``
  (``C = C_b^n``).  The initial covariance carries exactly this correlation, so the
  filter separates tilt from bias as soon as the vehicle turns.
* **Gyro bias.** The mean gyro output over the static period is bias plus the Earth rate;
  removing ``C_n^b w_ie`` leaves the bias, known to ``ARW / sqrt(T_static)``.  It becomes
  the initial gyro compensation, with that 1-sigma for the constant-bias state.
* **Heading.** From the GNSS course (``atan2(vE, vN)``) at the first epochs faster than
  ``course_speed`` (3 m/s), carried back to the start by the bias-compensated gyro's
  rotation about the levelled up axis (a vehicle moves along its forward axis: sideslip
  and the IMU's mounting yaw are inside the 1-sigma floor ``heading_floor``, 1 deg).
  Its 1-sigma is the scatter of those epochs' estimates over sqrt(n), with the floor.

Without a static start the tilt comes from the file's attitude (or from the mean specific
force over the first ``coarse_seconds``, which assumes no acceleration); a vehicle that
never moves gets the file's heading, or 0 with a 10 deg sigma and a warning (the error
filter is linearised: it cannot start from an unknown heading).
Units: SI, radians; Euler ``[pitch, roll, heading]`` (docs/conventions.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import attitude as att
from ..core import earth, units

#: GNSS horizontal speed [m/s] above which the vehicle counts as moving.
MOVING_SPEED = 0.5
#: Margin [s] left out of the static period before the first moving GNSS epoch.
STATIC_MARGIN = 1.0
#: Shortest static period [s] used for levelling and the gyro bias.
MIN_STATIC = 2.0


@dataclass
class Alignment:
    """Result of :func:`align`: Euler ``[pitch, roll, heading]`` [rad] at ``t0``, their
    1-sigma [rad], the tilt/accelerometer-bias coupling ``A`` (2, 3) (``[phiE, phiN] =
    A nabla_body``; None without levelling), the gyro bias estimate [rad/s] and its
    1-sigma (None without a static period), and what was done (``report``)."""

    euler: np.ndarray
    sigma: np.ndarray
    tilt_bias: np.ndarray | None = None
    gyro_bias: np.ndarray | None = None
    gyro_bias_sigma: float | None = None
    report: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)

    def __post_init__(self):
        self.report["euler_deg"] = [round(float(v), 4) for v in units.to_deg(self.euler)]
        self.report["sigma_deg"] = [round(float(v), 4) for v in units.to_deg(self.sigma)]


def coarse_level(accel_mean, heading: float = 0.0) -> np.ndarray:
    """Euler ``[pitch, roll, heading]`` from the mean specific force of a (quasi-)static
    period (body right-forward-up, m/s^2): the levelling part of coarse alignment."""
    fx, fy, fz = accel_mean
    pitch = np.arctan2(fy, np.hypot(fx, fz))
    roll = np.arctan2(-fx, fz)
    return np.array([pitch, roll, heading])


def static_span(t_gnss, vel_gnss, t_imu0: float) -> float:
    """Length [s] of the static period at the start: from ``t_imu0`` to 1 s before the
    first GNSS epoch moving faster than :data:`MOVING_SPEED` (0 if moving at once; the
    whole GNSS span if it never moves)."""
    speed = np.hypot(vel_gnss[:, 0], vel_gnss[:, 1])
    moving = np.flatnonzero(speed > MOVING_SPEED)
    end = t_gnss[moving[0]] if len(moving) else t_gnss[-1] + STATIC_MARGIN
    return max(0.0, float(end - STATIC_MARGIN - t_imu0))


def heading_from_course(t_imu, gyro, up_b, gyro_bias, t_gnss, vel_gnss, t0: float,
                        course_speed: float = 3.0, n_fix: int = 10):
    """Heading [rad] at ``t0`` from the first ``n_fix`` GNSS epochs faster than
    ``course_speed`` [m/s], each carried back to ``t0`` by the gyro rotation about the
    body up axis ``up_b``; returns (heading, scatter / sqrt(n), time of the first epoch) or
    None when the vehicle never gets that fast (then the fastest epochs above
    :data:`MOVING_SPEED` are tried)."""
    speed = np.hypot(vel_gnss[:, 0], vel_gnss[:, 1])
    idx = np.flatnonzero((speed > course_speed) & (t_gnss >= t0))[:n_fix]
    if len(idx) == 0:
        idx = np.flatnonzero((speed > MOVING_SPEED) & (t_gnss >= t0))
        idx = idx[np.argsort(-speed[idx])][:n_fix]
        if len(idx) == 0:
            return None
        idx = np.sort(idx)
    # Heading rate = -(yaw rate about up); integrate from t0 (rectangle rule per sample).
    w_up = (gyro - gyro_bias) @ up_b
    dpsi = -np.concatenate([[0.0], np.cumsum(w_up[:-1] * np.diff(t_imu))])
    turn0 = np.interp(t0, t_imu, dpsi)
    course = np.arctan2(vel_gnss[idx, 0], vel_gnss[idx, 1])
    back = course - (np.interp(t_gnss[idx], t_imu, dpsi) - turn0)
    z = np.exp(1j * back)
    mean = np.angle(z.mean())
    spread = np.abs(att.wrap_pi(back - mean))
    scatter = float(np.sqrt(np.mean(spread**2)) / np.sqrt(len(idx))) if len(idx) > 1 else 0.0
    return float(mean % (2 * np.pi)), scatter, float(t_gnss[idx[0]])


def align(imu, gnss, t0: float, i0: int, dt: float, gyro_arw: float, accel_noise: float,
          accel_bias_sigma: float, file_euler=None, file_sigma=None,
          coarse_seconds: float = 1.0, heading_override: float | None = None,
          heading_floor: float = units.deg(1.0)) -> Alignment:
    """Initial attitude at ``t0`` (IMU sample ``i0``) for :func:`fednav.process.process`.

    ``gyro_arw`` [rad/sqrt(s)], ``accel_noise`` white accelerometer noise [m/s/sqrt(s)],
    ``accel_bias_sigma`` [m/s^2] set the achieved accuracy; ``file_euler`` / ``file_sigma``
    the attitude a data file provides (used where the data cannot align).
    """
    report: dict = {}
    warnings: list[str] = []
    T_static = static_span(gnss.t, gnss.vel, t0) if gnss.vel is not None else 0.0
    static = T_static >= MIN_STATIC
    lat = float(gnss.lla[0, 0])
    g = earth.gravity(lat, float(gnss.lla[0, 2]))
    w_ie = earth.earth_rate(lat)
    tilt_bias = None
    gyro_bias = None
    gyro_bias_sigma = None
    if static:
        n = max(1, int(round(T_static / dt)))
        f_mean = imu.accel[i0:i0 + n].mean(axis=0)
        w_mean = imu.gyro[i0:i0 + n].mean(axis=0)
        euler = coarse_level(f_mean)
        tilt_sigma = np.hypot(accel_bias_sigma / g, accel_noise / np.sqrt(T_static) / g)
        sig = np.array([tilt_sigma, tilt_sigma, np.nan])
        report["levelling"] = f"static {T_static:.1f} s"
    elif file_euler is not None:
        euler = np.array(file_euler, dtype=float)
        sig = np.array(file_sigma if file_sigma is not None else units.deg([2.0, 2.0, 10.0]),
                       dtype=float)
        report["levelling"] = "file"
    else:
        n = max(1, int(round(coarse_seconds / dt)))
        euler = coarse_level(imu.accel[i0:i0 + n].mean(axis=0))
        sig = np.array([units.deg(2.0), units.deg(2.0), np.nan])
        report["levelling"] = f"coarse {coarse_seconds:g} s (no static start)"
    up_b = att.euler_to_dcm(np.r_[euler[:2], 0.0])[2]  # body components of the ENU up axis
    w_bias = w_mean - up_b * w_ie[2] if static else np.zeros(3)  # less the up Earth rate
    if heading_override is not None:
        euler[2], sig[2] = heading_override, units.deg(2.0)
        report["heading"] = "config"
    else:
        hc = None if gnss.vel is None else heading_from_course(
            imu.t, imu.gyro, up_b, w_bias, gnss.t, gnss.vel, t0)
        if hc is not None:
            euler[2] = hc[0]
            sig[2] = np.hypot(hc[1], heading_floor)
            report["heading"] = f"GNSS course from t = {hc[2] - t0:.1f} s"
        elif file_euler is not None:
            euler[2] = file_euler[2]
            sig[2] = file_sigma[2] if file_sigma is not None else units.deg(10.0)
            report["heading"] = "file"
        else:
            sig[2] = units.deg(10.0)
            report["heading"] = "none (0)"
            warnings.append("the vehicle never moves: no heading from the GNSS course; "
                            "initial heading 0 (give coarse_heading_deg)")
    if static:
        C = att.euler_to_dcm(euler)
        # Levelling zeroes the computed horizontal specific force: g phiN = (C nabla)_E,
        # -g phiE = (C nabla)_N.
        tilt_bias = np.vstack([-C[1], C[0]]) / g
        # Static gyro mean = bias + C_n^b w_ie (now with the heading).
        gyro_bias = w_mean - C.T @ w_ie
        gyro_bias_sigma = gyro_arw / np.sqrt(T_static)
    return Alignment(euler, sig, tilt_bias, gyro_bias, gyro_bias_sigma, report, warnings)
