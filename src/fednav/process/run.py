"""Post-processing of recorded data: the navigator on IMU, GNSS (and velocity-sensor)
files, with an optional RTS smoother.

The front end of ``fednav process``: the input checks (:mod:`fednav.process.checks`:
units, time offsets, IMU mounting, unused keys), the outages withheld
(:mod:`fednav.process.outages`), the initial attitude and P0
(:mod:`fednav.process.initial`), then the
system description run by the :class:`~fednav.navigator.Navigator` — by default a
loosely coupled federated Kalman filter with one local filter per sensor (``gnss``, and
``velocity`` when a velocity sensor is given), fusion-reset with equal sharing (which
equals the centralized filter), a measurement compared with the INS at its time of
validity — and the solution at every IMU sample with its sigmas, smoothed on request.
"""

from __future__ import annotations

import functools
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from pydantic import ValidationError

from ..core import units
from ..ins.alignment import UNKNOWN_HEADING_SIGMA, Alignment
from ..io.data import (
    RECORDINGS,
    DataError,
    FixData,
    ImuData,
    SensorData,
    Series,
    VelocityData,
    as_recording,
)
from ..navigator.health import (
    centralized_consistency,
    local_nis,
    readmission_warnings,
    row_nis,
    run_health,
)
from ..navigator.loop import InnovationRecord  # noqa: F401  (fednav.process's name)
from ..navigator.navigator import (
    InitialState,
    Navigator,
    declared_latency,
    residual_covariances,
    stamp_tolerance,
)
from ..navigator.solution import Solution, epoch_rate, imu_rate
from ..navigator.system import (
    System,
    imu_noise_model,
    initial_covariance,
    missing_figures,
    sensor_model,
)
from ..navigator.system import imu_figures as _imu_figures
from ..sensors import registry
from ..sensors.imu import FIGURES
from . import outages
from .checks import (  # noqa: F401  (fednav.process.run's names of 0.2)
    LATENCY_WARN_S,
    MAX_IMU_PERIOD_S,
    OFFSET_SEARCH_S,
    OFFSET_WARN_S,
    check_fix_timing,
    check_mounting,
    check_units,
    ignored_keys,
    mounted_imu,
    time_offset,
    velocity_latency,
    wheeled_hint,
)
from .culprit import culprit
from .evaluation import RENAMED_ERRORS, errors_against, rmse  # noqa: F401
from .initial import (  # noqa: F401  (fednav.process.run's names of 0.2)
    VELOCITY_WINDOW_S,
    attitude_at_start,
    fix_course,
    position_velocity,
    start_at_first_fix,
    start_covariance,
)

#: The processing config of fednav 0.1 is a system description now (one schema); the
#: old name is kept for one release.
ProcessConfig = System
#: fednav.process.run's names of 0.2 (the fixes were the GNSS's by name), kept.
check_gnss_timing, gnss_course = check_fix_timing, fix_course


def old_layout(*old: str):
    """Decorator of ``fn(imu, sensors, ...)``: a call in fednav 0.1's layout
    ``fn(imu, gnss, velocity, *old, sensors=...)`` (GNSS and velocity sensor as their own
    arguments) is read as ``fn(imu, {"gnss": gnss, "velocity": velocity, **sensors},
    ...)`` with a ``FutureWarning``, for one more release."""
    def wrap(fn):
        @functools.wraps(fn)
        def call(imu, *args, **kwargs):
            second = args[0] if args else kwargs.get("gnss")
            third = args[1] if len(args) > 1 else None
            if not ("gnss" in kwargs or "velocity" in kwargs
                    or isinstance(second, (FixData, VelocityData))
                    or isinstance(third, VelocityData)
                    or (len(args) > 2 and isinstance(args[2], System))
                    or (len(args) >= 2 and args[0] is None and args[1] is None
                        and (len(args) > 2 or old[0] in kwargs))):
                return fn(imu, *args, **kwargs)
            warnings.warn(f"{fn.__name__}(imu, gnss, velocity, ...) is now "
                          f"{fn.__name__}(imu, {{'gnss': gnss, 'velocity': velocity, ...}}, "
                          f"...): every sensor's series by its registered name; read for "
                          f"one more release", FutureWarning, stacklevel=2)
            given = dict(zip(("gnss", "velocity") + old, args, strict=False)) | kwargs
            sensors = dict(given.pop("sensors", None) or {})
            for name in ("gnss", "velocity"):
                if given.get(name) is not None:
                    if name in sensors:
                        raise DataError(f"{name} data given twice: as the {name} argument "
                                        f"and in sensors")
                    sensors[name] = given[name]
                given.pop(name, None)
            return fn(imu, sensors, **given)
        return call
    return wrap


def with_velocity_latency(cfg: System, name: str | None, fixes) -> tuple[System, dict,
                                                                          list[str]]:
    """``cfg`` with the fix sensor's ``velocity_latency_s`` resolved where its section
    leaves it to the data (None): the latency :func:`velocity_latency` sees from the
    positions when it is confident (positive, beyond :data:`LATENCY_WARN_S` and three
    of its sigmas), else 0.  Returns the system, the data quality
    (``<name>_velocity_latency_seen_s``, ``_sigma_s``, ``_applied_s`` [s], ``_seen_by``:
    ``positions``) and a line saying what was taken out."""
    sc = None if fixes is None else own_section(name, cfg)
    if sc is None or getattr(sc, "velocity_latency_s", 0.0) is not None:
        return cfg, {}, []
    lat = velocity_latency(fixes)
    take = lat is not None and lat[0] > max(LATENCY_WARN_S, 3.0 * lat[1])
    applied = round(lat[0], 3) if take else 0.0
    cfg = with_section(cfg, name, sc, velocity_latency_s=applied)
    if lat is None:
        return cfg, {}, []
    quality = {f"{name}_velocity_latency_seen_s": round(lat[0], 3),
               f"{name}_velocity_latency_sigma_s": round(lat[1], 3),
               f"{name}_velocity_latency_applied_s": applied,
               f"{name}_velocity_latency_seen_by": "positions"}
    said = ([f"{fixes.source}: the {registry.label(name)} velocity lags its positions by "
             f"{lat[0]:+.3f} s (+-{lat[1]:.3f} s, from the positions' differences): taken "
             f"out (sensors.{name}.velocity_latency_s: 0 keeps the stamps)"] if take else [])
    return cfg, quality, said


#: the positions' differences resolve a latency when their sigma is at most this [s] (a
#: latency at the warning threshold is then three sigmas out); else the INS is asked
LATENCY_RESOLVED_S = LATENCY_WARN_S / 3.0


