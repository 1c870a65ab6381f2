"""Launch scenarios (paper 001): YAML validated by pydantic, converted to SI here.

Keys carry their unit in the name, as in :mod:`fednav.sim.scenario`; an unknown key, a wrong
type or a value out of range is reported in one line naming the key and the file.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from ..core import units
from ..core.config import _Model, load_model
from ..sensors.imu import ImuConfig
from ..sim.scenario import cached_flight
from .frame import LaunchFrame
from .trajectory import AscentProfile, Burn, LaunchTrajectory, Manoeuvre, generate

#: Keys of fednav 0.1's launch scenarios, read for one more release.
_RENAMED = {"gps": "gnss", "pf_gps_likelihood": "pf_gnss_likelihood"}


def _renamed(data):
    """0.1's ``gps`` keys under their name now (``gnss``), with a FutureWarning."""
    if not isinstance(data, dict) or not any(k in data for k in _RENAMED):
        return data
    import warnings

    old = [k for k in data if k in _RENAMED]
    both = [k for k in old if _RENAMED[k] in data]
    if both:
        raise ValueError(f"'{both[0]}' and '{_RENAMED[both[0]]}' are the same setting; give "
                         f"it once")
    warnings.warn(f"launch scenario keys {', '.join(old)} are now "
                  f"{', '.join(_RENAMED[k] for k in old)} (the old names are read for one "
                  f"more release)", FutureWarning, stacklevel=2)
    return {_RENAMED.get(k, k): v for k, v in data.items()}


class LaunchSite(_Model):
    lat_deg: float = Field(ge=-89.0, le=89.0)
    lon_deg: float = Field(ge=-180.0, le=360.0)
    h_m: float = 0.0
    azimuth_deg: float
    epoch: datetime = datetime(2014, 11, 1, tzinfo=UTC)

    @field_validator("epoch")
    @classmethod
    def _utc(cls, v: datetime) -> datetime:
        return v if v.tzinfo is not None else v.replace(tzinfo=UTC)


class BurnConfig(_Model):
    start_s: float = Field(ge=0.0)
    duration_s: float = Field(gt=0.0)
    accel_mps2: float = Field(gt=0.0)
    mass_ratio: float = Field(gt=0.0, le=1.0)


class ManoeuvreConfig(_Model):
    start_s: float = Field(ge=0.0)
    duration_s: float = Field(gt=0.0)
    change_deg: float


class GnssConfig(_Model):
    """GNSS position fixes: isotropic white noise ``sigma_m`` (1-sigma per axis); with
    ``outlier_probability`` a fix is instead drawn with ``outlier_scale`` times the sigma
    (a heavy-tailed receiver)."""

    period_s: float = Field(gt=0.0)
    sigma_m: float = Field(gt=0.0)
    outlier_probability: float = Field(default=0.0, ge=0.0, lt=1.0)
    outlier_scale: float = Field(default=1.0, ge=1.0)
    available_from_s: float = Field(default=0.0, ge=0.0)


class StarConfig(_Model):
    """Star sensor attitude: isotropic rotation-vector noise ``sigma_arcsec``."""

    period_s: float = Field(gt=0.0)
    sigma_arcsec: float = Field(gt=0.0)
    available_from_s: float = Field(default=0.0, ge=0.0)


class InitialErrorConfig(_Model):
    """1-sigma of the initial navigation error (drawn per run; also the filter's P0)."""

    attitude_arcsec: tuple[float, float, float]
    position_m: float = Field(gt=0.0)
    velocity_mps: float = Field(gt=0.0)

    @field_validator("attitude_arcsec")
    @classmethod
    def _positive(cls, v):
        if min(v) <= 0:
            raise ValueError("attitude sigmas must be positive")
        return v


class FilterOptions(_Model):
    """Federated filter: two local filters (GNSS, star sensor), fusion and reset every cycle.

    ``particles`` per local PF; ``resample_threshold`` (ESS / N); ``roughening`` K;
    ``progressive_correction`` tempered updates when one update would collapse the set;
    ``sharing`` equal (beta = 1/2) or adaptive; ``pf_gnss_likelihood`` gaussian, or
    mixture (the PF uses the GNSS outlier model); ``ekf_gate_alpha`` chi-square test level
    on the EKF's GNSS local filter (none: off).
    """

    particles: int = Field(default=1000, ge=10)
    resample_threshold: float = Field(default=0.5, ge=0.0, le=1.0)
    roughening: float = Field(default=0.0, ge=0.0)
    progressive_correction: bool = True
    sharing: Literal["equal", "adaptive"] = "equal"
    pf_gnss_likelihood: Literal["gaussian", "mixture"] = "gaussian"
    ekf_gate_alpha: float | None = Field(default=None, gt=0.0, lt=1.0)

    @model_validator(mode="before")
    @classmethod
    def _legacy(cls, data):
        return _renamed(data)


