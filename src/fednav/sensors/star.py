"""Star sensor (CNS) giving the attitude as Euler angles [pitch, roll, heading]."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.attitude import wrap_2pi
from .base import MeasurementSeries, flight_times


@dataclass(frozen=True)
class StarSensor:
    """Attitude with white noise ``sigma`` [rad] (scalar or per angle) every ``period`` [s]."""

    sigma: float | tuple
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        e = truth.at(t)["euler"]
        sig = np.broadcast_to(np.asarray(self.sigma, dtype=float), (3,))
        z = e + rng.standard_normal(e.shape) * sig
        z[:, 2] = wrap_2pi(z[:, 2])
        return MeasurementSeries("star", t, z, sig.copy(), t_avail)
