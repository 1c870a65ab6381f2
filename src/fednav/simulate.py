"""Closed-loop simulation of one scenario mode: SINS + aiding sensors + (federated) filter.

One Monte Carlo run draws, from one ``numpy.random.Generator`` seeded with the run's
seed, the initial INS errors, the IMU errors and every aiding sensor's noise; all modes
of the scenario are then flown on the *same* data (common random numbers), so the modes
differ only by their aiding.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from . import attitude as att
from . import earth, units
from . import error_model as em
from .config import Scenario
from .filters import FederatedFilter, KalmanFilter, LinearModel, make_filter
from .measurements import MODELS, NavSnapshot
from .sensors import Barometer, MeasurementSeries, corrupt_imu, inject_faults
from .strapdown import STATE_LLA, STATE_Q, STATE_VEL, Strapdown, quat_to_dcm_nb
from .total_state import GnssTotal, StarTotal, TotalStateUKF

TOTAL_MODELS = {"gnss": GnssTotal(), "star": StarTotal()}
#: Positions of the total-state filter's 15 states in the 18-state error layout.
_NAV_BIAS = np.r_[0:12, 15:18]


@dataclass
class RunData:
    """Sensor data of one Monte Carlo run."""

    seed: int
    dtheta: np.ndarray
    dv: np.ndarray
    series: dict[str, MeasurementSeries]
    h_ref: np.ndarray
    init_phi: np.ndarray
    init_dv: np.ndarray
    init_dp: np.ndarray


@dataclass
class RunResult:
    """Navigation errors (computed minus true) at the statistics epochs.

    ``pos`` ENU [m], ``vel`` ENU [m/s], ``att`` platform angles phiE, phiN, phiU [rad];
    ``sigma`` filter 1-sigma of the 18 states in SI (NaN without a filter);
    ``beta`` sharing factors per filter epoch; ``fdi`` one row per local measurement:
    time, local filter, chi-square statistic, degrees of freedom, threshold (NaN when
    detection is off) and whether the local filter was isolated.
    """

    mode: str
    t: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    att: np.ndarray
    sigma: np.ndarray
    beta: dict[str, np.ndarray] = field(default_factory=dict)
    fdi: pd.DataFrame | None = None
    euler: np.ndarray | None = None  # Euler [pitch, roll, heading] estimated - true [rad]


def make_run_data(scn: Scenario, seed: int, max_time: float | None = None) -> RunData:
    """Draw the IMU errors, sensor noise and initial errors of run ``seed``."""
    truth = scn.trajectory(max_time)
    rng = np.random.default_rng(seed)
    ie = scn.initial_errors
    init_phi = rng.standard_normal(3) * units.arcsec(np.asarray(ie.attitude_arcsec))
    init_dv = rng.standard_normal(3) * ie.velocity_mps
    init_dp = rng.standard_normal(3) * ie.position_m
    dth, dv, _ = corrupt_imu(truth.dtheta, truth.dv, truth.dt, scn.imu.errors(truth.dt), rng)
    series = {}
    faults = [f.fault() for f in scn.faults]
    for name in ("star", "sar", "gnss", "baro"):
        cfg = getattr(scn.sensors, name)
        if cfg is not None:
            series[name] = inject_faults(cfg.sensor().simulate(truth, rng), faults)
    h_ref = (Barometer.on_imu_grid(series["baro"], truth.t[:-1]) if "baro" in series
             else np.full(len(truth.t) - 1, np.nan))
    return RunData(seed, dth, dv, series, h_ref, init_phi, init_dv, init_dp)


def _initial_ins(scn: Scenario, truth, data: RunData) -> Strapdown:
    lat, lon, h = truth.lla[0]
    rm, rn = earth.radii(lat)
    dp = data.init_dp
    lla = np.array([lat + dp[1] / (rm + h), lon + dp[0] / ((rn + h) * np.cos(lat)), h + dp[2]])
    C = att.apply_misalignment(att.euler_to_dcm(truth.euler[0]), data.init_phi)
    baro = scn.sensors.baro.loop() if scn.sensors.baro is not None else None
    return Strapdown(lla, truth.vel[0] + data.init_dv, att.dcm_to_euler(C), truth.dt, baro)


def initial_covariance(scn: Scenario) -> np.ndarray:
    """Filter P0 (filter units) from the scenario's initial errors and IMU specification."""
    ie, imu = scn.initial_errors, scn.imu
    sd = np.r_[
        units.arcsec(np.asarray(ie.attitude_arcsec)), np.full(3, ie.velocity_mps),
        np.full(3, ie.position_m),
        np.full(3, units.deg_per_h(imu.gyro_bias_deg_h)),
        np.full(3, units.deg_per_h(imu.gyro_markov_deg_h)),
        np.full(3, units.micro_g(max(imu.accel_bias_ug, imu.accel_markov_ug))),
    ]
    sd = np.maximum(sd / em.SCALE, 1e-6)  # keep P0 positive definite for states set to 0
    return np.diag(sd**2)


