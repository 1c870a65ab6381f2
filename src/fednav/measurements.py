"""Measurement models of the error-state filters (filter side of each sensor).

Every model turns a sensor value and the INS solution at the same instant into the
*observed residual* ``y = INS-derived - sensor`` and predicts it from the error state:
``h(X, nav)`` (nonlinear, rows of X in filter units, see :mod:`fednav.error_model`) and
its Jacobian ``H(nav)``.  Residual units: metres for positions, arc-minutes for angles.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from . import attitude as att
from . import earth
from .error_model import DP, N_STATES, PHI, SCALE
from .kernels import rotvec_to_dcm
from .units import ARCMIN


@dataclass
class NavSnapshot:
    """INS (computed) solution at one instant: lla [rad, rad, m], vel ENU [m/s], C = C_b^n."""

    lla: np.ndarray
    vel: np.ndarray
    C: np.ndarray

    @cached_property
    def euler(self) -> np.ndarray:
        return att.dcm_to_euler(self.C)


@numba.njit(cache=True)
def _euler_error_kernel(C_hat, phi, out):
    """Rows of ``out``: Euler(C_hat) - Euler(exp([phi_i x]) C_hat), [pitch, roll, heading]."""
    e0p = np.arcsin(min(1.0, max(-1.0, C_hat[2, 1])))
    e0r = np.arctan2(-C_hat[2, 0], C_hat[2, 2])
    e0h = np.arctan2(C_hat[0, 1], C_hat[1, 1])
    R = np.empty((3, 3))
    for i in range(phi.shape[0]):
        rotvec_to_dcm(phi[i, 0], phi[i, 1], phi[i, 2], R)
        C = R @ C_hat
        p = np.arcsin(min(1.0, max(-1.0, C[2, 1])))
        r = np.arctan2(-C[2, 0], C[2, 2])
        h = np.arctan2(C[0, 1], C[1, 1])
        out[i, 0] = e0p - p
        out[i, 1] = (e0r - r + np.pi) % (2 * np.pi) - np.pi
        out[i, 2] = (e0h - h + np.pi) % (2 * np.pi) - np.pi


def _euler_error(C_hat, X):
    """Euler of C_hat minus Euler of the attitude corrected by each row's phi (arcmin)."""
    phi = np.ascontiguousarray(X[:, PHI] * SCALE[PHI])
    out = np.empty((phi.shape[0], 3))
    _euler_error_kernel(np.ascontiguousarray(C_hat, dtype=float), phi, out)
    return out / ARCMIN


class StarAttitude:
    """Star sensor: residual = Euler(INS) - Euler(CNS), [pitch, roll, heading] (arcmin).

    First order: ``euler_error_jacobian`` (paper 002, eq. 3).
    """

    kind = "star"
    dim = 3

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        return att.euler_difference(nav.euler, z) / ARCMIN

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return _euler_error(nav.C, np.atleast_2d(X))

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((3, N_STATES))
        H[:, PHI] = att.euler_error_jacobian(nav.euler)  # arcmin per arcmin
        return H

    def R(self, sigma) -> np.ndarray:
        return np.diag((np.asarray(sigma, dtype=float) / ARCMIN) ** 2)


class SarFix:
    """SAR image matching: residual = [east m, north m, heading arcmin] of INS - SAR."""

    kind = "sar"
    dim = 3

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        lat, lon, h = nav.lla
        rm, rn = earth.radii(lat)
        return np.array([
            (lon - z[1]) * (rn + h) * np.cos(lat),
            (lat - z[0]) * (rm + h),
            att.wrap_pi(nav.euler[2] - z[2]) / ARCMIN,
        ])

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        X = np.atleast_2d(X)
        return np.column_stack([X[:, 6], X[:, 7], _euler_error(nav.C, X)[:, 2]])

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((3, N_STATES))
        H[0, 6] = H[1, 7] = 1.0
        H[2, PHI] = att.euler_error_jacobian(nav.euler)[2]
        return H

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north m, east m, heading rad], as z
        return np.diag([s[1] ** 2, s[0] ** 2, (s[2] / ARCMIN) ** 2])


class BaroHeight:
    """Barometric altimeter as a filter measurement: residual = h(INS) - h(baro) [m]."""

    kind = "baro"
    dim = 1

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        return np.array([nav.lla[2] - z[0]])

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X)[:, DP][:, 2:3]

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((1, N_STATES))
        H[0, 8] = 1.0
        return H

    def R(self, sigma) -> np.ndarray:
        return np.diag(np.asarray(sigma, dtype=float) ** 2)


class GnssPosVel:
    """GNSS position and velocity: residual = INS - GNSS, ``[dE, dN, dU] m, [dvE, dvN, dvU]``."""

    kind = "gnss"
    dim = 6
    _cols = np.array([6, 7, 8, 3, 4, 5])

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        lat, lon, h = nav.lla
        rm, rn = earth.radii(lat)
        v = nav.vel
        return np.array([(lon - z[1]) * (rn + h) * np.cos(lat), (lat - z[0]) * (rm + h),
                         h - z[2], v[0] - z[3], v[1] - z[4], v[2] - z[5]])

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X)[:, self._cols]

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((6, N_STATES))
        H[np.arange(6), self._cols] = 1.0
        return H

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north, east, up m, vE, vN, vU], as z
        return np.diag(s[[1, 0, 2, 3, 4, 5]] ** 2)


MODELS = {m.kind: m for m in (StarAttitude(), SarFix(), BaroHeight(), GnssPosVel())}
