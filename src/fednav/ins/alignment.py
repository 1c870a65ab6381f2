"""Initial alignment for post-processing: levelling, heading from the GNSS course, and
an initial covariance that never claims more than the alignment achieved.

A MEMS IMU cannot find north by gyrocompassing (its gyro bias, ~200 deg/h, dwarfs the
Earth rate, 15 deg/h), and a vehicle standing still gives no heading information at all.
Post-processing may look ahead, so fednav aligns as a surveyor would
(docs/recorded-data.md, "Alignment"):

* **Static start.** The IMU's stand-still detector (:func:`fednav.ins.stops.stationary`,
  thresholds from the IMU's noise figures) and the GNSS speed (below ``0.5 m/s``, less a
  1 s margin before motion) find the static period at the start.
* **Levelling.**  Over a static period of 2 s or more the mean specific force is the
  reaction to gravity: pitch and roll follow (:func:`coarse_level`).  Otherwise, in
  motion, where the heading at the start is known (the GNSS course carried back by the
  gyro, or the config's) and the receiver gives velocities (not ones from position
  differences, one-sided at the start), the specific force integrated in the start's
  body frame (the
  gyros carry the frame) matches the GNSS velocity's change plus gravity over a window of
  up to 20 s that the gyro bias allows (:func:`velocity_match_level`: 12 s for a
  20 deg/h gyro); else the mean specific force over the first 2 s (at least 5 GNSS
  periods) is the mean acceleration there — ``(v_end - v_start) / T`` from the GNSS
  velocity, turned into the vehicle's frame by its course — plus the gravity reaction
  (:func:`level_in_motion`).  The sigma holds the velocities' and the carried frame's
  uncertainty.  A vehicle pulling away at 1 m/s^2 is then levelled to ~0.05-0.2 deg
  instead of 5.8 deg off.  Either way the mean accelerometer bias is inseparable from
  the tilt: levelling makes the
  computed horizontal specific force match, so the tilt error is ``phiE = -(C nabla)_N /
  g``, ``phiN = (C nabla)_E / g`` (``C = C_b^n``), a correlation the initial covariance
  carries.
* **Gyro bias.** The mean gyro output over the static period is bias plus the Earth rate;
  removing ``C_n^b w_ie`` leaves the bias, known to ``ARW / sqrt(T_static)``.
* **Heading** (:func:`heading_from_course`).  Each GNSS epoch's course, corrected for the
  antenna's lever arm, is a heading with the 1-sigma ``sigma_v / speed`` (used up to
  20 deg), carried back to the start by the gyro with the carry's own sigma (bias sigma
  times the time, ARW times its root).  The course is tested against the gyro first: if
  the carried-back courses of the first minute scatter beyond three times their sigmas
  about a line in time, the course is not this vehicle's heading (it slides, or the IMU
  is not aligned with the direction of travel) and is not used, with a warning.  The 1 deg
  ``heading_floor`` covers sideslip.

Where nothing gives the heading (the vehicle never moves fast enough for a course, or the
course fails its test, and no file or config heading is there) the heading is unknown:
0 with the 1-sigma of a uniform angle (``pi / sqrt(3)``, 104 deg) and a warning.  The
error-state filter is linearised: from such a start its heading converges only where the
motion makes heading strongly observable, and its sigma is then no promise.  A constant
mounting yaw of the IMU against the direction of travel is not seen by the course test
(the course still follows the gyro): give the heading in the config for such a mount.
Units: SI, radians; Euler ``[pitch, roll, heading]`` (docs/conventions.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import attitude as att
from ..core import earth, units
from ..core.samples import held_integral
from . import strapdown
from .stops import stationary

#: GNSS horizontal speed [m/s] above which the vehicle counts as moving.
MOVING_SPEED = 0.5
#: Margin [s] left out of the static period before the first moving GNSS epoch.
STATIC_MARGIN = 1.0
#: Shortest static period [s] used for levelling and the gyro bias.
MIN_STATIC = 2.0
#: Window [s] of the in-motion levelling (no static start): at least this, and at least
#: :data:`LEVEL_EPOCHS` GNSS periods.
LEVEL_SECONDS = 2.0
LEVEL_EPOCHS = 5
#: Longest window [s] of the in-motion levelling by velocity matching
#: (:func:`velocity_match_level`), and its ends' span [s]: the fixes of the first and the
#: last second are averaged.
LEVEL_MAX_S = 20.0
LEVEL_END_S = 1.0
#: Largest 1-sigma [rad] of one GNSS epoch's course (velocity sigma / speed) that the
#: heading uses: 20 deg (speed above 2.9 sigma_v), where the course's error is still
#: close to Gaussian; many such epochs average to a heading.
MAX_COURSE_SIGMA = np.radians(20.0)
#: Time [s] over which the course errors of consecutive GNSS epochs are taken as one
#: (the vehicle's sideslip and the receiver's velocity filter are correlated over ~1 s).
COURSE_DECORRELATION_S = 1.0
#: Chi-square per degree of freedom of the carried-back courses about a line in time
#: beyond which the course is not a heading measurement (:func:`heading_from_course`):
#: 9, a scatter three times the stated sigmas.
SCATTER_LIMIT = 9.0
#: Span [s] of GNSS epochs over which the course's consistency is tested.
TEST_SPAN_S = 60.0
#: 1-sigma [rad] of a heading nothing tells: uniform over the circle (pi / sqrt(3)).
UNKNOWN_HEADING_SIGMA = np.pi / np.sqrt(3.0)


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


def level_in_motion(f_body, f_level) -> np.ndarray:
    """Euler ``[pitch, roll, 0]`` of the body whose mean specific force ``f_body`` (body
    right-forward-up, m/s^2) is ``f_level`` in the level frame of the vehicle's heading
    (right, forward, up: the acceleration there plus the gravity reaction): the two
    directions fix pitch and roll with the heading held at 0 (Newton's method from the
    levelling of each vector, :func:`coarse_level`; converged to 1e-12 rad)."""
    fb = np.asarray(f_body, dtype=float) / np.linalg.norm(f_body)
    fl = np.asarray(f_level, dtype=float) / np.linalg.norm(f_level)
    x = coarse_level(fb)[:2] - coarse_level(fl)[:2]

    def r(x):
        return (att.euler_to_dcm(np.r_[x, 0.0]) @ fb)[:2] - fl[:2]

    for _ in range(20):
        J = np.column_stack([(r(x + h) - r(x - h)) / 2e-7 for h in np.eye(2) * 1e-7])
        step = np.linalg.solve(J, r(x))
        x = x - step
        if np.max(np.abs(step)) < 1e-13:
            break
    return np.array([x[0], x[1], 0.0])


def static_span(t_fix, vel_fix, t_imu0: float, t_imu=None, still=None) -> float:
    """Length [s] of the static period at the start: from ``t_imu0`` to 1 s before the
    first GNSS epoch moving faster than :data:`MOVING_SPEED` (0 if moving at once; the
    whole GNSS span if it never moves) — and, given the IMU's stand-still flags ``still``
    at ``t_imu`` (:func:`fednav.ins.stops.stationary`), no later than the first sample
    that moves."""
    speed = np.hypot(vel_fix[:, 0], vel_fix[:, 1])
    moving = np.flatnonzero(speed > MOVING_SPEED)
    end = t_fix[moving[0]] - STATIC_MARGIN if len(moving) else t_fix[-1]
    if still is not None:
        after = np.flatnonzero(~np.asarray(still) & (np.asarray(t_imu) >= t_imu0))
        if len(after):
            end = min(end, float(t_imu[after[0]]))
    return max(0.0, float(end - t_imu0))


def mean_acceleration(t_fix, vel_fix, sigma_v, ta: float, tb: float):
    """Mean ENU acceleration [m/s^2] over ``[ta, tb]`` from the GNSS velocity there
    (interpolated; the mean of any acceleration history is ``(v_b - v_a) / T``), its
    1-sigma per axis [m/s^2] (``sqrt(2) sigma_v / T``) and the course [rad] at ``tb``
    (None where the speed is within 3 sigma of zero)."""
    va = np.array([np.interp(ta, t_fix, vel_fix[:, j]) for j in range(3)])
    vb = np.array([np.interp(tb, t_fix, vel_fix[:, j]) for j in range(3)])
    s = np.asarray(sigma_v, dtype=float)
    T = max(tb - ta, 1e-9)
    sig = np.sqrt(2.0) * s / T
    course = (float(np.arctan2(vb[0], vb[1])) if np.hypot(vb[0], vb[1]) > 3.0 * max(s[:2])
              else None)
    return (vb - va) / T, sig, course


def _horizontal_sigma(fixes, idx) -> np.ndarray:
    """1-sigma [m/s] of the horizontal GNSS velocity at epochs ``idx`` (the larger of east
    and north; per fix when the file gives one)."""
    if getattr(fixes, "sigma_rows", None) is not None:
        return np.max(fixes.sigma_rows[idx, 3:5], axis=1)
    return np.full(len(idx), float(np.max(np.asarray(fixes.sigma_vel, dtype=float)[:2])))


@dataclass
class CourseHeading:
    """:func:`heading_from_course`'s answer: ``heading`` [rad] at ``t0`` and its honest
    1-sigma ``sigma`` [rad], the time ``t_first`` [s] of the first epoch used, and the
    consistency test: ``scatter`` (chi-square per degree of freedom of the courses against
    the gyro-carried heading, 0 when untested) and whether the course ``follows`` the
    gyro's heading (False: it is not a heading measurement for this vehicle)."""

    heading: float
    sigma: float
    t_first: float
    scatter: float
    follows: bool


