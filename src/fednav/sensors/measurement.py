"""What every measurement model of the error-state filters shares.

A measurement model turns a sensor value ``z`` and the INS solution at the same instant
(:class:`NavSnapshot`) into the *observed residual* ``y = INS-derived - sensor`` and
predicts it from the error state: ``h(X, nav)`` for rows ``X`` of error states in filter
units (see :mod:`fednav.ins.error_model`) and its Jacobian ``H(nav)``.  Residual units:
metres for positions, m/s for velocities, arc-minutes for angles.

Most sensors measure parts of the navigation solution.  Such a sensor describes its
residual as *rows* (:class:`RowModel`): each row one quantity of the solution — position
east / north / up of the sensor's point (its lever arm), velocity east / north / up of
that point, pitch, roll or heading — against one component of ``z``.  One compiled
model (:func:`row_residual`, :func:`row_jacobian`, :func:`row_predict`) evaluates every
row kind; the navigator's compiled engine calls it with each measurement's rows, and
:class:`RowModel` calls the same functions from Python, so both paths compute the same
numbers from one source.  A sensor that measures something else writes its own model
(``residual``, ``h``, ``H``, ``R``) and runs in the navigator's Python loop.
"""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from ..core import attitude as att
from ..core import earth
from ..core.kernels import rotvec_to_dcm
from ..core.units import ARCMIN
from ..ins.error_model import N_STATES, SCALE
from ..ins.states import StateLayout

#: Row kinds: position east, north, up [m]; velocity east, north, up [m/s] (both of the
#: sensor's point at its lever arm); pitch, roll, heading [arcmin; roll and heading
#: wrapped to +-180 deg]; velocity of the sensor's point in body axes right, forward,
#: up [m/s] (odometer, DVL); body angular rate about x, y, z less the Earth rate seen
#: there, ``omega - C^T w_ie`` [deg/h] (zero-angular-rate updates of a vehicle at rest;
#: ``omega`` the epoch's mean compensated gyro rate).  A row compares its quantity with
#: ``z[index]`` (latitude, longitude [rad] and height [m] for the position rows, m/s,
#: rad, rad/s).
(POS_E, POS_N, POS_U, VEL_E, VEL_N, VEL_U, PITCH, ROLL, HEADING, BVEL_R, BVEL_F, BVEL_U,
 RATE_X, RATE_Y, RATE_Z) = range(15)
#: Error-state column of each position / velocity row kind.
_COLUMN = np.array([6, 7, 8, 3, 4, 5, -1, -1, -1, -1, -1, -1, -1, -1, -1])
#: rad/s per deg/h (the residual unit of the rate rows: the gyro drift's filter unit)
_DEG_H = float(SCALE[9])


#: The INS a measurement's rows compare with, as compiled code takes it (in the sensor's
#: axes): position [rad, rad, m], ENU velocity [m/s], attitude ``C`` (C_b^n, or ``C M``
#: in a mounted sensor's axes), body rate [rad/s] (``M' omega``).
View = namedtuple("View", "lla vel C omega")


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