class RegimeConfig(_Model):
    """A condition of the PF-vs-EKF sweep: the scenario with these parts replaced."""

    name: str
    gnss: GnssConfig | None = None
    star: StarConfig | None = None
    initial_error: InitialErrorConfig | None = None
    filters: FilterOptions | None = None

    @model_validator(mode="before")
    @classmethod
    def _legacy(cls, data):
        return _renamed(data)


class LaunchScenario(_Model):
    paper: str = "001"
    name: str = "launch-frame"
    description: str = ""
    launch: LaunchSite
    duration_s: float = Field(gt=0.0)
    imu_period_s: float = Field(default=0.02, gt=0.0)
    filter_period_s: float = Field(default=1.0, gt=0.0)
    gravity_degree: Literal[2, 4] = 4
    pitch0_deg: float = 90.0
    burns: list[BurnConfig]
    pitch_programme: list[ManoeuvreConfig] = []
    yaw_programme: list[ManoeuvreConfig] = []
    imu: ImuConfig
    gnss: GnssConfig
    star: StarConfig
    initial_error: InitialErrorConfig
    filters: FilterOptions = FilterOptions()
    particle_sweep: list[int] = [100, 300, 1000, 3000]
    particle_sweep_runs: int = Field(default=3, ge=1)
    regimes: list[RegimeConfig] = []
    regime_runs: int = Field(default=5, ge=1)

    @model_validator(mode="before")
    @classmethod
    def _legacy(cls, data):
        return _renamed(data)

    @model_validator(mode="after")
    def _consistent(self):
        per = self.filter_period_s / self.imu_period_s
        if abs(per - round(per)) > 1e-9 or round(per) < 2:
            raise ValueError("filter_period_s must be a multiple (>= 2) of imu_period_s")
        for s in (self.gnss, self.star):
            k = s.period_s / self.filter_period_s
            if abs(k - round(k)) > 1e-9:
                raise ValueError("sensor period_s must be a multiple of filter_period_s")
        if any(n < 10 for n in self.particle_sweep):
            raise ValueError("particle_sweep: every count must be >= 10")
        return self

    def frame(self) -> LaunchFrame:
        s = self.launch
        return LaunchFrame((float(units.deg(s.lat_deg)), float(units.deg(s.lon_deg)), s.h_m),
                           float(units.deg(s.azimuth_deg)), s.epoch, self.gravity_degree)

    def profile(self, max_time: float | None = None) -> AscentProfile:
        def man(m):
            return Manoeuvre(m.start_s, m.duration_s, float(units.deg(m.change_deg)))

        dur = self.duration_s if max_time is None else min(self.duration_s, max_time)
        return AscentProfile(
            self.frame(), dur,
            burns=tuple(Burn(b.start_s, b.duration_s, b.accel_mps2, b.mass_ratio)
                        for b in self.burns),
            pitch=tuple(man(m) for m in self.pitch_programme),
            yaw=tuple(man(m) for m in self.yaw_programme),
            pitch0=float(units.deg(self.pitch0_deg)))

    def trajectory(self, max_time: float | None = None) -> LaunchTrajectory:
        """The ascent's truth and ideal IMU (cached per flight definition)."""
        key = (type(self).__name__, max_time, self.model_dump_json(
            include={"launch", "duration_s", "imu_period_s", "gravity_degree", "pitch0_deg",
                     "burns", "pitch_programme", "yaw_programme"}))
        return cached_flight(key, lambda: generate(self.profile(max_time), self.imu_period_s))

    def with_regime(self, regime: RegimeConfig) -> LaunchScenario:
        upd = {k: getattr(regime, k) for k in ("gnss", "star", "initial_error", "filters")
               if getattr(regime, k) is not None}
        return self.model_copy(update=upd)


def load_launch_scenario(path: str | Path) -> LaunchScenario:
    """Read and validate a launch scenario YAML (errors: one line naming file and key)."""
    return load_model(path, LaunchScenario, "scenario")


def __getattr__(name: str):
    """0.1's name of the GNSS section, for one more release."""
    if name == "GpsConfig":
        import warnings

        warnings.warn("fednav.launch.scenario.GpsConfig is now GnssConfig", FutureWarning,
                      stacklevel=2)
        return GnssConfig
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
