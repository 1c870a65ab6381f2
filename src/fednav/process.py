"""Post-processing of real data: loosely coupled INS/GNSS (+ velocity sensors) in the
federated error-state filter, with an optional RTS smoother.

The IMU drives the strapdown mechanization (:class:`~fednav.strapdown.Strapdown`) at its
own rate; every ``period_s`` the 18-state error model (:mod:`fednav.error_model`) is
propagated and every local filter of the federated filter (``gnss``, and ``velocity``
when a velocity sensor is given) updates with the measurements that arrived during the
interval, then the fused estimate is fed back to the INS and the IMU compensation.  A
measurement taken ``dt`` before the epoch is compared with the INS position moved back
by ``v dt``.  With equal sharing and fusion-reset the federated filter equals the
centralized Kalman filter; chi-square fault detection isolates a local filter whose
measurements disagree (``fdi_alpha``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from . import attitude as att
from . import earth, units
from . import error_model as em
from .filters import FederatedFilter, KalmanFilter
from .io.data import DataError, GnssData, ImuData, Reference, VelocityData
from .measurements import GnssPosVel, NavSnapshot, VelocityENU
from .smoother import rts_errors
from .strapdown import STATE_LLA, STATE_Q, STATE_VEL, Strapdown, _correct

_V3 = tuple[float, float, float]
#: Names of the local filters of the processing federated filter.
LOCAL_FILTERS = {"gnss", "velocity"}


class ImuNoiseConfig(BaseModel):
    """Overrides of the IMU error figures (SI, isotropic); unset keys keep the file's."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    gyro_arw_rad_sqrt_s: float | None = Field(None, ge=0)
    accel_vrw_mps_sqrt_s: float | None = Field(None, ge=0)
    gyro_bias_radps: float | None = Field(None, ge=0)
    accel_bias_mps2: float | None = Field(None, ge=0)
    gyro_markov_radps: float | None = Field(None, ge=0)
    accel_markov_mps2: float | None = Field(None, ge=0)
    gyro_tau_s: float | None = Field(None, gt=0)
    accel_tau_s: float | None = Field(None, gt=0)


class ProcessConfig(BaseModel):
    """Options of :func:`process` (the YAML file of ``fednav process --config``)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    period_s: float | None = Field(None, gt=0, description="filter cycle; default: GNSS "
                                                             "period")
    imu: ImuNoiseConfig = ImuNoiseConfig()
    gnss_sigma_pos_m: _V3 | None = None  # [north, east, up]; default: the file's
    gnss_sigma_vel_mps: _V3 | None = None  # [east, north, up]; default: the file's
    gnss_lever_m: _V3 | None = None  # body right-forward-up; default: the file's
    initial_attitude: str = Field("file", pattern="^(file|coarse)$")
    initial_attitude_sigma_deg: _V3 | None = None  # [pitch, roll, heading]
    # coarse alignment heading; None: the GNSS course over coarse_seconds when the vehicle
    # moves faster than 0.5 m/s then (forward motion assumed), else 0
    coarse_heading_deg: float | None = None
    coarse_seconds: float = Field(1.0, gt=0)
    # chi-square test level: one for every local filter, or by name {gnss: .., velocity: ..}
    fdi_alpha: float | dict[str, float] | None = None
    fdi_recovery: int = Field(1, ge=1)
    substeps: int = Field(1, ge=1)
    # longest run of faulty IMU samples (NaN/inf/absurd) bridged by holding the last
    # good sample [s]; a longer run stops the processing with its time (docs/reliability)
    imu_max_bridge_s: float = Field(0.1, gt=0)

    @field_validator("fdi_alpha")
    @classmethod
    def _alpha(cls, v):
        values = v.values() if isinstance(v, dict) else [] if v is None else [v]
        if isinstance(v, dict) and set(v) - LOCAL_FILTERS:
            raise ValueError(f"unknown local filter(s) {sorted(set(v) - LOCAL_FILTERS)}; "
                             f"use {', '.join(sorted(LOCAL_FILTERS))}")
        if any(not 0.0 < a < 1.0 for a in values):
            raise ValueError("test level must be in (0, 1)")
        return v


@dataclass
class Solution:
    """Navigation solution at the filter epochs: ``t`` [s], ``lla`` (N, 3), ENU ``vel``,
    Euler ``[pitch, roll, heading]`` [rad], 1-sigma ``sigma`` (N, 9) of
    [phi (rad), dv ENU (m/s), dp ENU (m)]."""

    t: np.ndarray
    lla: np.ndarray
    vel: np.ndarray
    euler: np.ndarray
    sigma: np.ndarray
    omega: np.ndarray  # mean body angular rate over the last interval [rad/s]
    label: str = "forward"
    fdi: list = field(default_factory=list)


@dataclass
class ProcessResult:
    forward: Solution
    smoothed: Solution | None
    run_time_s: float
    epochs: int
    #: what the input checks did (samples bridged, epochs skipped) and their warnings
    data_quality: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)


def _noise(imu: ImuData, cfg: ProcessConfig):
    """Filter IMU model and initial bias sigmas from the file's figures and overrides."""
    e = imu.errors
    o = cfg.imu

    def pick(override, from_file, name):
        if override is not None:
            return float(override)
        if from_file is None:
            raise DataError(f"{imu.source}: no IMU error figures in the file; give "
                            f"imu.{name} in the processing config")
        return float(np.max(from_file))

    g = lambda name: None if e is None else getattr(e, name)  # noqa: E731
    n = em.ImuNoiseModel(
        gyro_arw=pick(o.gyro_arw_rad_sqrt_s, g("gyro_arw"), "gyro_arw_rad_sqrt_s"),
        accel_vrw=pick(o.accel_vrw_mps_sqrt_s, g("accel_vrw"), "accel_vrw_mps_sqrt_s"),
        gyro_markov_sigma=pick(o.gyro_markov_radps, g("gyro_markov"), "gyro_markov_radps"),
        gyro_markov_tau=pick(o.gyro_tau_s, g("gyro_tau"), "gyro_tau_s"),
        accel_markov_sigma=pick(o.accel_markov_mps2, g("accel_markov"), "accel_markov_mps2"),
        accel_markov_tau=pick(o.accel_tau_s, g("accel_tau"), "accel_tau_s"),
    )
    gb = pick(o.gyro_bias_radps, g("gyro_bias"), "gyro_bias_radps")
    ab = pick(o.accel_bias_mps2, g("accel_bias"), "accel_bias_mps2")
    return n, gb, ab