class RowModel:
    """A measurement model described by rows (see the module docstring): ``rows`` =
    ((row kind, index into z), ...); ``lever`` the sensor's point from the IMU (body
    right-forward-up, m).  Subclasses give ``kind``, ``rows`` and ``R``.

    A sensor whose value carries a time-correlated error that an optional error state
    models (:mod:`fednav.ins.states`) names that state, ``markov_block``, and the row
    kinds it adds to, ``markov_kinds`` (its three components in order); its config's
    ``MARKOV_KEY`` gives the error's 1-sigma (:func:`fednav.navigator.system.
    state_layout`)."""

    kind = "?"
    rows: tuple = ()
    markov_block: str | None = None
    markov_kinds: tuple = ()
    #: per row, the Gauss-Markov variance the state carries (:meth:`with_markov`)
    markov_var: np.ndarray | None = None

    #: ``C_s^b``, the sensor's axes to the body's (None: aligned with the body)
    mount: np.ndarray | None = None

    def __init__(self, lever=(0.0, 0.0, 0.0)):
        self.lever = _v(np.asarray(lever, dtype=float).reshape(3))
        self.kinds = np.array([k for k, _ in self.rows], dtype=np.int64)
        self.zindex = np.array([i for _, i in self.rows], dtype=np.int64)

    @property
    def lever_s(self) -> np.ndarray:
        """The lever arm in the sensor's axes, ``M^T l`` [m] (what the row kernels take
        together with the sensor frame's attitude ``C M``: ``C M M^T l = C l``)."""
        return self.lever if self.mount is None else _v(self.mount.T @ self.lever)

    @property
    def geometry(self) -> np.ndarray:
        """The sensor's geometry as the compiled engine takes it, (4, 3): the lever arm
        in the sensor's axes, then ``C_s^b`` (identity when aligned)."""
        return np.vstack([self.lever_s, np.eye(3) if self.mount is None else self.mount])

    @property
    def dim(self) -> int:
        return len(self.rows)

    @property
    def linear(self) -> bool:
        """Whether ``h(x) = H x`` (no Euler-angle rows)."""
        return not bool(np.any((self.kinds >= PITCH) & (self.kinds <= HEADING)))

    def _nav(self, nav: NavSnapshot):
        """The INS as the sensor sees it: position and velocity, the attitude of the
        sensor's axes ``C M`` and the body rate in them ``M^T omega`` (:func:`sensor_frame`)."""
        omega = _ZERO3 if nav.omega_b is None else _v(nav.omega_b)
        C, omega = sensor_frame(_v(nav.C), omega, self.mount)
        return _v(nav.lla), _v(nav.vel), C, omega

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        out = np.empty(self.dim)
        row_residual(self.kinds, self.zindex, *self._nav(nav), _v(z), self.lever_s, out)
        return out

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H = np.zeros((self.dim, N_STATES))
        row_jacobian(self.kinds, *self._nav(nav), self.lever_s, H)
        return H

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        X = _v(np.atleast_2d(X))
        Z = np.empty((X.shape[0], self.dim))
        row_predict(self.kinds, *self._nav(nav), self.lever_s, X, Z)
        return Z

    def with_markov(self, sigma):
        """This model for a filter with its ``markov_block`` state of stationary 1-sigma
        ``sigma`` (one value or per component): the sensor's sigma (config or file) is
        then the whole error's, as a receiver reports it, and :meth:`white` keeps its
        white part."""
        s = np.broadcast_to(np.asarray(sigma, dtype=float), (len(self.markov_kinds),))
        self.markov_var = np.array([s[self.markov_kinds.index(k)] ** 2
                                    if k in self.markov_kinds else 0.0 for k in self.kinds])
        return self

    def white(self, R) -> np.ndarray:
        """``R`` of this model's rows, less the Gauss–Markov part a state carries
        (:func:`white_part`; ``R`` itself without such a state)."""
        return R if self.markov_var is None else white_part(R, self.markov_var)


def sensor_frame(C, omega, M):
    """The attitude of a sensor's axes ``C_s^n = C_b^n M`` and the body rate in them
    ``M^T omega`` [rad/s], for a sensor mounted with ``M = C_s^b`` (None: ``C``, ``omega``
    themselves).  Every row kind then reads in the sensor's axes: attitude rows the
    sensor frame's Euler angles, body-velocity rows ``M^T (C^T v + omega x l)``, while
    positions and ENU velocities stay those of its point (the lever arm goes to the
    kernels in the sensor's axes, :attr:`RowModel.lever_s`).  The attitude error ``phi``
    of the navigation frame is the same for both, so the kernels' Jacobians hold as
    written."""
    if M is None:
        return C, omega
    return np.ascontiguousarray(C @ M), np.ascontiguousarray(M.T @ omega)


class Mounted:
    """A measurement model that is not rows (one that reads the attitude, such as the
    magnetometer's) fed the INS as seen in the sensor's axes (:func:`sensor_frame`);
    everything else is ``model``'s."""

    def __init__(self, model, M):
        self.model, self.mount = model, np.asarray(M, dtype=float)

    def __getattr__(self, name):
        return getattr(self.__dict__["model"], name)

    def _nav(self, nav: NavSnapshot) -> NavSnapshot:
        C, omega = sensor_frame(np.asarray(nav.C, dtype=float), np.zeros(3) if
                                nav.omega_b is None else nav.omega_b, self.mount)
        return NavSnapshot(nav.lla, nav.vel, C, omega)

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        return self.model.residual(self._nav(nav), z)

    def H(self, nav: NavSnapshot) -> np.ndarray:
        return self.model.H(self._nav(nav))

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        return self.model.h(X, self._nav(nav))


