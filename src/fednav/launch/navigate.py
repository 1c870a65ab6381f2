"""One closed-loop launch-frame run: simulated sensors, the launch-frame INS flown by the
navigator (:class:`~fednav.navigator.Navigator`) with federated PF or EKF local filters.

The launch inertial frame has its own mechanization and error model, so paper 001 brings
its own core (:class:`LaunchCore`) to the navigator's cycle.  Per filter cycle
(``filter_period_s``, 1 s in the paper):

1. the nominal SINS integrates the cycle's IMU samples (bias-compensated with its current
   estimates) in one compiled call and returns the interval summary;
2. both local filters (``gnss``, ``star``) time-update with their share of the process
   noise (``Q / beta_i``) — the PFs by drawing every particle from the transition prior
   (:class:`~fednav.launch.errors.LaunchProcess`);
3. each local filter takes its sensor's measurement (when one is due);
4. the master fuses ``P_g = (sum P_i^-1)^-1``, ``x_g = P_g sum P_i^-1 x_i`` (each PF's
   mean and covariance from its weighted particles), resets every local filter to
   ``(x_g, P_g / beta_i)`` — for a PF: redraws its particle set from that Gaussian — and
   the fused error is fed back into the nominal SINS (closed loop).

Errors (computed minus true) are recorded at every cycle after the feedback.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..core import units
from ..core.attitude import dcm_to_quat, misalignment, quat_to_dcm, rotvec_to_dcm
from ..core.kernels import quat_mul, rotvec_to_quat
from ..filters import FederatedFilter, KalmanFilter, ParticleFilter
from ..navigator import System
from ..navigator.loop import Mechanization
from ..navigator.navigator import Navigator
from ..sensors.imu import corrupt_imu
from .errors import (
    ACC,
    GYRO,
    N_STATES,
    POS,
    SCALE,
    VEL,
    GnssPositionLI,
    ImuNoise,
    LaunchProcess,
    StarAttitudeLI,
)
from .errors import PHI as PHI_
from .scenario import LaunchScenario
from .strapdown import LaunchStrapdown


@dataclass
class LaunchData:
    """Everything random about one run, shared by every filter run on it."""

    seed: int
    dtheta: np.ndarray         # (N, 3) measured angle increments [rad]
    dv: np.ndarray             # (N, 3) measured velocity increments [m/s]
    x0_err: np.ndarray         # (15,) initial navigation error, filter units (biases 0)
    gnss_t: np.ndarray
    gnss_lla: np.ndarray       # receiver output: geodetic lat, lon [rad], h [m]
    star_t: np.ndarray
    star_q_eci: np.ndarray     # star-sensor attitude q_b^eci


@dataclass
class LaunchResult:
    """Error time series (at filter epochs, after feedback) of one run of one filter."""

    name: str
    t: np.ndarray
    att: np.ndarray            # (K, 3) attitude error phi in LI [rad]
    pos: np.ndarray            # (K, 3) [m]
    vel: np.ndarray            # (K, 3) [m/s]
    sigma: np.ndarray          # (K, 9) filter 1-sigma of att [rad], pos, vel
    run_time_s: float
    min_ess: float = float("nan")
    max_stages: int = 1

    def rms(self) -> dict[str, float]:
        out = {}
        for key, arr, scale in (("att", self.att, 1.0 / units.ARCSEC), ("pos", self.pos, 1.0),
                                ("vel", self.vel, 1.0)):
            r = np.sqrt((arr**2).mean(axis=0)) * scale
            for j, ax in enumerate("xyz"):
                unit = {"att": "arcsec", "pos": "m", "vel": "mps"}[key]
                out[f"{key}_{ax}_{unit}"] = float(r[j])
        return out


def _noise(scn: LaunchScenario) -> ImuNoise:
    dt = scn.imu_period_s
    return ImuNoise(scn.imu.arw(dt), scn.imu.vrw(dt), scn.imu.gyro_rw(), scn.imu.accel_rw())


def initial_covariance(scn: LaunchScenario) -> np.ndarray:
    """P0 in filter units: initial errors, and the IMU's random constant biases."""
    ie = scn.initial_error
    sig = np.concatenate([ie.attitude_arcsec, np.full(3, ie.position_m),
                          np.full(3, ie.velocity_mps),
                          np.full(3, (scn.imu.gyro_bias_deg_h or 0.0) if scn.imu.random_bias
                                  else 0.0),
                          np.full(3, (scn.imu.accel_bias_ug or 0.0) * 1e-3 if scn.imu.random_bias
                                  else 0.0)])
    floor = np.concatenate([np.zeros(9), np.full(6, 1e-3)])  # bias sigma floor (filter units)
    return np.diag(np.maximum(sig, floor) ** 2)


