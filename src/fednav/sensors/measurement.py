"""What every measurement model of the error-state filters shares.

A measurement model turns a sensor value ``z`` and the INS solution at the same instant
(:class:`NavSnapshot`) into the *observed residual* ``y = INS-derived - sensor`` and
predicts it from the error state: ``h(X, nav)`` for rows ``X`` of error states in filter
units (see :mod:`fednav.ins.error_model`) and its Jacobian ``H(nav)``.  Residual units:
metres for positions, m/s for velocities, arc-minutes for angles.

Each sensor module writes its model once, as compiled kernels with the signatures below
(:class:`Kernels`): the navigator's compiled engine calls them directly, and
:class:`KernelModel` calls the same functions from Python, so both paths compute the
same numbers from one source.  A model without kernels (a Python-only sensor, the wind
constraint) runs in the navigator's Python loop only.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numba
import numpy as np
from numba import types
from numba.core.errors import NumbaExperimentalFeatureWarning

from ..core import attitude as att
from ..core.kernels import rotvec_to_dcm
from ..core.units import ARCMIN
from ..ins.error_model import N_STATES, SCALE

# Sensor kernels are passed to the compiled engine as first-class functions; numba marks
# the feature experimental and says so once per compilation.
warnings.filterwarnings("ignore", category=NumbaExperimentalFeatureWarning)

_V = types.float64[::1]
_M = types.float64[:, ::1]
#: ``residual(lla, vel, C, omega, z, aux, out)``: ``out[:dim]`` = INS-derived - ``z``.
RESIDUAL = types.void(_V, _V, _M, _V, _V, _V, _V)
#: ``jacobian(lla, vel, C, omega, aux, H)``: the non-zero entries of ``H`` (dim, 18),
#: filter units; the caller zeroes ``H``.
JACOBIAN = types.void(_V, _V, _M, _V, _V, _M)
#: ``predict(lla, vel, C, omega, aux, X, Z)``: ``Z[i, :dim] = h(X[i])`` for sigma points
#: (rows of X in filter units).  Linear models leave it to ``Z = X H'``.
PREDICT = types.void(_V, _V, _M, _V, _V, _M, _M)


class Kernels(NamedTuple):
    """A sensor's compiled measurement model (see the signatures above)."""

    residual: object
    jacobian: object
    predict: object
    linear: bool  # h(X) = X H' (then ``predict`` is never called)


@numba.njit(PREDICT, cache=True)
def predict_linear(lla, vel, C, omega, aux, X, Z):
    """The ``predict`` slot of a linear model (the engine computes ``X H'`` itself)."""
    Z[:, :] = np.nan


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


_ZERO3 = np.zeros(3)


def _v(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


class KernelModel:
    """A measurement model computed by its sensor's :class:`Kernels` (Python side).

    ``aux``: the model's parameters the kernels read (a lever arm ...)."""

    kind = "?"
    dim = 0
    kernels: Kernels

    def __init__(self, aux=()):
        self.aux = _v(np.atleast_1d(np.asarray(aux, dtype=float)).ravel())

    @property
    def linear(self) -> bool:
        return self.kernels.linear

    def _nav(self, nav: NavSnapshot):
        return (_v(nav.lla), _v(nav.vel), _v(nav.C),
                _ZERO3 if nav.omega_b is None else _v(nav.omega_b))

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        out = np.empty(self.dim)
        self.kernels.residual(*self._nav(nav), _v(z), self.aux, out)
        return out

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((self.dim, N_STATES))
        self.kernels.jacobian(*self._nav(nav), self.aux, H)
        return H

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        X = np.atleast_2d(X)
        if self.linear:
            return X @ self.H(nav).T
        Z = np.empty((X.shape[0], self.dim))
        self.kernels.predict(*self._nav(nav), self.aux, _v(X), Z)
        return Z


# ------------------------------------------------------------ shared pieces of models
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


_TWO_PI = 2.0 * np.pi


@numba.njit(cache=True, inline="always")
def wrap_pi_nb(a):
    """An angle wrapped to [-pi, pi) (as :func:`fednav.core.attitude.wrap_pi`)."""
    return (a + np.pi) % _TWO_PI - np.pi


@numba.njit(cache=True, inline="always")
def euler_of(C):
    """Euler ``[pitch, roll, heading]`` of C_b^n, heading in [0, 2 pi) (as
    :func:`fednav.core.attitude.dcm_to_euler`)."""
    pitch = np.arcsin(min(1.0, max(-1.0, C[2, 1])))
    roll = np.arctan2(-C[2, 0], C[2, 2])
    heading = np.arctan2(C[0, 1], C[1, 1]) % _TWO_PI
    return pitch, roll, heading


@numba.njit(cache=True, inline="always")
def euler_jacobian_rows(pitch, heading, H, row0, rows):
    """Rows ``rows`` (0 pitch, 1 roll, 2 heading) of d(Euler error)/d(phi) in arcmin per
    arcmin into ``H[row0 + i, 0:3]`` (:func:`fednav.core.attitude.euler_error_jacobian`)."""
    s, c = np.sin(heading), np.cos(heading)
    ct, tt = np.cos(pitch), np.tan(pitch)
    for i in range(rows.shape[0]):
        r = rows[i]
        if r == 0:
            H[row0 + i, 0], H[row0 + i, 1], H[row0 + i, 2] = -c, s, 0.0
        elif r == 1:
            H[row0 + i, 0], H[row0 + i, 1], H[row0 + i, 2] = -s / ct, -c / ct, 0.0
        else:
            H[row0 + i, 0], H[row0 + i, 1], H[row0 + i, 2] = -tt * s, -tt * c, 1.0


@numba.njit(cache=True, inline="always")
def lever_offsets(C, omega, lx, ly, lz):
    """ENU offsets of a sensor at the body lever ``(lx, ly, lz)`` [m] from the IMU:
    position ``C l`` [m] and velocity ``C (omega x l)`` [m/s] (the ``w_in x C l`` term,
    < 1e-4 m/s per metre of lever, is left out)."""
    wx, wy, wz = omega[0], omega[1], omega[2]
    ux, uy, uz = wy * lz - wz * ly, wz * lx - wx * lz, wx * ly - wy * lx
    p = (C[0, 0] * lx + C[0, 1] * ly + C[0, 2] * lz,
         C[1, 0] * lx + C[1, 1] * ly + C[1, 2] * lz,
         C[2, 0] * lx + C[2, 1] * ly + C[2, 2] * lz)
    v = (C[0, 0] * ux + C[0, 1] * uy + C[0, 2] * uz,
         C[1, 0] * ux + C[1, 1] * uy + C[1, 2] * uz,
         C[2, 0] * ux + C[2, 1] * uy + C[2, 2] * uz)
    return p, v


@numba.njit(cache=True, inline="always")
def skew_into(H, row0, col0, a0, a1, a2, k):
    """``H[row0:row0+3, col0:col0+3] = k [a x]``."""
    H[row0, col0 + 1], H[row0, col0 + 2] = -a2 * k, a1 * k
    H[row0 + 1, col0], H[row0 + 1, col0 + 2] = a2 * k, -a0 * k
    H[row0 + 2, col0], H[row0 + 2, col0 + 1] = -a1 * k, a0 * k


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