def with_ins_latency(imu: ImuData, sensors: dict, cfg: System, prep: Prepared) -> Prepared:
    """``prep`` again with the fix sensor's velocity latency the INS sees
    (:mod:`fednav.process.latency`) taken out, where the positions' differences could not
    tell it (:func:`with_velocity_latency`: noisy positions, no estimate or one whose
    sigma is above :data:`LATENCY_RESOLVED_S`, none taken out) and the section leaves it
    to the data: one pass flying the positions alone, smoothed, gives the antenna's velocity,
    and a lag beyond :data:`LATENCY_WARN_S` and three of its sigmas is taken out and
    said.

    The INS runs on the IMU's clock, so what it sees is the velocity's lag against the
    IMU: the velocity's own latency, or the receiver's whole output (positions too)
    stamped late.  Under noisy positions the two are hardly told apart (a position late
    by ``L`` is ``L v`` off, which the filter mostly takes for its own error: the NIS of
    the positions alone moved by ``L`` changed by 1 % on a 152 s drive), while the
    velocities' timing is what costs (measured in docs/real-data.md): so the velocities
    are moved, and the line names ``time_offset_s``, which moves the positions too.  The
    data quality gets what was seen (``<name>_velocity_latency_seen_s``, ``_sigma_s``,
    ``_applied_s``, ``_seen_by``: ``INS``).  Otherwise ``prep``."""
    name = registry.fix_sensor(sensors)
    fixes = sensors.get(name)
    sc = None if fixes is None else own_section(name, cfg)
    if (sc is None or getattr(sc, "velocity_latency_s", 0.0) is not None
            or fixes.vel is None or fixes.lla is None or name not in prep.series
            or getattr(prep.system.sensors[name], "measures", None) != "position_velocity"
            or prep.system.filter.state != "error"):
        return prep
    sigma = prep.quality.get(f"{name}_velocity_latency_sigma_s")
    if ((sigma is not None and sigma <= LATENCY_RESOLVED_S)
            or prep.quality.get(f"{name}_velocity_latency_applied_s", 0.0) > 0.0):
        return prep  # (resolved by the positions, or taken out by them already)
    lat = ins_velocity_latency(imu, sensors, cfg)
    if lat is None:
        return prep
    take = lat[0] > max(LATENCY_WARN_S, 3.0 * lat[1])
    applied = round(lat[0], 3) if take else 0.0
    if take:
        prep = prepare(imu, sensors, with_section(cfg, name, sc, velocity_latency_s=applied))
        prep.warnings.insert(0, f"{fixes.source}: the {registry.label(name)} velocity lags "
                                f"the INS by {lat[0]:+.3f} s (+-{lat[1]:.3f} s, against a "
                                f"pass on the positions alone): taken out "
                                f"(sensors.{name}.velocity_latency_s: 0 keeps the stamps); "
                                f"if the receiver stamps its positions as late, "
                                f"sensors.{name}.time_offset_s: "
                                f"{sc.time_offset_s - applied:+.3f} moves them too")
    prep.quality.update({f"{name}_velocity_latency_seen_s": round(lat[0], 3),
                         f"{name}_velocity_latency_sigma_s": round(lat[1], 3),
                         f"{name}_velocity_latency_applied_s": applied,
                         f"{name}_velocity_latency_seen_by": "INS"})
    return prep


def ins_velocity_latency(imu: ImuData, sensors: dict, cfg: System
                         ) -> tuple[float, float] | None:
    """The fix sensor's velocity latency [s] and its 1-sigma [s] against the INS
    (:func:`fednav.process.latency.velocity_latency_ins`): ``cfg`` flown with the
    positions alone (its section's ``measures: position``), and the receiver's velocities
    (``time_offset_s`` applied) fitted to that smoothed solution's antenna velocity.  None
    where that cannot tell (see there)."""
    from .latency import antenna_velocity, velocity_latency_ins

    name = registry.fix_sensor(sensors)
    sc = own_section(name, cfg)
    alone = prepare(imu, sensors, with_section(cfg, name, sc, measures="position",
                                               velocity_latency_s=0.0))
    res = alone.feed(alone.navigator(record_rows=True, record_covariance=True)).result()
    sol = imu_rate(res, smooth=True, sigmas=False)[1]  # (the motion: no 1-sigma read)
    d = alone.series[name]
    return velocity_latency_ins(d.t, d.z[:, 3:6], sol.t,
                                antenna_velocity(sol, alone.system.sensors[name].lever_m))


def _start_fixes(name: str, d: Series, cfg: System):
    """The fixes a run without a fix sensor's (and without ``initial:``) starts from,
    sensor ``name``'s own solutions (:attr:`SensorSpec.start`: the raw GNSS's single-point
    ones), with the section of the fix sensor's kind the start takes (their lever arm
    and 1-sigma); a one-line :class:`DataError` when there is none."""
    section = own_section(name, cfg)
    t, lla, vel, s_pos, s_vel = registry.spec(name).start(d, section)
    if not len(t):
        raise DataError(f"{d.source}: no epoch with four satellites (pseudoranges and "
                        f"range rates) to start from; give the initial state (initial:)")
    lever = section.lever()
    s_vel = np.where(np.isfinite(s_vel), s_vel, 1.0)  # (positions only: not used)
    fixes = FixData(f"{d.source} (single-point solutions)", t, lla, vel, s_pos, s_vel, lever)
    kind = registry.spec(registry.fix_sensor()).config
    return fixes, kind.model_validate({"lever_m": lever.tolist(),
                                       "sigma_pos_enu_m": s_pos.tolist(),
                                       "sigma_vel_mps": s_vel.tolist()})


def with_section(cfg: System, name: str, section, **update) -> System:
    """``cfg`` with sensor ``name``'s ``section`` (its own, :func:`own_section`) updated by
    ``update``."""
    return cfg.model_copy(update={"sensors": cfg.sensors.replace(
        **{name: section.model_copy(update=update)})})


def own_section(name: str, cfg: System):
    """The system's section of sensor ``name``, else the section's defaults (None when
    the section has no defaults: it needs its noise)."""
    if name in cfg.sensors:
        return cfg.sensors[name]
    try:
        return registry.spec(name).config()
    except ValidationError:
        return None