def mounted(model, lever, M):
    """``model`` at the sensor's lever arm ``lever`` (body, m) and mounting ``M = C_s^b``
    (None: aligned): a row model takes both (:attr:`RowModel.lever_s`, ``mount``); any
    other model only a mounting (:class:`Mounted`; a lever arm is refused for it by the
    sensor's spec)."""
    if isinstance(model, RowModel):
        model.lever = _v(np.asarray(lever, dtype=float).reshape(3))
        model.mount = None if M is None else _v(M)
        return model
    if getattr(model, "takes_lever", False):  # a point's model of its own (gnss_raw)
        model.lever = _v(np.asarray(lever, dtype=float).reshape(3))
    return model if M is None else Mounted(model, M)


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
def lever_offsets(C, omega, lever):
    """Whether the sensor sits away from the IMU, and the ENU offsets of its point at the
    body ``lever`` [m]: position ``C l`` [m] and velocity ``C (omega x l)`` [m/s] (the
    ``w_in x C l`` term, < 1e-4 m/s per metre of lever, is left out; zeros without a
    lever)."""
    lx, ly, lz = lever[0], lever[1], lever[2]
    if lx == 0.0 and ly == 0.0 and lz == 0.0:
        return False, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    wx, wy, wz = omega[0], omega[1], omega[2]
    ux, uy, uz = wy * lz - wz * ly, wz * lx - wx * lz, wx * ly - wy * lx
    p = (C[0, 0] * lx + C[0, 1] * ly + C[0, 2] * lz,
         C[1, 0] * lx + C[1, 1] * ly + C[1, 2] * lz,
         C[2, 0] * lx + C[2, 1] * ly + C[2, 2] * lz)
    v = (C[0, 0] * ux + C[0, 1] * uy + C[0, 2] * uz,
         C[1, 0] * ux + C[1, 1] * uy + C[1, 2] * uz,
         C[2, 0] * ux + C[2, 1] * uy + C[2, 2] * uz)
    return True, p, v


@numba.njit(cache=True, inline="always")
def _cross_j(a, b, j):
    """Component ``j`` of ``a x b``."""
    if j == 0:
        return a[1] * b[2] - a[2] * b[1]
    if j == 1:
        return a[2] * b[0] - a[0] * b[2]
    return a[0] * b[1] - a[1] * b[0]


@numba.njit(cache=True, inline="always")
def skew_row(H, r, which, a0, a1, a2, k):
    """Row ``which`` (0, 1, 2) of ``k [a x]`` into ``H[r, 0:3]``."""
    if which == 0:
        H[r, 1], H[r, 2] = -a2 * k, a1 * k
    elif which == 1:
        H[r, 0], H[r, 2] = a2 * k, -a0 * k
    else:
        H[r, 0], H[r, 1] = -a1 * k, a0 * k


