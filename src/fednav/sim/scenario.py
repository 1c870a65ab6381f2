"""Scenario files: YAML validated by pydantic, converted to SI at this edge.

Keys carry their unit in the name (``_deg``, ``_arcsec``, ``_deg_h``, ``_ug``, ``_m``,
``_s`` ...).  An unknown key, a wrong type or a missing value is reported in one line
naming the key and the file (:class:`ConfigError`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from ..core import units
from ..core.config import ConfigError, _Model, load_model  # noqa: F401
from ..ins.error_model import ImuNoiseModel
from ..ins.strapdown import BaroLoop
from ..sensors import (
    AirData,
    Barometer,
    Fault,
    Gnss,
    ImuErrors,
    Latency,
    SarMatcher,
    SarVelocity,
    StarSensor,
    measurement_times,
)
from .trajectory import Segment
from .wind import Episode, WindField

_FLIGHTS: dict = {}


def cached_flight(key, make):
    """The truth of a flight, computed once per process and flight definition ``key``.

    The cache lives in the process, not in the scenario object, so scenarios shipped to
    worker processes stay small (a 1200 s flight at 100 Hz is 16 MB); forked workers
    inherit what the parent computed.  At most 8 flights are kept."""
    if key not in _FLIGHTS:
        if len(_FLIGHTS) >= 8:
            del _FLIGHTS[next(iter(_FLIGHTS))]
        _FLIGHTS[key] = make()
    return _FLIGHTS[key]


class StartConfig(_Model):
    lat_deg: float = Field(ge=-89.0, le=89.0)
    lon_deg: float = Field(ge=-180.0, le=360.0)
    h_m: float
    speed_mps: float = Field(ge=0.0)
    heading_deg: float
    pitch_deg: float = 0.0
    roll_deg: float = 0.0


class SegmentConfig(_Model):
    duration_s: float = Field(gt=0.0)
    accel_mps2: float = 0.0
    pitch_rate_deg_s: float = 0.0
    roll_rate_deg_s: float = 0.0
    heading_rate_deg_s: float = 0.0
    name: str = ""

    def to_segment(self) -> Segment:
        return Segment(self.duration_s, self.accel_mps2, units.deg(self.pitch_rate_deg_s),
                       units.deg(self.roll_rate_deg_s), units.deg(self.heading_rate_deg_s),
                       self.name)


class ImuConfig(_Model):
    """IMU errors.  ``accel_white_ug`` / ``gyro_white_deg_h`` are the 1-sigma of the
    white noise on each *sample* of specific force / rate (converted to VRW / ARW with
    the IMU period).  ``*_bias_rw_*_sqrt_h``: bias random walk, the bias grows by that
    much (1-sigma) per square-root hour."""

    gyro_bias_deg_h: float = 0.0
    gyro_markov_deg_h: float = 0.0
    gyro_markov_tau_s: float = Field(default=float("inf"), gt=0.0, allow_inf_nan=True)
    gyro_arw_deg_sqrt_h: float = 0.0
    gyro_white_deg_h: float = 0.0
    gyro_bias_rw_deg_h_sqrt_h: float = 0.0
    accel_bias_rw_ug_sqrt_h: float = 0.0
    accel_bias_ug: float = 0.0
    accel_markov_ug: float = 0.0
    accel_markov_tau_s: float = Field(default=float("inf"), gt=0.0, allow_inf_nan=True)
    accel_white_ug: float = 0.0
    accel_vrw_ug_sqrt_hz: float = 0.0   # white noise as a density (ug/sqrt(Hz))
    random_bias: bool = False

    def arw(self, dt: float) -> float:
        return float(np.hypot(units.deg_per_sqrt_h(self.gyro_arw_deg_sqrt_h),
                              units.deg_per_h(self.gyro_white_deg_h) * np.sqrt(dt)))

    def vrw(self, dt: float) -> float:
        return float(np.hypot(units.micro_g(self.accel_white_ug) * np.sqrt(dt),
                              units.micro_g(self.accel_vrw_ug_sqrt_hz)))

    def gyro_rw(self) -> float:
        return float(units.deg_per_h(self.gyro_bias_rw_deg_h_sqrt_h) / np.sqrt(units.HOUR))

    def accel_rw(self) -> float:
        return float(units.micro_g(self.accel_bias_rw_ug_sqrt_h) / np.sqrt(units.HOUR))

    def errors(self, dt: float) -> ImuErrors:
        return ImuErrors(
            gyro_bias=float(units.deg_per_h(self.gyro_bias_deg_h)), gyro_arw=self.arw(dt),
            gyro_bias_rw=self.gyro_rw(), accel_bias_rw=self.accel_rw(),
            gyro_markov_sigma=float(units.deg_per_h(self.gyro_markov_deg_h)),
            gyro_markov_tau=self.gyro_markov_tau_s,
            accel_bias=float(units.micro_g(self.accel_bias_ug)), accel_vrw=self.vrw(dt),
            accel_markov_sigma=float(units.micro_g(self.accel_markov_ug)),
            accel_markov_tau=self.accel_markov_tau_s, random_bias=self.random_bias)

    def noise_model(self, dt: float) -> ImuNoiseModel:
        return ImuNoiseModel(
            gyro_arw=self.arw(dt), accel_vrw=self.vrw(dt), gyro_bias_rw=self.gyro_rw(),
            accel_bias_rw=self.accel_rw(),
            gyro_markov_sigma=float(units.deg_per_h(self.gyro_markov_deg_h)),
            gyro_markov_tau=self.gyro_markov_tau_s,
            accel_markov_sigma=float(units.micro_g(self.accel_markov_ug)),
            accel_markov_tau=self.accel_markov_tau_s)


class TimingConfig(_Model):
    """When a sensor's measurements become available and how the filter treats the delay.

    Latency: ``latency_s`` (fixed), ``latency_range_s`` [lo, hi] (uniform per measurement)
    or ``latency_list_s`` (cycled); none = available when taken.  ``sequential``: the next
    measurement starts when the previous one ends (instead of every ``period_s``).
    ``delay_compensation``: ``none`` (use the delayed value as if current),
    ``curve_fit`` (polynomial of ``curve_fit_degree`` through the last
    ``curve_fit_points`` values, extrapolated to the epoch of use), ``ins_increment``
    (paper 004 eq. 6: add the INS increment since the capture instant) or ``recompute``
    (re-run the filter from the capture epoch; the exact, costly reference).
    """

    latency_s: float | None = Field(default=None, ge=0.0)
    latency_range_s: tuple[float, float] | None = None
    latency_list_s: list[float] | None = None
    sequential: bool = False
    delay_compensation: Literal["none", "curve_fit", "ins_increment", "recompute"] = "none"
    curve_fit_degree: Literal[1, 2, 3] = 2
    curve_fit_points: int = Field(default=4, ge=2)

    @model_validator(mode="after")
    def _one_latency(self):
        given = [x is not None for x in (self.latency_s, self.latency_range_s,
                                         self.latency_list_s)]
        if sum(given) > 1:
            raise ValueError("give only one of latency_s, latency_range_s, latency_list_s")
        if self.latency_range_s is not None and not (
                0.0 <= self.latency_range_s[0] <= self.latency_range_s[1]):
            raise ValueError("latency_range_s must be [low, high] with 0 <= low <= high")
        if self.sequential and not any(given):
            raise ValueError("sequential timing needs a latency")
        if self.curve_fit_points < self.curve_fit_degree + 1:
            raise ValueError("curve_fit_points must be at least curve_fit_degree + 1")
        return self

    def latency(self) -> Latency:
        if self.latency_range_s is not None:
            return Latency.uniform(*self.latency_range_s)
        if self.latency_list_s is not None:
            return Latency.from_list(self.latency_list_s)
        return Latency.fixed(self.latency_s or 0.0)


class _SensorConfig(_Model):
    """Common to every aiding sensor: its period and timing."""

    period_s: float = Field(gt=0.0)
    timing: TimingConfig = TimingConfig()

    def simulate(self, truth, rng):
        """The sensor's measurements over the flight, with their timing."""
        tm = self.timing
        if tm.latency().is_zero and not tm.sequential:
            return self.sensor().simulate(truth, rng)
        t, ta = measurement_times(float(truth.t[0]), float(truth.t[-1]), self.period_s,
                                  tm.latency(), tm.sequential, rng, truth.dt)
        return self.sensor().simulate(truth, rng, t, ta)