@dataclass
class ProcessResult:
    """What :func:`process` gives: the solution at every IMU sample and the run's report.

    Attributes
    ----------
    forward : Solution
        The forward filter's solution with its 1-sigma (lat/lon [rad], h [m], ENU
        velocity [m/s], Euler angles [rad]; :class:`fednav.Solution`).
    smoothed : Solution or None
        The RTS-smoothed solution, when asked for.
    run_time_s : float
        Wall time of the run [s]; on a first run it includes numba's compilation of the
        kernels (``fednav process`` leaves that out and says it apart).
    epochs : int
        Filter epochs processed [-].
    data_quality : dict
        What the input checks did (samples bridged, measurements skipped, counts [-]) and
        what they measured (``*_seen_s`` [s]).
    warnings : list of str
        One line per warning about the data or the run.
    alignment : dict
        How the initial attitude was found (:mod:`fednav.ins.alignment`).
    optional_states : dict
        The optional error states' (``filter.states``) ``estimate`` and ``sigma`` per axis
        at the end of the run, SI (:attr:`fednav.navigator.NavResult.optional`).
    consistency : dict
        Per local filter: ``nis_per_dof``, the mean NIS per degree of freedom over every
        measurement, isolated ones included, against the innovation covariance of the
        equivalent centralized filter (1 for a consistent filter;
        :func:`~fednav.navigator.health.local_nis`), ``gate_nis_per_dof``, the local
        filter's own (what its chi-square gate tests: smaller in a federation that shares
        its information), ``isolated_fraction`` and ``measurements``.
    outages : dict
        Per sensor with ``outages_s`` in the system description, its windows
        ``[start, end)`` [s] whose measurements were withheld from the filter
        (:mod:`fednav.process.outages`; ``summary.json`` scores the errors inside them).
    fixes_flown : GnssData or None
        The fixes (of the sensor that starts the recording, the GNSS:
        :func:`fednav.sensors.registry.fix_sensor`) the filter was given (those outside
        the outages).
    integrity : IntegrityResult or None
        With the system's ``integrity:``, the protection levels [m, rad], tests and
        exclusions of every row (:class:`fednav.navigator.integrity.IntegrityResult`;
        ``forward`` is then the output after any exclusion).
    noise : Identified or None
        The IMU noise figures identified from the recording (prior -> identified,
        NIS/dof before -> after; :mod:`fednav.process.identify`), None with the system's
        ``noise: as-given`` and for the total-state navigator (``filter.state: total``,
        which has no smoother to identify with).
    hints : list of str
        What the run suggests the description could add (one line each): nothing is
        wrong without it (:func:`fednav.process.checks.wheeled_hint`).
    figures : dict
        Per sensor with a figure of its own recording (:attr:`fednav.sensors.spec.
        SensorSpec.figure`: the raw GNSS's satellites, DOP and exclusions), a function
        of no argument that draws it (``fednav process`` writes ``NAME.png``).
    """

    forward: Solution
    smoothed: Solution | None
    run_time_s: float
    epochs: int
    #: what the input checks did (samples bridged, epochs skipped) and their warnings
    data_quality: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    #: how the initial attitude was found (:mod:`fednav.ins.alignment`)
    alignment: dict = field(default_factory=dict)
    optional_states: dict = field(default_factory=dict)
    outages: dict = field(default_factory=dict)
    fixes_flown: FixData | None = None
    consistency: dict = field(default_factory=dict)
    #: the protection levels, tests and exclusions (the system's ``integrity:``;
    #: :class:`fednav.navigator.integrity.IntegrityResult`), else None
    integrity: object = None
    #: the noise identification's report (:class:`fednav.process.identify.Identified`;
    #: None with ``noise: as-given``)
    noise: object = None
    #: what the run suggests the description could add (one line each)
    hints: list = field(default_factory=list)
    #: per sensor with a figure of its own, a function drawing it (``NAME.png``)
    figures: dict = field(default_factory=dict)

    @property
    def gnss_flown(self) -> FixData | None:
        """Deprecated: :attr:`fixes_flown`."""
        warnings.warn("ProcessResult.gnss_flown is now ProcessResult.fixes_flown: read "
                      "for one more release", FutureWarning, stacklevel=2)
        return self.fixes_flown


def adjust_sensors(fixes: FixData, velocity: VelocityData | None, cfg: System):
    """fednav 0.1's: the system description's corrections of the GNSS and the velocity
    sensor (:meth:`fednav.io.GnssData.adjusted`, :meth:`fednav.io.VelocityData.adjusted`:
    time offsets, the velocity latency, the velocity sensor's axis order and 1-sigma).
    Returns new data objects."""
    return tuple(None if d is None else d.adjusted(own_section(d.name, cfg))
                 for d in (fixes, velocity))


def imu_figures(imu: ImuData, cfg: System) -> dict[str, float | None]:
    """Every IMU figure (SI, by its SI key of the ``imu:`` section): the system
    description's, else the data file's (its largest axis), else None."""
    f = _imu_figures(cfg.imu, imu.errors)
    return {FIGURES[k][2]: v for k, v in f.items()}


def _noise(imu: ImuData, cfg: System, dt: float):
    """Filter IMU model and initial bias sigmas from the file's figures and the system
    description's (:func:`fednav.navigator.system.imu_noise_model`).

    The gyro has a constant-bias state and a Gauss–Markov one.  With the default
    ``filter.accel_bias: random_walk`` the accelerometer has one bias state, which must
    carry both the turn-on (constant) bias and the Gauss–Markov part: a Markov state
    alone would let the estimate of the constant bias decay with the correlation time
    (the tilt it is coupled to would then absorb it).  It is therefore a random constant
    (1-sigma ``sqrt(bias^2 + markov^2)``) driven by the random walk whose short-term
    growth equals the Markov process's, ``q = 2 sigma_m^2 / tau``.
    Returns (noise model, gyro constant-bias sigma, accelerometer bias sigma).
    """
    _check_figures(imu, cfg)
    return imu_noise_model(cfg, dt, imu.errors)