@numba.njit(cache=True)
def row_residual(kinds, zindex, lla, vel, C, omega, z, lever, out):
    """The residual of each row (INS-derived - ``z``) into ``out``."""
    has_lever, p, v = lever_offsets(C, omega, lever)
    pitch, roll, heading = euler_of(C)
    lat, lon, h = lla[0], lla[1], lla[2]
    rm, rn = earth.radii_nb(lat)
    for r in range(kinds.shape[0]):
        k, zi = kinds[r], zindex[r]
        if k == POS_E:
            out[r] = earth.wrap_lon(lon - z[zi]) * (rn + h) * np.cos(lat)
        elif k == POS_N:
            out[r] = (lat - z[zi]) * (rm + h)
        elif k == POS_U:
            out[r] = h - z[zi]
        elif k <= VEL_U:
            out[r] = vel[k - VEL_E] - z[zi]
        elif k == PITCH:
            out[r] = (pitch - z[zi]) / ARCMIN
        elif k == ROLL:
            out[r] = wrap_pi_nb(roll - z[zi]) / ARCMIN
        elif k == HEADING:
            out[r] = wrap_pi_nb(heading - z[zi]) / ARCMIN
        elif k >= RATE_X:  # body axis j: omega_j - (C^T w_ie)_j
            j = k - RATE_X
            w_ie = earth.OMEGA_IE * (C[1, j] * np.cos(lat) + C[2, j] * np.sin(lat))
            out[r] = (omega[j] - w_ie - z[zi]) / _DEG_H
        else:  # body axis j: (C^T v)_j + (omega x l)_j
            j = k - BVEL_R
            u = _cross_j(omega, lever, j)
            out[r] = C[0, j] * vel[0] + C[1, j] * vel[1] + C[2, j] * vel[2] + u - z[zi]
        if has_lever and k <= POS_U:
            out[r] += p[k - POS_E]
        elif has_lever and k <= VEL_U:
            out[r] += v[k - VEL_E]


@numba.njit(cache=True)
def row_jacobian(kinds, lla, vel, C, omega, lever, H):
    """The non-zero entries of each row of ``H`` (filter units; ``H`` zeroed by the
    caller): 1 on the position / velocity error, the lever arm's attitude coupling
    ``[(C l) x]`` / ``[(C (w x l)) x]``, the Euler-error Jacobian of attitude rows."""
    has_lever, p, v = lever_offsets(C, omega, lever)
    pitch, _, heading = euler_of(C)
    one = np.zeros(1, dtype=np.int64)
    for r in range(kinds.shape[0]):
        k = kinds[r]
        if k <= VEL_U:
            H[r, _COLUMN[k]] = 1.0
            if has_lever:
                a = p if k <= POS_U else v
                skew_row(H, r, (k - POS_E) % 3, a[0], a[1], a[2], ARCMIN)
        elif k <= HEADING:
            one[0] = k - PITCH
            euler_jacobian_rows(pitch, heading, H, r, one)
        elif k >= RATE_X:
            # omega - C_hat^T w_ie with C_hat^T = C^T (I + [phi x]): the residual drift
            # (constant and Markov) plus c_j . (w_ie x phi) = (c_j x w_ie) . phi
            j = k - RATE_X
            H[r, 9 + j], H[r, 12 + j] = 1.0, 1.0
            wn, wu = earth.OMEGA_IE * np.cos(lla[0]), earth.OMEGA_IE * np.sin(lla[0])
            c0, c1, c2 = C[0, j], C[1, j], C[2, j]
            f = ARCMIN / _DEG_H
            H[r, 0], H[r, 1], H[r, 2] = (c1 * wu - c2 * wn) * f, -c0 * wu * f, c0 * wn * f
        else:
            # C_hat^T v_hat = C^T (I + [phi x]) (v + dv): row j is c_j . dv - (c_j x v) . phi
            # (c_j: column j of C)
            j = k - BVEL_R
            c0, c1, c2 = C[0, j], C[1, j], C[2, j]
            H[r, 3], H[r, 4], H[r, 5] = c0, c1, c2
            H[r, 0] = (vel[1] * c2 - vel[2] * c1) * ARCMIN
            H[r, 1] = (vel[2] * c0 - vel[0] * c2) * ARCMIN
            H[r, 2] = (vel[0] * c1 - vel[1] * c0) * ARCMIN


