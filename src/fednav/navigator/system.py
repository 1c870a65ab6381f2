"""The system description: one schema for every navigation system fednav runs.

A system description (YAML, or a mapping; :func:`load_system`) says what the navigator
is made of::

    imu:        the IMU's error figures (fednav.sensors.imu.ImuConfig)
    sensors:    each aiding sensor's section, by registered name (fednav.sensors.registry):
                noise, lever arm, period, latency handling
    aiding:     which of them feed the filter (default: every one that can)
    constraint: wind — the air-data constraint in every local filter (paper 000)
    filter:     local filter type (any name of fednav.filters.registry.FILTERS, per local filter
                in ``locals``), federated / centralized, sharing, reset, fault detection,
                period, the filter's IMU bias model
    alignment:  how recorded data find the initial attitude
    integrity:  protection levels by solution separation (fednav.navigator.integrity)
    smoother:   also run the RTS smoother
    noise:      identify the IMU's process noise from a recording (fednav process), or as-given
    output_rate_hz: solution rows per second of fednav process's files (default: 10 Hz)

The papers' scenario files are a system description plus the flight and the experiment
(:class:`fednav.sim.scenario.Scenario` extends :class:`System`); the processing config of
``fednav process`` is one.  Units are in the key names; everything is converted to SI
here.  Errors are one line naming the key (and the file).
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, NonNegativeInt, field_validator, model_validator

from ..core.config import _Model, nested_error, read_mapping, recording_only, validate
from ..filters.registry import FILTERS
from ..ins.error_model import ImuNoiseModel
from ..ins.states import CORE, StateLayout
from ..sensors.imu import ImuConfig
from ..sensors.registry import SENSORS, SensorSet, check_names
from .integrity import IntegrityConfig

_V3 = tuple[float, float, float]


def _check_filter(v: str) -> str:
    if v.lower() not in FILTERS:
        raise ValueError(f"unknown filter '{v}'; registered: {', '.join(sorted(FILTERS))}")
    return v.lower()


def _check_locals(names) -> None:
    known = set(SENSORS) | {"central"}
    for k in names:
        if k not in known:
            raise ValueError(f"unknown local filter '{k}'; local filters are named after "
                             f"their sensor ({', '.join(sorted(SENSORS))}) or 'central'")


class LocalFilterConfig(_Model):
    """Settings of one local filter that differ from ``filter``'s: its ``type`` and its
    covariance ``form`` (``standard`` or ``square_root``); either may be left out."""

    type: str | None = None
    form: Literal["standard", "square_root"] | None = None

    @field_validator("type")
    @classmethod
    def _type(cls, v):
        return None if v is None else _check_filter(v)


class QAdaptationConfig(_Model):
    """Online process-noise adaptation of each local filter (recorded data whose IMU
    figures, often a data sheet's, leave out the vehicle's vibration): after every
    accepted measurement ``log s += (T / time_constant_s) (NIS/dof - 1)``, held within
    ``[0, ln max_scale]``, and the white part of the filter's process noise (the IMU's
    ARW and VRW: what vibration adds to) is ``s`` times the figures' — slow (the time
    constant), bounded (``max_scale``: 1e4 is 100 times the white noise's sigma) and never
    below the figures (``s >= 1``); the bias instabilities keep theirs.  Covariance
    matching in the manner of Sage–Husa Q estimation, on one scalar per filter."""

    time_constant_s: float = Field(default=60.0, gt=0.0)
    max_scale: float = Field(default=1e4, ge=1.0)


class ParticleConfig(_Model):
    """The particle filters' settings (``filter.type: pf``, or ``pf`` local filters):
    ``particles`` per filter; ``resample_threshold`` resample when the effective sample
    size falls below this fraction of them; ``roughening`` K of the jitter after
    resampling (0: off); ``progressive_correction`` apply an update that would leave
    fewer than half the particles effective in tempered stages (without it, a precise
    measurement meeting the 18-state error cloud leaves one particle: every GNSS design
    degenerated at its first fixes); ``seed`` of numpy's ``SeedSequence``, which gives
    each local filter a stream of its own (a campaign's run adds the run's seed).
    :class:`fednav.filters.particle.ParticleFilter`."""

    particles: int = Field(default=1000, ge=10)
    resample_threshold: float = Field(default=0.5, ge=0.0, le=1.0)
    roughening: float = Field(default=0.0, ge=0.0)
    progressive_correction: bool = True
    seed: NonNegativeInt | list[NonNegativeInt] = 0

    def options(self) -> dict:
        """The constructor's keywords (without the random stream)."""
        return {"n_particles": self.particles, "resample_threshold": self.resample_threshold,
                "roughening": self.roughening, "progressive": self.progressive_correction}


class FilterConfig(_Model):
    """The estimator.

    ``type``: the local filters' estimator (a name of the filter registry: kf ekf ukf
    sukf cukf cekf aekf raukf sghqf aasghqf pf); ``locals``: another type for some local
    filters (by sensor name).  ``state``: ``error`` (closed-loop error-state filters,
    18 states) or ``total`` (paper 003: a total-state UKF master time-updates the
    navigation state, the local filters update linearly).  ``architecture``:
    ``federated`` (one local filter per aiding sensor, fused) or ``centralized`` (one
    filter; each epoch stacks H and R of the sensors that delivered).  ``sharing`` of the
    information between the local filters (and the ``master`` filter, which has no
    sensor): equal, fixed (``fixed_factors``) or adaptive (paper 002, eq. 13).  ``reset``:
    fusion-reset every epoch.  ``fdi_alpha``: chi-square fault detection level, one for
    every local filter or by name; ``fdi_recovery``: passes in a row before an isolated
    local filter returns; ``fdi_readmit_s`` [s]: when every position source (GNSS, SAR
    fix) has been isolated this long, the most consistent one is re-admitted with an
    inflated covariance if its innovations drifted beyond what the filter's covariance
    allows — a filter too confident of its IMU figures, not a sensor fault
    (:func:`fednav.filters.federated.lockout_step`; None: never).  ``period_s``: the filter
    epoch (default: every IMU sample for a navigator, the GNSS period for ``fednav
    process``; scenarios state it).
    ``form``: how every filter keeps its covariance — ``standard`` (the covariance
    itself, the default) or ``square_root`` (its Cholesky factor: every Gaussian filter
    has that form, :mod:`fednav.filters.square_root`; a fusion of factored filters is the
    square-root information form); per local filter in ``locals`` (``{star: {form:
    square_root}}``).  The compiled engine runs the square-root ``kf``, ``ekf``, ``ukf``
    and ``sukf``, alone or beside standard ones; other square-root filters run the
    Python loop.
    ``substeps`` of the nonlinear error propagation; ``alpha``, ``beta``, ``kappa`` of the
    unscented transform; ``grid_level`` of the sparse-grid filters; ``pf`` the particle
    filters' settings (:class:`ParticleConfig`).  ``accel_bias``: the
    filter's accelerometer-bias state —
    ``random_walk`` (a random constant, 1-sigma ``hypot(bias, markov)``, driven by the
    random walk whose short-term growth equals the Gauss–Markov process's) or
    ``gauss_markov`` (the Gauss–Markov process with its correlation time; 1-sigma
    ``max(bias, markov)``).  ``q_adaptation``: online process-noise adaptation
    (:class:`QAdaptationConfig`; off when absent).
    ``states``: optional error states after the 18 (:mod:`fednav.ins.states`) —
    ``gyro_scale`` and ``accel_scale`` (scale-factor errors, 1-sigma from
    ``imu.gyro_scale_ppm`` / ``imu.accel_scale_ppm`` or the IMU grade; with both, the
    21-state model of KF-GINS plus fednav's Markov drift), ``gnss_markov`` (the GNSS
    position's time-correlated error, from ``sensors.gnss.markov_sigma_enu_m`` and
    ``markov_tau_s``), ``velocity_markov`` (the velocity sensor's, from
    ``sensors.velocity.markov_sigma_mps`` and ``markov_tau_s``).  None by default.
    """

    type: str = "kf"
    locals: dict[str, LocalFilterConfig] = {}
    form: Literal["standard", "square_root"] = "standard"
    state: Literal["error", "total"] = "error"
    architecture: Literal["federated", "centralized"] = "federated"
    period_s: float | None = Field(default=None, gt=0.0)
    alpha: float = Field(default=1e-3, gt=0.0)
    beta: float = 2.0
    kappa: float = 0.0
    sharing: Literal["equal", "fixed", "adaptive"] = "equal"
    fixed_factors: dict[str, float] | None = None
    master: bool = False
    reset: bool = True
    substeps: int = Field(default=1, ge=1)
    fdi_alpha: float | dict[str, float] | None = None
    fdi_recovery: int = Field(default=1, ge=1)
    fdi_readmit_s: float | None = Field(default=5.0, gt=0.0)
    grid_level: int = Field(default=3, ge=1, le=5)
    pf: ParticleConfig = ParticleConfig()
    accel_bias: Literal["random_walk", "gauss_markov"] = "random_walk"
    q_adaptation: QAdaptationConfig | None = None
    states: list[str] = []

    @field_validator("states")
    @classmethod
    def _states(cls, v):
        from ..ins.states import BLOCKS

        for k in v:
            if k not in BLOCKS:
                raise ValueError(f"unknown optional error state '{k}'; known: "
                                 f"{', '.join(BLOCKS)}")
        if len(set(v)) != len(v):
            raise ValueError("each optional state once")
        return v

    @field_validator("type")
    @classmethod
    def _type(cls, v):
        return _check_filter(v)

    @field_validator("fdi_alpha")
    @classmethod
    def _alpha(cls, v):
        values = v.values() if isinstance(v, dict) else [] if v is None else [v]
        if any(not 0.0 < a < 1.0 for a in values):
            raise ValueError("test level must be in (0, 1)")
        _check_locals(v if isinstance(v, dict) else {})
        return v

    @field_validator("locals")
    @classmethod
    def _locals(cls, v):
        _check_locals(v)
        return v

    @model_validator(mode="after")
    def _q_adaptation(self):
        if self.q_adaptation is not None and self.state == "total":
            raise ValueError("q_adaptation adapts the error-state filters' process noise "
                             "(filter.state: error); the total-state UKF has its own")
        return self

    @model_validator(mode="after")
    def _forms(self):
        from ..filters.registry import square_root_names

        for name in [*self.locals, None]:
            t = self.type if name is None else self.type_of(name)
            if self.form_of(name) == "square_root" and t not in square_root_names():
                where = "filter" if name is None else f"filter.locals.{name}"
                raise ValueError(f"{where}: '{t}' has no square-root form (the Gaussian "
                                 f"filters have one: {', '.join(square_root_names())})")
        return self

    def types(self) -> set[str]:
        """Every estimator the filter names (``type`` and the ``locals``' types)."""
        return {self.type} | {c.type for c in self.locals.values() if c.type is not None}

    def type_of(self, local: str) -> str:
        """The estimator of local filter ``local``."""
        c = self.locals.get(local)
        return self.type if c is None or c.type is None else c.type

    def form_of(self, local: str | None) -> str:
        """The covariance form (``standard`` / ``square_root``) of local filter ``local``
        (None: the master's, ``filter.form``)."""
        c = self.locals.get(local) if local is not None else None
        return self.form if c is None or c.form is None else c.form


class AlignmentConfig(_Model):
    """How recorded data find the initial attitude (:mod:`fednav.ins.alignment`).

    ``initial_attitude``: ``align`` (levelling while static, heading from the GNSS course
    once moving), ``file`` (the data file's attitude) or ``coarse`` (level over
    ``coarse_seconds`` at the start; heading ``coarse_heading_deg``, else the GNSS course
    then when faster than 0.5 m/s, else 0); ``initial_attitude_sigma_deg`` [pitch, roll,
    heading] overrides what the method claims."""

    initial_attitude: Literal["align", "file", "coarse"] = "align"
    initial_attitude_sigma_deg: _V3 | None = None
    coarse_heading_deg: float | None = None
    coarse_seconds: float = Field(1.0, gt=0.0)


class InitialSigmaConfig(_Model):
    """1-sigma of the initial state (the filter's P0): ``attitude_arcsec`` platform
    misalignment about east, north, up (tilts and heading), ``velocity_mps`` (one value
    or [east, north, up]), ``position_m`` (one value or [east, north, up]).  The IMU bias
    states take theirs from the ``imu:`` figures."""

    attitude_arcsec: _V3
    velocity_mps: float | _V3 = 0.0
    position_m: float | _V3 = 0.0


class InitialConfig(_Model):
    """Where the navigator starts, when it is known (a transfer alignment, a surveyed
    start, a simulation) or cannot come from the data (no GNSS): time ``t_s`` (default:
    the first IMU sample), ``lat_deg``, ``lon_deg``, ``h_m`` (the IMU's point), ENU
    ``vel_mps``, attitude ``euler_deg`` [pitch, roll, heading] and the 1-sigma of each
    (``sigma``).  Given, it replaces the alignment and the start from the first GNSS
    fix."""

    t_s: float | None = None
    lat_deg: float = Field(ge=-90.0, le=90.0)
    lon_deg: float = Field(ge=-180.0, le=360.0)
    h_m: float
    vel_mps: _V3 = (0.0, 0.0, 0.0)
    euler_deg: _V3
    sigma: InitialSigmaConfig

    def lla(self) -> np.ndarray:
        return np.array([np.radians(self.lat_deg), np.radians(self.lon_deg), self.h_m])

    def euler(self) -> np.ndarray:
        return np.radians(np.asarray(self.euler_deg, dtype=float))


#: Keys of ``files:`` besides the registered sensors' names.
FILE_KEYS = ("imu", "reference")


#: Keys of the flat processing config of fednav 0.1 -> their place in a system
#: description, but for the sensors' (each section's ``flat_keys``: :func:`legacy_keys`).
LEGACY_KEYS = {
    "period_s": ("filter", "period_s"), "substeps": ("filter", "substeps"),
    "fdi_alpha": ("filter", "fdi_alpha"), "fdi_recovery": ("filter", "fdi_recovery"),
    "imu_max_bridge_s": ("imu", "max_bridge_s"),
    "initial_attitude": ("alignment", "initial_attitude"),
    "initial_attitude_sigma_deg": ("alignment", "initial_attitude_sigma_deg"),
    "coarse_heading_deg": ("alignment", "coarse_heading_deg"),
    "coarse_seconds": ("alignment", "coarse_seconds"),
}


def legacy_keys() -> tuple[dict[str, tuple], dict[str, tuple]]:
    """Every key of fednav 0.1's flat processing config -> its place in a system
    description, and those whose value is converted -> (the conversion, what the
    warning says of it)."""
    keys, order = dict(LEGACY_KEYS), {}
    for name, spec in SENSORS.items():
        for flat, (key, *conversion) in spec.config.flat_keys.items():
            keys[flat] = ("sensors", name, key)
            if conversion:
                order[flat] = tuple(conversion)
    return keys, order


def _translate_legacy(data: dict) -> dict:
    """A flat fednav 0.1 processing config rewritten as a system description."""
    keys, order = legacy_keys()
    old = [k for k in data if k in keys]
    if not old:
        return data
    out = dict(data)
    for k in old:
        *path, leaf = keys[k]
        d = out
        for p in path:
            if not isinstance(d.get(p) or {}, dict):
                break  # the section is malformed: its own error says so, the key stays
            d[p] = dict(d.get(p) or {})
            d = d[p]
        else:
            if leaf in d:
                raise ValueError(f"'{k}' and '{'.'.join(keys[k])}' are the same "
                                 f"setting; give it once")
            v = out.pop(k)
            d[leaf] = order[k][0](v) if k in order else v
    warnings.warn("processing-config keys of fednav 0.1 (" + ", ".join(
        f"{k} -> {'.'.join(keys[k])}"
        + (f", reordered {order[k][1]}" if k in order else "")
        for k in old) + ") are read for one more release", FutureWarning, stacklevel=2)
    return out


class HealthConfig(_Model):
    """The health monitor (:mod:`fednav.navigator.health`): ``nis_band`` [low, high], the
    band of a sensor's run-mean NIS/dof (and of each of its row kinds: positions,
    velocities, attitude ...) outside which a run is warned about, with the likely causes
    ranked (a consistent filter gives 1; over a few hundred measurements the mean of a
    consistent filter lies within a few percent of it)."""

    nis_band: tuple[float, float] = (0.5, 2.0)

    @field_validator("nis_band")
    @classmethod
    def _band(cls, v):
        if not 0.0 < v[0] < 1.0 < v[1]:
            raise ValueError(f"a band [low, high] with 0 < low < 1 < high, got {list(v)}")
        return v


class System(_Model):
    """A navigation system: IMU, aiding sensors, estimator (see the module docstring).

    Immutable (a pydantic model): ``system.model_copy(update={...})`` gives a changed
    copy; :func:`load_system` makes one from YAML or a mapping.  Each key's unit is in its
    name (``_deg``, ``_m``, ``_mps``, ``_s`` ...) and converted to SI here; vectors are
    in the order their key documents (``docs/conventions.md``).

    Parameters
    ----------
    imu : ImuConfig
        The IMU's error figures (:class:`fednav.sensors.imu.ImuConfig`; each in the unit
        its key names, e.g. ``gyro_arw_deg_sqrt_h`` [deg/sqrt(h)]) or a grade preset.
    sensors : SensorSet
        Each aiding sensor's section by registered name (``gnss``, ``star``, ``baro``
        ...): noise, lever arm (body right-forward-up [m]), period [s], timing.
    aiding : list of str, optional
        The sensors that feed the filter; default: every configured one that can.
    constraint : str, optional
        ``"wind"``: the air-data wind constraint in every local filter (paper 000).
    filter : FilterConfig
        The estimator: local filter type(s), federated or centralized, sharing, reset,
        fault detection (``fdi_alpha``), epoch ``period_s`` [s], the bias model.
    alignment : AlignmentConfig
        How recorded data find the initial attitude (levelling, GNSS course, or given).
    initial : InitialConfig, optional
        A known start (``lat_deg``, ``lon_deg`` [deg], ``h_m`` [m], ENU ``vel_mps``
        [m/s], ``euler_deg`` [deg] with their 1-sigma); replaces the alignment.
    health : HealthConfig
        The health monitor's NIS/dof band (``nis_band`` [low, high]).
    integrity : IntegrityConfig, optional
        Protection levels by solution separation (:mod:`fednav.navigator.integrity`):
        the integrity-risk and false-alert budget, each sensor's prior fault
        probability, the alert limits; None (default): no levels.
    smoother : bool
        Also run the RTS smoother.
    noise : {"identify", "identify-all", "as-given"}
        ``fednav process``: identify the IMU's process noise from the recording before
        the final pass (:mod:`fednav.process.identify`; the given figures its prior and
        floor); ``identify-all``: the sensors' sigmas that no file gives as well (not the
        default: docs/real-data.md has the evidence); or fly the figures as given.
    output_rate_hz : float or {"imu", "filter"}, optional
        Solution rows per second of ``fednav process``'s files [Hz] when its
        ``--output-rate`` is not given (None: 10 Hz, at most the IMU rate); ``imu``:
        every IMU sample, ``filter``: the filter epochs.
    files : dict of str to str
        Recorded files of this system (``imu``, ``reference``, sensor names), relative
        to the description's folder.
    """

    imu: ImuConfig = ImuConfig()
    sensors: SensorSet = SensorSet()
    aiding: list[str] | None = None
    constraint: Literal["wind"] | None = None
    filter: FilterConfig = FilterConfig()
    alignment: AlignmentConfig = AlignmentConfig()
    initial: InitialConfig | None = None
    health: HealthConfig = HealthConfig()
    integrity: IntegrityConfig | None = None
    smoother: bool = False
    noise: Literal["identify", "identify-all", "as-given"] = Field(
        "identify", json_schema_extra=recording_only(
            "fednav process's noise identification from a recording"))
    output_rate_hz: float | Literal["imu", "filter"] | None = Field(
        None, json_schema_extra=recording_only("fednav process's solution files"))

    @field_validator("output_rate_hz", mode="before")
    @classmethod
    def _output_rate(cls, v):
        """A rate [Hz] > 0, ``imu`` or ``filter`` (one line naming the value otherwise)."""
        if v is None or v in ("imu", "filter"):
            return v
        try:
            rate = float(v)
        except (TypeError, ValueError):
            rate = float("nan")
        if not rate > 0.0 or rate == float("inf") or isinstance(v, bool):
            raise ValueError("a rate in Hz > 0, 'imu' (every IMU sample) or 'filter' (the "
                             "filter epochs)")
        return rate

    #: recorded data of this system: ``imu``, ``reference`` and sensor name -> CSV file
    #: (relative to the description's folder; what ``fednav process csv`` reads when its
    #: options do not name a file)
    files: dict[str, str] = {}

    @field_validator("files")
    @classmethod
    def _files(cls, v):
        for k in v:
            if k not in FILE_KEYS and k not in SENSORS:
                raise ValueError(f"unknown file '{k}' (files are {', '.join(FILE_KEYS)} or a "
                                 f"registered sensor: {', '.join(sorted(SENSORS))})")
        return v

    @model_validator(mode="before")
    @classmethod
    def _legacy(cls, data):
        return _translate_legacy(data) if isinstance(data, dict) else data

    @field_validator("aiding")
    @classmethod
    def _aiding(cls, v):
        return None if v is None else check_names(v, "aiding sensor", aiding=True)

    @model_validator(mode="after")
    def _consistent(self):
        if self.aiding is not None:
            missing = [a for a in self.aiding if a not in self.sensors]
            if missing:
                raise nested_error(["aiding"], f"sensor '{missing[0]}' has no section in "
                                               f"sensors")
        if self.constraint == "wind" and self.sensors.airdata is None:
            raise nested_error(["constraint"], "the wind constraint needs sensors.airdata")
        if self.filter.states:
            state_layout(self, validating=True)  # (one line naming the key a state lacks)
        return self

    def roles(self) -> dict[str, str]:
        """The sensor that plays each role besides aiding: each section's
        :meth:`~fednav.sensors.spec.SensorConfig.roles`.

        Returns
        -------
        dict of str to str
            Role -> the sensor's registered name (``{"damping": "baro", "constraint":
            "airdata"}`` when both fly).
        """
        return {r: n for n in self.sensors for r in self.sensors[n].roles(self)}

    def aiding_sensors(self, available=None) -> list[str]:
        """The sensors that feed the filter.

        Parameters
        ----------
        available : collection of str, optional
            Only those of these names (the sensors that have data).

        Returns
        -------
        list of str
            ``aiding``, else every configured sensor that can aid.
        """
        if self.aiding is not None:
            names = list(self.aiding)
        else:
            names = [n for n in self.sensors if SENSORS[n].aiding]
        return names if available is None else [n for n in names if n in available]


def load_system(source) -> System:
    """A validated system description from YAML, a mapping or a System.

    A paper's scenario file is accepted too: its system description is returned (the
    flight and the experiment are left out).  The flat keys of fednav 0.1 are read with a
    ``FutureWarning`` naming their new places.

    Parameters
    ----------
    source : str, Path, dict or System
        A YAML file's path, the same content as a mapping, or a System (returned as it
        is).  Units are in the key names (``sigma_pos_enu_m`` [m] east, north, up,
        ``lever_m`` body right-forward-up [m], ``period_s`` [s], ``gyro_arw_deg_sqrt_h``
        ...).

    Returns
    -------
    System
        The validated description, in SI units inside.

    Raises
    ------
    ConfigError
        One line naming the key (and the file) that is wrong.
    """
    if isinstance(source, System):
        return source
    if isinstance(source, dict):
        data, where, folder = source, "system description", None
    else:
        data = read_mapping(source, "system description")
        where, folder = f"system description file {source}", Path(source).parent
    if _SCENARIO_KEYS & set(data):
        data = {k: v for k, v in data.items() if k in System.model_fields}
    return validate(data, System, where, folder)  # (paths relative to its folder)


#: Keys that make a file a scenario (a system description plus flight and experiment).
_SCENARIO_KEYS = {"start", "segments", "modes", "imu_period_s"}


def state_layout(system: System, validating: bool = False) -> StateLayout:
    """The error state's optional blocks (``filter.states``, :mod:`fednav.ins.states`)
    with their 1-sigma and correlation times from the IMU and sensor sections.

    ``validating``: called by the system's validator, which leaves a scale factor's
    missing figure to the run (``fednav process`` gives an IMU without figures a grade
    preset, whose figure it then has).

    Raises
    ------
    ConfigError
        One line naming the key a selected state lacks (during validation, pydantic's
        error, reported the same way).
    """
    from ..core.config import ConfigError

    def fail(path, message):
        if validating:
            raise nested_error(path, message)
        raise ConfigError(f"key '{'.'.join(path)}': {message}")

    states = list(system.filter.states)
    own = {}  # the blocks an aiding sensor's measurement needs (its model's own_block)
    for sensor in system.aiding_sensors():
        block = getattr(SENSORS[sensor].model, "own_block", None) \
            if sensor in SENSORS else None
        if block is not None and sensor in system.sensors:
            own[block] = system.sensors[sensor].block_figures()
    states += [b for b in own if b not in states]
    if not states:
        return CORE
    if system.filter.state == "total":
        fail(["filter", "states"], "optional error states are states of the error-state "
                                   "filters (filter.state: error)")
    blocks = {}
    for which in ("gyro", "accel"):
        if f"{which}_scale" in states:
            s = system.imu.scale_sigma(which)
            if s is None and not validating:
                fail(["filter", "states"], f"{which}_scale needs its 1-sigma: "
                                           f"imu.{which}_scale_ppm (or imu.grade)")
            blocks[f"{which}_scale"] = (s or 0.0, system.imu.scale_tau(which))
    for sensor, spec in SENSORS.items():  # a sensor's own error (its model's markov_block)
        block = getattr(spec.model, "markov_block", None)
        if block not in states:
            continue
        c = system.sensors[sensor] if sensor in system.sensors else None
        key = spec.config.MARKOV_KEY
        if c is None or getattr(c, key) is None or c.markov_tau_s is None:
            fail(["filter", "states"], f"{block} needs sensors.{sensor}.{key} and "
                                       f"markov_tau_s")
        s = np.broadcast_to(np.asarray(getattr(c, key), dtype=float), (3,))
        if not (s > 0.0).all():
            fail(["sensors", sensor, key], "a Gauss-Markov sigma is positive")
        blocks[block] = (s, float(c.markov_tau_s))
    for block in states:
        if block not in blocks and block not in own:
            fail(["filter", "states"], f"{block} is the state of a sensor's measurement: "
                                       f"it joins when that sensor aids")
    return StateLayout.of({**blocks, **own})


def sensor_model(system: System, name: str, section=None):
    """Sensor ``name``'s measurement model in ``system`` (its ``section``, default the
    system's): the section's model, noise-split for its Gauss–Markov state when the
    system selects it (:meth:`~fednav.sensors.measurement.RowModel.with_markov`)."""
    section = system.sensors[name] if section is None else section
    model = section.measurement_model()
    if getattr(model, "markov_block", None) in system.filter.states:
        model = model.with_markov(getattr(section, section.MARKOV_KEY))
    return model


# ---------------------------------------------------------------- the filter's IMU model
def initial_covariance(system: System, dt: float, attitude, velocity, position,
                       file_errors=None) -> np.ndarray:
    """The filter's P0 (filter units of :mod:`fednav.ins.error_model`, diagonal) from the
    1-sigma of the initial platform misalignment ``attitude`` [rad] (east, north, up),
    ``velocity`` [m/s] and ``position`` [m] (one value or ENU) and the IMU figures
    (:func:`imu_noise_model`): the bias states' sigmas.  A state with no uncertainty gets
    1e-6 filter units (P0 stays positive definite)."""

    _, gb, ab = imu_noise_model(system, dt, file_errors)
    markov = imu_figures(system.imu, file_errors)["gyro_markov"] or 0.0
    return covariance_from_sigmas(attitude, velocity, position, gb, markov, ab)


def covariance_from_sigmas(attitude, velocity, position, gyro_bias, gyro_markov,
                           accel_bias) -> np.ndarray:
    """A diagonal P0 (18, 18) in the filter units of :mod:`fednav.ins.error_model`
    (``diag((sigma / SCALE)^2)``) from the 1-sigma of each block, SI, one value or three:
    platform misalignment [phi east, north, up] [rad], velocity and position errors ENU
    [m/s, m], gyro constant and Gauss–Markov drift [rad/s] and accelerometer bias
    [m/s^2] (body axes right, forward, up).  A state with no uncertainty gets 1e-6 filter
    units (P0 stays positive definite)."""
    from ..ins.error_model import SCALE

    sd = np.r_[np.broadcast_to(np.asarray(attitude, dtype=float), (3,)),
               np.broadcast_to(np.asarray(velocity, dtype=float), (3,)),
               np.broadcast_to(np.asarray(position, dtype=float), (3,)),
               np.broadcast_to(np.asarray(gyro_bias, dtype=float), (3,)),
               np.broadcast_to(np.asarray(gyro_markov, dtype=float), (3,)),
               np.broadcast_to(np.asarray(accel_bias, dtype=float), (3,))]
    sd = np.maximum(sd / SCALE, 1e-6)
    return np.diag(sd**2)


def imu_noise_model(system: System, dt: float, file_errors=None
                    ) -> tuple[ImuNoiseModel, float | None, float | None]:
    """The filter's IMU model and the 1-sigma of its gyro constant bias [rad/s] and
    accelerometer bias [m/s^2] states (for P0), from the system's figures, each left-out
    figure taken from ``file_errors`` (a data file's :class:`~fednav.io.ImuErrors`,
    its largest axis) when given, else zero (infinite correlation time).  ``dt``: the IMU
    period [s] (per-sample white figures).

    ``filter.accel_bias`` chooses the accelerometer-bias state (see
    :class:`FilterConfig`); the gyro has a constant-bias state and a Gauss–Markov one.
    """
    imu = system.imu
    f = imu_figures(imu, file_errors)
    inf = float("inf")
    # White noise: the system's (density and per-sample figures), else the file's.
    given = imu.si("gyro_arw") is not None or imu.gyro_white_deg_h is not None
    arw = imu.arw(dt) if given or f["gyro_arw"] is None else f["gyro_arw"]
    given = imu.si("accel_vrw") is not None or imu.accel_white_ug is not None
    vrw = imu.vrw(dt) if given or f["accel_vrw"] is None else f["accel_vrw"]
    g_markov, g_tau = f["gyro_markov"] or 0.0, f["gyro_tau"] or inf
    a_markov, a_tau = f["accel_markov"] or 0.0, f["accel_tau"] or inf
    gb, ab = f["gyro_bias"] or 0.0, f["accel_bias"] or 0.0
    if system.filter.accel_bias == "gauss_markov":
        n = ImuNoiseModel(gyro_arw=arw, accel_vrw=vrw, gyro_bias_rw=imu.gyro_rw(),
                          accel_bias_rw=imu.accel_rw(), gyro_markov_sigma=g_markov,
                          gyro_markov_tau=g_tau, accel_markov_sigma=a_markov,
                          accel_markov_tau=a_tau)
        return n, gb, max(ab, a_markov)
    walk = a_markov * np.sqrt(2.0 / a_tau) if np.isfinite(a_tau) else 0.0
    if imu.accel_bias_rw_ug_sqrt_h:
        walk = float(np.hypot(walk, imu.accel_rw()))
    n = ImuNoiseModel(gyro_arw=arw, accel_vrw=vrw, gyro_bias_rw=imu.gyro_rw(),
                      gyro_markov_sigma=g_markov, gyro_markov_tau=g_tau, accel_bias_rw=walk)
    return n, gb, float(np.hypot(ab, a_markov))


#: Each figure of :data:`fednav.sensors.imu.FIGURES` and the field of a data file's
#: :class:`~fednav.io.ImuErrors` that gives it.
FILE_FIELDS = {"gyro_arw": "gyro_arw", "accel_vrw": "accel_vrw", "gyro_bias": "gyro_bias",
               "accel_bias": "accel_bias", "gyro_markov": "gyro_markov",
               "accel_markov": "accel_markov", "gyro_tau": "gyro_tau",
               "accel_tau": "accel_tau"}


def imu_figures(imu: ImuConfig, file_errors=None) -> dict[str, float | None]:
    """Every IMU figure (SI, by figure name): the system's, else the data file's (its
    largest axis), else the system's ``grade`` preset, else None."""
    out = {}
    for key, name in FILE_FIELDS.items():
        v = imu.si(key)
        if v is None and file_errors is not None:
            v = getattr(file_errors, name)
        if v is None:
            v = imu.preset(key)
        out[key] = None if v is None else float(np.max(v))
    return out


def missing_figures(imu: ImuConfig, file_errors=None) -> list[str]:
    """The IMU figures (SI keys of the ``imu:`` section) that neither ``imu`` nor the data
    file's ``file_errors`` gives (a white noise given per sample counts; a correlation
    time is not needed without its Gauss–Markov figure)."""
    from ..sensors.imu import FIGURES

    f = {FIGURES[k][2]: v for k, v in imu_figures(imu, file_errors).items()}
    if imu.gyro_white_deg_h is not None:
        f["gyro_arw_rad_sqrt_s"] = f["gyro_arw_rad_sqrt_s"] or 0.0
    if imu.accel_white_ug is not None:
        f["accel_vrw_mps_sqrt_s"] = f["accel_vrw_mps_sqrt_s"] or 0.0
    for markov, tau in (("gyro_markov_radps", "gyro_tau_s"),
                        ("accel_markov_mps2", "accel_tau_s")):
        if f[markov] == 0.0:
            f[tau] = f[tau] or float("inf")
    return [k for k, v in f.items() if v is None]
