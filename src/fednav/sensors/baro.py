"""Barometric altimeter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import MeasurementSeries, flight_times


@dataclass(frozen=True)
class Barometer:
    """Height with white noise ``sigma`` [m] every ``period`` [s]."""

    sigma: float
    period: float

    def simulate(self, truth, rng: np.random.Generator, t=None,
                 t_avail=None) -> MeasurementSeries:
        t = flight_times(truth, self.period, t)
        h = truth.at(t)["lla"][:, 2]
        z = h + rng.standard_normal(len(t)) * self.sigma
        return MeasurementSeries("baro", t, z[:, None], np.array([self.sigma]), t_avail)

    @staticmethod
    def on_imu_grid(series: MeasurementSeries, t_imu: np.ndarray) -> np.ndarray:
        """Baro heights placed on the IMU sample grid for the damping loop.

        Sample k of the result (covering ``(t_imu[k], t_imu[k+1]]``) holds the baro height
        measured at ``t_imu[k]``, NaN elsewhere.  ``t_imu`` are the IMU interval start times.
        """
        out = np.full(len(t_imu), np.nan)
        idx = np.searchsorted(t_imu, series.t - 1e-9)
        ok = (idx < len(t_imu)) & (np.abs(t_imu[np.minimum(idx, len(t_imu) - 1)] - series.t)
                                   < 1e-6)
        out[idx[ok]] = series.z[ok, 0]
        return out
