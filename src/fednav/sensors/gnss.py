"""GNSS receiver: position (latitude, longitude, height) and ENU velocity fixes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import MeasurementSeries, flight_times, position_noise_to_llh


@dataclass(frozen=True)
class Gnss:
    """Fix ``[lat, lon, h, vE, vN, vU]`` every ``period`` [s] with white noise.

    ``sigma_pos`` [m]: scalar, or ``(north, east, up)``; ``sigma_vel`` [m/s]: scalar or
    ``(east, north, up)``.  The series' ``sigma`` follows ``z``:
    ``[north m, east m, up m, vE, vN, vU]``.
    """

    sigma_pos: float | tuple
    sigma_vel: float | tuple
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        tr = truth.at(t)
        sp = np.broadcast_to(np.asarray(self.sigma_pos, dtype=float), (3,))
        sv = np.broadcast_to(np.asarray(self.sigma_vel, dtype=float), (3,))
        npos = rng.standard_normal((len(t), 3)) * sp
        z = np.column_stack([position_noise_to_llh(tr["lla"], npos),
                             tr["vel"] + rng.standard_normal((len(t), 3)) * sv])
        return MeasurementSeries("gnss", t, z, np.r_[sp, sv], t_avail)