class StarConfig(_SensorConfig):
    sigma_arcsec: float = Field(gt=0.0)

    def sensor(self) -> StarSensor:
        return StarSensor(float(units.arcsec(self.sigma_arcsec)), self.period_s)


class SarConfig(_SensorConfig):
    """SAR image-matching fix: position and heading."""

    sigma_pos_m: float = Field(gt=0.0)
    sigma_heading_deg: float = Field(gt=0.0)

    def sensor(self) -> SarMatcher:
        return SarMatcher(self.sigma_pos_m, float(units.deg(self.sigma_heading_deg)),
                          self.period_s)


class SarVelocityConfig(_SensorConfig):
    """SAR sequential-image velocity (east, north)."""

    sigma_mps: float = Field(gt=0.0)

    def sensor(self) -> SarVelocity:
        return SarVelocity(self.sigma_mps, self.period_s)


class AirDataConfig(_SensorConfig):
    """Air data (horizontal airspeed) and the wind estimate the wind constraint uses."""

    sigma_airspeed_mps: float = Field(gt=0.0)
    wind_sigma_mps: float = Field(default=0.0, ge=0.0)
    wind_bias_mps: tuple[float, float] = (0.0, 0.0)  # (east, north) error of the estimate

    def sensor(self) -> AirData:
        return AirData(self.sigma_airspeed_mps, max(self.wind_sigma_mps, 1e-6),
                       self.wind_bias_mps, self.period_s)


