"""Star sensor (CNS): the attitude as Euler angles [pitch, roll, heading].

Section ``sensors.star``: ``sigma_arcsec`` (1-sigma of each angle), ``period_s``.
File columns: ``t_s, pitch_deg, roll_deg, heading_deg``.  Residual: Euler(INS) -
Euler(CNS) [arcmin], roll and heading wrapped to +-180 deg; ``H`` is
``euler_error_jacobian`` (paper 002, eq. 3); sigma points use the exact Euler error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from pydantic import Field

from ..core import attitude as att
from ..core import units
from ..core.attitude import dcm_to_euler, quat_to_dcm, wrap_2pi
from ..core.kernels import dcm_to_rotvec, euler_to_dcm
from ..core.kernels import quat_to_dcm as quat_to_dcm_nb
from ..core.units import ARCMIN
from ..ins.strapdown import STATE_Q
from ..ins.total_state import N_BIAS, TSCALE
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
@numba.njit(cache=True)
def _star_terms(q_est, z, sigma, unit):
    """Residual log(C_star C_est') and its covariance from Euler-angle noise ``sigma``
    (both in units of ``unit`` radians)."""
    C_est = quat_to_dcm_nb(q_est)
    M = euler_to_dcm(z[0], z[1], z[2]) @ C_est.T
    r = np.empty(3)
    dcm_to_rotvec(M, r)
    # Euler angles of the estimate and d(Euler)/d(phi) (attitude.euler_error_jacobian).
    th = np.arcsin(min(1.0, max(-1.0, C_est[2, 1])))
    psi = np.arctan2(C_est[0, 1], C_est[1, 1])
    s, c, ct, tt = np.sin(psi), np.cos(psi), np.cos(th), np.tan(th)
    J = np.array([[-c, s, 0.0], [-s / ct, -c / ct, 0.0], [-tt * s, -tt * c, 1.0]])
    Ji = np.linalg.inv(J)
    Re = np.diag((sigma / unit) ** 2)
    return r / unit, Ji @ Re @ Ji.T


class StarTotal:
    """Star sensor on the total state: residual = ``log(C_star C_est')`` (arc-minutes);
    ``H = [I 0 0]``.  The Euler-angle noise of the sensor maps to the rotation space with
    the inverse of :func:`~fednav.core.attitude.euler_error_jacobian`."""

    kind = "star"
    dim = 3
    H = np.hstack([np.eye(3), np.zeros((3, 6 + N_BIAS))])

    def terms(self, state, z, sigma) -> tuple[np.ndarray, np.ndarray]:
        """(residual, R) at once (one compiled call)."""
        return _star_terms(np.ascontiguousarray(state[STATE_Q]), np.asarray(z, dtype=float),
                           np.asarray(sigma, dtype=float), TSCALE[0])

    def residual(self, state, z) -> np.ndarray:
        return self.terms(state, z, np.ones(3))[0]

    def R_at(self, state, sigma) -> np.ndarray:
        return self.terms(state, att.quat_to_euler(state[STATE_Q]), sigma)[1]


SPEC = SensorSpec(
    "star", "star sensor (CNS): attitude as Euler angles [pitch, roll, heading]",
    StarConfig, StarAttitude,
    columns=(Column("pitch_deg", _DEG, sigma=("sigma_pitch_arcsec", _ARCSEC)),
             Column("roll_deg", _DEG, sigma=("sigma_roll_arcsec", _ARCSEC)),
             Column("heading_deg", _DEG, wrap_2pi=True,
                    sigma=("sigma_heading_arcsec", _ARCSEC))),
    angles=(0, 1, 2), alternative=(("qw", "qx", "qy", "qz"), euler_of_quaternion),
    total=StarTotal())
