"""SAR image matching: latitude, longitude and heading fixes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.attitude import wrap_2pi
from .base import MeasurementSeries, flight_times, position_noise_to_llh


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