class BaroConfig(_SensorConfig):
    """Barometric altimeter: damps the INS vertical channel (``damping_loop``) and/or aids
    the filter as a measurement (``baro`` in a mode's aiding)."""

    sigma_m: float = Field(gt=0.0)
    damping_loop: bool = True
    loop_time_constant_s: float = Field(default=20.0, gt=0.0)
    loop_order: Literal[2, 3] = 2

    def sensor(self) -> Barometer:
        return Barometer(self.sigma_m, self.period_s)

    def loop(self) -> BaroLoop | None:
        if not self.damping_loop:
            return None
        return BaroLoop(self.loop_time_constant_s, self.loop_order)


class GnssConfig(_SensorConfig):
    """GNSS position sigma (north, east, up) [m] or one value, velocity sigma [m/s]."""

    sigma_pos_m: float | tuple[float, float, float]
    sigma_vel_mps: float | tuple[float, float, float]

    def sensor(self) -> Gnss:
        return Gnss(self.sigma_pos_m, self.sigma_vel_mps, self.period_s)


class SensorsConfig(_Model):
    star: StarConfig | None = None
    sar: SarConfig | None = None
    gnss: GnssConfig | None = None
    baro: BaroConfig | None = None
    sarvel: SarVelocityConfig | None = None
    airdata: AirDataConfig | None = None


class FaultConfig(_Model):
    """Additive sensor fault: ``size_sigma`` times the sensor sigma on ``components``
    (indices into the sensor's measurement; all when omitted), ``step`` or ``ramp``."""

    sensor: Literal["star", "sar", "gnss", "baro", "sarvel", "airdata"]
    start_s: float
    end_s: float
    size_sigma: float | list[float]
    kind: Literal["step", "ramp"] = "step"
    components: list[int] | None = None

    def fault(self) -> Fault:
        size = self.size_sigma if isinstance(self.size_sigma, float) else tuple(self.size_sigma)
        comps = None if self.components is None else tuple(self.components)
        return Fault(self.sensor, self.start_s, self.end_s, size, self.kind, comps)


class FilterConfig(_Model):
    """``architecture``: ``federated`` (one local filter per aiding sensor, fused) or
    ``centralized`` (one filter; at each epoch H and R are stacked from the sensors that
    delivered since the last epoch)."""

    type: Literal["ukf", "sukf", "kf", "ekf", "cukf", "cekf", "aekf", "raukf", "sghqf",
                  "aasghqf"] = "ukf"
    architecture: Literal["federated", "centralized"] = "federated"
    period_s: float = Field(default=1.0, gt=0.0)
    alpha: float = Field(default=1e-3, gt=0.0)
    beta: float = 2.0
    kappa: float = 0.0
    sharing: Literal["equal", "fixed", "adaptive"] = "adaptive"
    fixed_factors: dict[str, float] | None = None
    master: bool = True
    reset: bool = True
    substeps: int = Field(default=2, ge=1)
    fdi_alpha: float | None = Field(default=None, gt=0.0, lt=1.0)
    fdi_recovery: int = Field(default=1, ge=1)  # consecutive passes to return after isolation
    grid_level: int = Field(default=3, ge=1, le=5)  # sparse-grid accuracy level (sghqf, aasghqf)


class InitialErrorConfig(_Model):
    """1-sigma of the initial INS errors (drawn per run) and of the filter's P0."""

    attitude_arcsec: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_mps: float = Field(default=0.0, ge=0.0)
    position_m: float | tuple[float, float, float] = 0.0  # one value or (east, north, up)


FilterType = Literal["ukf", "sukf", "kf", "ekf", "cukf", "cekf", "aekf", "raukf",
                     "sghqf", "aasghqf", "total-ukf"]


