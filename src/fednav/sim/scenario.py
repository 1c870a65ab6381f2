"""Scenario files: a system description plus the flight and the experiment of a paper.

A scenario is a :class:`~fednav.navigator.system.System` (IMU, sensors, filter) with
the flight (``start``, ``segments``, ``wind``), the simulated errors
(``initial_errors``, ``faults``) and the ``modes`` to compare: each mode is the system
with some of the sensors aiding, and optionally another filter, delay strategy or
constraint (:meth:`Scenario.system_for`).  YAML validated by pydantic, converted to SI at
this edge; keys carry their unit in the name; an error is one line naming the key and
the file (:class:`ConfigError`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from ..core import units
from ..core.config import (  # noqa: F401
    ConfigError,
    _Model,
    load_model,
    read_text_file,  # noqa: F401  (0.1's fednav.config names)
)
from ..navigator.system import FilterConfig, System  # noqa: F401
from ..sensors import (  # noqa: F401  (0.1's fednav.config names)
    AirDataConfig,
    BaroConfig,
    Fault,
    GnssConfig,
    SarConfig,
    SarVelocityConfig,
    StarConfig,
    TimingConfig,
)
from ..sensors.imu import ImuConfig  # noqa: F401  (the section's class, for its users)
from ..sensors.registry import SensorSet as SensorsConfig  # noqa: F401  (0.1's name)
from ..sensors.registry import check_names
from ..sensors.timing import DELAY_COMPENSATIONS
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


class Between(_Model):
    """A value drawn per run, uniformly between the two bounds ``between: [low, high]``."""

    between: tuple[float, float]

    @field_validator("between")
    @classmethod
    def _ordered(cls, v):
        if not v[1] >= v[0]:
            raise ValueError(f"between: [low, high] with high >= low, got {list(v)}")
        return v

    def draw(self, rng: np.random.Generator) -> float:
        return float(rng.uniform(*self.between))


def _value(v, rng: np.random.Generator):
    """A fixed value as it is, a :class:`Between` drawn."""
    return v.draw(rng) if isinstance(v, Between) else v


class FaultConfig(_Model):
    """A sensor fault injected in every run (:mod:`fednav.sensors.faults`): ``kind`` (step,
    ramp, drift, burst, false_match, misidentification, spoofing) on ``components``
    (indices into the sensor's measurement; omitted: all, or the position's for
    false_match and spoofing, the angles for misidentification), of ``size_sigma`` times
    the sensor's sigma, from ``start_s`` to ``end_s`` (or for ``duration_s``).  Start,
    duration and size may each be ``{between: [low, high]}``, drawn per run; the
    direction of a false match or a spoofing pull and the signs of a misidentification are
    always drawn per run — from a stream of their own, so the runs' noise is the same with
    or without faults.  ``share`` (0 < share <= 1): the fraction of runs that draw this
    fault — the faults with a share are alternatives, each run draws at most one of them
    (with shares summing to less than 1, the other runs are fault-free: false-alert runs);
    a fault without one is injected in every run."""

    sensor: str
    start_s: float | Between
    end_s: float | None = None
    duration_s: float | Between | None = None
    size_sigma: float | list[float] | Between
    kind: Literal["step", "ramp", "drift", "burst", "false_match", "misidentification",
                  "spoofing"] = "step"
    components: list[int] | None = None
    share: float | None = Field(default=None, gt=0.0, le=1.0)

    @field_validator("sensor")
    @classmethod
    def _sensor(cls, v):
        return check_names([v])[0]

    @model_validator(mode="after")
    def _window(self):
        if (self.end_s is None) == (self.duration_s is None):
            raise ValueError("give end_s or duration_s (one of them)")
        if self.end_s is not None and isinstance(self.start_s, Between):
            raise ValueError("a start drawn per run (start_s: {between: ...}) takes "
                             "duration_s, not end_s")
        lo = self.duration_s.between[0] if isinstance(self.duration_s, Between) \
            else self.duration_s
        if lo is not None and not lo > 0.0:
            raise ValueError(f"duration_s must be positive, got {lo}")
        from ..sensors.faults import HORIZONTAL
        from ..sensors.registry import spec

        sp = spec(self.sensor)
        if self.kind in HORIZONTAL and sp.latlon is None:
            raise ValueError(f"kind: {self.kind} moves a position fix; the {self.sensor} "
                             f"sensor measures no latitude/longitude")
        if self.kind == "misidentification" and not sp.angles:
            raise ValueError(f"kind: misidentification is an attitude jump; the "
                             f"{self.sensor} sensor measures no angle")
        return self

    @property
    def end_fixed(self) -> float | None:
        """The end [s] when nothing of the window is drawn, else None."""
        if self.end_s is not None:
            return self.end_s
        if isinstance(self.start_s, Between) or isinstance(self.duration_s, Between):
            return None
        return self.start_s + self.duration_s

    def fault(self, rng: np.random.Generator | None = None) -> Fault:
        """The fault of one run, what is drawn drawn from ``rng`` (the run's fault stream;
        None: a generator seeded 0)."""
        rng = np.random.default_rng(0) if rng is None else rng
        start = float(_value(self.start_s, rng))
        end = self.end_s if self.end_s is not None else start + _value(self.duration_s, rng)
        size = _value(self.size_sigma, rng)
        size = float(size) if not isinstance(size, list) else tuple(size)
        comps = None if self.components is None else tuple(self.components)
        bearing = float(rng.uniform(0.0, 2.0 * np.pi))
        signs = tuple(float(s) for s in rng.choice([-1.0, 1.0], 3))
        return Fault(self.sensor, start, float(end), size, self.kind, comps, bearing, signs,
                     int(rng.integers(2**31)))


class InitialErrorConfig(_Model):
    """1-sigma of the initial INS errors (drawn per run) and of the filter's P0."""

    attitude_arcsec: tuple[float, float, float] = (0.0, 0.0, 0.0)
    velocity_mps: float = Field(default=0.0, ge=0.0)
    position_m: float | tuple[float, float, float] = 0.0  # one value or (east, north, up)