def _build_filter(scn: Scenario, aiding: list[str], ftype: str) -> FederatedFilter:
    f = scn.filter
    P0 = initial_covariance(scn)
    opts = ({"alpha": f.alpha, "beta": f.beta, "kappa": f.kappa}
            if ftype in ("ukf", "sukf") else {})
    locals_ = {a: make_filter(ftype, np.zeros(em.N_STATES), P0, **opts) for a in aiding}
    for a, flt in locals_.items():
        flt.name = f"{ftype} local '{a}'"
    master = None
    if f.master and len(aiding) > 1:
        master = make_filter(ftype, np.zeros(em.N_STATES), P0, **opts)
        master.name = f"{ftype} master"
    return FederatedFilter(locals_, master, sharing=f.sharing, fixed=f.fixed_factors,
                           reset=f.reset, fdi_alpha=f.fdi_alpha,
                           fdi_recovery=f.fdi_recovery)


def _schedule(series: MeasurementSeries, T: float, n_cycles: int) -> list[list[int]]:
    """Measurement indices to use at the end of each filter cycle (first cycle ending at or
    after the measurement becomes available)."""
    k = np.ceil(series.t_avail / T - 1e-9).astype(int) - 1
    out: list[list[int]] = [[] for _ in range(n_cycles)]
    for i, kk in enumerate(k):
        if 0 <= kk < n_cycles:
            out[kk].append(i)
    return out


