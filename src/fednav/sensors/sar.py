"""SAR image matching: latitude, longitude and heading fixes.

Section ``sensors.sar``: ``sigma_pos_m`` (each horizontal axis), ``sigma_heading_deg``,
``period_s``.  File columns: ``t_s, lat_deg, lon_deg, heading_deg``.  Residual: INS -
SAR ``[east m, north m, heading arcmin]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from ..core import units
from ..core.attitude import wrap_2pi
from ..core.units import ARCMIN
from .base import MeasurementSeries, flight_times, position_noise_to_llh
from .measurement import HEADING, POS_E, POS_N, RowModel
from .spec import Column, SensorConfig, SensorSpec


@dataclass(frozen=True)
class SarMatcher:
    """Fix ``[lat, lon, heading]`` with horizontal position noise ``sigma_pos`` [m]
    (each axis) and heading noise ``sigma_heading`` [rad], every ``period`` [s].

    ``sigma`` of the series follows ``z``: ``[north m, east m, heading rad]``.
    """

    sigma_pos: float
    sigma_heading: float
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        """Fixes every ``period``, or at the capture times ``t`` (available at ``t_avail``)."""
        t = flight_times(truth, self.period, t)
        tr = truth.at(t)
        n = rng.standard_normal((len(t), 3))
        # (north, east) from draws 1 and 0: the draw order of earlier releases, so seeded
        # runs reproduce exactly.
        d = np.column_stack([n[:, 1] * self.sigma_pos, n[:, 0] * self.sigma_pos,
                             np.zeros(len(t))])
        pos = position_noise_to_llh(tr["lla"], d)
        z = np.column_stack([pos[:, 0], pos[:, 1],
                             wrap_2pi(tr["euler"][:, 2] + n[:, 2] * self.sigma_heading)])
        return MeasurementSeries("sar", t, z,
                                 np.array([self.sigma_pos, self.sigma_pos, self.sigma_heading]),
                                 t_avail)


class SarFix(RowModel):
    """SAR image matching: residual = [east m, north m, heading arcmin] of INS - SAR."""

    kind = "sar"
    rows = ((POS_E, 1), (POS_N, 0), (HEADING, 2))

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north m, east m, heading rad], as z
        return np.diag([s[1] ** 2, s[0] ** 2, (s[2] / ARCMIN) ** 2])


class SarConfig(SensorConfig):
    """SAR image-matching fix: position and heading."""

    sigma_pos_m: float = Field(gt=0.0)
    sigma_heading_deg: float = Field(gt=0.0)

    def sensor(self) -> SarMatcher:
        return SarMatcher(self.sigma_pos_m, float(units.deg(self.sigma_heading_deg)),
                          self.period_s)

    def model(self) -> SarFix:
        return SarFix()

    def sigma(self) -> np.ndarray:
        return np.array([self.sigma_pos_m, self.sigma_pos_m,
                         float(units.deg(self.sigma_heading_deg))])


_DEG = float(units.deg(1.0))
SPEC = SensorSpec(
    "sar", "SAR image matching: position fix and heading", SarConfig, SarFix,
    columns=(Column("lat_deg", _DEG, sigma=("sigma_north_m", 1.0)),
             Column("lon_deg", _DEG, sigma=("sigma_east_m", 1.0)),
             Column("heading_deg", _DEG, wrap_2pi=True)),
    angles=(2,), latlon=(0, 1))
