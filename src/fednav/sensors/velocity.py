"""A velocity sensor in the navigation frame (visual odometry, DVL output in ENU ...).

Section ``sensors.velocity``: ``sigma_mps`` ([east, north, up]; the file's covariance
when left out), ``lever_m`` (body right-forward-up), ``axes`` (what the file's three
columns hold, e.g. ``[N, E, U]``; a leading ``-`` flips a sign), ``time_offset_s`` (added
to the file's time stamps), ``period_s``.  File columns: ``t_s, vE_mps, vN_mps, vU_mps``
[``, sigma_vE_mps, sigma_vN_mps, sigma_vU_mps``] (:func:`fednav.io.read_velocity_csv`).
Residual: INS-derived sensor velocity - measured, ENU [m/s] (linear).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from pydantic import Field, field_validator

from .base import MeasurementSeries, flight_times
from .measurement import VEL_E, VEL_N, VEL_U, RowModel
from .spec import Column, SensorConfig, SensorSpec

_V3 = tuple[float, float, float]


@dataclass(frozen=True)
class VelocitySensor:
    """ENU velocity of the sensor's point (``truth``: the trajectory seen from it,
    :class:`~fednav.sensors.base.SensorView`) with white noise ``sigma`` ([east, north,
    up] m/s) every ``period`` [s]."""

    sigma: tuple
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        v = truth.at(t)["vel"]
        sig = np.asarray(self.sigma, dtype=float)
        z = v + rng.standard_normal(v.shape) * sig
        return MeasurementSeries("velocity", t, z, sig.copy(), t_avail)


class VelocityENU(RowModel):
    """A velocity sensor at ``lever`` (body, m): residual = INS-derived sensor velocity -
    measured, ENU [m/s]; ``R`` is the sensor's covariance."""

    kind = "velocity"
    rows = ((VEL_E, 0), (VEL_N, 1), (VEL_U, 2))

    #: the sensor's time-correlated error, [east, north, up] (``velocity_markov``)
    markov_block, markov_kinds = "velocity_markov", (VEL_E, VEL_N, VEL_U)

    def R(self, cov) -> np.ndarray:
        c = np.asarray(cov, dtype=float)
        return self.white(np.diag(c**2) if c.ndim == 1 else c)


class VelocityConfig(SensorConfig):
    """Velocity sensor: 1-sigma [east, north, up] m/s (None: the file's covariance), lever
    arm (None: the file's, else zero), the file's axis order and a time offset;
    ``markov_sigma_mps`` (one value or [east, north, up] m/s) and ``markov_tau_s`` [s]:
    the time-correlated part of its error (first-order Gauss–Markov: visual odometry's
    drift), which the optional ``velocity_markov`` error state (``filter.states``)
    estimates; the sigma is then the whole error's and R its white part."""

    flat_keys: ClassVar[dict[str, tuple]] = {
        "velocity_time_offset_s": ("time_offset_s",), "velocity_axes": ("axes",),
        "velocity_sigma_mps": ("sigma_mps",)}

    sigma_mps: _V3 | None = None
    axes: tuple[str, str, str] = ("E", "N", "U")
    time_offset_s: float = 0.0
    markov_sigma_mps: float | _V3 | None = None
    markov_tau_s: float | None = Field(default=None, gt=0.0)
    #: the key of the 1-sigma the model's Gauss-Markov state takes
    MARKOV_KEY: ClassVar[str] = "markov_sigma_mps"

    @field_validator("axes")
    @classmethod
    def _axes(cls, v):
        names = [a.lstrip("+-").upper() for a in v]
        if sorted(names) != ["E", "N", "U"]:
            raise ValueError(f"must name E, N and U once each (a leading '-' flips a sign), "
                             f"got {list(v)}")
        return v

    @field_validator("sigma_mps")
    @classmethod
    def _sigma(cls, v):
        if v is not None and min(v) <= 0:
            raise ValueError("sigmas must be positive")
        return v

    def sensor(self) -> VelocitySensor:
        from ..core.config import ConfigError

        if self.sigma_mps is None:
            raise ConfigError("sensors.velocity.sigma_mps: needed to simulate the sensor")
        return VelocitySensor(self.sigma_mps, self.period_s)

    def model(self) -> VelocityENU:
        return VelocityENU()

    def sigma(self) -> np.ndarray | None:
        return None if self.sigma_mps is None else np.asarray(self.sigma_mps, dtype=float)

    def for_recording(self, data) -> VelocityConfig:
        """The section as it flies the recording ``data``: the sensor's lever arm the
        section leaves out taken from the data (:class:`~fednav.io.VelocityData`'s;
        ``period_s`` left as it is)."""
        lever = self.lever_m if self.lever_m is not None else getattr(data, "lever", None)
        return self if lever is None else self.model_copy(update={
            "lever_m": tuple(map(float, lever))})


SPEC = SensorSpec("velocity", "velocity sensor (visual odometry, DVL ...): ENU velocity "
                  "at its lever arm", VelocityConfig, VelocityENU,
                  columns=(Column("vE_mps"), Column("vN_mps"), Column("vU_mps")),
                  tuned=("sigma_mps",))