def run_mode(scn: Scenario, aiding: list[str], data: RunData, mode: str = "",
             max_time: float | None = None, filter_type: str | None = None) -> RunResult:
    """Fly one mode (list of aiding sensors; empty = free SINS) on the run's data.

    ``filter_type`` overrides the scenario's; ``total-ukf`` runs :func:`run_total_state`.
    """
    ftype = filter_type or scn.filter.type
    if ftype == "total-ukf":
        return run_total_state(scn, aiding, data, mode, max_time)
    truth = scn.trajectory(max_time)
    dt = truth.dt
    T = scn.filter.period_s
    n_per = round(T / dt)
    if abs(n_per * dt - T) > 1e-9:
        raise ValueError(f"scenario {scn.name}: filter period {T} s is not a multiple of the "
                         f"IMU period {dt} s")
    n_cycles = (len(truth.t) - 1) // n_per
    for a in aiding:
        if a not in data.series:
            raise ValueError(f"scenario {scn.name}: mode '{mode}' uses sensor '{a}' which the "
                             f"scenario does not configure")
    ins = _initial_ins(scn, truth, data)
    fed = _build_filter(scn, aiding, ftype) if aiding else None
    noise = scn.imu.noise_model(dt)
    baro_gains = ins.baro_gains[:2]
    baro = scn.sensors.baro
    baro_q = baro.sigma_m**2 * baro.period_s if baro is not None else 0.0
    sched = {a: _schedule(data.series[a], T, n_cycles) for a in aiding}
    comp_g = np.zeros(3)
    comp_a = np.zeros(3)
    states = np.empty((n_cycles, ins.state.size))  # INS state after each cycle
    var = np.full((n_cycles, em.N_STATES), np.nan)  # fused covariance diagonal (filter units)
    betas = {k: np.empty(n_cycles) for k in (fed.filters if fed else {})}
    for k in range(n_cycles):
        sl = slice(k * n_per, (k + 1) * n_per)
        dth = data.dtheta[sl] - comp_g * dt
        dvc = data.dv[sl] - comp_a * dt
        s0 = ins.state.copy() if fed is not None else None
        ins.run(dth, dvc, data.h_ref[sl], record=False)
        if fed is not None:
            s1 = ins.state
            qm = s0[STATE_Q] + s1[STATE_Q]
            Cm = quat_to_dcm_nb(qm / np.sqrt(qm @ qm))
            pm = 0.5 * (s0[STATE_LLA] + s1[STATE_LLA])
            nom = em.Nominal(lat=pm[0], h=pm[2], vel=0.5 * (s0[STATE_VEL] + s1[STATE_VEL]),
                             C=Cm, fn=Cm @ dvc.sum(axis=0) / T)
            proc = em.ErrorProcess(nom, T, noise, baro_gains, baro_q, scn.filter.substeps)
            fed.predict(proc)
            nav = None
            for a in aiding:
                for i in sched[a][k]:
                    if nav is None:
                        nav = NavSnapshot(ins.lla, ins.vel, ins.dcm)
                    s = data.series[a]
                    model = MODELS[a]
                    fed.update(a, model.residual(nav, s.z[i]), model, nav, model.R(s.sigma),
                               t=truth.t[(k + 1) * n_per])
            fed.fuse()
            var[k] = np.diagonal(fed.P)
            for name, b in fed.beta.items():
                betas[name][k] = b
            dx = em.to_si(fed.feedback())
            ins.correct(dx[em.PHI], dx[em.DV], dx[em.DP])
            comp_g += dx[em.EPS_C] + dx[em.EPS_R]
            comp_a += dx[em.NABLA]
        states[k] = ins.state
    sigma = np.sqrt(var) * em.SCALE
    return _result(scn, truth, n_per, states, mode, sigma,
                   betas, fed.log if fed is not None else None)


def _result(scn, truth, n_per, states, mode, sigma, betas, log) -> RunResult:
    """Errors of the INS states recorded after each filter cycle against the truth."""
    n_cycles = len(states)
    lla, vel, quat = states[:, STATE_LLA], states[:, STATE_VEL], states[:, STATE_Q]
    idx = (np.arange(n_cycles) + 1) * n_per
    t = truth.t[idx]
    tl = truth.lla[idx]
    pos_err = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], tl[:, 0], tl[:, 1],
                                       tl[:, 2])
    vel_err = vel - truth.vel[idx]
    C = att.quat_to_dcm(quat)
    att_err = att.misalignment(att.euler_to_dcm(truth.euler[idx]), C)
    euler_err = att.euler_difference(att.dcm_to_euler(C), truth.euler[idx])
    keep = _stats_epochs(t, scn.stats_period_s)
    fdi = None
    if log is not None:
        fdi = pd.DataFrame(log, columns=["t", "local", "statistic", "dof", "threshold",
                                         "isolated"])
    return RunResult(mode, t[keep], pos_err[keep], vel_err[keep], att_err[keep], sigma[keep],
                     {k: v[keep] for k, v in betas.items()}, fdi, euler_err[keep])


def total_state_models(scn: Scenario, T: float, dt: float):
    """P0 (15, 15), Qw (6, 6), Qb (6, 6) and bias decay (6,) of the total-state UKF.

    Bias states (filter units deg/h, mg) start from the scenario's constant/Markov bias
    sigma and follow a first-order Gauss–Markov process with the scenario's correlation
    time (random walk when it is infinite), driven by the bias random walk and the Markov
    noise; ``Qw`` is the white gyro/accelerometer noise averaged over one interval.
    """
    noise = scn.imu.noise_model(dt)
    P18 = initial_covariance(scn)
    P0 = P18[np.ix_(_NAV_BIAS, _NAV_BIAS)]
    decay = np.r_[np.full(3, np.exp(-T / noise.gyro_markov_tau)),
                  np.full(3, np.exp(-T / noise.accel_markov_tau))]
    qb = np.r_[np.full(3, noise.gyro_bias_rw**2 * T
                       + (1 - decay[0] ** 2) * noise.gyro_markov_sigma**2),
               np.full(3, noise.accel_bias_rw**2 * T
                       + (1 - decay[3] ** 2) * noise.accel_markov_sigma**2)]
    bscale = np.r_[em.SCALE[9:12], em.SCALE[15:18]]
    Qw = np.diag(np.r_[np.full(3, noise.gyro_arw**2 / T), np.full(3, noise.accel_vrw**2 / T)])
    return P0, Qw, np.diag(qb / bscale**2), decay