@dataclass
class Prepared:
    """Recorded data made ready for the navigator (:func:`prepare`).

    Attributes
    ----------
    system : System
        The system it flies: the description with the filter epoch period and the
        sensors' effective settings.
    initial : InitialState
        Where it starts (time [s], lat/lon [rad], h [m], ENU velocity [m/s], Euler
        angles [rad], P0).
    dt : float
        IMU period [s].
    t : ndarray, shape (N,)
        IMU time stamps from the start, whole epochs only [s].
    gyro : ndarray, shape (N, 3)
        Angular rates, body right-forward-up [rad/s].
    accel : ndarray, shape (N, 3)
        Specific force, body right-forward-up [m/s^2].
    series : dict of str to Series
        Every sensor's measurements as the navigator takes them, by registered name
        (:class:`fednav.io.data.Series`: times of validity and arrival [s], ``z`` in
        the sensor's layout — GNSS: lat, lon [rad], h [m], ENU velocity [m/s] — and
        each row's 1-sigma or covariance; the noise becomes R in one place, the
        navigator's :meth:`~fednav.navigator.Navigator.add_measurements`), in the order
        they are fed.
    imu_errors : ImuErrors or None
        The IMU file's error figures (SI units).
    n_per : int
        IMU samples per filter epoch [-].
    warnings : list of str
        What the checks found, one line each.
    alignment : Alignment
        How the initial attitude was found (:mod:`fednav.ins.alignment`).
    quality : dict
        What the input checks did (counts [-]) and measured (``*_seen_s`` [s]).
    increments : tuple of ndarray or None
        The IMU file's own increments (dtheta [rad], dv [m/s]) of these samples, when it
        held them.
    """

    system: System
    initial: InitialState
    dt: float
    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    series: dict
    imu_errors: object
    n_per: int
    warnings: list
    alignment: Alignment
    quality: dict
    #: the IMU file's own increments (dtheta, dv) of these samples, when it held them
    increments: tuple | None = None

    def navigator(self, **options) -> Navigator:
        """A navigator for these data, nothing fed yet.

        Parameters
        ----------
        **options
            :class:`~fednav.navigator.Navigator` options (``record_rows``,
            ``record_covariance``, ``innovations``, ``hold_s``, ``engine``).

        Returns
        -------
        Navigator
            Built from :attr:`system`, :attr:`initial`, :attr:`dt` [s] and
            :attr:`imu_errors`.
        """
        return Navigator(self.system, self.initial, self.dt, imu_errors=self.imu_errors,
                         **options)

    # -- fednav 0.1's names, read for one more release (the series hold all of it now)
    def _old(self, name: str, new: str):
        warnings.warn(f"Prepared.{name} is now {new}: read for one more release",
                      FutureWarning, stacklevel=3)

    @property
    def measurements(self) -> dict:
        """Deprecated: ``{name: self.rows(name)}`` for the GNSS and the velocity sensor."""
        self._old("measurements", "Prepared.series (Prepared.rows(name) for (t, z, R))")
        return {n: self.rows(n) for n in ("gnss", "velocity") if n in self.series}

    @property
    def others(self) -> dict:
        """Deprecated: the series of the sensors other than the GNSS and velocity sensor."""
        self._old("others", "Prepared.series")
        return {n: d for n, d in self.series.items() if n not in ("gnss", "velocity")}

    @property
    def sigmas(self) -> dict:
        """Deprecated: each series' 1-sigma (the series' ``sigma``)."""
        self._old("sigmas", "Prepared.series[name].sigma")
        return {n: d.sigma for n, d in self.series.items() if d.sigma is not None}

    @property
    def arrivals(self) -> dict:
        """Deprecated: each series' arrival times (the series' ``t_arrival``)."""
        self._old("arrivals", "Prepared.series[name].t_arrival")
        return {n: d.t_arrival for n, d in self.series.items() if d.t_arrival is not None}

    def rows(self, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One sensor's series with each row's R, for a stream that passes its own R
        with each measurement.

        Parameters
        ----------
        name : str
            The sensor's registered name (a key of :attr:`series`).

        Returns
        -------
        tuple of ndarray
            ``(t, z, R)``: times of validity (N,) [s], values (N, m) in the sensor's
            layout [rad, m, m/s], residual covariances (N, r, r) by the system's
            measurement model [residual units squared]
            (:func:`~fednav.navigator.navigator.residual_covariances`).
        """
        d = self.series[name]
        noise = d.cov if d.cov is not None else d.sigma
        if noise is None:
            noise = np.broadcast_to(self.system.sensors[name].sigma(), d.z.shape)
        return d.t, d.z, residual_covariances(sensor_model(self.system, name), noise)

    def feed(self, nav: Navigator) -> Navigator:
        """Feed every measurement, then every IMU sample, in one block each.

        Parameters
        ----------
        nav : Navigator
            A navigator from :meth:`navigator`.

        Returns
        -------
        Navigator
            ``nav``, fed (its :meth:`~fednav.navigator.Navigator.result` is the run's).
        """
        for d in self.series.values():
            nav.add_series(d)
        if self.increments is not None:
            nav.add_imu(self.t, dtheta=self.increments[0], dv=self.increments[1])
        else:
            nav.add_imu(self.t, self.gyro, self.accel)
        return nav


def _pseudo(name: str, cfg: System, imu: ImuData, T: float) -> SensorData:
    """Rows ``z = 0`` of a pseudo-measurement (a non-holonomic constraint) every
    ``sensors.NAME.period_s`` (default: the filter period ``T``) over the IMU data."""
    period = cfg.sensors[name].period_s or T
    t = np.arange(imu.t[0] + period, imu.t[-1] + 1e-9, period)
    m = len(registry.spec(name).columns)
    return SensorData(name, f"sensors.{name} (no file: every {period:g} s)", t,
                      np.zeros((len(t), m)), quality={})


def _section(data: Series, cfg: System):
    """The system's section of a recorded sensor as it flies ``data``: the description's
    (else the section's defaults when they suffice), the components the file leaves out
    said, and what the section leaves to the data taken from them
    (:meth:`~fednav.sensors.spec.SensorConfig.for_recording`)."""
    spec = registry.spec(data.name)
    sc = own_section(data.name, cfg)
    if sc is None:  # (the section's defaults do not suffice: it needs its noise)
        if data.sigma is None:
            raise DataError(f"{data.source}: the system description needs a "
                            f"'sensors.{data.name}' section (its noise) to use this "
                            f"file, or the file each row's 1-sigma")
        # each row gives its noise: the section's other settings at their defaults
        sc = spec.config.model_construct()
    for j in data.absent:  # a column the file leaves out: the section says so
        if spec.columns[j].absent:
            sc = sc.model_copy(update=spec.columns[j].absent)
    sc = sc.for_recording(data)
    if spec.aiding and data.sigma is None and data.cov is None and sc.sigma() is None:
        raise DataError(f"{data.source}: sensors.{data.name} gives no noise figure")
    return sc


def _plain(d: Series) -> SensorData:
    """A series as the navigator is fed it: its own fields only (a sigma for every row
    given once, as a simulated series has it, repeated per row)."""
    if type(d) is SensorData:
        return d
    sigma = d.sigma
    if sigma is not None and np.ndim(sigma) == 1:
        sigma = np.broadcast_to(np.asarray(sigma, dtype=float), np.shape(d.z))
    return SensorData(d.name, d.source, np.asarray(d.t, dtype=float), np.asarray(d.z),
                      d.t_arrival, dict(d.quality), sigma, d.absent, d.cov)


def samples_within(interval: float, dt: float) -> int:
    """The whole number of IMU samples ``dt`` [s] nearest ``interval`` [s] (at least
    one)."""
    return max(1, int(round(interval / dt)))


def epoch_drift(cfg: System, fixes: FixData | None, T: float, dt: float, n_cycles: int,
                quality: dict) -> list[str]:
    """A warning when the filter epochs — a whole number of IMU samples, ``T`` [s] by the
    IMU's stamps — drift against fixes taken every GNSS period by more than one IMU
    sample ``dt`` over the run's ``n_cycles`` epochs (an IMU clock a few hundred ppm off
    its nominal rate): each fix then waits a varying part of an epoch for its update, and
    the solution between a fix and its epoch is the prediction.  Records the drift in
    ``quality["epoch_drift_s"]``."""
    if cfg.filter.period_s is not None or fixes is None or len(fixes.t) < 2:
        return []
    p = float(np.median(np.diff(fixes.t)))
    drift = abs(T - p) * n_cycles
    if drift <= dt:
        return []
    quality["epoch_drift_s"] = round(drift, 6)
    n = samples_within(p / 5, dt)
    return [f"the filter epochs ({int(round(T / dt))} IMU samples, {T:.6f} s by the IMU's "
            f"stamps) drift against the GNSS fixes ({p:.6f} s apart) by {drift:.3f} s over "
            f"the run: a fix waits up to one epoch for its update, and the solution between "
            f"a fix and its epoch is the prediction; set filter.period_s to a fraction of the "
            f"fix interval (e.g. {n * dt:.6g} s, {n} IMU samples) to bound the wait"]


def _period(cfg: System, fixes: FixData | None, others: dict) -> float:
    """The filter epoch: the system's, else the GNSS period, else the shortest median
    period of the other aiding sensors' data."""
    if cfg.filter.period_s is not None:
        return cfg.filter.period_s
    if fixes is not None and len(fixes.t) > 1:
        return float(np.median(np.diff(fixes.t)))
    periods = [float(np.median(np.diff(d.t))) for d in others.values()
               if len(d.t) > 1 and registry.spec(d.name).aiding]
    if not periods:
        raise DataError("filter.period_s: give the filter period (no aiding sensor's data "
                        "has two measurements to take it from)")
    return min(periods)


#: The IMU grade assumed for data that come with no IMU figure at all (with a warning).
DEFAULT_GRADE = "consumer"


def with_imu_figures(imu: ImuData, cfg: System) -> tuple[System, list[str]]:
    """``cfg``, with the :data:`DEFAULT_GRADE` preset (and a warning naming it) when
    neither its ``imu:`` section nor the data file gives any IMU figure; a one-line
    :class:`DataError` naming a figure that some are given but not that one (0 must be
    said: a filter that trusts the IMU completely is a choice)."""
    figures = set(cfg.imu.model_fields_set) - {"max_bridge_s", "random_bias", "mounting",
                                               "gyro_scale_ppm", "accel_scale_ppm",
                                               "gyro_scale_tau_s", "accel_scale_tau_s"}
    if not figures and imu.errors is None:
        cfg = cfg.model_copy(update={"imu": cfg.imu.model_copy(
            update={"grade": DEFAULT_GRADE})})
        return cfg, [f"{imu.source}: no IMU error figures in the file or the config: the "
                     f"'{DEFAULT_GRADE}' MEMS preset is assumed (fednav.sensors.imu.GRADES); "
                     f"give the IMU's figures or imu.grade (consumer, industrial, tactical, "
                     f"navigation)"]
    missing = missing_figures(cfg.imu, imu.errors)
    if missing:
        raise DataError(f"{imu.source}: no IMU error figures in the file; give "
                        f"imu.{missing[0]} in the processing config (or imu.grade: consumer, "
                        f"industrial, tactical or navigation, for the figures left out)")
    return cfg, []


def _check_figures(imu: ImuData, cfg: System) -> None:
    """:func:`with_imu_figures`' refusal alone."""
    with_imu_figures(imu, cfg)


@old_layout("cfg", "sensors")
def prepare(imu: ImuData, sensors: Mapping[str, Series] | None = None,
            cfg: System | None = None) -> Prepared:
    """Make recorded data ready for a :class:`~fednav.navigator.Navigator`: the input
    checks, the sensor corrections, the initial state and P0 of :func:`process`.

    The initial state is the system description's ``initial:`` section when it has one,
    else the first GNSS fix with the alignment's attitude (``alignment:``); without GNSS
    positions the section is needed.

    Parameters
    ----------
    imu : ImuData
        IMU samples (:class:`fednav.io.ImuData`: ``t`` [s], rates [rad/s] and specific
        force [m/s^2], body right-forward-up).
    sensors : dict of str to Series
        Every sensor's recording by its registered name (:class:`fednav.io.data.Series`:
        ``"gnss"`` — :class:`fednav.io.GnssData` or ``read_sensor_csv("gnss", ...)``:
        lat/lon [rad], h [m] and/or ENU velocity [m/s] — ``"velocity"``, ``"baro"``,
        ``"star"`` ...); a row's noise is its 1-sigma (or covariance) when the file gives
        it [sensor units], else the system description's.
    cfg : System, optional
        The system description (:func:`fednav.load_system`); default: ``System()``.

    Returns
    -------
    Prepared
        :class:`fednav.process.run.Prepared`: the system flown, the initial state, the
        IMU samples from the start (``t`` [s], ``gyro`` [rad/s], ``accel`` [m/s^2]),
        each sensor's measurements ``(t, z, R)`` in ``measurements``; its
        ``navigator()`` makes a Navigator for them, ``feed(nav)`` feeds them all.

    Raises
    ------
    DataError
        One line for data it cannot use.
    """
    cfg = cfg or System()
    others = withheld_inputs(cfg, recordings(sensors, cfg))
    emptied = [f"{d.source}: every {n} measurement lies inside sensors.{n}.outages_s "
               f"(not used)" for n, d in others.items() if not len(d.t)]
    others = {n: d for n, d in others.items() if len(d.t)}
    fix_name = registry.fix_sensor(others)  # (the GNSS: what starts the run)
    fixes = others.get(fix_name)
    if cfg.filter.state == "total" and (cfg.smoother or cfg.output_rate_hz):
        raise DataError("filter.state: total — the total-state navigator's solution is at "
                        "its filter epochs (no IMU-rate rows to smooth or thin)")
    init = cfg.initial
    start_name = None  # (a sensor whose own solutions start the run: the raw GNSS's)
    if init is None and (fixes is None or fixes.lla is None):
        start_name = registry.start_sensor(others)
    if init is None and (fixes is None or fixes.lla is None) and start_name is None:
        raise DataError(f"the initial position: no "
                        f"{registry.label(fix_name or registry.fix_sensor())} positions to "
                        f"start from; give the initial state in the system description "
                        f"(initial: lat_deg, lon_deg, h_m, vel_mps, euler_deg, sigma)")
    imu = mounted_imu(imu, cfg.imu.mounting)
    dt = imu.period()
    if dt > MAX_IMU_PERIOD_S:
        raise DataError(f"{imu.source}: IMU samples {dt:g} s apart: time stamps in "
                        f"milliseconds (fednav expects seconds)? A strapdown IMU samples at "
                        f"{1 / MAX_IMU_PERIOD_S:g} Hz or faster")
    cfg, assumed = with_imu_figures(imu, cfg)
    cfg, latency, taken = with_velocity_latency(cfg, fix_name, fixes)
    others = {n: d.adjusted(own_section(n, cfg)) for n, d in others.items()}
    fixes = others.get(fix_name)
    start_fixes, start_section = (fixes, None) if start_name is None else \
        _start_fixes(start_name, others[start_name], cfg)
    warnings, quality_extra = check_fix_timing(imu, fixes)
    quality_extra.update(latency)  # (what the stamps showed, before it was taken out)
    warnings[:0] = taken
    warnings[:0] = emptied + assumed + check_units(imu, fixes) + check_mounting(imu, fixes)
    unused = ignored_keys(cfg)
    period = _period(cfg, fixes, others)
    n_per = max(1, int(round(period / dt)))
    T = n_per * dt
    if init is not None and init.t_s is not None:
        t0 = init.t_s
        if not imu.t[0] - 0.5 * dt <= t0 <= imu.t[-1]:
            raise DataError(f"initial.t_s = {t0:.6f} s is outside the IMU data "
                            f"({imu.t[0]:.6f} .. {imu.t[-1]:.6f} s)")
        j = int(np.argmin(np.abs(imu.t - t0)))
        if abs(imu.t[j] - t0) > 1e-6 * dt:  # the navigator starts on an IMU time stamp
            warnings.append(f"initial.t_s = {t0:.6f} s moved to the nearest IMU time stamp "
                            f"{imu.t[j]:.6f} s (the initial state is taken to hold there)")
            init = init.model_copy(update={"t_s": float(imu.t[j])})
            t0 = init.t_s
    else:
        t0 = (imu.t[0] if start_fixes is None or init is not None
              else max(imu.t[0], start_fixes.t[0]))
    # the first IMU sample at or after t0 (the first GNSS fix): the epoch grid t0 + k T
    # then lies at or just after the fixes' stamps — from the nearest sample, which can
    # lie just before, every fix waited a whole filter period for its epoch
    i0 = int(np.searchsorted(imu.t, t0 - stamp_tolerance(float(t0))))
    n_cycles = (len(imu.t) - 1 - i0) // n_per
    warnings += epoch_drift(cfg, fixes, T, dt, n_cycles, quality_extra)
    span = float(imu.t[-1] - imu.t[0])
    if T > span:
        raise DataError(f"filter.period_s = {T:g} s is longer than the IMU data "
                        f"({span:g} s)")
    if n_cycles < 1:
        what = (f"the {registry.label(fix_name)} data" if fixes is not None
                else "the initial time")
        raise DataError(f"{imu.source}: IMU data does not overlap {what} by one filter "
                        f"period ({T:g} s)")
    if fixes is not None and not np.any((fixes.t >= imu.t[i0]) & (fixes.t <= imu.t[-1])):
        who = registry.label(fix_name)
        raise DataError(f"{fixes.source}: no {who} fix within the IMU data's time span "
                        f"({who} {fixes.t[0]:.6g}..{fixes.t[-1]:.6g} s, IMU "
                        f"{imu.t[i0]:.6g}..{imu.t[-1]:.6g} s): the two in different time "
                        f"bases (Unix time, GPS seconds of the week, milliseconds)?")
    noise, gb, ab = imu_noise_model(cfg, dt, imu.errors)
    for name in cfg.sensors:  # constraints the vehicle always obeys, detected stops
        spec = registry.spec(name)
        if name in others or (cfg.aiding is not None and name not in cfg.aiding):
            continue
        if spec.pseudo:
            others[name] = outages.withhold(_pseudo(name, cfg, imu, T),
                                            outages.windows_of(cfg, name), name)
        elif spec.detector is not None:
            t_nav = init.t_s if init is not None and init.t_s is not None else imu.t[i0]
            found = spec.detector(imu, fixes, cfg.sensors[name], noise, gb, T, float(t_nav))
            t_det, sig = found if isinstance(found, tuple) else (found, None)
            t_det = np.asarray(t_det, dtype=float)
            quality_extra[f"{name}_epochs_detected"] = len(t_det)
            if not len(t_det):
                warnings.append(f"sensors.{name}: its detector found nothing in the data "
                                f"(not used)")
                continue
            others[name] = outages.withhold(SensorData(
                name, f"sensors.{name} (no file: detected)", t_det,
                np.zeros((len(t_det), len(spec.columns))), quality={}, sigma=sig),
                outages.windows_of(cfg, name), name)

    for name, d in list(others.items()):  # corrections a sensor makes to its file
        calibrate = registry.spec(name).calibrate
        if calibrate is not None:
            section = cfg.sensors[name] if name in cfg.sensors else None
            others[name], q, w = calibrate(d, fixes, section)
            quality_extra.update(q)
            warnings += w

    # Every recorded sensor's section as it flies its data (what the section leaves to
    # the file taken from it: the GNSS's lever arm and noise, a sensor's period), and its
    # series as the navigator takes it, in one order: the fixes (GNSS), the others.
    recorded = ({} if fixes is None else {fix_name: fixes}) | others
    sensors = {name: _section(d, cfg) for name, d in recorded.items()}
    series = {name: _plain(d) for name, d in recorded.items()}
    for name, sc in sensors.items():
        why = sc.total_state_refusal() if cfg.filter.state == "total" else None
        if why:
            raise DataError(f"{recorded[name].source}: filter.state: total — {why}")

    # Initial state: the description's, else the first GNSS fix (antenna moved to the
    # IMU), its velocity and the alignment's attitude.
    if init is not None:
        sig = init.sigma
        lla0, vel0, euler0 = init.lla(), np.asarray(init.vel_mps, dtype=float), init.euler()
        P0 = initial_covariance(cfg, dt, units.arcsec(np.asarray(sig.attitude_arcsec)),
                                sig.velocity_mps, sig.position_m, imu.errors)
        al = Alignment(euler0, units.arcsec(np.asarray(sig.attitude_arcsec)),
                       report={"levelling": "initial", "heading": "initial"})
        gyro_bias = None
    else:
        al, lla0, vel0, P0 = start_at_first_fix(
            imu, start_fixes, sensors[fix_name] if start_section is None else start_section,
            cfg, t0, i0, dt, noise, ab, gb)
        euler0, gyro_bias = al.euler, al.gyro_bias
    warnings += al.warnings

    # The system the navigator flies: the config with the epoch period and the sensors'
    # effective settings.
    have = [n for n in sensors if registry.spec(n).aiding]
    aiding = have if cfg.aiding is None else [n for n in cfg.aiding if n in have]
    for name, d in recorded.items():  # (a sensor's data feed a local filter, or a role)
        if name not in aiding and not sensors[name].roles(cfg):
            why = ("it is not in the system's aiding list" if registry.spec(name).aiding
                   else f"{registry.spec(name).summary}; the system gives it no role")
            warnings.append(f"{d.source}: not used ({why})")
    if not aiding:
        raise DataError(f"the system's aiding list {cfg.aiding} names none of the sensors "
                        f"given ({', '.join(have) or 'none'})")
    system = cfg.model_copy(update={
        "filter": cfg.filter.model_copy(update={"period_s": T}),
        "sensors": cfg.sensors.replace(**sensors), "aiding": aiding})
    late = {n: d.t_arrival - d.t for n, d in series.items() if d.t_arrival is not None}
    unused += [f"sensors.{n}.timing.{k} (the {n} data have no arrival times, "
               f"t_arrival_s: each measurement is used at its time of validity)"
               for n in aiding if late.get(n) is None and n in cfg.sensors
               for k in ("latency_s", "latency_range_s", "latency_list_s",
                         "delay_compensation")
               if k in cfg.sensors[n].timing.model_fields_set]
    if unused:
        warnings.append("system description: not used on recorded data: "
                        + "; ".join(unused))
    for name, lag in late.items():
        if name not in aiding or not len(lag):
            continue
        how = system.sensors[name].timing.delay_compensation
        declared = declared_latency(system).get(name, 0.0)  # (held: used when valid)
        if how == "interpolate" and float(lag.max()) > max(T, declared):
            warnings.append(f"{name}: measurements arrive up to {lag.max():.3f} s after their "
                            f"time of validity, more than the filter period ({T:g} s) that "
                            f"sensors.{name}.timing.delay_compensation: interpolate corrects; "
                            f"declare sensors.{name}.timing.latency_s, or use recompute or "
                            f"ins_increment (docs/paper004.md)")
    m = slice(i0, i0 + n_cycles * n_per)
    quality = {**imu.quality, **quality_extra}
    t_start = init.t_s if init is not None and init.t_s is not None else float(imu.t[i0])
    t_end = imu.t[m][-1]
    for name, d in recorded.items():
        quality.update(d.quality)
        if name in others and (d.t[-1] < t_start or d.t[0] > t_end):
            warnings.append(f"{d.source}: no {name} measurement falls within the IMU "
                            f"data's {t_start:.1f}..{t_end:.1f} s (a time offset?)")
    return Prepared(system, InitialState(t_start, lla0, vel0, euler0, P0,
                                         gyro_bias=gyro_bias), dt, imu.t[m], imu.gyro[m],
                    imu.accel[m], series, imu.errors, n_per, warnings, al, quality,
                    None if imu.increments is None
                    else (imu.increments[0][m], imu.increments[1][m]))


def recordings(sensors: Mapping[str, Series] | None, cfg: System) -> dict[str, Series]:
    """The recordings by registered name, checked (an unknown name, or a series given
    under another sensor's name, is one line); a sensor's series of any reader as its
    recording (:func:`fednav.io.data.as_recording`: the section's figures for rows
    without their own noise, its lever arm); a name given None is left out."""
    out = {}
    for name, d in (sensors or {}).items():
        if d is None:  # (a sensor without data: left out)
            continue
        if name not in registry.SENSORS:
            raise DataError(f"{getattr(d, 'source', name)}: unknown sensor '{name}'; "
                            f"registered: {', '.join(sorted(registry.SENSORS))}")
        if not isinstance(d, Series):
            raise DataError(f"sensors['{name}']: a {type(d).__name__}, not a sensor's "
                            f"series (fednav.io.read_sensor_csv, read_gnss_csv ...)")
        if d.name != name:
            raise DataError(f"{d.source}: {d.name} data given as sensor '{name}'")
        if not isinstance(d, (SensorData, *RECORDINGS.values())):
            d = _plain(d)  # (a simulated series: one sigma for every row, as rows)
        out[name] = as_recording(d, own_section(name, cfg))
    return out


def withheld_inputs(cfg: System, sensors: dict[str, Series]) -> dict[str, Series]:
    """The recordings without the measurements inside their sensor's ``outages_s``
    (:func:`fednav.process.outages.withhold`).  The windows are on the IMU's clock: a
    recording whose section shifts its stamps (``time_offset_s``, applied later by its
    ``adjusted``: a receiver's files in GPS time) is withheld on its own stamps, the
    windows shifted back alike."""
    out = {}
    for n, d in sensors.items():
        sec = own_section(n, cfg)
        off = float(getattr(sec, "time_offset_s", 0.0) or 0.0)
        out[n] = outages.withhold(d, [(a - off, b - off)
                                      for a, b in outages.windows_of(cfg, n)], n)
    return out


def flown_fixes(fixes: FixData | None, system: System) -> FixData | None:
    """The fixes (the GNSS's) as the navigator flew them (``system``: a
    :class:`Prepared`'s; :meth:`fednav.io.GnssData.flown`): the configured corrections
    applied, the effective lever arm and sigmas."""
    if fixes is None or fixes.name not in system.sensors:
        return None
    return fixes.flown(system.sensors[fixes.name])


@old_layout("cfg", "smooth", "innovations", "sensors", "force")
def process(imu: ImuData, sensors: Mapping[str, Series], cfg: System | None = None,
            smooth: bool = False, innovations: list | None = None,
            force: bool = False) -> ProcessResult:
    """Process recorded data: loosely coupled INS/GNSS (/velocity, /any registered
    sensor) through the navigator — what ``fednav process`` runs (``fednav.process_data``).

    The input checks, alignment and initial state of :func:`prepare`, every measurement
    and IMU sample through the system's :class:`~fednav.navigator.Navigator`, the
    solution at every IMU sample with its 1-sigma (smoothed on request) and the health
    monitor's warnings.

    Parameters
    ----------
    imu : ImuData
        IMU samples (:class:`fednav.io.ImuData`: ``t`` [s], rates [rad/s] and specific
        force [m/s^2], body right-forward-up).
    sensors : dict of str to Series
        Every sensor's recording by its registered name (see :func:`prepare`).
    cfg : System, optional
        The system description (:func:`fednav.load_system`); default: ``System()``.
    smooth : bool
        Also run the RTS smoother (``ProcessResult.smoothed``).
    innovations : list, optional
        When given, receives one :class:`~fednav.navigator.loop.InnovationRecord` per
        measurement (what :mod:`fednav.process.tuning` estimates noise figures from).
    force : bool
        Give the solution even when a local filter's mean NIS/dof exceeds
        :data:`~fednav.navigator.health.NIS_REFUSE` (the data are then most likely wrong:
        a unit, an axis order, a time base).

    Returns
    -------
    ProcessResult
        ``forward`` (and ``smoothed``) :class:`~fednav.navigator.solution.Solution` at
        every IMU sample, ``epochs``, ``run_time_s`` [s], ``warnings``,
        ``data_quality`` and ``alignment``.

    Raises
    ------
    DataError
        One line for data it cannot use or a run whose innovations refuse it.
    """
    t_start = time.perf_counter()
    cfg = cfg or System()
    imu = mounted_imu(imu, cfg.imu.mounting)
    sensors = withheld_inputs(cfg, recordings(sensors, cfg))
    fixes = sensors.get(registry.fix_sensor(sensors))
    prep = with_ins_latency(imu, sensors, cfg, prepare(imu, sensors, cfg))
    noise = nav = None
    if prep.system.noise != "as-given" and prep.system.filter.state == "error":
        from .identify import identify

        prep, noise, nav = identify(imu, prep, force=force)  # (nav: the final pass)
    if nav is None:
        nav = prep.feed(prep.navigator(record_rows=True, record_covariance=True,
                                       innovations=True))
    out = nav.result()
    res = solution(out, prep, smooth)
    constraints = [n for n in prep.system.aiding
                   if registry.spec(n).pseudo or registry.spec(n).detector is not None]
    band = prep.system.health.nis_band
    res.consistency = centralized_consistency(res.forward.fdi, out.innovations)
    means = {k: v["nis_per_dof"] for k, v in res.consistency.items()}
    blame = culprit(prep, means, band, constraints)
    res.warnings += run_health(res.forward.fdi, imu, flown_fixes(fixes, prep.system),
                               res.forward, imu_figures(imu, prep.system), force,
                               list(res.warnings), band,
                               row_nis(out.innovations, nav.row_kinds), constraints, blame,
                               prep.system.imu.grade is not None, local_nis(out.innovations))
    if blame:
        res.warnings.append(blame)
    res.warnings += readmission_warnings(out.readmissions)
    res.hints += wheeled_hint(res.forward, prep.system)
    if prep.system.filter.q_adaptation is not None and hasattr(nav.loop, "q_scales"):
        res.data_quality["q_scale_final"] = {k: round(v, 3)
                                             for k, v in nav.loop.q_scales().items()}
    res.optional_states = out.optional
    for name in prep.system.aiding_sensors(prep.series):  # (a sensor's own figures)
        spec = registry.spec(name)
        if spec.report is not None:
            res.data_quality[f"{name}_geometry"] = spec.report(
                prep.series[name], res.forward, nav.models.get(name))
        if spec.figure is not None:
            res.figures[name] = functools.partial(
                spec.figure, prep.series[name], res.forward,
                [e for e in out.excluded if e[1] == name])
    if out.excluded:  # units fault detection left out of a measurement (satellites)
        counts: dict = {}
        for _, local, unit, _ in out.excluded:
            key = f"{local}_excluded"
            counts.setdefault(key, {})
            counts[key][str(unit)] = counts[key].get(str(unit), 0) + 1
        res.data_quality.update(counts)
    if prep.system.integrity is not None:
        from .integrity import run_integrity

        res.forward, res.integrity, said = run_integrity(prep, res.forward,
                                                         prep.system.integrity)
        res.warnings += said
    res.outages = {n: w for n in prep.system.sensors if (w := outages.windows_of(cfg, n))}
    res.fixes_flown = fixes
    res.noise = noise
    res.run_time_s = time.perf_counter() - t_start
    if innovations is not None:
        innovations.extend(out.innovations)
    return res


def solution(res, prep: Prepared, smooth: bool = False) -> ProcessResult:
    """The IMU-rate forward solution (and the smoothed one) of a navigator's result on
    prepared recorded data; the total-state navigator's at its filter epochs (no
    smoother)."""
    if prep.system.filter.state == "total":
        if smooth:
            raise DataError("--smooth: the total-state navigator (filter.state: total) has "
                            "no smoother")
        return ProcessResult(epoch_rate(res), None, 0.0, len(res.states) - 1,
                             dict(prep.quality), list(prep.warnings), prep.alignment.report)
    forward, smoothed = imu_rate(res, smooth or prep.system.smoother)
    if (prep.alignment.report.get("heading", "").startswith("unknown")
            and prep.system.alignment.initial_attitude_sigma_deg is None):
        # A linearised filter started from an unknown heading converges only where the
        # motion makes the heading strongly observable; its heading sigma is no promise
        # there (a standing vehicle's shrinks through the lever arm while 40 deg off).
        for sol in (forward, smoothed):
            if sol is not None:
                sol.sigma_euler[:, 2] = np.maximum(sol.sigma_euler[:, 2],
                                                   UNKNOWN_HEADING_SIGMA)
                sol.sigma[:, 2] = np.maximum(sol.sigma[:, 2], UNKNOWN_HEADING_SIGMA)
    return ProcessResult(forward, smoothed, 0.0, len(res.states) - 1, dict(prep.quality),
                         list(prep.warnings), prep.alignment.report)


def fix_z(fixes: FixData, i: int) -> np.ndarray:
    """GNSS fix ``i`` as the measurement vector ``[lat, lon, h, vE, vN, vU]``."""
    return np.concatenate((fixes.lla[i], fixes.vel[i]))


#: fednav.process.run's names of 0.2, kept.
gnss_z, flown_gnss = fix_z, flown_fixes
