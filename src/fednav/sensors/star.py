"""Star sensor (CNS): the attitude as Euler angles [pitch, roll, heading].

Section ``sensors.star``: ``sigma_arcsec`` (1-sigma of each angle), ``period_s``.
File columns: ``t_s, pitch_deg, roll_deg, heading_deg``.  Residual: Euler(INS) -
Euler(CNS) [arcmin], roll and heading wrapped to +-180 deg; ``H`` is
``euler_error_jacobian`` (paper 002, eq. 3); sigma points use the exact Euler error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from ..core import units
from ..core.attitude import dcm_to_euler, quat_to_dcm, wrap_2pi
from ..core.units import ARCMIN
from ..ins.total_state import StarTotal
from .base import MeasurementSeries, flight_times
from .measurement import HEADING, PITCH, ROLL, RowModel
from .spec import Column, SensorConfig, SensorSpec


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


class StarAttitude(RowModel):
    """Star sensor: residual = Euler(INS) - Euler(CNS), [pitch, roll, heading] (arcmin)."""

    kind = "star"
    rows = ((PITCH, 0), (ROLL, 1), (HEADING, 2))

    def R(self, sigma) -> np.ndarray:
        return np.diag((np.asarray(sigma, dtype=float) / ARCMIN) ** 2)


class StarConfig(SensorConfig):
    """Star sensor: ``sigma_arcsec`` 1-sigma of each Euler angle."""

    sigma_arcsec: float = Field(gt=0.0)

    def sensor(self) -> StarSensor:
        return StarSensor(float(units.arcsec(self.sigma_arcsec)), self.period_s)

    def model(self) -> StarAttitude:
        return StarAttitude()

    def sigma(self) -> np.ndarray:
        return np.full(3, float(units.arcsec(self.sigma_arcsec)))


def euler_of_quaternion(q) -> np.ndarray:
    """The star sensor's other file layout: unit quaternions ``q_b^n`` (N, 4) scalar
    first, rotating body right-forward-up into ENU (fednav's ``q``,
    ``docs/conventions.md``; not normalised in the file: normalised here) -> Euler
    ``[pitch, roll, heading]`` [rad]."""
    q = np.asarray(q, dtype=float)
    return dcm_to_euler(quat_to_dcm(q / np.linalg.norm(q, axis=1)[:, None]))


_DEG = float(units.deg(1.0))
_ARCSEC = float(units.arcsec(1.0))
SPEC = SensorSpec(
    "star", "star sensor (CNS): attitude as Euler angles [pitch, roll, heading]",
    StarConfig, StarAttitude,
    columns=(Column("pitch_deg", _DEG, sigma=("sigma_pitch_arcsec", _ARCSEC)),
             Column("roll_deg", _DEG, sigma=("sigma_roll_arcsec", _ARCSEC)),
             Column("heading_deg", _DEG, wrap_2pi=True,
                    sigma=("sigma_heading_arcsec", _ARCSEC))),
    angles=(0, 1, 2), alternative=(("qw", "qx", "qy", "qz"), euler_of_quaternion),
    total=StarTotal())
