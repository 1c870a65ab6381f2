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
import scipy.linalg

from ..core import attitude as att
from ..core import earth, units
from ..filters import FederatedFilter, FilterError, KalmanFilter, LinearModel, make_filter
from ..ins import error_model as em
from ..ins.strapdown import STATE_LLA, STATE_Q, STATE_VEL, Strapdown, quat_to_dcm_nb
from ..ins.total_state import GnssTotal, StarTotal, TotalStateUKF
from ..navigator.system import imu_noise_model
from ..sensors import (
    MODELS,
    Barometer,
    MeasurementSeries,
    NavSnapshot,
    StackedModel,
    WindConstraint,
    corrupt_imu,
    inject_faults,
)
from ..sensors.delays import ANGLE_COLUMNS, InsIncrements, curve_fit_value
from ..sensors.registry import SENSORS
from . import compiled_loop
from .scenario import Scenario

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
    init_dp = rng.standard_normal(3) * np.asarray(ie.position_m, dtype=float)
    dth, dv, _ = corrupt_imu(truth.dtheta, truth.dv, truth.dt, scn.imu.errors(truth.dt), rng)
    series = {}
    faults = [f.fault() for f in scn.faults]
    for name in SENSORS:  # registry order: the order of the draws
        cfg = scn.sensors.get(name)
        if cfg is not None:
            series[name] = inject_faults(cfg.simulate(truth, rng, name), faults)
    baro = scn.sensors.baro
    h_ref = (Barometer.on_imu_grid(series["baro"], truth.t[:-1])
             if baro is not None and baro.damping_loop else np.full(len(truth.t) - 1, np.nan))
    return RunData(seed, dth, dv, series, h_ref, init_phi, init_dv, init_dp)


def _initial_ins(scn: Scenario, truth, data: RunData) -> Strapdown:
    lla = earth.move_enu(truth.lla[0], data.init_dp)
    C = att.apply_misalignment(att.euler_to_dcm(truth.euler[0]), data.init_phi)
    baro = scn.sensors.baro.loop() if scn.sensors.baro is not None else None
    return Strapdown(lla, truth.vel[0] + data.init_dv, att.dcm_to_euler(C), truth.dt, baro)


def initial_covariance(scn: Scenario) -> np.ndarray:
    """Filter P0 (filter units) from the scenario's initial errors and IMU specification."""
    ie = scn.initial_errors
    _, gb, ab = imu_noise_model(scn, scn.imu_period_s)
    sd = np.r_[
        units.arcsec(np.asarray(ie.attitude_arcsec)), np.full(3, ie.velocity_mps),
        np.broadcast_to(np.asarray(ie.position_m, dtype=float), (3,)),
        np.full(3, gb), np.full(3, scn.imu.si("gyro_markov") or 0.0), np.full(3, ab),
    ]
    sd = np.maximum(sd / em.SCALE, 1e-6)  # keep P0 positive definite for states set to 0
    return np.diag(sd**2)


def _build_filter(scn: Scenario, aiding: list[str], ftype: str) -> FederatedFilter:
    f = scn.filter
    P0 = initial_covariance(scn)
    opts = ({"alpha": f.alpha, "beta": f.beta, "kappa": f.kappa}
            if ftype in ("ukf", "sukf", "cukf", "raukf") else
            {"level": f.grid_level} if ftype in ("sghqf", "aasghqf") else {})
    names = ["central"] if f.architecture == "centralized" else aiding
    locals_ = {a: make_filter(ftype, np.zeros(em.N_STATES), P0, **opts) for a in names}
    for a, flt in locals_.items():
        flt.name = f"{ftype} local '{a}'"
    master = None
    if f.master and len(locals_) > 1:
        master = make_filter(ftype, np.zeros(em.N_STATES), P0, **opts)
        master.name = f"{ftype} master"
    return FederatedFilter(locals_, master, sharing=f.sharing, fixed=f.fixed_factors,
                           reset=f.reset, fdi_alpha=f.fdi_alpha,
                           fdi_recovery=f.fdi_recovery)


def _cycle_of(t, t0: float, T: float) -> np.ndarray:
    """Index of the filter cycle that ends at or after each time ``t`` (cycle k ends at
    ``t0 + (k + 1) T``)."""
    return np.ceil((np.asarray(t) - t0) / T - 1e-9).astype(int) - 1


