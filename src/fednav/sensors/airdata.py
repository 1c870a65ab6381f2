"""Air data: true airspeed, and the wind estimate that goes with it (paper 000).

The airship's ground velocity is its air velocity plus the wind.  The air-data system
measures the airspeed; the wind constraint of the CUKF also needs the current wind,
which the paper takes as known.  fednav makes both explicit: the series carries
``z = [airspeed (m/s), wind east, wind north (m/s)]`` where the wind estimate is the
truth plus white noise ``wind_sigma`` and a constant ``wind_bias`` (east, north) — the
knob that shows what a wrong wind estimate does to the constrained filter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import MeasurementSeries, flight_times


@dataclass(frozen=True)
class AirData:
    """Airspeed noise ``sigma`` [m/s], wind-estimate noise ``wind_sigma`` [m/s] and bias
    ``wind_bias`` (east, north) [m/s], every ``period`` [s]."""

    sigma: float
    wind_sigma: float
    wind_bias: tuple[float, float]
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        tr = truth.at(t)
        air = tr["vel"][:, :2] - tr["wind"][:, :2]
        n = rng.standard_normal((len(t), 3))
        z = np.column_stack([np.linalg.norm(air, axis=1) + n[:, 0] * self.sigma,
                             tr["wind"][:, :2] + np.asarray(self.wind_bias)
                             + n[:, 1:] * self.wind_sigma])
        return MeasurementSeries("airdata", t, z,
                                 np.array([self.sigma, self.wind_sigma, self.wind_sigma]),
                                 t_avail)