def make_data(scn: LaunchScenario, seed: int, max_time: float | None = None) -> LaunchData:
    """Draw the IMU errors, initial error and sensor noise of run ``seed``."""
    tr = scn.trajectory(max_time)
    rng = np.random.default_rng([seed, 1])
    dth, dv, _ = corrupt_imu(tr.dtheta, tr.dv, tr.dt, scn.imu.errors(tr.dt), rng)
    P0 = initial_covariance(scn)
    x0 = rng.standard_normal(15) * np.sqrt(np.diag(P0))
    x0[9:] = 0.0  # the bias errors are those corrupt_imu drew
    fr, T = tr.frame, tr.t[-1]
    g = scn.gnss
    gt = np.arange(max(g.period_s, g.available_from_s), T + 1e-9, g.period_s)
    gi = tr.index(gt)
    noise = rng.standard_normal((len(gt), 3)) * g.sigma_m
    if g.outlier_probability > 0:
        out = rng.random(len(gt)) < g.outlier_probability
        noise[out] *= g.outlier_scale
    r_ecef = fr.li_to_ecef(tr.r[gi], gt) + noise
    from .frame import ecef_to_geodetic

    gnss_lla = ecef_to_geodetic(r_ecef)
    s = scn.star
    st = np.arange(max(s.period_s, s.available_from_s), T + 1e-9, s.period_s)
    si = tr.index(st)
    n = rng.standard_normal((len(st), 3)) * float(units.arcsec(s.sigma_arcsec))
    C_star_li = rotvec_to_dcm(n) @ tr.C[si]
    q_eci = dcm_to_quat(fr.C_eci_li @ C_star_li)
    return LaunchData(seed, dth, dv, x0, gt, gnss_lla, st, q_eci)


def _make_locals(kind: str, scn: LaunchScenario, P0, seed: int, particles: int | None):
    x0 = np.zeros(15)
    if kind == "pf":
        fo = scn.filters
        N = particles or fo.particles
        return {name: ParticleFilter(x0, P0, name=f"pf/{name}", n_particles=N,
                                     rng=np.random.default_rng([seed, 2, i]),
                                     resample_threshold=fo.resample_threshold,
                                     roughening=fo.roughening,
                                     progressive=fo.progressive_correction)
                for i, name in enumerate(SENSORS)}
    if kind == "ekf":
        return {name: KalmanFilter(x0, P0, name=f"ekf/{name}") for name in SENSORS}
    raise ValueError(f"unknown launch filter '{kind}'; choose pf or ekf")


class LaunchCore:
    """The launch-frame mechanization / error-model pair as a navigator core (see
    :mod:`fednav.navigator.loop`): the nominal SINS (:class:`LaunchStrapdown`), its
    15-state error model (:class:`LaunchProcess`) and the closed-loop feedback into the
    attitude, velocity, position and the IMU bias compensation."""

    n = N_STATES

    def __init__(self, ins: LaunchStrapdown, frame, T: float, noise: ImuNoise):
        self.ins, self.frame, self.T, self.noise = ins, frame, float(T), noise
        self.eps = np.zeros(3)  # gyro bias estimate [rad/s]
        self.nab = np.zeros(3)  # accelerometer bias estimate [m/s^2]

    @property
    def state(self) -> np.ndarray:
        return self.ins.state

    def snapshot(self) -> tuple:
        return self.ins.state.copy(), self.eps.copy(), self.nab.copy()

    def restore(self, snap) -> None:
        state, eps, nab = snap
        self.ins.state[:] = state
        self.eps, self.nab = eps.copy(), nab.copy()

    def propagate(self, fed, dtheta, dv, h_ref, dt: float, record: bool):
        aux = self.ins.interval(dtheta - self.eps * dt, dv - self.nab * dt)
        proc = LaunchProcess(self.frame, aux, self.T, self.noise)
        fed.predict(proc)
        return proc, None, None, None

    def nav(self, omega=None):
        return None  # the launch models read the INS state itself

    def measure(self, m, i: int, nav, dt: float = 0.0):
        return m.model.residual(self.ins.state, m.z[i]), m.model, None, m.R[i]

    def feed_back(self, fed) -> np.ndarray:
        """Fuse; closed loop: C <- exp([phi x]) C_hat, v -= dv, r -= dr, biases +=."""
        fed.fuse()
        dx = fed.feedback() * SCALE
        st = self.ins.state
        q = quat_mul(rotvec_to_quat(np.ascontiguousarray(dx[PHI_])), st[0:4])
        st[0:4] = q / np.linalg.norm(q)
        st[4:7] -= dx[VEL]
        st[7:10] -= dx[POS]
        self.eps += dx[GYRO]
        self.nab += dx[ACC]
        return dx


