"""SINS error-state model (18 states, ENU) for the error-state (indirect) filters.

State, in SI inside this module::

    0:3   phi      platform error angles phiE, phiN, phiU [rad] (C_hat = exp(-[phi x]) C)
    3:6   dv       velocity error vE, vN, vU, computed minus true [m/s]
    6:9   dp       position error east, north, up, computed minus true [m]
    9:12  eps_c    gyro constant drift, body axes [rad/s]
    12:15 eps_r    gyro first-order Gauss-Markov drift, body axes [rad/s]
    15:18 nabla    accelerometer bias, body axes [m/s^2] (Gauss-Markov; constant if tau = inf)

This is paper 002's state (phi, dVE, dVN, dL, dlambda, eps_c, eps_r, nabla_c) extended by
the vertical channel (dvU, dh) and with position in metres, the paper-004 18-state layout.
With a barometric damping loop in the mechanization the loop terms appear in F, so the
filter knows the vertical channel is held.

Filters see the state in *filter units* ``x_f = x_SI / SCALE`` (arc-minutes, m/s, m,
deg/h, mg): covariance entries are then O(1e-4 .. 1e2) instead of spanning 1e-15 .. 1e2,
which keeps Cholesky factors and the information-form fusion well conditioned.

Two propagation models share the same physics:

* :meth:`ErrorProcess.F` — the classic linear model (Qin Yongyuan / Titterton);
* :meth:`ErrorProcess.transition` — the exact nonlinear model for large errors:
  ``dE/dt = [(C_hat eps - w_in_hat) x] E + E [w_in x]`` for the error rotation
  ``E = C_n^n'``, velocity error ``(I - E^T) f_hat + E^T C_hat nabla`` + Coriolis and gravity
  differences, position from the latitude/longitude-rate differences.  This is paper
  000's eq. 40 written with a rotation matrix instead of Euler platform angles (no
  singularity).  The test suite checks that F is its Jacobian at zero error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from . import earth, units
from .attitude import skew

N_STATES = 18
PHI, DV, DP, EPS_C, EPS_R, NABLA = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12),
                                     slice(12, 15), slice(15, 18))
STATE_NAMES = ("phiE", "phiN", "phiU", "dvE", "dvN", "dvU", "dE", "dN", "dU",
               "eps_cx", "eps_cy", "eps_cz", "eps_rx", "eps_ry", "eps_rz",
               "nabla_x", "nabla_y", "nabla_z")
#: SI value of one filter unit per state (see module docstring).
SCALE = np.r_[np.full(3, units.ARCMIN), np.ones(6), np.full(6, units.deg_per_h(1.0)),
              np.full(3, units.milli_g(1.0))]


@dataclass(frozen=True)
class ImuNoiseModel:
    """What the filter assumes about the IMU (SI units, per axis, isotropic).

    gyro_arw [rad/sqrt(s)], accel_vrw [m/s/sqrt(s)]; Markov sigma and tau for the gyro
    drift [rad/s, s] and accelerometer bias [m/s^2, s] (tau = inf: constant bias).
    """

    gyro_arw: float = 0.0
    accel_vrw: float = 0.0
    gyro_markov_sigma: float = 0.0
    gyro_markov_tau: float = np.inf
    accel_markov_sigma: float = 0.0
    accel_markov_tau: float = np.inf


@numba.njit(cache=True)
def _rv2dcm(r):
    a2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    a = np.sqrt(a2)
    if a < 1e-6:
        s, c = 1.0 - a2 / 6.0, 0.5 - a2 / 24.0
    else:
        s, c = np.sin(a) / a, (1.0 - np.cos(a)) / a2
    K = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    return np.eye(3) + s * K + c * (K @ K)


@numba.njit(cache=True)
def _dcm2rv(C):
    tr = C[0, 0] + C[1, 1] + C[2, 2]
    cosa = min(1.0, max(-1.0, 0.5 * (tr - 1.0)))
    a = np.arccos(cosa)
    v = np.array([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]])
    if a < 1e-6:
        return 0.5 * (1.0 + a * a / 6.0) * v
    return a / (2.0 * np.sin(a)) * v


@numba.njit(cache=True)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


@numba.njit(cache=True)
def _rates(lat, h, v, rm, rn):
    om = earth.OMEGA_IE
    w_ie = np.array([0.0, om * np.cos(lat), om * np.sin(lat)])
    w_en = np.array([-v[1] / (rm + h), v[0] / (rn + h), v[0] * np.tan(lat) / (rn + h)])
    return w_ie, w_en


@numba.njit(cache=True)
def _vec_rates(x, E, lat0, h0, v0, C0, fn, rm, rn, k1, k2, itg, ita):
    """Time derivative of the non-attitude states and the attitude rotation rates."""
    dv = x[3:6]
    dp = x[6:9]
    eps = x[9:12] + x[12:15]
    nab = x[15:18]
    lat = lat0 - dp[1] / (rm + h0)
    h = h0 - dp[2]
    v = v0 - dv
    wie0, wen0 = _rates(lat0, h0, v0, rm, rn)
    wie, wen = _rates(lat, h, v, rm, rn)
    w_left = C0 @ eps - (wie0 + wen0)  # rotation applied on the left of E
    w_right = wie + wen  # rotation applied on the right of E
    Et = E.T
    ddv = (fn - Et @ fn) + Et @ (C0 @ nab)
    ddv -= _cross(2.0 * wie0 + wen0, v0) - _cross(2.0 * wie + wen, v)
    ddv[2] += -earth.gravity_nb(lat0, h0) + earth.gravity_nb(lat, h) - k2 * dp[2]
    ddp = np.empty(3)
    ddp[0] = (rn + h0) * np.cos(lat0) * (v0[0] / ((rn + h0) * np.cos(lat0))
                                         - v[0] / ((rn + h) * np.cos(lat)))
    ddp[1] = (rm + h0) * (v0[1] / (rm + h0) - v[1] / (rm + h))
    ddp[2] = dv[2] - k1 * dp[2]
    out = np.zeros(18)
    out[3:6] = ddv
    out[6:9] = ddp
    out[12:15] = -itg * x[12:15]
    out[15:18] = -ita * x[15:18]
    return out, w_left, w_right


@numba.njit(cache=True)
def _transition(X, T, nsub, lat0, h0, v0, C0, fn, rm, rn, k1, k2, itg, ita, scale):
    """Propagate each row of X (filter units) over T seconds with the nonlinear model."""
    out = np.empty_like(X)
    hstep = T / nsub
    for i in range(X.shape[0]):
        x = X[i] * scale
        E = _rv2dcm(-x[0:3])
        for _ in range(nsub):
            d1, wl1, wr1 = _vec_rates(x, E, lat0, h0, v0, C0, fn, rm, rn, k1, k2, itg, ita)
            xm = x + 0.5 * hstep * d1
            Em = _rv2dcm(0.5 * hstep * wl1) @ E @ _rv2dcm(0.5 * hstep * wr1)
            d2, wl2, wr2 = _vec_rates(xm, Em, lat0, h0, v0, C0, fn, rm, rn, k1, k2, itg, ita)
            x = x + hstep * d2
            E = _rv2dcm(hstep * wl2) @ E @ _rv2dcm(hstep * wr2)
        x[0:3] = -_dcm2rv(E)
        out[i] = x / scale
    return out


@dataclass
class Nominal:
    """INS (computed) navigation over one filter interval, at its midpoint.

    lat [rad], h [m], vel ENU [m/s], C = C_b^n (computed), fn = mean specific force in
    the navigation frame [m/s^2].
    """

    lat: float
    h: float
    vel: np.ndarray
    C: np.ndarray
    fn: np.ndarray


class ErrorProcess:
    """The error model over one interval ``T``: Phi, Qd and the nonlinear transition.

    Everything returned is in filter units (see :data:`SCALE`).
    """

    def __init__(self, nom: Nominal, T: float, noise: ImuNoiseModel,
                 baro_gains=(0.0, 0.0), baro_q: float = 0.0, nsub: int = 2):
        self.nom, self.T, self.noise, self.nsub = nom, float(T), noise, int(nsub)
        self.k1, self.k2 = float(baro_gains[0]), float(baro_gains[1])
        self.rm, self.rn = earth.radii(nom.lat)
        self.itg = 0.0 if np.isinf(noise.gyro_markov_tau) else 1.0 / noise.gyro_markov_tau
        self.ita = 0.0 if np.isinf(noise.accel_markov_tau) else 1.0 / noise.accel_markov_tau
        self.baro_q = float(baro_q)
        F = self.F_si()
        # Transition matrix: 4th-order Taylor series over T/2, squared (||F T|| < 1 here).
        A = F * (0.5 * T)
        A2 = A @ A
        half = np.eye(N_STATES) + A + A2 @ (np.eye(N_STATES) / 2.0 + A / 6.0 + A2 / 24.0)
        Phi = half @ half
        Qc = self.Qc_si()
        Qd = 0.5 * (Phi @ Qc @ Phi.T + Qc) * T
        s = SCALE
        self.Phi = Phi * s[None, :] / s[:, None]
        self.Qd = Qd / np.outer(s, s)
        self.Qd = 0.5 * (self.Qd + self.Qd.T)

    # ------------------------------------------------------------------ SI models
    def F_si(self) -> np.ndarray:
        """Continuous-time linear error dynamics (SI units)."""
        n = self.nom
        lat, h, v, C, fn = n.lat, n.h, np.asarray(n.vel), n.C, n.fn
        rm, rn = self.rm, self.rn
        Rm, Rn = rm + h, rn + h
        sl, cl, tl = np.sin(lat), np.cos(lat), np.tan(lat)
        om = earth.OMEGA_IE
        w_ie = np.array([0.0, om * cl, om * sl])
        w_en = np.array([-v[1] / Rm, v[0] / Rn, v[0] * tl / Rn])
        # d(w_ie)/d(dp), d(w_en)/d(dv), d(w_en)/d(dp) with dp = [dE, dN, dU] in metres.
        dwie_dp = np.zeros((3, 3))
        dwie_dp[1, 1] = -om * sl / Rm
        dwie_dp[2, 1] = om * cl / Rm
        dwen_dv = np.array([[0.0, -1 / Rm, 0.0], [1 / Rn, 0.0, 0.0], [tl / Rn, 0.0, 0.0]])
        dwen_dp = np.zeros((3, 3))
        dwen_dp[0, 2] = v[1] / Rm**2
        dwen_dp[1, 2] = -v[0] / Rn**2
        dwen_dp[2, 1] = v[0] / (cl**2 * Rn * Rm)
        dwen_dp[2, 2] = -v[0] * tl / Rn**2
        F = np.zeros((N_STATES, N_STATES))
        F[PHI, PHI] = -skew(w_ie + w_en)
        F[PHI, DV] = dwen_dv
        F[PHI, DP] = dwie_dp + dwen_dp
        F[PHI, EPS_C] = -C
        F[PHI, EPS_R] = -C
        F[DV, PHI] = skew(fn)
        F[DV, DV] = -skew(2 * w_ie + w_en) + skew(v) @ dwen_dv
        F[DV, DP] = skew(v) @ (2 * dwie_dp + dwen_dp)
        F[5, 8] += earth.gravity_gradient(lat, h) - self.k2
        F[5, 7] -= earth.gravity_dlat(lat) / Rm
        F[DV, NABLA] = C
        F[6, 3] = 1.0
        F[6, 7] = v[0] * tl / Rm
        F[6, 8] = -v[0] / Rn
        F[7, 4] = 1.0
        F[7, 8] = -v[1] / Rm
        F[8, 5] = 1.0
        F[8, 8] = -self.k1
        F[EPS_R, EPS_R] = -self.itg * np.eye(3)
        F[NABLA, NABLA] = -self.ita * np.eye(3)
        return F

    def Qc_si(self) -> np.ndarray:
        """Continuous process-noise spectral density (SI units)."""
        nz = self.noise
        C = self.nom.C
        Q = np.zeros((N_STATES, N_STATES))
        Q[PHI, PHI] = C @ (nz.gyro_arw**2 * np.eye(3)) @ C.T
        Q[DV, DV] = C @ (nz.accel_vrw**2 * np.eye(3)) @ C.T
        Q[5, 5] += self.k2**2 * self.baro_q
        Q[8, 8] += self.k1**2 * self.baro_q
        Q[5, 8] = Q[8, 5] = self.k1 * self.k2 * self.baro_q
        Q[EPS_R, EPS_R] = 2.0 * nz.gyro_markov_sigma**2 * self.itg * np.eye(3)
        Q[NABLA, NABLA] = 2.0 * nz.accel_markov_sigma**2 * self.ita * np.eye(3)
        return Q

    # ------------------------------------------------------------ filter interface
    def transition(self, X: np.ndarray) -> np.ndarray:
        """Nonlinear propagation of state rows ``X`` (S, 18) in filter units over T."""
        n = self.nom
        X = np.ascontiguousarray(np.atleast_2d(X), dtype=float)
        return _transition(X, self.T, self.nsub, n.lat, n.h, np.asarray(n.vel, float),
                           np.ascontiguousarray(n.C), np.asarray(n.fn, float), self.rm,
                           self.rn, self.k1, self.k2, self.itg, self.ita, SCALE)

    def linear_transition(self, X: np.ndarray) -> np.ndarray:
        """``Phi @ x`` for each row of X (filter units)."""
        return np.atleast_2d(X) @ self.Phi.T


def to_si(x):
    """Filter units -> SI for a state vector (or rows of vectors)."""
    return np.asarray(x) * SCALE


def cov_to_si(P):
    """Filter units -> SI for a covariance."""
    return np.asarray(P) * np.outer(SCALE, SCALE)


def from_si(x):
    """SI -> filter units for a state vector."""
    return np.asarray(x) / SCALE