class ModeConfig(_Model):
    """A mode: which aiding sensors feed local filters, and (optionally) a filter type
    that overrides ``filter.type`` for this mode (``total-ukf``: the total-state
    federated UKF of paper 003) and a delay strategy for its delayed sensors (paper 004)."""

    name: str
    aiding: list[Literal["star", "sar", "gnss", "sarvel", "baro"]] = []
    filter: FilterType | None = None
    # overrides timing.delay_compensation of every aiding sensor that has a latency
    delay_compensation: Literal["none", "curve_fit", "ins_increment", "recompute"] | None = None
    # equality constraint applied in every local filter each epoch (needs sensors.airdata)
    constraint: Literal["wind"] | None = None


class WindEpisodeConfig(_Model):
    start_s: float = Field(ge=0.0)
    end_s: float
    speed_range_mps: tuple[float, float]
    from_range_deg: tuple[float, float]
    change_interval_s: float = Field(gt=0.0)


class WindConfig(_Model):
    """Wind field (``fednav.sim.wind``): constant wind from ``from_deg`` (meteorological, 270 =
    west wind) plus random episodes; one realisation per scenario (``seed``)."""

    speed_mps: float = Field(ge=0.0)
    from_deg: float
    ramp_s: float = Field(default=10.0, gt=0.0)
    episodes: list[WindEpisodeConfig] = []
    seed: int = 0

    def field(self) -> WindField:
        eps = [Episode(e.start_s, e.end_s, e.speed_range_mps,
                       (units.deg(e.from_range_deg[0]), units.deg(e.from_range_deg[1])),
                       e.change_interval_s) for e in self.episodes]
        return WindField(self.speed_mps, units.deg(self.from_deg), eps, self.ramp_s,
                         np.random.default_rng(self.seed))


class FaultExperimentConfig(_Model):
    """A second experiment on the first ``duration_s`` of the flight with ``fault``
    injected, flown with and without fault isolation (paper 003)."""

    duration_s: float = Field(gt=0.0)
    fault: FaultConfig
    mode: str  # name of the mode (in ``modes``) that flies it


class Scenario(_Model):
    paper: str
    name: str
    description: str = ""
    start: StartConfig
    imu_period_s: float = Field(gt=0.0)
    segments: list[SegmentConfig] = Field(min_length=1)
    imu: ImuConfig
    sensors: SensorsConfig
    filter: FilterConfig = FilterConfig()
    initial_errors: InitialErrorConfig = InitialErrorConfig()
    modes: list[ModeConfig] = Field(min_length=1)
    faults: list[FaultConfig] = []
    fault_experiment: FaultExperimentConfig | None = None
    stats_period_s: float = Field(default=1.0, gt=0.0)
    wind: WindConfig | None = None  # segments then describe the flight through the air

    @model_validator(mode="after")
    def _constraint_needs_air_data(self):
        if any(m.constraint == "wind" for m in self.modes) and self.sensors.airdata is None:
            raise ValueError("a mode with constraint: wind needs sensors.airdata")
        return self

    @model_validator(mode="after")
    def _fault_experiment_needs_detection(self):
        if self.fault_experiment is not None and self.filter.fdi_alpha is None:
            raise ValueError("fault_experiment needs filter.fdi_alpha (the detection "
                             "significance level)")
        return self

    @property
    def duration(self) -> float:
        return float(sum(s.duration_s for s in self.segments))

    def trajectory(self, max_time: float | None = None):
        """The true flight (cached per scenario object)."""
        from .trajectory import generate

        # Keyed by what defines the flight: copies made with model_copy share this dict.
        key = (type(self).__name__, max_time, self.model_dump_json(
            include={"start", "segments", "imu_period_s", "wind"}))
        def make():
            segs = [s.to_segment() for s in self.segments]
            if max_time is not None:
                segs = _truncate(segs, max_time)
            st = self.start
            return generate(
                [units.deg(st.lat_deg), units.deg(st.lon_deg), st.h_m], st.speed_mps,
                [units.deg(st.pitch_deg), units.deg(st.roll_deg), units.deg(st.heading_deg)],
                segs, self.imu_period_s,
                wind=None if self.wind is None else self.wind.field())

        return cached_flight(key, make)


def _truncate(segs: list[Segment], max_time: float) -> list[Segment]:
    out, t = [], 0.0
    for s in segs:
        if t >= max_time:
            break
        d = min(s.duration, max_time - t)
        out.append(Segment(d, s.accel, s.pitch_rate, s.roll_rate, s.heading_rate, s.name))
        t += d
    return out


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file (errors: :class:`ConfigError`, one line)."""
    return load_model(path, Scenario, "scenario")