def _schedule(series: MeasurementSeries, T: float, n_cycles: int,
              t0: float = 0.0) -> list[list[int]]:
    """Measurement indices to use at the end of each filter cycle (first cycle ending at or
    after the measurement becomes available)."""
    out: list[list[int]] = [[] for _ in range(n_cycles)]
    for i, kk in enumerate(_cycle_of(series.t_avail, t0, T)):
        if 0 <= kk < n_cycles:
            out[kk].append(i)
    return out


class _ClosedLoop:
    """SINS + error-state (federated or centralized) filter with feedback, one filter
    cycle at a time, on one run's data; measurements carry their timing and are treated
    by their sensor's delay strategy (:mod:`fednav.sensors.delays`)."""

    def __init__(self, scn: Scenario, aiding: list[str], data: RunData, ftype: str, truth,
                 delay: str | None = None, constraint: str | None = None):
        self.scn, self.aiding, self.data = scn, aiding, data
        self.dt, self.T = truth.dt, scn.filter.period_s
        self.n_per = round(self.T / self.dt)
        self.t_epoch = truth.t[0] + self.T * np.arange(len(truth.t) // self.n_per + 2)
        self.ins = _initial_ins(scn, truth, data)
        self.fed = _build_filter(scn, aiding, ftype) if aiding else None
        self.central = scn.filter.architecture == "centralized"
        self.noise = imu_noise_model(scn, self.dt)[0]
        self.baro_gains = self.ins.baro_gains[:2]
        baro = scn.sensors.baro
        self.baro_q = (baro.sigma_m**2 * baro.period_s
                       if baro is not None and baro.damping_loop else 0.0)
        self.comp_g = np.zeros(3)
        self.comp_a = np.zeros(3)
        self.timing = {}
        for a in aiding:
            tm = scn.sensors[a].timing
            if delay is not None and not (tm.latency().is_zero and not tm.sequential):
                tm = tm.model_copy(update={"delay_compensation": delay})
            self.timing[a] = tm
        self.constraint = constraint
        if constraint is not None and "airdata" not in data.series:
            raise ValueError(f"scenario {scn.name}: the wind constraint needs sensors.airdata")
        self.incs = None
        if any(tm.delay_compensation in ("ins_increment", "recompute")
               for tm in self.timing.values()):
            self.incs = InsIncrements((len(truth.t) - 1) // self.n_per, truth.t[0], self.T)

    def snapshot(self) -> tuple:
        return (self.ins.state.copy(), self.fed.snapshot(), self.comp_g.copy(),
                self.comp_a.copy())

    def restore(self, snap: tuple) -> None:
        state, fed, g, a = snap
        self.ins.state[:] = state
        self.fed.restore(fed)
        self.comp_g, self.comp_a = g.copy(), a.copy()

    def _residual(self, a: str, i: int, how: str, nav: NavSnapshot, k: int) -> np.ndarray:
        s = self.data.series[a]
        model = MODELS[a]
        if how in ("ins_increment", "recompute"):
            return model.residual(self.incs.carry_back(nav, k + 1, s.t[i]), s.z[i])
        if how == "curve_fit":
            tm = self.timing[a]
            known = np.flatnonzero(s.t_avail <= self.t_epoch[k + 1] + 1e-9)  # t increases
            z = curve_fit_value(s.t[known], s.z[known], self.t_epoch[k + 1],
                                tm.curve_fit_degree, tm.curve_fit_points,
                                ANGLE_COLUMNS.get(a, ()))
            return model.residual(nav, z)
        return model.residual(nav, s.z[i])

    def _wind_constraint(self, k: int) -> None:
        """The air-data wind constraint (latest air data available) in every local filter."""
        s = self.data.series["airdata"]
        i = int(np.searchsorted(s.t_avail, self.t_epoch[k + 1] + 1e-9)) - 1
        if i < 0:
            return
        nav = NavSnapshot(self.ins.lla, self.ins.vel, self.ins.dcm)
        model = WindConstraint(s.z[i, 0])
        d, R = model.residual(nav, s.z[i]), model.R(s.sigma, nav)
        for name in self.fed.locals:
            self.fed.update(name, d, model, nav, R, t=self.t_epoch[k + 1])

    def cycle(self, k: int, meas: list[tuple[str, int, str]]) -> None:
        """Filter cycle ``k`` (ends at epoch k+1) applying ``meas`` = (sensor, index, how)."""
        n_per, T, dt = self.n_per, self.T, self.dt
        sl = slice(k * n_per, (k + 1) * n_per)
        dth = self.data.dtheta[sl] - self.comp_g * dt
        dvc = self.data.dv[sl] - self.comp_a * dt
        ins, fed = self.ins, self.fed
        s0 = ins.state.copy()
        ins.run(dth, dvc, self.data.h_ref[sl], record=False)
        s1 = ins.state
        if self.incs is not None:
            self.incs.record(k + 1, s0[STATE_LLA], s0[STATE_VEL], quat_to_dcm_nb(s0[STATE_Q]),
                             s1[STATE_LLA], s1[STATE_VEL], ins.dcm)
        fed.predict(em.interval_process(s0, s1, dvc.sum(axis=0), T, self.noise,
                                        self.baro_gains, self.baro_q,
                                        self.scn.filter.substeps))
        if meas:
            nav = NavSnapshot(ins.lla, ins.vel, ins.dcm)
            t = self.t_epoch[k + 1]
            if self.central:
                ys, models, Rs = [], [], []
                for a, i, how in meas:
                    ys.append(self._residual(a, i, how, nav, k))
                    models.append(MODELS[a])
                    Rs.append(MODELS[a].R(self.data.series[a].sigma))
                fed.update("central", np.concatenate(ys), StackedModel(models), nav,
                           scipy.linalg.block_diag(*Rs), t=t)
            else:
                for a, i, how in meas:
                    model = MODELS[a]
                    fed.update(a, self._residual(a, i, how, nav, k), model, nav,
                               model.R(self.data.series[a].sigma), t=t)
        if self.constraint == "wind":
            self._wind_constraint(k)
        fed.fuse()
        dg, da = em.apply_feedback(ins, fed.feedback())
        self.comp_g += dg
        self.comp_a += da


def run_mode(scn: Scenario, aiding: list[str], data: RunData, mode: str = "",
             max_time: float | None = None, filter_type: str | None = None,
             delay: str | None = None, constraint: str | None = None) -> RunResult:
    """Fly one mode (list of aiding sensors; empty = free SINS) on the run's data.

    ``filter_type`` overrides the scenario's; ``total-ukf`` runs :func:`run_total_state`.
    ``delay`` overrides the delay strategy of every aiding sensor with a latency;
    ``constraint="wind"`` applies the air-data wind constraint in every local filter.
    Each aiding sensor's measurements are used at the first filter epoch after they
    become available, treated by the sensor's ``timing.delay_compensation``; with
    ``recompute`` the filter is re-run from the epoch of the capture instant.
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
    loop = _ClosedLoop(scn, aiding, data, ftype, truth, delay, constraint)
    fed = loop.fed
    how = {a: loop.timing[a].delay_compensation for a in aiding}
    t0 = truth.t[0]
    sched = {a: _schedule(data.series[a], T, n_cycles, t0) for a in aiding}
    if fed is None:  # free INS: the whole flight in one compiled call
        m = n_cycles * n_per
        rec = loop.ins.run(data.dtheta[:m], data.dv[:m], data.h_ref[:m])
        states = np.zeros((n_cycles, loop.ins.state.size))
        end = np.arange(1, n_cycles + 1) * n_per - 1
        for sl, key in ((STATE_Q, "q"), (STATE_VEL, "vel"), (STATE_LLA, "lla")):
            states[:, sl] = rec[key][end]
        return _result(scn, truth, n_per, states, mode, np.full((n_cycles, em.N_STATES),
                                                                 np.nan), {}, None)
    if compiled_loop.supported(ftype, aiding, loop.timing, loop.central, constraint,
                               scn.filter.fdi_alpha, scn.filter.reset, loop.incs):
        return _run_compiled(scn, truth, loop, sched, n_cycles, mode)
    recompute = [a for a in aiding if how[a] == "recompute"]
    capture = {a: _cycle_of(data.series[a].t, t0, T) for a in recompute}
    avail = {a: _cycle_of(data.series[a].t_avail, t0, T) for a in recompute}

    def planned(m: int, now: int) -> list[tuple[str, int, str]]:
        out = []
        for a in aiding:
            if a in capture:  # everything known by `now` that was captured in cycle m
                idx = np.flatnonzero((np.maximum(capture[a], 0) == m) & (avail[a] <= now))
                out += [(a, int(i), "recompute") for i in idx]
            else:
                out += [(a, i, how[a]) for i in sched[a][m]]
        return out

    states = np.empty((n_cycles, loop.ins.state.size))  # INS state after each cycle
    var = np.full((n_cycles, em.N_STATES), np.nan)  # fused covariance diagonal (filter units)
    betas = {k: np.empty(n_cycles) for k in fed.filters}
    snaps: list = [None] * n_cycles
    first = loop.snapshot() if recompute else None
    for k in range(n_cycles):
        j = k
        for a in recompute:
            for i in sched[a][k]:
                j = min(j, max(int(capture[a][i]), 0))
        if j < k:  # re-run the filter from the capture cycle with what is known now
            loop.restore(snaps[j - 1] if j > 0 else first)
            for m in range(j, k):
                loop.cycle(m, planned(m, k))
                snaps[m] = loop.snapshot()
        loop.cycle(k, planned(k, k))
        if first is not None:
            snaps[k] = loop.snapshot()
        var[k] = np.diagonal(fed.P)
        for name, b in fed.beta.items():
            betas[name][k] = b
        states[k] = loop.ins.state
    sigma = np.sqrt(var) * em.SCALE
    return _result(scn, truth, n_per, states, mode, sigma, betas, fed.log)


def _run_compiled(scn, truth, loop: _ClosedLoop, sched, n_cycles: int, mode: str) -> RunResult:
    """:func:`run_mode` through :func:`fednav.compiled_loop.closed_loop` (same filters,
    same order of measurements, one compiled call)."""
    fed, data = loop.fed, loop.data
    names = list(fed.filters)
    first = fed.filters[names[0]]
    X = np.array([f.x for f in fed.filters.values()])
    P = np.array([f.P for f in fed.filters.values()])
    beta = np.array([fed.beta[k] for k in names])
    kinds = np.array([compiled_loop.KINDS.get(k, -1) for k in names])
    R = np.zeros((len(names), 3, 3))
    for i, a in enumerate(loop.aiding):
        R[i] = MODELS[a].R(data.series[a].sigma)
    meas = [(k, i, j) for k in range(n_cycles) for i, a in enumerate(loop.aiding)
            for j in sched[a][k]]
    m_cycle = np.array([k for k, _, _ in meas], dtype=np.int64)
    m_filter = np.array([i for _, i, _ in meas], dtype=np.int64)
    m_z = np.array([data.series[loop.aiding[i]].z[j] for _, i, j in meas],
                   dtype=float).reshape(-1, 3)
    k1, k2, itg, ita, noise = em.model_constants(loop.noise, loop.baro_gains, loop.baro_q)
    n = loop.ins.state.size
    states = np.empty((n_cycles, n))
    var = np.empty((n_cycles, em.N_STATES))
    betas = np.empty((n_cycles, len(names)))
    nis = np.empty(len(meas))
    state = loop.ins.state.copy()
    code, k, f = compiled_loop.closed_loop(
        state, np.ascontiguousarray(data.dtheta), np.ascontiguousarray(data.dv),
        np.ascontiguousarray(data.h_ref, dtype=float), loop.dt, loop.ins.baro_gains,
        loop.n_per, float(loop.T), k1, k2, itg, ita, noise, int(scn.filter.substeps),
        em.SCALE, X, P, beta, first.c, first.Wm, first.Wc,
        compiled_loop.SHARING[fed.sharing], kinds, m_cycle, m_filter, m_z, R, states, var,
        betas, nis)
    if code:
        who = (fed.filters[names[f]].name if 0 <= f < len(names) and code != 1
               else "strapdown INS" if code == 1 else "federated fusion")
        raise FilterError(f"{who} at step {k + 1}: {compiled_loop.FAILURES[code]}")
    loop.ins.state[:] = state
    log = [(loop.t_epoch[k + 1], loop.aiding[i], float(v), 3, float("nan"), False)
           for (k, i, _), v in zip(meas, nis, strict=True)]
    sigma = np.sqrt(var) * em.SCALE
    return _result(scn, truth, loop.n_per, states, mode, sigma,
                   {k: betas[:, i].copy() for i, k in enumerate(names)}, log)


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
    noise = imu_noise_model(scn, dt)[0]
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
    """Run a :class:`~fednav.sim.scenario.ModeConfig` of the scenario."""
    return run_mode(scn, list(mode.aiding), data, mode.name, max_time, mode.filter,
                    mode.delay_compensation, mode.constraint)
