"""SAR image matching: latitude, longitude and heading fixes.

Section ``sensors.sar``: ``sigma_pos_m`` (each horizontal axis), ``sigma_heading_deg``,
``period_s``.  File columns: ``t_s, lat_deg, lon_deg, heading_deg``.  Residual: INS -
SAR ``[east m, north m, heading arcmin]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field, model_validator

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
    """SAR image matching: residual = [east m, north m, heading arcmin] of INS - SAR
    (without ``heading``: the position rows only)."""

    kind = "sar"
    rows = ((POS_E, 1), (POS_N, 0), (HEADING, 2))

    def __init__(self, heading: bool = True):
        self.rows = SarFix.rows if heading else SarFix.rows[:2]
        super().__init__()

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north m, east m, heading rad], as z
        return np.diag([s[1] ** 2, s[0] ** 2, (s[2] / ARCMIN) ** 2][:self.dim])


class SarConfig(SensorConfig):
    """SAR image-matching fix: position and heading (``use_heading: false``, or a file
    without ``heading_deg``: the position alone; ``sigma_heading_deg`` is then not
    needed)."""

    sigma_pos_m: float = Field(gt=0.0)
    sigma_heading_deg: float | None = Field(default=None, gt=0.0)
    use_heading: bool = True

    @model_validator(mode="after")
    def _heading_sigma(self):
        if self.use_heading and self.sigma_heading_deg is None:
            raise ValueError("sigma_heading_deg: needed with the heading (use_heading: true)")
        return self

    def sensor(self) -> SarMatcher:
        return SarMatcher(self.sigma_pos_m, float(units.deg(self.sigma_heading_deg or 1.0)),
                          self.period_s)

    def model(self) -> SarFix:
        return SarFix(self.use_heading)

    def sigma(self) -> np.ndarray:
        return np.array([self.sigma_pos_m, self.sigma_pos_m,
                         float(units.deg(self.sigma_heading_deg or 1.0))])


_DEG = float(units.deg(1.0))
SPEC = SensorSpec(
    "sar", "SAR image matching: position fix and heading", SarConfig, SarFix,
    columns=(Column("lat_deg", _DEG, sigma=("sigma_north_m", 1.0)),
             Column("lon_deg", _DEG, sigma=("sigma_east_m", 1.0)),
             Column("heading_deg", _DEG, wrap_2pi=True, absent={"use_heading": False})),
    angles=(2,), latlon=(0, 1))
