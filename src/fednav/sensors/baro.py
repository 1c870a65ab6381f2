"""Barometric altimeter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import MeasurementSeries, sample_times


@dataclass(frozen=True)
class Barometer:
    """Height with white noise ``sigma`` [m] every ``period`` [s]."""

    sigma: float
    period: float

    def simulate(self, truth, rng: np.random.Generator) -> MeasurementSeries:
        t = sample_times(truth.t[-1], self.period, truth.t[0] + self.period)
        h = truth.at(t)["lla"][:, 2]
        z = h + rng.standard_normal(len(t)) * self.sigma
        return MeasurementSeries("baro", t, z[:, None], np.array([self.sigma]))

    @staticmethod
    def hold(series: MeasurementSeries, t_imu: np.ndarray) -> np.ndarray:
        """Zero-order hold of the baro heights onto IMU sample times (NaN before the first)."""
        idx = np.searchsorted(series.t, t_imu, side="right") - 1
        out = np.full(len(t_imu), np.nan)
        ok = idx >= 0
        out[ok] = series.z[idx[ok], 0]
        return out