def heading_from_course(t_imu, gyro, up_b, gyro_bias, t_fix, vel_fix, t0: float,
                        sigma_v=0.05, lever=(0.0, 0.0, 0.0), gyro_bias_sigma: float = 0.0,
                        gyro_arw: float = 0.0, floor: float = units.deg(1.0),
                        decorrelation_s: float = COURSE_DECORRELATION_S,
                        n_fix: int = 10, turned=None) -> CourseHeading | None:
    """Heading [rad] at ``t0`` from the GNSS course, carried back to ``t0`` by the gyro
    rotation about the body up axis ``up_b``, with an honest 1-sigma.

    Each GNSS epoch ``i`` faster than :data:`MOVING_SPEED` gives the heading
    ``course_i - asin((w x l)_right / speed_i)`` (the antenna at lever arm ``l`` moves
    sideways by ``w x l`` while the vehicle turns), with the course's 1-sigma
    ``sigma_v,i / speed_i`` (``sigma_v`` [m/s]: one value or one per epoch) — used when
    at most :data:`MAX_COURSE_SIGMA` — and the carry-back's ``gyro_bias_sigma |dt| +
    gyro_arw sqrt|dt|``.  One epoch per ``decorrelation_s`` is kept (the best), so that
    the kept epochs' errors are independent.  ``turned`` [rad], one per GNSS epoch: how
    far north has turned about up (:func:`fednav.core.earth.north_turn`: Earth rate and
    transport rate), which turns the course and not the gyro: taken from each course
    before it is carried back (1.3 deg/s at 89.9 deg and 250 m/s; None: not taken).

    **Consistency.**  Over the first :data:`TEST_SPAN_S` of kept epochs, the carried-back
    headings must agree with a straight line in time (its slope: the gyro's residual
    bias) within their sigmas and the sideslip ``floor``: chi-square per degree of freedom
    at most :data:`SCATTER_LIMIT`.  Beyond it the course does not follow the gyro's
    heading (the vehicle slides, the IMU is not aligned with the direction of travel, the
    gyro's axes are wrong) and ``follows`` is False.

    **Estimate.**  The kept epochs, in order of their own total sigma, are averaged
    (weights 1 / course variance) as far as the mean's sigma falls (at most ``n_fix``);
    the sigma is inflated by the consistency test's scatter where it exceeds 1.  Returns
    None when no epoch qualifies."""
    speed = np.hypot(vel_fix[:, 0], vel_fix[:, 1])
    sv = np.broadcast_to(np.asarray(sigma_v, dtype=float), speed.shape)
    with np.errstate(divide="ignore"):
        sc = sv / speed
    ok = np.flatnonzero((speed > MOVING_SPEED) & (sc <= MAX_COURSE_SIGMA) & (t_fix >= t0)
                        & (t_fix <= t_imu[-1]))
    if len(ok) == 0:
        return None
    # One epoch (the least course sigma) per decorrelation time.
    bins = np.floor((t_fix[ok] - t0) / max(decorrelation_s, 1e-9)).astype(np.int64)
    order = np.lexsort((sc[ok], bins))
    first = np.r_[True, np.diff(bins[order]) != 0]
    ok = np.sort(ok[order[first]])
    w_c = gyro - gyro_bias
    # Heading rate = -(yaw rate about up); integrate from t0 (rectangle rule per sample).
    dpsi = -held_integral(t_imu, w_c @ up_b)
    w = np.column_stack([np.interp(t_fix[ok], t_imu, w_c[:, j]) for j in range(3)])
    side = np.cross(w, np.asarray(lever, dtype=float)) @ np.cross(
        np.array([0.0, 1.0, 0.0]), up_b)  # (w x l) along the body's level right axis
    slip = np.arcsin(np.clip(side / speed[ok], -1.0, 1.0))
    course = np.arctan2(vel_fix[ok, 0], vel_fix[ok, 1]) - slip
    back = course - (np.interp(t_fix[ok], t_imu, dpsi) - np.interp(t0, t_imu, dpsi))
    if turned is not None:  # north's own turn from t0 to each epoch
        turned = np.asarray(turned, dtype=float)
        back = back - (turned[ok] - np.interp(t0, t_fix, turned))

    # Consistency: a straight line in time through the first TEST_SPAN_S of epochs.
    tt = t_fix[ok] - t0
    m = tt <= tt[0] + TEST_SPAN_S
    scatter, follows = 0.0, True
    if m.sum() >= 5:
        ref = float(np.angle(np.sum(np.exp(1j * back[m]))))
        y = att.wrap_pi(back[m] - ref)
        wts = 1.0 / (sc[ok][m] ** 2 + floor**2)
        X = np.column_stack([np.ones(m.sum()), tt[m]])
        coef = np.linalg.lstsq(X * np.sqrt(wts)[:, None], y * np.sqrt(wts), rcond=None)[0]
        scatter = float(np.sum(wts * (y - X @ coef) ** 2)) / (m.sum() - 2)
        follows = scatter <= SCATTER_LIMIT

    lag = np.abs(tt)
    s_gyro = gyro_bias_sigma * lag + gyro_arw * np.sqrt(lag)
    # The epochs in order of their own sigma; as many as make the mean's sigma least.
    order = np.argsort(sc[ok] ** 2 + s_gyro**2, kind="stable")
    info = np.cumsum(1.0 / sc[ok][order] ** 2)
    lag_mean = np.cumsum(lag[order] / sc[ok][order] ** 2) / info
    total = 1.0 / info + (gyro_bias_sigma * lag_mean + gyro_arw * np.sqrt(lag_mean)) ** 2
    best = int(np.argmin(total[:n_fix]))
    pick = np.sort(order[:best + 1])
    wt = 1.0 / sc[ok][pick] ** 2
    mean = float(np.angle(np.sum(wt * np.exp(1j * back[pick]))))
    s_course = np.sqrt(1.0 / wt.sum()) * np.sqrt(max(1.0, scatter))
    sigma = float(np.hypot(s_course, np.sqrt(total[best] - 1.0 / info[best])))
    return CourseHeading(mean % (2 * np.pi), sigma, float(t_fix[ok][pick[0]]), scatter,
                         follows)


