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
from .filters import FederatedFilter, make_filter
from .measurements import MODELS, NavSnapshot
from .sensors import Barometer, MeasurementSeries, corrupt_imu, inject_faults
from .strapdown import STATE_LLA, STATE_Q, STATE_VEL, Strapdown, quat_to_dcm_nb


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
    C = att.apply_misalignment(truth.dcm[0], data.init_phi)
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


def _build_filter(scn: Scenario, aiding: list[str]) -> FederatedFilter:
    f = scn.filter
    P0 = initial_covariance(scn)
    opts = ({"alpha": f.alpha, "beta": f.beta, "kappa": f.kappa}
            if f.type in ("ukf", "sukf") else {})
    locals_ = {a: make_filter(f.type, np.zeros(em.N_STATES), P0, **opts) for a in aiding}
    for a, flt in locals_.items():
        flt.name = f"{f.type} local '{a}'"
    master = None
    if f.master and len(aiding) > 1:
        master = make_filter(f.type, np.zeros(em.N_STATES), P0, **opts)
        master.name = f"{f.type} master"
    return FederatedFilter(locals_, master, sharing=f.sharing, fixed=f.fixed_factors,
                           reset=f.reset, fdi_alpha=f.fdi_alpha)


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
             max_time: float | None = None) -> RunResult:
    """Fly one mode (list of aiding sensors; empty = free SINS) on the run's data."""
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
    fed = _build_filter(scn, aiding) if aiding else None
    noise = scn.imu.noise_model(dt)
    baro_gains = ins._gains[:2]
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
    lla, vel, quat = states[:, STATE_LLA], states[:, STATE_VEL], states[:, STATE_Q]
    sigma = np.sqrt(var) * em.SCALE
    idx = (np.arange(n_cycles) + 1) * n_per
    t = truth.t[idx]
    tl = truth.lla[idx]
    pos_err = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2], tl[:, 0], tl[:, 1],
                                       tl[:, 2])
    vel_err = vel - truth.vel[idx]
    att_err = att.misalignment(truth.dcm[idx], att.quat_to_dcm(quat))
    keep = _stats_epochs(t, scn.stats_period_s)
    fdi = None
    if fed is not None:
        fdi = pd.DataFrame(fed.log, columns=["t", "local", "statistic", "dof", "threshold",
                                             "isolated"])
    return RunResult(mode, t[keep], pos_err[keep], vel_err[keep], att_err[keep], sigma[keep],
                     {k: v[keep] for k, v in betas.items()}, fdi)


def _stats_epochs(t, period):
    ph = np.mod(t + 1e-9, period)
    return ph < 1e-6