def coarse_level(accel_mean, heading: float = 0.0) -> np.ndarray:
    """Euler ``[pitch, roll, heading]`` from the mean specific force of a (quasi-)static
    period (body right-forward-up, m/s^2): the levelling part of coarse alignment."""
    fx, fy, fz = accel_mean
    pitch = np.arctan2(fy, np.hypot(fx, fz))
    roll = np.arctan2(-fx, fz)
    return np.array([pitch, roll, heading])


def gnss_course(gnss: GnssData, seconds: float, min_speed: float = 0.5) -> float | None:
    """Mean course over ground [rad, from north toward east] over the first ``seconds``
    of GNSS velocity, or None when the vehicle is slower than ``min_speed`` [m/s]."""
    if gnss.vel is None:
        return None
    v = gnss.vel[gnss.t <= gnss.t[0] + seconds, :2].mean(axis=0)
    if np.hypot(*v) < min_speed:
        return None
    return float(np.arctan2(v[0], v[1]) % (2 * np.pi))


def _initial_attitude(imu: ImuData, gnss: GnssData, cfg: ProcessConfig, dt: float):
    sig = None if cfg.initial_attitude_sigma_deg is None else units.deg(
        np.asarray(cfg.initial_attitude_sigma_deg))
    if cfg.initial_attitude == "file" and imu.initial_euler is not None:
        euler = imu.initial_euler
        sig = imu.initial_euler_sigma if sig is None else sig
    else:
        n = max(1, int(round(cfg.coarse_seconds / dt)))
        if cfg.coarse_heading_deg is not None:
            heading = float(units.deg(cfg.coarse_heading_deg))
        else:
            heading = gnss_course(gnss, cfg.coarse_seconds) or 0.0
        euler = coarse_level(imu.accel[:n].mean(axis=0), heading)
    if sig is None:
        sig = units.deg(np.array([2.0, 2.0, 10.0]))
    return euler, sig


def _assign(t_meas: np.ndarray, t_epochs: np.ndarray) -> np.ndarray:
    """Epoch index at or after each measurement (-1 if before the first / after the last)."""
    k = np.searchsorted(t_epochs, t_meas - 1e-9, side="left")
    k[(k >= len(t_epochs)) | (t_meas <= t_epochs[0] - 1e-9)] = -1
    return k


