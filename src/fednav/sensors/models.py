"""Measurement models of the error-state filters (filter side of each sensor).

Every model turns a sensor value and the INS solution at the same instant into the
*observed residual* ``y = INS-derived - sensor`` and predicts it from the error state:
``h(X, nav)`` (nonlinear, rows of X in filter units, see :mod:`fednav.ins.error_model`) and
its Jacobian ``H(nav)``.  Residual units: metres for positions, arc-minutes for angles.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from ..core import attitude as att
from ..core import earth
from ..core.kernels import rotvec_to_dcm
from ..core.units import ARCMIN
from ..ins.error_model import DP, N_STATES, PHI, SCALE


@dataclass
class NavSnapshot:
    """INS (computed) solution at one instant: lla [rad, rad, m], vel ENU [m/s], C = C_b^n."""

    lla: np.ndarray
    vel: np.ndarray
    C: np.ndarray
    omega_b: np.ndarray | None = None  # body angular rate w_ib [rad/s] (lever-arm terms)

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


@numba.njit(cache=True)
def euler_error_nb(C_hat, X):
    """Euler of C_hat minus Euler of the attitude corrected by each row's phi (rows of X
    in filter units; arcmin)."""
    m = X.shape[0]
    phi = np.empty((m, 3))
    for i in range(m):
        for j in range(3):
            phi[i, j] = X[i, j] * SCALE[j]
    out = np.empty((m, 3))
    _euler_error_kernel(C_hat, phi, out)
    return out / ARCMIN


def _euler_error(C_hat, X):
    return euler_error_nb(np.ascontiguousarray(C_hat, dtype=float),
                          np.ascontiguousarray(X, dtype=float))


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


def _lever_terms(nav: NavSnapshot, lever) -> tuple[np.ndarray, np.ndarray]:
    """Lever-arm offsets in ENU of a sensor at ``lever`` (body, m): position ``C l`` [m]
    and velocity ``C (w_ib x l)`` [m/s] (the ``w_in x C l`` term, < 1e-4 m/s per metre of
    lever, is left out)."""
    lx, ly, lz = lever
    wx, wy, wz = (0.0, 0.0, 0.0) if nav.omega_b is None else nav.omega_b
    wl = np.array([wy * lz - wz * ly, wz * lx - wx * lz, wx * ly - wy * lx])  # w x l
    return nav.C @ lever, nav.C @ wl


class GnssPosVel:
    """GNSS position and velocity of an antenna at ``lever`` (body right-forward-up, m)
    from the IMU: residual = INS-derived antenna - GNSS, ``[dE, dN, dU] m, [dvE, dvN, dvU]``.

    The INS-derived antenna position is ``p + C l``; with ``C_hat = exp(-[phi x]) C`` its
    error is ``dp + [(C l) x] phi`` (and likewise ``[(C (w x l)) x] phi`` for the
    velocity), so a lever arm makes attitude observable from GNSS (tested numerically)."""

    linear = True  # h(x) = H x
    kind = "gnss"
    dim = 6
    _cols = np.array([6, 7, 8, 3, 4, 5])

    def __init__(self, lever=(0.0, 0.0, 0.0)):
        self.lever = np.asarray(lever, dtype=float)
        self._has_lever = bool(np.any(self.lever))

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        lat, lon, h = nav.lla
        rm, rn = earth.radii(lat)
        v = nav.vel
        r = np.array([(lon - z[1]) * (rn + h) * np.cos(lat), (lat - z[0]) * (rm + h),
                      h - z[2], v[0] - z[3], v[1] - z[4], v[2] - z[5]])
        if self._has_lever:
            dp, dv = _lever_terms(nav, self.lever)
            r[:3] += dp
            r[3:] += dv
        return r

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X) @ self.H(nav).T

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((6, N_STATES))
        H[np.arange(6), self._cols] = 1.0
        if self._has_lever:
            dp, dv = _lever_terms(nav, self.lever)
            H[0:3, PHI] = att.skew(dp) * ARCMIN
            H[3:6, PHI] = att.skew(dv) * ARCMIN
        return H

    def R(self, sigma) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [north, east, up m, vE, vN, vU], as z
        return np.diag(s[[1, 0, 2, 3, 4, 5]] ** 2)


class VelocityENU:
    """A velocity sensor (visual odometry, DVL ...) at ``lever`` (body, m): residual =
    INS-derived sensor velocity - measured, ENU [m/s]; ``R`` is the sensor's covariance."""

    linear = True  # h(x) = H x
    kind = "velocity"
    dim = 3

    def __init__(self, lever=(0.0, 0.0, 0.0)):
        self.lever = np.asarray(lever, dtype=float)

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        return nav.vel + _lever_terms(nav, self.lever)[1] - np.asarray(z, dtype=float)

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X) @ self.H(nav).T

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((3, N_STATES))
        H[:, 3:6] = np.eye(3)
        H[:, PHI] = att.skew(_lever_terms(nav, self.lever)[1]) * ARCMIN
        return H

    def R(self, cov) -> np.ndarray:
        return np.asarray(cov, dtype=float)


