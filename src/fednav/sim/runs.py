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

from ..core import attitude as att
from ..core import earth, units
from ..ins import error_model as em
from ..ins.strapdown import STATE_LLA, STATE_Q, STATE_VEL
from ..navigator.navigator import TOTAL_MODELS  # noqa: F401  (0.1's fednav.simulate names)
from ..navigator.system import initial_covariance as _p0
from ..navigator.total import total_state_models  # noqa: F401
from ..sensors import (
    MeasurementSeries,
    corrupt_imu,
    inject_faults,
)
from ..sensors.registry import SENSORS
from .scenario import Scenario


@dataclass
class RunData:
    """Sensor data of one Monte Carlo run."""

    seed: int
    dtheta: np.ndarray
    dv: np.ndarray
    series: dict[str, MeasurementSeries]
    init_phi: np.ndarray
    init_dv: np.ndarray
    init_dp: np.ndarray
    faults: list = field(default_factory=list)  # the run's drawn faults (sensors.faults)


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
    #: per local filter, the mean NIS/dof against the centralized filter's innovation
    #: covariance (:func:`fednav.navigator.health.local_nis`; run with ``innovations``)
    nis: dict[str, float] | None = None
    #: units fault detection left out of a measurement whose rest it used (a raw GNSS
    #: epoch's satellite): (t [s], local filter, unit, statistic) (:attr:`fednav.
    #: navigator.NavResult.excluded`)
    excluded: list = field(default_factory=list)


#: The second word of the seed of a run's fault draws (``[seed, FAULT_STREAM]``).
FAULT_STREAM = 0xFA17


def feed_order(aiding, system) -> list[str]:
    """The sensors a navigator of ``system`` is fed, in order: the ``aiding`` ones, then
    those with another role in it (:meth:`fednav.navigator.system.System.roles`: a
    barometer's damping loop, air data for the wind constraint)."""
    return list(aiding) + [n for n in dict.fromkeys(system.roles().values())
                           if n not in aiding]


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
    # (the faults' draws from a stream of their own: the noise is the same without them)
    frng = np.random.default_rng([seed, FAULT_STREAM])
    faults = scn.draw_faults(frng)
    for name in SENSORS:  # registry order: the order of the draws
        cfg = scn.sensors.get(name)
        if cfg is not None:
            series[name] = inject_faults(cfg.simulate(truth, rng, name), faults)
    return RunData(seed, dth, dv, series, init_phi, init_dv, init_dp, faults)


def initial_covariance(scn: Scenario) -> np.ndarray:
    """Filter P0 (filter units) from the scenario's initial errors and IMU specification."""
    ie = scn.initial_errors
    return _p0(scn, scn.imu_period_s,
               units.arcsec(np.asarray(ie.attitude_arcsec)), ie.velocity_mps, ie.position_m)


def _initial_state(scn: Scenario, truth, data: RunData):
    """The navigator's start: the truth moved by the run's initial errors, P0 from the
    scenario."""
    from ..navigator.navigator import InitialState

    C = att.apply_misalignment(att.euler_to_dcm(truth.euler[0]), data.init_phi)
    return InitialState(float(truth.t[0]), earth.move_enu(truth.lla[0], data.init_dp),
                        truth.vel[0] + data.init_dv, att.dcm_to_euler(C),
                        initial_covariance(scn))


def run_mode(scn: Scenario, aiding: list[str], data: RunData, mode: str = "",
             max_time: float | None = None, filter_type: str | None = None,
             delay: str | None = None, constraint: str | None = None,
             innovations: bool = False) -> RunResult:
    """Fly one mode (list of aiding sensors; empty = free SINS) on the run's data.

    ``filter_type`` overrides the scenario's (``total-ukf``: the total-state navigator);
    ``delay`` overrides the delay strategy of every aiding sensor with a latency;
    ``constraint="wind"`` applies the air-data wind constraint in every local filter;
    ``innovations``: record them, for each local filter's NIS against the centralized
    filter's innovation covariance (:attr:`RunResult.nis`).
    The mode is the scenario's system with these settings (:meth:`Scenario.system_for`),
    flown by the :class:`~fednav.navigator.Navigator`.
    """
    from ..navigator.navigator import Navigator
    from .scenario import ModeConfig

    truth = scn.trajectory(max_time)
    dt = truth.dt
    T = scn.filter.period_s
    n_per = round(T / dt)
    if abs(n_per * dt - T) > 1e-9:
        raise ValueError(f"scenario {scn.name}: filter period {T} s is not a multiple of the "
                         f"IMU period {dt} s")
    for a in aiding:
        if a not in data.series:
            raise ValueError(f"scenario {scn.name}: mode '{mode}' uses sensor '{a}' which the "
                             f"scenario does not configure")
    system = scn.system_for(ModeConfig(name=mode or "mode", aiding=list(aiding),
                                       filter=filter_type, delay_compensation=delay,
                                       constraint=constraint))
    if "pf" in system.filter.types():  # the particle filters' draws differ run to run
        pf = system.filter.pf
        pf = pf.model_copy(update={"seed": [*np.atleast_1d(pf.seed).tolist(), data.seed]})
        system = system.model_copy(update={"filter": system.filter.model_copy(
            update={"pf": pf})})
    feed = feed_order(aiding, system)
    need = system.roles().get("constraint")
    if need is not None and need not in data.series:
        raise ValueError(f"scenario {scn.name}: the {constraint} constraint needs "
                         f"sensors.{need}")
    nav = Navigator(system, _initial_state(scn, truth, data), dt, record_rows=False,
                    record_covariance=False, innovations=innovations)
    for a in feed:
        if a in data.series:
            nav.add_series(data.series[a])
    m = len(truth.t) - 1  # (the run's data may be longer than the flight flown)
    nav.add_imu(truth.t[:-1], dtheta=data.dtheta[:m], dv=data.dv[:m])
    res = nav.result()
    K = len(res.states) - 1
    if not aiding:
        sigma = np.full((K, em.N_STATES), np.nan)
        return _result(scn, truth, n_per, res.states[1:], mode, sigma, {}, None)
    out = _result(scn, truth, n_per, res.states[1:], mode, res.sigma[1:], res.beta, res.fdi)
    out.excluded = list(res.excluded)
    if innovations:
        from ..navigator.health import local_nis

        out.nis = {k: v for k, (v, _) in local_nis(res.innovations, every=True).items()}
    return out


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


def _stats_epochs(t, period):
    """Filter epochs that fall on the statistics grid (every ``period`` seconds)."""
    ph = np.mod(t + 1e-9, period)
    return ph < 1e-6


def run_all_modes(scn: Scenario, data: RunData, max_time: float | None = None,
                  innovations: bool = False) -> dict[str, RunResult]:
    """Every mode of the scenario flown on the same run data, by mode name."""
    return {m.name: run_configured_mode(scn, m, data, max_time, innovations)
            for m in scn.modes}


def run_configured_mode(scn: Scenario, mode, data: RunData, max_time: float | None = None,
                        innovations: bool = False) -> RunResult:
    """Run a :class:`~fednav.sim.scenario.ModeConfig` of the scenario."""
    return run_mode(scn, list(mode.aiding), data, mode.name, max_time, mode.filter,
                    mode.delay_compensation, mode.constraint, innovations)