def coriolis(lla, vel) -> np.ndarray:
    """The Coriolis and transport terms of the ENU velocity's rate, ``(2 w_ie + w_en) x v``
    [m/s^2], at each fix's ``lla`` (N, 3) and ENU velocity ``vel`` (N, 3): the part of the
    specific force a levelling takes out with the acceleration."""
    return np.cross(2.0 * earth.earth_rate(lla[:, 0])
                    + earth.transport_rate(lla[:, 0], lla[:, 2], vel), vel)


def to_level_frame(v, heading: float) -> np.ndarray:
    """ENU vector ``v`` in the level frame of ``heading`` [rad, from north toward east]:
    right, forward, up."""
    c, s_ = np.cos(heading), np.sin(heading)
    return np.array([v[0] * c - v[1] * s_, v[0] * s_ + v[1] * c, v[2]])


def velocity_match_level(imu, fixes, t0: float, i0: int, dt: float, heading: float,
                         heading_sigma: float, gyro_bias_sigma: float, gyro_arw: float,
                         accel_noise: float, accel_bias_sigma: float):
    """Pitch and roll at ``t0`` (IMU sample ``i0``) of a vehicle in motion, by matching
    the specific force integrated in the start's body frame with the GNSS velocity's
    change over a window of up to :data:`LEVEL_MAX_S`, and their 1-sigma [rad].

    Over ``[t0, t]`` the velocity changes by ``C0 alpha(t) - gamma(t)``: ``alpha`` the
    specific force integrated in the body frame at ``t0`` (the gyros carry the frame:
    :func:`fednav.ins.strapdown.body_frame_velocity`), ``C0 = C_b^n(t0)`` sought, and
    ``gamma`` gravity, Coriolis and the navigation frame's own turn (``w_in x g t^2 /
    2``); the antenna's velocity adds ``C0 R(t) (w x l)`` (``R``: the carried frame, ``l``
    the lever arm), taken into ``alpha``.  Means over the fixes of the window's first and
    last second match ``C0 dalpha = beta``; the two directions with the ``heading`` at
    ``t0`` give pitch and roll (:func:`level_in_motion`).  The gyros carry the frame, so
    the window that gives the best tilt balances the GNSS velocity's noise over it
    (``sqrt(2/n) sigma_v / T``) against the carried frame's error (``gyro_bias_sigma T /
    2``):
    ``T = sqrt(2 sqrt2 sigma_v / (g b_g))``, between :data:`LEVEL_SECONDS` and
    :data:`LEVEL_MAX_S` (12 s for a 20 deg/h gyro under 0.05 m/s velocities, 4 s at
    200 deg/h; the noise term taken for one fix per end, a window longer than the optimum
    for several, whose drift the sigma carries).  Fixes without a velocity or position are
    left out.  Returns ``(euler [pitch, roll, 0], tilt sigma, T, M)`` — ``M`` the mean
    of the carried frame ``R`` over the window, through which a constant accelerometer
    bias enters (``C0 M`` replaces ``C0`` in the tilt/bias coupling) — or None where the
    window has no fixes at both ends."""
    ok = np.isfinite(fixes.vel).all(axis=1) & np.isfinite(fixes.lla).all(axis=1)
    tf, vf, llaf = fixes.t[ok], fixes.vel[ok], fixes.lla[ok]  # (fixes without a value out)
    if len(tf) < 2:
        return None
    s_fix = _horizontal_sigma(fixes, np.flatnonzero(ok))
    lat, h = float(llaf[0, 0]), float(llaf[0, 2])
    g = earth.gravity(lat, h)
    sv = float(np.median(s_fix))
    T = float(np.sqrt(2.0 * np.sqrt(2.0) * sv / (g * max(gyro_bias_sigma, 1e-9))))
    T = min(max(T, LEVEL_SECONDS), LEVEL_MAX_S, float(tf[-1]) - t0,
            float(imu.t[-1]) - t0)
    w = min(LEVEL_END_S, 0.25 * T)
    first = (tf >= t0 - 1e-9) & (tf <= t0 + w)
    last = (tf >= t0 + T - w) & (tf <= t0 + T + 1e-9)
    if T < LEVEL_SECONDS - 1e-9 or not first.any() or not last.any():
        return None
    n = min(int(round(T / dt)), len(imu.t) - 1 - i0)
    span = slice(i0, i0 + n)  # the samples of the intervals after t0 (each from its stamp)
    alpha, q = np.zeros((n + 1, 3)), np.zeros((n + 1, 4))
    q[0, 0] = 1.0
    strapdown.body_frame_velocity(imu.gyro[span] * dt, imu.accel[span] * dt, alpha[1:],
                                  q[1:])
    t_alpha = imu.t[i0:i0 + n + 1]
    # a constant accelerometer bias enters alpha as (integral of R) bias
    R = att.quat_to_dcm(q)
    R_int = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(R[:-1] * dt, axis=0)])
    # the antenna's velocity is the IMU's plus C (w x l): in the start's frame R (w x l)
    lever = np.asarray(fixes.lever, dtype=float)
    w_in = (earth.earth_rate(lat)
            + earth.transport_rate(lat, h, vf[first].mean(axis=0)))
    cor = coriolis(llaf, vf)
    cum = np.vstack([np.zeros(3), np.cumsum(0.5 * (cor[1:] + cor[:-1])
                                            * np.diff(tf)[:, None], axis=0)])
    up_g = np.array([0.0, 0.0, g])

    def mean(sel):  # [alpha, v + cor integral + g tau + w_in x g tau^2 / 2] over the fixes
        tau = tf[sel] - t0
        a = np.column_stack([np.interp(tf[sel], t_alpha, alpha[:, j]) for j in range(3)])
        k = np.clip(np.searchsorted(t_alpha, tf[sel] - 0.5 * dt), 0, n)
        a += np.einsum("nij,nj->ni", R[k], np.cross(imu.gyro[i0 + k], lever))
        b = (vf[sel] + cum[sel] + tau[:, None] * up_g
             + np.outer(0.5 * tau**2, np.cross(w_in, up_g)))
        return a.mean(axis=0), b.mean(axis=0), R_int[k].mean(axis=0)

    (a0, b0, r0), (a1, b1, r1) = mean(first), mean(last)
    d_alpha, beta = a1 - a0, b1 - b0
    euler = level_in_motion(d_alpha, to_level_frame(beta, heading))
    if not np.all(np.isfinite(euler)):
        return None
    span_t = float(np.mean(tf[last]) - np.mean(tf[first]))
    s_dv = np.sqrt(np.mean(s_fix[first] ** 2) / first.sum()
                   + np.mean(s_fix[last] ** 2) / last.sum())
    tilt_sigma = float(np.sqrt((accel_bias_sigma / g) ** 2 + (s_dv / (g * span_t)) ** 2
                               + (accel_noise / np.sqrt(span_t) / g) ** 2
                               + (gyro_bias_sigma * span_t / 2.0) ** 2
                               + gyro_arw**2 * span_t / 3.0
                               + (np.hypot(beta[0], beta[1]) / (g * span_t)
                                  * heading_sigma) ** 2))
    return euler, tilt_sigma, T, (r1 - r0) / span_t