@numba.njit(cache=True)
def row_predict(kinds, lla, vel, C, omega, lever, X, Z):
    """``Z[i] = h(X[i])`` for sigma points (rows of X in filter units): the exact Euler
    error for attitude rows, ``H x`` for the others."""
    H = np.zeros((kinds.shape[0], X.shape[1]))
    row_jacobian(kinds, lla, vel, C, omega, lever, H)
    has_lever = lever[0] != 0.0 or lever[1] != 0.0 or lever[2] != 0.0
    e = np.empty((0, 3))
    if np.any((kinds >= PITCH) & (kinds <= HEADING)):
        e = euler_error_nb(C, X)
    for r in range(kinds.shape[0]):
        k = kinds[r]
        if PITCH <= k <= HEADING:
            for i in range(X.shape[0]):
                Z[i, r] = e[i, k - PITCH]
        elif k >= RATE_X:
            j = k - RATE_X
            for i in range(X.shape[0]):
                Z[i, r] = (H[r, 0] * X[i, 0] + H[r, 1] * X[i, 1] + H[r, 2] * X[i, 2]
                           + X[i, 9 + j] + X[i, 12 + j])
        elif k >= BVEL_R:
            for i in range(X.shape[0]):
                s = 0.0
                for j in range(6):
                    s += H[r, j] * X[i, j]
                Z[i, r] = s
        elif has_lever:
            for i in range(X.shape[0]):
                s = X[i, _COLUMN[k]]
                for j in range(3):
                    s += H[r, j] * X[i, j]
                Z[i, r] = s
        else:
            for i in range(X.shape[0]):
                Z[i, r] = X[i, _COLUMN[k]]


def bias_columns(layout: StateLayout, model) -> np.ndarray:
    """Per row of a measurement ``model``, the error-state column of the additive error
    its value carries (-1: none): the columns of its ``markov_block`` in ``layout``, on
    the rows of its ``markov_kinds`` (:class:`RowModel`)."""
    kinds = getattr(model, "kinds", ())
    out = np.full(len(kinds), -1, dtype=np.int64)
    block = getattr(model, "markov_block", None)
    i = layout.start(block) if block is not None else -1
    if i >= 0:
        for r, k in enumerate(kinds):
            if k in model.markov_kinds:
                out[r] = i + model.markov_kinds.index(k)
    return out


def white_part(R, markov_var) -> np.ndarray:
    """The white part of a noise covariance ``R`` whose diagonal holds a Gauss–Markov
    process's variance ``markov_var`` too (a state carries that): ``D R D`` with ``D =
    diag(sqrt(max(1 - markov_var / R_ii, WHITE_FLOOR)))`` — the diagonal less the
    process's variance, at least :data:`WHITE_FLOOR` of it, correlations kept."""
    R = np.asarray(R, dtype=float)
    d = np.sqrt(np.maximum(1.0 - np.asarray(markov_var, dtype=float) / np.diag(R),
                           WHITE_FLOOR))
    return R * np.outer(d, d)


#: The least part of a noise variance :func:`white_part` keeps as white noise.
WHITE_FLOOR = 0.01


class BiasedModel:
    """A measurement model over an error state with optional blocks
    (:mod:`fednav.ins.states`): ``model``'s ``h`` and ``H`` on the first 18 states (every
    model of the 18-state filter reads only those),
    ``H`` widened to ``n`` columns, and the rows with a sensor bias (``bias[r]``: its
    column, -1 none) take the bias estimate out of the value (``xa``: the totals the
    navigator keeps, SI, read when called) and have ``-1`` on its error (the residual
    ``INS - (z - b_hat) = dp - db``).  Everything else is ``model``'s."""

    def __init__(self, model, n: int, bias, xa):
        self.model, self.n, self.xa = model, int(n), xa
        self.bias = np.asarray(bias, dtype=np.int64).reshape(-1)
        self._rows = np.flatnonzero(self.bias >= 0)

    def __getattr__(self, name):
        return getattr(self.__dict__["model"], name)

    def residual(self, nav: NavSnapshot, z) -> np.ndarray:
        y = np.array(self.model.residual(nav, z), dtype=float)
        y[self._rows] += self.xa[self.bias[self._rows]]
        return y

    def H(self, nav: NavSnapshot) -> np.ndarray:
        H0 = np.asarray(self.model.H(nav), dtype=float)
        H = np.zeros((H0.shape[0], self.n))
        H[:, :H0.shape[1]] = H0
        H[self._rows, self.bias[self._rows]] = -1.0
        return H

    def h(self, X, nav: NavSnapshot) -> np.ndarray:
        X = np.atleast_2d(X)
        Z = np.array(self.model.h(np.ascontiguousarray(X[:, :N_STATES]), nav),
                     dtype=float).reshape(X.shape[0], -1)
        Z[:, self._rows] -= X[:, self.bias[self._rows]]
        return Z


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
