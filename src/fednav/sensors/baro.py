"""Barometric altimeter: damps the INS vertical channel and/or aids a filter.

Section ``sensors.baro``: ``sigma_m``, ``period_s``, ``damping_loop`` (feed the
mechanization's vertical loop, :class:`~fednav.ins.strapdown.BaroLoop`), its
``loop_time_constant_s`` and ``loop_order``.  File columns: ``t_s, h_m``.  As a filter
measurement: residual h(INS) - h(baro) [m] (linear).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field

from ..ins.strapdown import BaroLoop
from .base import MeasurementSeries, flight_times
from .measurement import POS_U, RowModel
from .spec import Column, SensorConfig, SensorSpec


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


class BaroHeight(RowModel):
    """Barometric altimeter as a filter measurement: residual = h(INS) - h(baro) [m]."""

    kind = "baro"
    rows = ((POS_U, 0),)

    def R(self, sigma) -> np.ndarray:
        return np.diag(np.asarray(sigma, dtype=float) ** 2)


class BaroConfig(SensorConfig):
    """Barometric altimeter: damps the INS vertical channel (``damping_loop``) and/or aids
    the filter as a measurement (``baro`` among the aiding sensors)."""

    sigma_m: float = Field(gt=0.0)
    damping_loop: bool = True
    loop_time_constant_s: float = Field(default=20.0, gt=0.0)
    loop_order: Literal[2, 3] = 2

    def sensor(self) -> Barometer:
        return Barometer(self.sigma_m, self.period_s)

    def model(self) -> BaroHeight:
        return BaroHeight()

    def sigma(self) -> np.ndarray:
        return np.array([self.sigma_m])

    def roles(self, system) -> dict[str, str]:
        """The damping loop of the INS vertical channel, when ``damping_loop``."""
        return {"damping": "sensors.baro.damping_loop"} if self.damping_loop else {}

    def damping_noise(self) -> float:
        """The damping loop's height noise as white process noise [m^2 s]: ``sigma_m^2``
        times the period."""
        if self.period_s is None:
            raise ValueError("sensors.baro.period_s: the damping loop's noise needs the "
                             "barometer's period")
        return self.sigma_m**2 * self.period_s

    def loop(self) -> BaroLoop | None:
        if not self.damping_loop:
            return None
        return BaroLoop(self.loop_time_constant_s, self.loop_order, tuple(self.lever()))


SPEC = SensorSpec("baro", "barometric altimeter: height (vertical-channel damping and/or "
                  "a filter measurement)", BaroConfig, BaroHeight, columns=(Column("h_m"),))