def align(imu, fixes, t0: float, i0: int, dt: float, gyro_arw: float, accel_noise: float,
          accel_bias_sigma: float, file_euler=None, file_sigma=None,
          coarse_seconds: float = 1.0, heading_override: float | None = None,
          heading_floor: float = units.deg(1.0), gyro_bias_sigma: float = 0.0,
          velocity_decorrelation_s: float = COURSE_DECORRELATION_S) -> Alignment:
    """Initial attitude at ``t0`` (IMU sample ``i0``) for :func:`fednav.process.process`.

    ``gyro_arw`` [rad/sqrt(s)], ``accel_noise`` white accelerometer noise [m/s/sqrt(s)],
    ``accel_bias_sigma`` [m/s^2] and ``gyro_bias_sigma`` [rad/s] (the turn-on biases' 1-sigma)
    set the achieved accuracy; ``file_euler`` / ``file_sigma`` the attitude a data file
    provides (used where the data cannot align); ``velocity_decorrelation_s``: the time
    [s] over which GNSS velocity errors are correlated (1 s for Doppler velocities; the
    window of velocities from position differences).
    """
    report: dict = {}
    warnings: list[str] = []
    bias_frame = None  # (velocity matching: the carried frame's mean, C0 M)
    still = stationary(imu.gyro[i0:], imu.accel[i0:], dt, gyro_arw, accel_noise,
                       gyro_bias_sigma)
    T_static = (static_span(fixes.t, fixes.vel, t0, imu.t[i0:], still)
                if fixes.vel is not None else 0.0)
    static = T_static >= MIN_STATIC
    lat = float(fixes.lla[0, 0])
    g = earth.gravity(lat, float(fixes.lla[0, 2]))
    w_ie = earth.earth_rate(lat)
    sv = np.asarray(fixes.sigma_vel, dtype=float)
    n_static = max(1, int(round(T_static / dt)))
    w_mean = imu.gyro[i0:i0 + n_static].mean(axis=0)
    carry_sigma = gyro_arw / np.sqrt(T_static) if static else gyro_bias_sigma
    turned = None if fixes.vel is None else earth.north_turn(fixes.t, fixes.lla, fixes.vel)

    def course(euler):
        """The heading from the GNSS course, the gyro integrated about the up axis of
        the tilt ``euler`` (less the static gyro mean's bias)."""
        if fixes.vel is None or heading_override is not None:
            return None
        up_b = att.euler_to_dcm(np.r_[euler[:2], 0.0])[2]  # body components of ENU up
        w_bias = w_mean - up_b * w_ie[2] if static else np.zeros(3)
        return heading_from_course(imu.t, imu.gyro, up_b, w_bias, fixes.t, fixes.vel, t0,
                                   _horizontal_sigma(fixes, np.arange(len(fixes.t))),
                                   fixes.lever, carry_sigma, gyro_arw, heading_floor,
                                   velocity_decorrelation_s, turned=turned)

    # The course first, on a provisional tilt: whether it follows the gyro decides if
    # it may orient the acceleration of an in-motion levelling.
    n1 = max(1, int(round(max(coarse_seconds, T_static) / dt)))
    hc = course(coarse_level(imu.accel[i0:i0 + n1].mean(axis=0)))
    if fixes.vel is not None:  # the mean acceleration over the first seconds
        period = float(np.median(np.diff(fixes.t))) if len(fixes.t) > 1 else 1.0
        T = max(LEVEL_SECONDS, LEVEL_EPOCHS * period)
        n = max(1, int(round((min(t0 + T, float(fixes.t[-1]), float(imu.t[-1])) - t0) / dt)))
        T = n * dt
        a, s_a, heading_at_T = mean_acceleration(fixes.t, fixes.vel, sv, t0, t0 + T)
        # the specific force also holds the Coriolis and transport terms of the ENU
        # velocity's rate, (2 w_ie + w_en) x v (0.036 m/s^2, 0.2 deg of roll, at 250 m/s
        # and 45 deg; 0.6 m/s^2 near the pole): their mean over the window, from each
        # fix's (near a pole v turns by degrees within it)
        cor = coriolis(fixes.lla, fixes.vel)
        tw = np.linspace(t0, t0 + T, 101)
        a = a + np.array([np.interp(tw, fixes.t, cor[:, j]).mean() for j in range(3)])
        a_h = float(np.hypot(a[0], a[1]))
    if static:
        euler = coarse_level(imu.accel[i0:i0 + n_static].mean(axis=0))
        tilt_sigma = np.hypot(accel_bias_sigma / g, accel_noise / np.sqrt(T_static) / g)
        report["levelling"] = f"static {T_static:.1f} s"
    elif fixes.vel is not None and (hc is None or hc.follows):
        # In motion, where the heading at t0 is known (the config's, or the GNSS course
        # carried back by the gyro): the specific force integrated in the start's body
        # frame matches the GNSS velocity's change over a window the gyros can carry.
        head = ((heading_override, units.deg(2.0)) if heading_override is not None
                else None if hc is None else (hc.heading, hc.sigma))
        if velocity_decorrelation_s > COURSE_DECORRELATION_S:
            head = None  # velocities from position differences: one-sided at the start
        matched = None if head is None else velocity_match_level(
            imu, fixes, t0, i0, dt, head[0], head[1], gyro_bias_sigma, gyro_arw,
            accel_noise, accel_bias_sigma)
        if matched is not None:
            euler, tilt_sigma, T_m, bias_frame = matched
            report["levelling"] = (f"in motion {T_m:.1f} s (the specific force against the "
                                   f"GNSS velocity's change)")
        else:
            # The mean specific force over the first seconds is the mean acceleration
            # (from the GNSS velocity) plus the gravity reaction, the acceleration turned
            # into the vehicle's frame by its course.
            if heading_at_T is None:  # hardly moving yet: along the vehicle
                a_level = np.array([0.0, a_h if a_h > 3.0 * max(s_a[:2]) else 0.0, a[2]])
            else:
                a_level = to_level_frame(a, heading_at_T)
            euler = level_in_motion(imu.accel[i0:i0 + n].mean(axis=0),
                                    a_level + [0.0, 0.0, g])
            tilt_sigma = np.sqrt((accel_bias_sigma / g) ** 2 + (max(s_a[:2]) / g) ** 2
                                 + (accel_noise / np.sqrt(T) / g) ** 2)
            report["levelling"] = (f"in motion {T:.1f} s (mean acceleration {a_h:.2f} "
                                   f"m/s^2 from the GNSS velocity)")
    elif file_euler is not None:
        euler = np.array(file_euler, dtype=float)
        sig = np.array(file_sigma if file_sigma is not None else units.deg([2.0, 2.0, 10.0]),
                       dtype=float)
        tilt_sigma = None
        report["levelling"] = "file"
    else:
        # Levelled as if not accelerating: the acceleration the GNSS shows is the error.
        n = max(1, int(round(coarse_seconds / dt)))
        euler = coarse_level(imu.accel[i0:i0 + n].mean(axis=0))
        tilt_sigma = (units.deg(2.0) if fixes.vel is None else
                      float(np.sqrt((a_h / g) ** 2 + (max(s_a[:2]) / g) ** 2
                                    + (accel_bias_sigma / g) ** 2)))
        report["levelling"] = f"coarse {coarse_seconds:g} s (no static start)"
    if tilt_sigma is not None:
        sig = np.array([tilt_sigma, tilt_sigma, np.nan])
    if hc is not None:
        hc = course(euler)  # on the final tilt
    if heading_override is not None:
        euler[2], sig[2] = heading_override, units.deg(2.0)
        report["heading"] = "config"
    else:
        if hc is not None:
            report["course_scatter"] = round(float(hc.scatter), 2)
            if not hc.follows and file_euler is None:
                warnings.append(
                    f"the GNSS course does not follow the gyro's heading (scatter "
                    f"{np.sqrt(hc.scatter):.1f} x its sigma over the first "
                    f"{TEST_SPAN_S:g} s of motion): the vehicle slides sideways, the IMU is "
                    f"not aligned with the direction of travel, or the gyro's axes are "
                    f"wrong; the initial heading is unknown (+-180 deg, and so is the "
                    f"solution's) — give alignment.coarse_heading_deg or the initial "
                    f"attitude")
        if hc is not None and hc.follows:
            euler[2] = hc.heading
            sig[2] = np.hypot(hc.sigma, heading_floor)
            report["heading"] = f"GNSS course from t = {hc.t_first - t0:.1f} s"
        elif hc is not None and file_euler is None:
            euler[2], sig[2] = hc.heading, UNKNOWN_HEADING_SIGMA
            report["heading"] = "unknown (GNSS course inconsistent with the gyro)"
        elif file_euler is not None:
            euler[2] = file_euler[2]
            sig[2] = file_sigma[2] if file_sigma is not None else units.deg(10.0)
            # The course not taken: a note, not a warning (nothing to change for a sliding
            # or skid-steered vehicle; wrong gyro axes show in the health monitor's NIS).
            report["heading"] = "file" if hc is None else (
                f"file (the GNSS course does not follow the gyro's heading: scatter "
                f"{np.sqrt(hc.scatter):.1f} x its sigma — a sliding or skid-steered "
                f"vehicle, or the IMU's axes not along the travel)")
        else:
            euler[2], sig[2] = 0.0, UNKNOWN_HEADING_SIGMA
            report["heading"] = "unknown (0)"
            warnings.append(f"the vehicle never moves faster than the GNSS velocity can tell "
                            f"a course ({units.to_deg(MAX_COURSE_SIGMA):g} deg): the heading "
                            f"is unknown (0 +- 180 deg, and so is the solution's); give "
                            f"alignment.coarse_heading_deg or the initial attitude")
    C = att.euler_to_dcm(euler)
    # Levelling zeroes the computed horizontal specific force (less the known
    # acceleration): g phiN = (C nabla)_E, -g phiE = (C nabla)_N.
    Cb = C if bias_frame is None else C @ bias_frame  # (velocity matching: C0 M)
    tilt_bias = np.vstack([-Cb[1], Cb[0]]) / g if report["levelling"] != "file" else None
    gyro_bias = gyro_bias_sigma_out = None
    if static:
        # Static gyro mean = bias + C_n^b w_ie (now with the heading).
        gyro_bias = w_mean - C.T @ w_ie
        gyro_bias_sigma_out = gyro_arw / np.sqrt(T_static)
    return Alignment(euler, sig, tilt_bias, gyro_bias, gyro_bias_sigma_out, report, warnings)
