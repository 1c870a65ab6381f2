"""SAR image matching: latitude, longitude and heading fixes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import earth
from ..attitude import wrap_2pi
from .base import MeasurementSeries, sample_times


@dataclass(frozen=True)
class SarMatcher:
    """Fix ``[lat, lon, heading]`` with horizontal position noise ``sigma_pos`` [m]
    (each axis) and heading noise ``sigma_heading`` [rad], every ``period`` [s].

    ``sigma`` of the series is ``[sigma_east_m, sigma_north_m, sigma_heading]``.
    """

    sigma_pos: float
    sigma_heading: float
    period: float

    def simulate(self, truth, rng: np.random.Generator) -> MeasurementSeries:
        t = sample_times(truth.t[-1], self.period, truth.t[0] + self.period)
        tr = truth.at(t)
        lat, lon, h = tr["lla"].T
        rm, rn = earth.radii(lat)
        n = rng.standard_normal((len(t), 3))
        z = np.column_stack([
            lat + n[:, 1] * self.sigma_pos / (rm + h),
            lon + n[:, 0] * self.sigma_pos / ((rn + h) * np.cos(lat)),
            wrap_2pi(tr["euler"][:, 2] + n[:, 2] * self.sigma_heading),
        ])
        return MeasurementSeries("sar", t, z,
                                 np.array([self.sigma_pos, self.sigma_pos, self.sigma_heading]))