def check_units(imu: ImuData, gnss: GnssData) -> list[str]:
    """Refuse IMU data in the wrong unit; warn about GNSS positions that look like radians.

    * accelerometer: the median specific-force magnitude of a vehicle on or near the
      Earth is about 9.8 m/s^2; a median near 1 means the file is in g;
    * gyro: the yaw rate measured about the mean "up" axis (the mean specific force) is
      regressed on the GNSS course rate over the intervals where the vehicle moves and
      turns; a slope near 57 means deg/s (needs some turning: a straight run is not
      tested);
    * GNSS latitude/longitude all within 3.2 deg of (0, 0): radians read as degrees?
      (a warning: real data there exist).
    Returns the warnings; raises DataError for the refusals.
    """
    warnings = []
    fmag = float(np.median(np.linalg.norm(imu.accel, axis=1)))
    if 0.5 < fmag < 1.5:
        raise DataError(f"{imu.source}: median specific force {fmag:.3f}: looks like g; "
                        f"fednav expects m/s^2")
    if gnss.vel is not None and len(gnss.t) > 5:
        up = np.mean(imu.accel, axis=0)
        up /= max(np.linalg.norm(up), 1e-12)
        # GNSS epochs at least 1 s apart: the course rate of 5 Hz fixes is mostly noise
        keep = [0]
        for i in range(1, len(gnss.t)):
            if gnss.t[i] - gnss.t[keep[-1]] >= 1.0 - 1e-9:
                keep.append(i)
        tg, vg = gnss.t[keep], gnss.vel[keep]
        speed = np.hypot(vg[:, 0], vg[:, 1])
        course = np.unwrap(np.arctan2(vg[:, 0], vg[:, 1]))
        dt = np.diff(tg)
        c_rate = -np.diff(course) / dt  # heading from north toward east: yaw rate = -dpsi/dt
        moving = (speed[1:] > 2.0) & (speed[:-1] > 2.0) & (dt < 5.0)
        yaw = np.cumsum(np.r_[0.0, (imu.gyro[1:] @ up) * np.diff(imu.t)])
        g_rate = (np.interp(tg[1:], imu.t, yaw) - np.interp(tg[:-1], imu.t, yaw)) / dt
        inside = (tg[:-1] >= imu.t[0]) & (tg[1:] <= imu.t[-1])
        turning = moving & inside & (np.abs(c_rate) > np.radians(3.0))
        if turning.sum() >= 5:
            c, g = c_rate[turning], g_rate[turning]
            slope = float(c @ g / (c @ c))
            if 20.0 < abs(slope) < 200.0:
                raise DataError(f"{imu.source}: gyro rates are {slope:.1f} x the GNSS course "
                                f"rate while turning: looks like deg/s; fednav expects rad/s")
    lat, lon = np.degrees(gnss.lla[:, 0]), np.degrees(gnss.lla[:, 1])
    if np.all(np.abs(lat) < 1.6) and np.all(np.abs(lon) < 3.2):
        warnings.append(f"{gnss.source}: every position lies within 1.6 deg of latitude 0 and "
                        f"3.2 deg of longitude 0: latitude/longitude in radians where "
                        f"degrees are expected?")
    return warnings