class ModeConfig(_Model):
    """A mode: which aiding sensors feed local filters, and (optionally) a filter type
    that overrides ``filter.type`` for this mode (a name of the filter registry, or
    ``total-ukf``: the total-state federated UKF of paper 003) and a delay strategy for
    its delayed sensors (paper 004)."""

    name: str
    aiding: list[str] = []
    filter: str | None = None
    # overrides timing.delay_compensation of every aiding sensor that has a latency
    delay_compensation: Literal[DELAY_COMPENSATIONS] | None = None
    # equality constraint applied in every local filter each epoch (needs sensors.airdata)
    constraint: Literal["wind"] | None = None

    @field_validator("aiding")
    @classmethod
    def _aiding(cls, v):
        return check_names(v, "aiding sensor", aiding=True)

    @field_validator("filter")
    @classmethod
    def _filter(cls, v):
        from ..navigator.system import _check_filter

        return v if v is None or v == "total-ukf" else _check_filter(v)


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

    @model_validator(mode="after")
    def _fixed(self):
        if self.fault.end_fixed is None:
            raise ValueError("fault_experiment.fault: its window is fixed (start_s and "
                             "end_s), not drawn per run")
        return self

    @model_validator(mode="after")
    def _in_every_run(self):
        if self.fault.share is not None:
            raise ValueError("fault_experiment.fault: share: the fault experiment injects its "
                             "fault in every run (share is for a design's alternative faults)")
        return self