#: The local filters, in the order they update each cycle.
SENSORS = ("gnss", "star")


def launch_system(scn: LaunchScenario, kind: str) -> System:
    """The system description of a launch-frame run: its two sensors (used at the filter
    epoch), the filter type and period."""
    return System.model_validate({
        "sensors": {"gnss": {"sigma_pos_enu_m": scn.gnss.sigma_m,
                             "period_s": scn.gnss.period_s,
                             "timing": {"delay_compensation": "none"}},
                    "star": {"sigma_arcsec": scn.star.sigma_arcsec,
                             "period_s": scn.star.period_s,
                             "timing": {"delay_compensation": "none"}}},
        "aiding": list(SENSORS),
        "filter": {"type": kind, "period_s": scn.filter_period_s,
                   "sharing": scn.filters.sharing}})


def run(scn: LaunchScenario, data: LaunchData, kind: str, max_time: float | None = None,
        particles: int | None = None) -> LaunchResult:
    """Fly one run with federated ``kind`` ('pf' or 'ekf') local filters."""
    t_start = time.perf_counter()
    tr = scn.trajectory(max_time)
    fr = tr.frame
    per = round(scn.filter_period_s / tr.dt)
    K = (len(tr.t) - 1) // per
    T = per * tr.dt
    P0 = initial_covariance(scn)
    # Nominal SINS: truth corrupted by the drawn initial error.
    x0 = data.x0_err * SCALE
    C0 = rotvec_to_dcm(-x0[PHI_]) @ tr.C[0]
    ins = LaunchStrapdown(fr, dcm_to_quat(C0), tr.v[0] + x0[VEL], tr.r[0] + x0[POS], tr.dt)
    fo = scn.filters
    alpha = {"gnss": fo.ekf_gate_alpha, "star": None} if kind == "ekf" else None
    fed = FederatedFilter(_make_locals(kind, scn, P0, data.seed, particles), master=None,
                          sharing=fo.sharing, reset=True, fdi_alpha=alpha)
    gnss_model = GnssPositionLI(scn.gnss.outlier_probability, scn.gnss.outlier_scale) \
        if kind == "pf" and fo.pf_gnss_likelihood == "mixture" else GnssPositionLI()
    core = LaunchCore(ins, fr, T, _noise(scn))
    nav = Navigator(launch_system(scn, kind), None, tr.dt, record_rows=False,
                    record_covariance=False,
                    mechanization=Mechanization(core, fed, {"gnss": gnss_model,
                                                            "star": StarAttitudeLI()},
                                                float(tr.t[0]), "the launch-frame INS"))
    # Sensor outputs converted to LI once (each at its own time).
    if len(data.gnss_t):
        nav.add_measurements("gnss", data.gnss_t, fr.geodetic_to_li(data.gnss_lla, data.gnss_t),
                             R=np.broadcast_to(np.eye(3) * scn.gnss.sigma_m**2,
                                               (len(data.gnss_t), 3, 3)))
    if len(data.star_t):
        C_star = fr.C_eci_li.T @ quat_to_dcm(data.star_q_eci)
        nav.add_measurements("star", data.star_t, C_star.reshape(-1, 9),
                             R=np.broadcast_to(np.eye(3) * scn.star.sigma_arcsec**2,
                                               (len(data.star_t), 3, 3)))
    n = K * per
    nav.add_imu(tr.t[:n], dtheta=data.dtheta[:n], dv=data.dv[:n])
    res = nav.result()
    st = res.states[1:]
    q_hat, v_hat, r_hat = st[:, 0:4], st[:, 4:7], st[:, 7:10]
    sig = np.sqrt(np.diagonal(res.P[1:], axis1=1, axis2=2)[:, :9]) * SCALE[:9]
    ts = res.t[1:]
    j = (np.arange(K) + 1) * per
    att = misalignment(tr.C[j], quat_to_dcm(q_hat))
    pos, vel = r_hat - tr.r[j], v_hat - tr.v[j]
    min_ess, stages = float("nan"), 1
    if kind == "pf":
        logs = [e for f in fed.locals.values() for e in f.ess_log]
        min_ess = float(min(logs)) if logs else float("nan")
        stages = max((s for f in fed.locals.values() for s in f.stage_log), default=1)
    return LaunchResult(kind.upper(), ts, att, pos, vel, sig, time.perf_counter() - t_start,
                        min_ess, stages)