def process(imu: ImuData, gnss: GnssData, velocity: VelocityData | None = None,
            cfg: ProcessConfig | None = None, smooth: bool = False) -> ProcessResult:
    """Loosely coupled INS/GNSS(/velocity) processing; see the module docstring."""
    cfg = cfg or ProcessConfig()
    t_start = time.perf_counter()
    dt = imu.period()
    warnings = check_units(imu, gnss)
    if gnss.vel is None:
        raise DataError(f"{gnss.source}: GNSS velocity is required by the loosely coupled "
                        f"filter")
    period = cfg.period_s or float(np.median(np.diff(gnss.t)))
    n_per = max(1, int(round(period / dt)))
    T = n_per * dt
    t0 = max(imu.t[0], gnss.t[0])
    i0 = int(np.searchsorted(imu.t, t0 - 1e-9))
    n_cycles = (len(imu.t) - 1 - i0) // n_per
    if n_cycles < 1:
        raise DataError(f"{imu.source}: IMU data does not overlap the GNSS data")
    t_ep = imu.t[i0] + T * np.arange(n_cycles + 1)
    noise, gb, ab = _noise(imu, cfg)

    sig_pos = np.asarray(cfg.gnss_sigma_pos_m or gnss.sigma_pos, dtype=float)
    sig_vel = np.asarray(cfg.gnss_sigma_vel_mps or gnss.sigma_vel, dtype=float)
    lever = np.asarray(cfg.gnss_lever_m or gnss.lever, dtype=float)
    g_sigma = np.r_[sig_pos, sig_vel]

    # Initial state: first GNSS fix (antenna moved to the IMU), its velocity, attitude.
    euler0, att_sig = _initial_attitude(imu, gnss, cfg, dt)
    C0 = att.euler_to_dcm(euler0)
    lla0 = earth.move_enu(gnss.lla[0], -(C0 @ lever))
    ins = Strapdown(lla0, gnss.vel[0], euler0, dt)
    sd0 = np.r_[att_sig, sig_vel, sig_pos[[1, 0, 2]], np.full(3, gb),
                np.full(3, noise.gyro_markov_sigma), np.full(3, max(ab, noise.accel_markov_sigma))]
    P0 = np.diag((np.maximum(sd0 / em.SCALE, 1e-6)) ** 2)

    locals_ = {"gnss": KalmanFilter(np.zeros(em.N_STATES), P0, name="kf local 'gnss'")}
    sensors = {"gnss": (GnssPosVel(lever), gnss.t, _assign(gnss.t, t_ep))}
    if velocity is not None:
        locals_["velocity"] = KalmanFilter(np.zeros(em.N_STATES), P0,
                                           name="kf local 'velocity'")
        sensors["velocity"] = (VelocityENU(velocity.lever), velocity.t,
                               _assign(velocity.t, t_ep))
    alpha = cfg.fdi_alpha
    if isinstance(alpha, dict):
        alpha = {k: v for k, v in alpha.items() if k in locals_}
    fed = FederatedFilter(locals_, None, sharing="equal", reset=True, fdi_alpha=alpha,
                          fdi_recovery=cfg.fdi_recovery)
    # Measurements of each epoch (index lists), in time order per sensor.
    todo = {}
    for name, (_, _, k) in sensors.items():
        order = np.argsort(k, kind="stable")
        ks = k[order]
        todo[name] = (order, np.searchsorted(ks, np.arange(n_cycles + 2)))

    nS = ins.state.size
    states = np.empty((n_cycles + 1, nS))
    states[0] = ins.state
    P_post = np.empty((n_cycles + 1, em.N_STATES, em.N_STATES))
    P_post[0] = P0
    Phis = np.zeros_like(P_post)
    Qs = np.zeros_like(P_post)
    dxs = np.zeros((n_cycles + 1, em.N_STATES))
    omegas = np.zeros((n_cycles + 1, 3))
    comp_g = np.zeros(3)
    comp_a = np.zeros(3)
    wb = imu.gyro * dt
    fb = imu.accel * dt
    for k in range(1, n_cycles + 1):
        sl = slice(i0 + (k - 1) * n_per, i0 + k * n_per)
        dth = wb[sl] - comp_g * dt
        dvc = fb[sl] - comp_a * dt
        s0 = ins.state.copy()
        ins.run(dth, dvc, record=False)
        proc = em.interval_process(s0, ins.state, dvc.sum(axis=0), T, noise,
                                   nsub=cfg.substeps)
        fed.predict(proc)
        Phis[k], Qs[k] = proc.Phi, proc.Qd
        omega = dth.sum(axis=0) / T
        omegas[k] = omega
        lla, vel, C = ins.lla, ins.vel, ins.dcm
        for name, (model, tm, _) in sensors.items():
            order, bounds = todo[name]
            for i in order[bounds[k]:bounds[k + 1]]:
                lag = t_ep[k] - tm[i]
                nav = NavSnapshot(earth.move_enu(lla, -lag * vel), vel, C, omega)
                if name == "gnss":
                    z, R = gnss_z(gnss, i), model.R(g_sigma)
                else:
                    z, R = velocity.vel[i], model.R(velocity.cov[i])
                fed.update(name, model.residual(nav, z), model, nav, R, t=tm[i])
        fed.fuse()
        P_post[k] = fed.P
        dxs[k] = fed.feedback()
        dg, da = em.apply_feedback(ins, dxs[k])
        comp_g += dg
        comp_a += da
        states[k] = ins.state
    forward = _solution(t_ep, states, P_post, omegas, "forward", fed.log)
    smoothed = None
    if smooth:
        e, Ps = rts_errors(P_post, Phis, Qs, dxs)
        es = em.to_si(e)
        sm = states.copy()
        for k in range(len(sm)):
            _correct(sm[k], es[k, em.PHI], es[k, em.DV], es[k, em.DP])
        smoothed = _solution(t_ep, sm, Ps, omegas, "smoothed")
    quality = {**imu.quality, **gnss.quality, **(velocity.quality if velocity else {})}
    return ProcessResult(forward, smoothed, time.perf_counter() - t_start, n_cycles,
                         quality, warnings)


