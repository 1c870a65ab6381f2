"""What a sensor module declares: its section of the system description and its entry
in the sensor registry (:mod:`fednav.sensors.registry`).

A sensor module holds, for one aiding sensor, everything fednav knows of it:

* a :class:`SensorConfig` subclass — its keys in a system description or scenario file
  (noise in the units its key names carry, period, lever arm, timing) and the two objects
  built from them: the simulator (``sensor()``, turning a true trajectory into a
  :class:`~fednav.sensors.base.MeasurementSeries`) and the filter-side measurement model
  (``model()``, :mod:`fednav.sensors.measurement`);
* its CSV file layout (:class:`Column` s after ``t_s``);
* a :class:`SensorSpec` naming all of it, which one line of the registry adds.
"""

from __future__ import annotations

from abc import abstractmethod
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
from pydantic import Field, field_validator

from ..core import mounting
from ..core.config import ConfigError, _Model
from .base import SensorView
from .measurement import BVEL_R, HEADING, PITCH, RATE_X, VEL_U, RowModel, mounted
from .timing import TimingConfig, measurement_times

_V3 = tuple[float, float, float]


class SensorConfig(_Model):
    """Common to every sensor's section: its period (for simulation), timing and
    outages (simulated windows ``[start_s, end_s)`` without measurements: a GNSS
    dropout, a star sensor blinded by the sun), and where it sits on the vehicle:
    ``lever_m``, its point from the IMU (body right-forward-up, m; None: the data
    file's where it gives one, else zero) and ``mounting``, the rotation from its own
    axes to the body frame (:mod:`fednav.core.mounting`: axis letters such as ``FRD`` or
    ``{euler_deg: [pitch, roll, heading]}``; None: aligned with the body).  Both are
    applied by one code path in the simulator (:meth:`simulate` hands the sensor the
    truth seen from its point and axes, :class:`~fednav.sensors.base.SensorView`) and one
    in the filter (:meth:`measurement_model`); a sensor on which one of them cannot act
    refuses it (:meth:`SensorSpec.check_geometry`).  A sensor's section gives its
    simulator (``sensor``) and measurement model (``model``)."""

    #: old spellings of the section's keys -> today's, read for one more release
    #: (:meth:`renamed_keys`)
    old_keys: ClassVar[dict[str, str]] = {}
    #: keys of fednav 0.1's flat processing config -> (this section's key[, the
    #: conversion of the value, what the warning says of it]), read for one more release
    #: (:func:`fednav.navigator.system.legacy_keys`)
    flat_keys: ClassVar[dict[str, tuple]] = {}

    period_s: float | None = Field(default=None, gt=0.0)
    timing: TimingConfig = TimingConfig()
    outages_s: list[tuple[float, float]] = []
    lever_m: _V3 | None = None
    mounting: str | dict | None = None

    @field_validator("mounting")
    @classmethod
    def _mounting(cls, v):
        return mounting.validate(v)

    @classmethod
    def renamed_keys(cls, data, where: str = "sensors.<name>"):
        """A section's mapping with its :attr:`old_keys` in today's places (``where``:
        the section's place, for the warning); as it is here."""
        return data

    def lever(self) -> np.ndarray:
        """The lever arm [m] (body right-forward-up; zeros when none is set)."""
        return np.zeros(3) if self.lever_m is None else np.asarray(self.lever_m, dtype=float)

    def mount(self) -> np.ndarray | None:
        """``C_s^b`` of the mounting (None: aligned with the body)."""
        M = mounting.parse(self.mounting)
        return None if mounting.is_identity(M) else M

    def measurement_model(self):
        """The filter-side model of this sensor at its lever arm and mounting (the one
        place the filter takes them from the section)."""
        return mounted(self.model(), self.lever(), self.mount())

    @field_validator("outages_s")
    @classmethod
    def _outages(cls, v):
        for a, b in v:
            if not b > a:
                raise ValueError(f"an outage ends after it starts, got [{a}, {b}]")
        return v

    @abstractmethod
    def sensor(self):
        """The simulator of this sensor (a frozen dataclass with ``simulate``)."""

    @abstractmethod
    def model(self):
        """The filter-side measurement model (residual, ``h``, ``H``, ``R``)."""

    def sigma(self) -> np.ndarray | None:
        """1-sigma of each component of ``z`` (the units of the sensor's series), or None
        when the configuration leaves it to the data."""
        return None

    def roles(self, system) -> dict[str, str]:
        """What the sensor's data feed in ``system`` (a
        :class:`~fednav.navigator.system.System`) besides a local filter of its own
        (``system.aiding``), each with the key that turns it on: ``{"damping": ...}``,
        ``{"constraint": ...}``; {} for most sensors."""
        return {}

    def for_recording(self, data) -> SensorConfig:
        """This section as it flies the recording ``data`` (a
        :class:`~fednav.io.data.Series`): the settings it leaves to the data taken from
        them — here the period, the median interval of the time stamps [s]; a sensor whose
        file carries more (the GNSS's antenna lever arm and noise) takes those too."""
        if self.period_s is None and len(data.t) > 1:
            return self.model_copy(update={"period_s": float(np.median(np.diff(data.t)))})
        return self

    def total_state_refusal(self) -> str | None:
        """Why this section, as it flies a recording (:meth:`for_recording`), cannot
        fly in the total-state navigator (``filter.state: total``); None: it can."""
        return None

    def simulate(self, truth, rng, name: str = "sensor"):
        """The sensor's measurements over the flight, with their timing."""
        if self.period_s is None:
            raise ConfigError(f"sensors.{name}.period_s: needed to simulate the sensor")
        truth = SensorView.of(truth, self.lever(), self.mount())
        tm = self.timing
        if not tm.delayed:
            series = self.sensor().simulate(truth, rng)
        else:
            t, ta = measurement_times(float(truth.t[0]), float(truth.t[-1]), self.period_s,
                                      tm.latency(), tm.sequential, rng, truth.dt)
            series = self.sensor().simulate(truth, rng, t, ta)
        if not self.outages_s:
            return series
        # every measurement is drawn first (the run's random numbers stay the same), then
        # those inside an outage are removed
        keep = np.ones(len(series.t), dtype=bool)
        for a, b in self.outages_s:
            keep &= ~((series.t >= a) & (series.t < b))
        return replace(series, t=series.t[keep], z=series.z[keep],
                       t_avail=series.t_avail[keep])