class Scenario(System):
    """A paper's experiment or a user's design (``fednav run``): the system description
    (IMU, sensors, filter) and the flight, the simulated errors and the modes to compare.
    ``paper``: the paper number a packaged scenario reproduces (None for a design)."""

    paper: str | None = None
    name: str
    description: str = ""
    start: StartConfig
    imu_period_s: float = Field(gt=0.0)
    segments: list[SegmentConfig] = Field(min_length=1)
    initial_errors: InitialErrorConfig = InitialErrorConfig()
    modes: list[ModeConfig] = Field(min_length=1)
    faults: list[FaultConfig] = []
    fault_experiment: FaultExperimentConfig | None = None
    stats_period_s: float = Field(default=1.0, gt=0.0)
    wind: WindConfig | None = None  # segments then describe the flight through the air

    @model_validator(mode="after")
    def _filter_period_stated(self):
        if self.filter.period_s is None:
            raise ValueError("filter.period_s: a scenario states its filter period")
        return self

    @model_validator(mode="after")
    def _shares_add_up(self):
        total = sum(f.share for f in self.faults if f.share is not None)
        if total > 1.0 + 1e-9:
            raise ValueError(f"faults: the shares of the alternative faults add up to "
                             f"{total:g}; each run draws at most one of them (at most 1)")
        return self

    def draw_faults(self, rng: np.random.Generator) -> list:
        """The faults of one run (:class:`~fednav.sensors.faults.Fault`), drawn from
        ``rng`` (the run's fault stream): every fault's parameters in order, then — when
        some faults have a ``share`` — which one of those alternatives the run takes (or
        none), so that a fault's parameters do not depend on the choice."""
        faults = [f.fault(rng) for f in self.faults]
        alt = [i for i, f in enumerate(self.faults) if f.share is not None]
        if not alt:
            return faults
        u = rng.uniform()
        edges = np.cumsum([self.faults[i].share for i in alt])
        k = int(np.searchsorted(edges, u, side="right"))
        chosen = alt[k] if k < len(alt) else None
        return [f for i, f in enumerate(faults) if i not in alt or i == chosen]

    @model_validator(mode="after")
    def _constraint_needs_air_data(self):
        if any(m.constraint == "wind" for m in self.modes) and self.sensors.airdata is None:
            raise ValueError("a mode with constraint: wind needs sensors.airdata")
        return self

    @model_validator(mode="after")
    def _modes_use_configured_sensors(self):
        for m in self.modes:
            for a in m.aiding:
                if a not in self.sensors:
                    raise ValueError(f"mode '{m.name}' uses sensor '{a}', which has no "
                                     f"section in sensors")
        for name, cfg in self.sensors.items():
            if cfg.period_s is None:
                raise ValueError(f"sensors.{name}.period_s is needed to simulate the sensor")
        return self

    def system_for(self, mode) -> System:
        """The system one mode flies: its aiding sensors, its filter type, delay strategy
        (for the sensors whose measurements arrive late) and constraint."""
        flt = self.filter
        if mode.filter == "total-ukf":
            flt = flt.model_copy(update={"state": "total"})
        elif mode.filter is not None:
            flt = flt.model_copy(update={"type": mode.filter})
        sensors = self.sensors
        if mode.delay_compensation is not None:
            sensors = sensors.replace(**{
                a: cfg.model_copy(update={"timing": cfg.timing.model_copy(
                    update={"delay_compensation": mode.delay_compensation})})
                for a in mode.aiding if (cfg := self.sensors[a]).timing.delayed})
        return System(imu=self.imu, sensors=sensors, aiding=list(mode.aiding),
                      constraint=mode.constraint, filter=flt, integrity=self.integrity)

    @model_validator(mode="after")
    def _navigation_reader(self):
        # a sky simulated from a navigation file (a section's navigation_file) is read by
        # the file layer's RINEX reader, which registers with the models when imported
        # (imported here only then: the file layer costs 0.4 s of start-up)
        if any(getattr(self.sensors[n], "navigation_file", None) for n in self.sensors):
            from ..io import rinex  # noqa: F401
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
