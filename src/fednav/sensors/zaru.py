"""Zero-angular-rate updates (ZARU): a vehicle at rest turns with the Earth only.

``zaru`` — at a stop the epoch's mean compensated gyro rate equals the Earth rate seen
in body axes, ``C^T w_ie``; the residual ``omega - C^T w_ie`` [deg/h] is the gyro drift
still uncompensated (constant and Markov states) plus the small attitude coupling
``(c_j x w_ie) . phi`` (compiled rate rows of :mod:`fednav.sensors.measurement`).  It
makes the gyro bias — the heading drift's cause — observable at every stop, which ZUPT
alone does not.  Section ``sensors.zaru``: ``sigma_radps`` (default on recorded data:
the gyro's white noise over the filter period, ``ARW / sqrt(T)``), the stop detection of
:class:`~fednav.sensors.bodyvel.StopConfig`; without a file ``fednav process`` detects the
stops (:func:`~fednav.sensors.bodyvel.detect_stops`).  File columns: ``t_s, wx_radps,
wy_radps, wz_radps`` (zeros).  Units: SI; body axes right, forward, up.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from .bodyvel import StandstillDetector, StopConfig, detect_stops
from .measurement import _DEG_H, RATE_X, RATE_Y, RATE_Z, RowModel
from .spec import Column, SensorSpec


class ZeroRate(RowModel):
    """ZARU: residual = epoch-mean compensated body rate - Earth rate in body axes - 0,
    per body axis [deg/h]; ``R`` from the 1-sigma [rad/s]."""

    kind = "zaru"
    rows = ((RATE_X, 0), (RATE_Y, 1), (RATE_Z, 2))

    def R(self, sigma) -> np.ndarray:
        s = np.broadcast_to(np.asarray(sigma, dtype=float), (3,)) / _DEG_H
        return np.diag(s**2)


class ZaruConfig(StopConfig):
    """Zero-angular-rate updates: 1-sigma of the epoch-mean rate at rest [rad/s] (None:
    the gyro's white noise over the filter period, from the IMU figures, on recorded
    data; simulations need it given); stops as
    :class:`~fednav.sensors.bodyvel.StopConfig`."""

    sigma_radps: float | None = Field(default=None, gt=0.0)

    def sensor(self) -> StandstillDetector:
        if self.sigma_radps is None:
            from ..core.config import ConfigError

            raise ConfigError("sensors.zaru.sigma_radps: give it for a simulation")
        return StandstillDetector(self.sigma_radps, self.stationary_below_mps,
                                  self.period_s, "zaru")

    def model(self) -> ZeroRate:
        return ZeroRate()

    def sigma(self) -> np.ndarray | None:
        return None if self.sigma_radps is None else np.full(3, self.sigma_radps)


def detect(imu, gnss, section: ZaruConfig, noise, gyro_bias: float, period: float,
           t0: float):
    """The stops of :func:`~fednav.sensors.bodyvel.detect_stops`, each with the 1-sigma
    of a filter epoch's mean gyro rate, ``ARW / sqrt(T)`` [rad/s] (None when the section
    gives ``sigma_radps``)."""
    t = detect_stops(imu, gnss, section, noise, gyro_bias, period, t0)
    if section.sigma_radps is not None:
        return t, None
    s = noise.gyro_arw / np.sqrt(period)
    return t, np.full((len(t), 3), max(s, 1e-12))


SPEC = SensorSpec("zaru", "zero-angular-rate update: the body turns with the Earth only "
                  "while stopped (no file: stops detected from the IMU)", ZaruConfig,
                  ZeroRate, columns=(Column("wx_radps"), Column("wy_radps"),
                                     Column("wz_radps")), detector=detect)