def run_total_state(scn: Scenario, aiding: list[str], data: RunData, mode: str = "",
                    max_time: float | None = None) -> RunResult:
    """Paper 003's federated total-state UKF: the master time-updates the navigation state
    (augmented UKF through the mechanization), shares ``P / beta_j`` with the local
    filters, which update linearly (simplified UKF) with their sensor; the fused
    correction moves the navigation state (which is the INS)."""
    truth = scn.trajectory(max_time)
    dt, T = truth.dt, scn.filter.period_s
    n_per = round(T / dt)
    n_cycles = (len(truth.t) - 1) // n_per
    for a in aiding:
        if a not in data.series or a not in TOTAL_MODELS:
            raise ValueError(f"scenario {scn.name}: mode '{mode}' uses sensor '{a}' which the "
                             f"scenario or the total-state filter does not provide")
    ins = _initial_ins(scn, truth, data)
    f = scn.filter
    P0, Qw, Qb, decay = total_state_models(scn, T, dt)
    ukf = TotalStateUKF(ins, P0, Qw, Qb, decay, f.alpha, f.beta, f.kappa)
    fed = FederatedFilter({a: KalmanFilter(np.zeros(15), np.eye(15), name=f"local '{a}'")
                           for a in aiding}, None, sharing="equal" if f.sharing == "adaptive"
                          else f.sharing, fixed=f.fixed_factors, reset=True,
                          fdi_alpha=f.fdi_alpha, fdi_recovery=f.fdi_recovery)
    sched = {a: _schedule(data.series[a], T, n_cycles) for a in aiding}
    models = {a: (TOTAL_MODELS[a], LinearModel(TOTAL_MODELS[a].H)) for a in aiding}
    states = np.empty((n_cycles, ins.state.size))
    var = np.full((n_cycles, em.N_STATES), np.nan)
    for k in range(n_cycles):
        sl = slice(k * n_per, (k + 1) * n_per)
        ukf.predict(data.dtheta[sl], data.dv[sl], data.h_ref[sl])
        fed.share(np.zeros(15), ukf.P)
        tk = truth.t[(k + 1) * n_per]
        for a in aiding:
            model, lin = models[a]
            s = data.series[a]
            for i in sched[a][k]:
                y, R = model.terms(ins.state, s.z[i], s.sigma)
                fed.update(a, y, lin, None, R, t=tk)
        dx, P = fed.fuse()
        ukf.apply(dx)
        ukf.P = P
        var[k, _NAV_BIAS] = np.diagonal(P)
        states[k] = ins.state
    sigma = np.sqrt(var) * em.SCALE
    return _result(scn, truth, n_per, states, mode, sigma, {}, fed.log)


def _stats_epochs(t, period):
    """Filter epochs that fall on the statistics grid (every ``period`` seconds)."""
    ph = np.mod(t + 1e-9, period)
    return ph < 1e-6


def run_all_modes(scn: Scenario, data: RunData,
                  max_time: float | None = None) -> dict[str, RunResult]:
    """Every mode of the scenario flown on the same run data, by mode name."""
    return {m.name: run_configured_mode(scn, m, data, max_time) for m in scn.modes}


def run_configured_mode(scn: Scenario, mode, data: RunData,
                        max_time: float | None = None) -> RunResult:
    """Run a :class:`~fednav.config.ModeConfig` of the scenario."""
    return run_mode(scn, list(mode.aiding), data, mode.name, max_time, mode.filter)