@dataclass(frozen=True)
class Column:
    """One column of a sensor's CSV file: its header ``name`` (unit in the name), the
    factor that turns its values into the SI value of ``z`` and, for angles, whether it
    is wrapped to [0, 2 pi).  ``sigma``: the header and SI factor of the optional column
    holding each row's 1-sigma of this component (default ``sigma_<name>`` in the same
    unit; latitude and longitude give theirs in metres, north and east).  ``absent``:
    for a column a file may leave out, the section's settings that say so (its model
    then has no row for the component, whose ``z`` is NaN)."""

    name: str
    to_si: float = 1.0
    wrap_2pi: bool = False
    sigma: tuple[str, float] | None = None
    #: an optional column: the sensor section's settings when a file lacks it (e.g. a
    #: SAR fix without heading: ``{"use_heading": False}``); None: required
    absent: dict | None = None

    @property
    def sigma_column(self) -> tuple[str, float]:
        """(header, factor to SI) of this component's 1-sigma column."""
        return self.sigma or (f"sigma_{self.name}", self.to_si)


@dataclass(frozen=True)
class SensorSpec:
    """A registered sensor.

    ``name``: its key in ``sensors:``, the name of its local filter and of its CLI file
    option; ``summary``: one line for the docs and ``--help``; ``config``: its section;
    ``model``: its measurement model's class (a
    :class:`~fednav.sensors.measurement.RowModel` runs in the navigator's compiled engine,
    as does a model naming its compiled rows, ``engine_rows``; any other model in its
    Python loop); ``columns``: its CSV file after ``t_s`` (one per
    component of ``z``, in order); ``aiding``: whether it can feed a local filter (air
    data only constrains); ``angles``: components of ``z`` that are angles (unwrapped
    before curve fitting); ``latlon``: components holding latitude and longitude (faults
    are metric offsets there), ``height``: the component holding the height, if any.
    """

    name: str
    summary: str
    config: type[SensorConfig]
    model: type
    columns: tuple[Column, ...] = ()
    aiding: bool = True
    angles: tuple[int, ...] = ()
    latlon: tuple[int, int] | None = None
    height: int | None = None
    #: another layout of the same measurement: (its columns after ``t_s``, a function
    #: of their values (N, k) -> ``z`` (N, m) in SI), e.g. the star sensor's quaternion
    alternative: tuple[tuple[str, ...], object] | None = None
    #: which rows of ``z`` (N, m) [SI] are measurements at all (a function -> (N,) bool;
    #: the others are dropped and counted), e.g. a magnetometer reporting zeros
    valid: object = None
    #: a constraint with ``z = 0`` always (non-holonomic): recorded data need no file —
    #: ``fednav process`` makes its rows every ``period_s`` (default: each filter epoch)
    pseudo: bool = False
    #: recorded data without a file: a function ``(imu, gnss, section, noise, gyro_bias,
    #: period, t0) -> times [s]`` (or ``(times, per-row 1-sigma)``) on the filter's epoch
    #: grid ``t0 + k period`` of the rows a detector finds (``z = 0`` there), e.g. the
    #: stand-still detector of ZUPT; ``noise`` is the filter's
    #: :class:`~fednav.ins.error_model.ImuNoiseModel`, ``gyro_bias`` the turn-on gyro
    #: bias 1-sigma [rad/s], ``period`` the filter period [s]
    detector: object = None
    #: recorded data: a function ``(data, gnss, section) -> (data, {quality},
    #: [warnings])`` correcting a file's values before filtering, e.g. the odometer's
    #: scale factor estimated against the GNSS speed
    calibrate: object = None
    #: a model that is not rows but reads the attitude in the sensor's axes (the
    #: magnetometer): its ``mounting`` acts (:func:`~fednav.sensors.measurement.mounted`)
    mountable: bool = False
    #: the sensor gives fixes in the layout ``lat, lon [rad], h [m], vE, vN, vU [m/s]``
    #: of its antenna (position, velocity or both per row) from which a recording
    #: starts: without an ``initial:`` section the first fix is the initial position,
    #: its velocity's course the alignment's heading, its period the filter epoch, and
    #: the input checks (time offset, units, IMU axes) test the IMU against it
    #: (:func:`~fednav.sensors.registry.fix_sensor`)
    fixes: bool = False
    #: how messages name the sensor ("GNSS"); default: its name
    label: str = ""
    #: the section's 1-sigma keys ``fednav tune`` estimates from the data (its
    #: innovation covariance matching): the fix sensor's position and velocity, the
    #: velocity sensor's
    tuned: tuple[str, ...] = ()
    #: the sensor's model in the total-state navigator (:mod:`fednav.ins.total_state`);
    #: None: it cannot fly there
    total: object = None
    #: how the docs name a file layout too long to list column by column (the raw
    #: GNSS's satellite slots); default: the columns
    columns_doc: str = ""
    #: a row's values may be NaN where the measurement has nothing (the raw GNSS's empty
    #: satellite slots): its file's rows are kept by ``valid`` alone
    sparse: bool = False
    #: the file formats of its own ``fednav process --NAME FILE`` also reads, for the
    #: help (:data:`fednav.io.sensorfile.OWN_FORMATS` reads them)
    files_doc: str = ""
    #: recorded data: a function ``(series, solution, model) -> dict`` of what
    #: ``summary.json`` says of the sensor's recording as flown by its measurement model
    #: (the raw GNSS: satellites, DOP, clock resets)
    report: object = None
    #: recorded data: a function ``(series, solution, excluded) -> Figure`` drawing the
    #: sensor's recording as flown (``excluded``: the units fault detection left out,
    #: ``(t, local filter, unit, statistic)``; the raw GNSS: satellites, DOP,
    #: exclusions), written as ``NAME.png`` by ``fednav process``
    figure: object = None
    #: recorded data: a function ``(series, section) -> (t, lla, ENU velocity, position
    #: 1-sigma ENU, velocity 1-sigma)`` of fixes a recording without a fix sensor's (and
    #: without ``initial:``) starts from (the raw GNSS: its single-point solutions)
    start: object = None

    @property
    def fixes_position(self) -> bool:
        """Whether it fixes the horizontal position (its ``z`` holds latitude and
        longitude, or its model says so: a receiver's satellites): the sources fault
        isolation may not lock out all at once (``filter.fdi_readmit_s``)."""
        return self.latlon is not None or getattr(self.model, "fixes_position", False)

    @property
    def compiled(self) -> bool:
        """Whether its model runs in the navigator's compiled engine (a row model, or a
        model with compiled rows of its own: ``engine_rows``, the raw GNSS's)."""
        return issubclass(self.model, RowModel) or hasattr(self.model, "engine_rows")

    def check_geometry(self, cfg: SensorConfig) -> str | None:
        """Why ``cfg``'s lever arm or mounting cannot act on this sensor (one line naming
        the key), or None.  A lever arm acts on a point's position or velocity (position,
        velocity and body-velocity rows); a mounting on the sensor's own axes (attitude
        and body-axis rows, or a model that reads the attitude, such as the
        magnetometer's); neither on a sensor measured from the IMU itself (ZARU)."""
        kinds = {k for k, _ in getattr(self.model, "rows", ())}
        row = issubclass(self.model, RowModel)
        lever_ok = (row and any(k <= VEL_U or BVEL_R <= k < RATE_X for k in kinds)) or \
            getattr(self.model, "takes_lever", False)
        mount_ok = (not row and self.mountable) or any(
            PITCH <= k <= HEADING or BVEL_R <= k < RATE_X for k in kinds)
        if cfg.lever_m is not None and any(cfg.lever_m) and not lever_ok:
            return (f"lever_m: the {self.name} sensor measures no point's position or "
                    f"velocity, so a lever arm cannot act on it")
        if cfg.mount() is not None and not mount_ok:
            return (f"mounting: the {self.name} sensor's values are in the navigation "
                    f"frame (or the IMU's own axes), so a mounting rotation cannot act on "
                    f"them")
        return None