class SarVelocityEN:
    """SAR sequential-image velocity: residual = ``[vE, vN]`` INS - SAR [m/s]."""

    kind = "sarvel"
    dim = 2
    _H = np.zeros((2, N_STATES))
    _H[0, 3] = _H[1, 4] = 1.0

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        return np.asarray(nav.vel[:2], dtype=float) - np.asarray(z, dtype=float)

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X)[:, 3:5]

    def H(self, nav: NavSnapshot) -> np.ndarray:
        return self._H

    def R(self, sigma) -> np.ndarray:
        return np.diag(np.asarray(sigma, dtype=float) ** 2)


class WindConstraint:
    """Air-data wind constraint on the velocity errors (paper 000, eq. 3 and 49–50),
    derived in fednav's convention (heading ψ from north toward east):

    the true ground velocity is ``v = v_a u(ψ) + w`` with ``u(ψ) = [sin ψ, cos ψ]``, so
    with the measured airspeed ``v_a``, the INS heading ``ψ^`` and the wind estimate ``w^``::

        d = v^_EN - (v_a u(ψ^) + w^)  =  δv_EN - v_a u'(ψ) δψ      u' = [cos ψ, -sin ψ]
        D = [ -v_a u'(ψ) ⊗ ∂δψ/∂φ ,  I (δvE, δvN) ]

    ``δψ = φU - tanθ (sinψ φE + cosψ φN)`` (``attitude.euler_error_jacobian``).  The paper
    prints ``D = [.. sinψ .. ; .. cosψ ..]`` on δvE/δvN and ``d = δv_w + δv_a cos/sinψ``;
    its sin/cos placement fits a heading from east; here both rows follow from the same
    expression, and the test suite checks ``D x = d`` against a perturbed truth.

    ``z = [airspeed, wind E, wind N]`` (:class:`~fednav.sensors.AirData`); ``R`` is the
    covariance of ``d`` from the airspeed and wind-estimate noise.  ``constraint = True``:
    constrained filters project onto it (CUKF), others would treat it as a measurement.
    """

    kind = "airdata"
    dim = 2
    constraint = True

    def __init__(self, airspeed: float = 0.0):
        self.va = float(airspeed)  # measured airspeed [m/s] (enters D)

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        psi = nav.euler[2]
        u = np.array([np.sin(psi), np.cos(psi)])
        return np.asarray(nav.vel[:2], dtype=float) - (z[0] * u + np.asarray(z[1:3]))

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.atleast_2d(X) @ self.H(nav).T

    def H(self, nav: NavSnapshot) -> np.ndarray:
        va = self.va
        psi = nav.euler[2]
        du = np.array([np.cos(psi), -np.sin(psi)])
        jpsi = att.euler_error_jacobian(nav.euler)[2]  # d(heading error)/d(phi)
        D = np.zeros((2, N_STATES))
        D[:, PHI] = -va * np.outer(du, jpsi) * ARCMIN
        D[0, 3] = D[1, 4] = 1.0
        return D

    def R(self, sigma, nav: NavSnapshot | None = None) -> np.ndarray:
        s = np.asarray(sigma, dtype=float)  # [airspeed, wind E, wind N]
        R = np.diag(s[1:3] ** 2)
        if nav is not None:
            psi = nav.euler[2]
            u = np.array([np.sin(psi), np.cos(psi)])
            R = R + s[0] ** 2 * np.outer(u, u)
        return R


class StackedModel:
    """Several measurement models of the same epoch as one: ``h`` and ``H`` stacked in the
    given order (the residuals and a block-diagonal R are stacked by the caller).  This is
    how a centralized filter assembles H and R from whichever sensors delivered."""

    def __init__(self, models):
        self.models = list(models)
        self.dim = sum(m.dim for m in self.models)

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return np.hstack([m.h(X, nav) for m in self.models])

    def H(self, nav: NavSnapshot) -> np.ndarray:
        return np.vstack([m.H(nav) for m in self.models])


MODELS = {m.kind: m for m in (StarAttitude(), SarFix(), BaroHeight(), GnssPosVel(),
                              SarVelocityEN())}
