"""SAR sequential-image velocity: east and north ground velocity.

Section ``sensors.sarvel``: ``sigma_mps`` (each axis), ``period_s``.  File columns:
``t_s, vE_mps, vN_mps``.  Residual: ``[vE, vN]`` INS - SAR [m/s] (linear).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from .base import MeasurementSeries, flight_times
from .measurement import VEL_E, VEL_N, RowModel
from .spec import Column, SensorConfig, SensorSpec


@dataclass(frozen=True)
class SarVelocity:
    """Sequential-image velocity ``[vE, vN]`` [m/s] with white noise ``sigma`` (each axis),
    every ``period`` [s] or at given capture times."""

    sigma: float
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        v = truth.at(t)["vel"][:, :2]
        z = v + rng.standard_normal(v.shape) * self.sigma
        return MeasurementSeries("sarvel", t, z, np.array([self.sigma, self.sigma]), t_avail)


class SarVelocityEN(RowModel):
    """SAR sequential-image velocity: residual = ``[vE, vN]`` INS - SAR [m/s]."""

    kind = "sarvel"
    rows = ((VEL_E, 0), (VEL_N, 1))

    def R(self, sigma) -> np.ndarray:
        return np.diag(np.asarray(sigma, dtype=float) ** 2)


class SarVelocityConfig(SensorConfig):
    """SAR sequential-image velocity (east, north)."""

    sigma_mps: float = Field(gt=0.0)

    def sensor(self) -> SarVelocity:
        return SarVelocity(self.sigma_mps, self.period_s)

    def model(self) -> SarVelocityEN:
        return SarVelocityEN()

    def sigma(self) -> np.ndarray:
        return np.full(2, self.sigma_mps)


SPEC = SensorSpec("sarvel", "SAR sequential-image velocity: east and north",
                  SarVelocityConfig, SarVelocityEN,
                  columns=(Column("vE_mps"), Column("vN_mps")))