def gnss_z(gnss: GnssData, i: int) -> np.ndarray:
    """GNSS fix ``i`` as the measurement vector ``[lat, lon, h, vE, vN, vU]``."""
    return np.concatenate((gnss.lla[i], gnss.vel[i]))


def _solution(t, states, P, omega, label, log=None) -> Solution:
    sd = np.sqrt(np.diagonal(P, axis1=1, axis2=2)[:, :9]) * em.SCALE[:9]
    euler = att.quat_to_euler(states[:, STATE_Q])
    return Solution(t, states[:, STATE_LLA].copy(), states[:, STATE_VEL].copy(), euler, sd,
                    omega, label, log or [])


def errors_against(sol: Solution, ref: Reference) -> dict[str, np.ndarray]:
    """Solution minus reference at the reference times inside the solution's span:
    north/east/down [m], vN/vE/vD [m/s] and, if the reference has attitude, roll, pitch,
    yaw [rad] (``*_rad``; NED naming, as navigation users report them).  The solution is moved to
    the point the reference describes (its lever arm) before differencing."""
    m = (ref.t >= sol.t[0]) & (ref.t <= sol.t[-1])
    if not m.any():
        raise DataError(f"{ref.source}: reference does not overlap the solution in time")
    tr = ref.t[m]
    interp = lambda a: np.column_stack([np.interp(tr, sol.t, a[:, j])  # noqa: E731
                                        for j in range(a.shape[1])])
    lla, vel = sol.lla, sol.vel
    if np.any(ref.lever):
        lla, vel = earth.lever_arm_point(lla, vel, att.euler_to_dcm(sol.euler), sol.omega,
                                         ref.lever)
    lla = interp(lla)
    vel = interp(vel)
    rl = ref.lla[m]
    d = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], rl[:, 0], rl[:, 1], rl[:, 2])
    dv = vel - ref.vel[m]
    far = float(np.median(np.hypot(d[:, 0], d[:, 1])))
    if far > 10_000.0:
        raise DataError(f"{ref.source}: the solution and the reference are {far / 1000:.0f} "
                        f"km apart (median): reference or GNSS positions in another unit "
                        f"(radians vs degrees) or datum?")
    out = {"t": tr, "north_m": d[:, 1], "east_m": d[:, 0], "down_m": -d[:, 2],
           "vn_mps": dv[:, 1], "ve_mps": dv[:, 0], "vd_mps": -dv[:, 2]}
    if ref.euler is not None:
        # Interpolate attitude through unit quaternions (no heading wrap problems).
        q = att.euler_to_quat(sol.euler)
        flip = np.r_[1.0, np.sign(np.sum(q[1:] * q[:-1], axis=1))]
        q = q * np.cumprod(np.where(flip == 0, 1.0, flip))[:, None]  # continuous sign
        qi = interp(q)
        qi /= np.linalg.norm(qi, axis=1)[:, None]
        de = att.euler_difference(att.quat_to_euler(qi), ref.euler[m])
        out.update({"pitch_rad": de[:, 0], "roll_rad": de[:, 1], "yaw_rad": de[:, 2]})
    return out


def rmse(err: dict[str, np.ndarray]) -> dict[str, float]:
    """RMSE of each error series; angles (``*_rad``) are reported in degrees (``*_deg``)."""
    out = {}
    for k, v in err.items():
        if k == "t":
            continue
        r = float(np.sqrt(np.mean(v**2)))
        if k.endswith("_rad"):
            out[k[:-4] + "_deg"] = float(units.to_deg(r))
        else:
            out[k] = r
    return out
