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
from .kernels import dcm_to_rotvec, matmul_sparse, rotvec_to_dcm
from .kernels import quat_to_dcm as _quat_to_dcm

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

    gyro_arw [rad/sqrt(s)], accel_vrw [m/s/sqrt(s)]; bias random walks gyro_bias_rw
    [rad/s/sqrt(s)] and accel_bias_rw [m/s^2/sqrt(s)] (on the constant-bias states);
    Markov sigma and tau for the gyro
    drift [rad/s, s] and accelerometer bias [m/s^2, s] (tau = inf: constant bias).
    """

    gyro_arw: float = 0.0
    accel_vrw: float = 0.0
    gyro_bias_rw: float = 0.0
    accel_bias_rw: float = 0.0
    gyro_markov_sigma: float = 0.0
    gyro_markov_tau: float = np.inf
    accel_markov_sigma: float = 0.0
    accel_markov_tau: float = np.inf


@numba.njit(cache=True, inline="always")
def _rotate(E, wl, wr, h, tmp, R):
    """E <- exp(h [wl x]) E exp(h [wr x])."""
    rotvec_to_dcm(h * wl[0], h * wl[1], h * wl[2], R)
    for i in range(3):
        for j in range(3):
            tmp[i, j] = R[i, 0] * E[0, j] + R[i, 1] * E[1, j] + R[i, 2] * E[2, j]
    rotvec_to_dcm(h * wr[0], h * wr[1], h * wr[2], R)
    for i in range(3):
        for j in range(3):
            E[i, j] = tmp[i, 0] * R[0, j] + tmp[i, 1] * R[1, j] + tmp[i, 2] * R[2, j]


@numba.njit(cache=True)
def _nominal_terms(p):
    """Terms of ``_rates`` that depend on the nominal only: w_ie0 + w_en0 (3),
    (2 w_ie0 + w_en0) x v0 (3), cos(lat0), sin(lat0),
    1 / (rm + h0)."""
    lat0, h0, rm, rn = p[0], p[1], p[8], p[9]
    v0e, v0n, v0u = p[2], p[3], p[4]
    om = earth.OMEGA_IE
    c0, s0 = np.cos(lat0), np.sin(lat0)
    wie = np.array([0.0, om * c0, om * s0])
    wen = np.array([-v0n / (rm + h0), v0e / (rn + h0), v0e * s0 / c0 / (rn + h0)])
    a = 2.0 * wie + wen
    out = np.empty(9)
    out[0:3] = wie + wen
    out[3] = a[1] * v0u - a[2] * v0n
    out[4] = a[2] * v0e - a[0] * v0u
    out[5] = a[0] * v0n - a[1] * v0e
    out[6] = c0
    out[7] = s0
    out[8] = 1.0 / (rm + h0)
    return out


@numba.njit(cache=True, inline="always")
def _cos_sin_minus(c0, s0, d):
    """cos and sin of ``a - d`` from those of ``a``; ``d`` below 1e-3 rad by its series
    (error under 1e-20), which is what sigma points a few kilometres apart need."""
    if abs(d) < 1e-3:
        d2 = d * d
        cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 / 720.0))
        sd = d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 / 5040.0)))
    else:
        cd, sd = np.cos(d), np.sin(d)
    return c0 * cd + s0 * sd, s0 * cd - c0 * sd


@numba.njit(cache=True, inline="always")
def _rates(x, E, p, C0, out, wl, wr, k0):
    """Derivative of the non-attitude states into ``out``; attitude rotation rates into
    ``wl`` (left of E) and ``wr`` (right of E).  ``p`` = [lat0, h0, vE0, vN0, vU0, fE, fN, fU,
    rm, rn, k1, k2, 1/tau_g, 1/tau_a, g0]."""
    h0 = p[1]
    fe, fn_, fu = p[5], p[6], p[7]
    rm, rn, k1, k2, itg, ita, g0 = p[8], p[9], p[10], p[11], p[12], p[13], p[14]
    om = earth.OMEGA_IE
    h = h0 - x[8]
    v0e, v0n, v0u = p[2], p[3], p[4]
    ve, vn, vu = v0e - x[3], v0n - x[4], v0u - x[5]
    # True rates (the computed ones are in k0); true latitude lat0 - dN / (rm + h0).
    c0 = k0[6]
    c1, s1 = _cos_sin_minus(c0, k0[7], x[7] * k0[8])
    irm, irn, ic1 = 1.0 / (rm + h), 1.0 / (rn + h), 1.0 / c1
    wie1 = (0.0, om * c1, om * s1)
    wen1 = (-vn * irm, ve * irn, ve * s1 * ic1 * irn)
    e0 = x[9] + x[12]
    e1 = x[10] + x[13]
    e2 = x[11] + x[14]
    for i in range(3):
        wl[i] = C0[i, 0] * e0 + C0[i, 1] * e1 + C0[i, 2] * e2 - k0[i]
        wr[i] = wie1[i] + wen1[i]
    # Velocity error: (I - E^T) f + E^T C0 nabla - Coriolis difference + gravity difference.
    cn0 = C0[0, 0] * x[15] + C0[0, 1] * x[16] + C0[0, 2] * x[17]
    cn1 = C0[1, 0] * x[15] + C0[1, 1] * x[16] + C0[1, 2] * x[17]
    cn2 = C0[2, 0] * x[15] + C0[2, 1] * x[16] + C0[2, 2] * x[17]
    a0, a1, a2 = fe - cn0, fn_ - cn1, fu - cn2
    a1x = 2 * wie1[0] + wen1[0]
    a1y = 2 * wie1[1] + wen1[1]
    a1z = 2 * wie1[2] + wen1[2]
    cor0 = k0[3] - (a1y * vu - a1z * vn)
    cor1 = k0[4] - (a1z * ve - a1x * vu)
    cor2 = k0[5] - (a1x * vn - a1y * ve)
    out[3] = fe - (E[0, 0] * a0 + E[1, 0] * a1 + E[2, 0] * a2) - cor0
    out[4] = fn_ - (E[0, 1] * a0 + E[1, 1] * a1 + E[2, 1] * a2) - cor1
    out[5] = (fu - (E[0, 2] * a0 + E[1, 2] * a1 + E[2, 2] * a2) - cor2
              - g0 + earth.gravity_of_sin2_nb(s1 * s1, h) - k2 * x[8])
    out[6] = v0e - ve * ((rn + h0) * c0) * irn * ic1
    out[7] = v0n - vn * (rm + h0) * irm
    out[8] = x[5] - k1 * x[8]
    for i in range(3):
        out[9 + i] = 0.0
        out[12 + i] = -itg * x[12 + i]
        out[15 + i] = -ita * x[15 + i]


@numba.njit(cache=True)
def _transition(X, T, nsub, p, C0, scale):
    """Propagate each row of X (filter units) over T seconds with the nonlinear model
    (midpoint rule: geometric for the attitude error rotation, RK2 for the rest)."""
    out = np.empty_like(X)
    hs = T / nsub
    n = X.shape[1]
    x = np.empty(n)
    xm = np.empty(n)
    d = np.empty(n)
    E = np.empty((3, 3))
    Em = np.empty((3, 3))
    tmp = np.empty((3, 3))
    R = np.empty((3, 3))
    wl = np.empty(3)
    wr = np.empty(3)
    rv = np.empty(3)
    k0 = _nominal_terms(p)
    for i in range(X.shape[0]):
        for j in range(n):
            x[j] = X[i, j] * scale[j]
        rotvec_to_dcm(-x[0], -x[1], -x[2], E)
        for _ in range(nsub):
            _rates(x, E, p, C0, d, wl, wr, k0)
            for j in range(3, n):
                xm[j] = x[j] + 0.5 * hs * d[j]
            Em[:, :] = E
            _rotate(Em, wl, wr, 0.5 * hs, tmp, R)
            _rates(xm, Em, p, C0, d, wl, wr, k0)
            for j in range(3, n):
                x[j] += hs * d[j]
            _rotate(E, wl, wr, hs, tmp, R)
        dcm_to_rotvec(E, rv)
        x[0], x[1], x[2] = -rv[0], -rv[1], -rv[2]
        for j in range(n):
            out[i, j] = x[j] / scale[j]
    return out


@numba.njit(cache=True)
def _F(p, C):
    """Continuous linear error dynamics F (SI) at the nominal ``p`` (see ``_rates``)."""
    lat, h = p[0], p[1]
    ve, vn, vu = p[2], p[3], p[4]
    fe, fn, fu = p[5], p[6], p[7]
    rm, rn, k1, k2, itg, ita = p[8], p[9], p[10], p[11], p[12], p[13]
    Rm, Rn = rm + h, rn + h
    sl, cl = np.sin(lat), np.cos(lat)
    tl = sl / cl
    om = earth.OMEGA_IE
    w = np.array([0.0, om * cl, om * sl])  # w_ie
    wen = np.array([-vn / Rm, ve / Rn, ve * tl / Rn])
    win = w + wen
    a = 2.0 * w + wen
    # d(w_ie)/d(dp), d(w_en)/d(dv), d(w_en)/d(dp) with dp = [dE, dN, dU] in metres.
    dwie = np.zeros((3, 3))
    dwie[1, 1] = -om * sl / Rm
    dwie[2, 1] = om * cl / Rm
    dwv = np.zeros((3, 3))
    dwv[0, 1] = -1.0 / Rm
    dwv[1, 0] = 1.0 / Rn
    dwv[2, 0] = tl / Rn
    dwp = np.zeros((3, 3))
    dwp[0, 2] = vn / Rm**2
    dwp[1, 2] = -ve / Rn**2
    dwp[2, 1] = ve / (cl**2 * Rn * Rm)
    dwp[2, 2] = -ve * tl / Rn**2
    V = np.array([[0.0, -vu, vn], [vu, 0.0, -ve], [-vn, ve, 0.0]])
    F = np.zeros((18, 18))
    # Attitude: phi' = -w_in x phi + dw_in - C eps.
    F[0, 1], F[0, 2], F[1, 0], F[1, 2], F[2, 0], F[2, 1] = (
        win[2], -win[1], -win[2], win[0], win[1], -win[0])
    F[0:3, 3:6] = dwv
    F[0:3, 6:9] = dwie + dwp
    F[0:3, 9:12] = -C
    F[0:3, 12:15] = -C
    # Velocity: dv' = f x phi + C nabla - (2 w_ie + w_en) x dv + v x (2 dw_ie + dw_en) + dg.
    F[3, 1], F[3, 2], F[4, 0], F[4, 2], F[5, 0], F[5, 1] = -fu, fn, fu, -fe, -fn, fe
    F[3:6, 3:6] = V @ dwv
    F[3, 4] += a[2]
    F[3, 5] -= a[1]
    F[4, 3] -= a[2]
    F[4, 5] += a[0]
    F[5, 3] += a[1]
    F[5, 4] -= a[0]
    F[3:6, 6:9] = V @ (2.0 * dwie + dwp)
    F[5, 8] += earth.gravity_gradient_nb(lat, h) - k2
    F[5, 7] -= earth.gravity_dlat_nb(lat) / Rm
    F[3:6, 15:18] = C
    # Position (metres).
    F[6, 3] = 1.0
    F[6, 7] = ve * tl / Rm
    F[6, 8] = -ve / Rn
    F[7, 4] = 1.0
    F[7, 8] = -vn / Rm
    F[8, 5] = 1.0
    F[8, 8] = -k1
    for i in range(3):
        F[12 + i, 12 + i] = -itg
        F[15 + i, 15 + i] = -ita
    return F


@numba.njit(cache=True)
def _Qc(p, C, q):
    """Continuous process-noise density (SI); q = [arw, vrw, gyro GM sigma, accel GM sigma,
    baro noise density, gyro bias random walk, accel bias random walk]."""
    k1, k2, itg, ita = p[10], p[11], p[12], p[13]
    Q = np.zeros((18, 18))
    Q[0:3, 0:3] = q[0] ** 2 * (C @ C.T)
    Q[3:6, 3:6] = q[1] ** 2 * (C @ C.T)
    Q[5, 5] += k2**2 * q[4]
    Q[8, 8] += k1**2 * q[4]
    Q[5, 8] = k1 * k2 * q[4]
    Q[8, 5] = Q[5, 8]
    for i in range(3):
        Q[9 + i, 9 + i] = q[5] ** 2
        Q[12 + i, 12 + i] = 2.0 * q[2] ** 2 * itg
        Q[15 + i, 15 + i] = 2.0 * q[3] ** 2 * ita + q[6] ** 2
    return Q


@numba.njit(cache=True)
def _discretize(p, C, q, T, scale):
    """Phi (4th-order Taylor over T/2, squared) and Qd (trapezoid), in filter units."""
    F = _F(p, C)
    Qc = _Qc(p, C, q)
    A = F * (0.5 * T)
    A2 = matmul_sparse(A, A)
    half = np.eye(18) + A + matmul_sparse(A2, np.eye(18) / 2.0 + A / 6.0 + A2 / 24.0)
    Phi = matmul_sparse(half, half)
    Qd = 0.5 * (matmul_sparse(Phi, matmul_sparse(Qc, Phi.T)) + Qc) * T
    for i in range(18):
        for j in range(18):
            Phi[i, j] *= scale[j] / scale[i]
            Qd[i, j] /= scale[i] * scale[j]
    return Phi, 0.5 * (Qd + Qd.T)


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


def model_constants(noise: ImuNoiseModel, baro_gains=(0.0, 0.0), baro_q: float = 0.0):
    """What the compiled model functions read besides the nominal point: baro loop gains
    k1, k2, inverse Markov times 1/tau_g, 1/tau_a [1/s] (0 for a constant bias) and the
    noise vector of ``_Qc``."""
    itg = 0.0 if np.isinf(noise.gyro_markov_tau) else 1.0 / noise.gyro_markov_tau
    ita = 0.0 if np.isinf(noise.accel_markov_tau) else 1.0 / noise.accel_markov_tau
    vec = np.array([noise.gyro_arw, noise.accel_vrw, noise.gyro_markov_sigma,
                    noise.accel_markov_sigma, float(baro_q), noise.gyro_bias_rw,
                    noise.accel_bias_rw])
    return float(baro_gains[0]), float(baro_gains[1]), itg, ita, vec


class ErrorProcess:
    """The error model over one interval ``T``: Phi, Qd and the nonlinear transition.

    Everything returned is in filter units (see :data:`SCALE`).
    """

    def __init__(self, nom: Nominal, T: float, noise: ImuNoiseModel,
                 baro_gains=(0.0, 0.0), baro_q: float = 0.0, nsub: int = 2):
        self._set_model(T, noise, baro_gains, baro_q, nsub)
        v, f = np.asarray(nom.vel, float), np.asarray(nom.fn, float)
        params = _nominal_params(float(nom.lat), float(nom.h), v[0], v[1], v[2], f[0], f[1],
                                 f[2], self.k1, self.k2, self.itg, self.ita)
        C0 = np.ascontiguousarray(nom.C, dtype=float)
        self._set_nominal(params, C0, *_discretize(params, C0, self._noise, self.T, SCALE), nom)

    @classmethod
    def of_interval(cls, s0, s1, dv_sum, T: float, noise: ImuNoiseModel,
                    baro_gains=(0.0, 0.0), baro_q: float = 0.0, nsub: int = 2):
        """The model linearised at the middle of an INS interval (see
        :func:`interval_process`): nominal point, Phi and Qd in one compiled call."""
        self = cls.__new__(cls)
        self._set_model(T, noise, baro_gains, baro_q, nsub)
        self._set_nominal(*_interval(np.asarray(s0, dtype=float), np.asarray(s1, dtype=float),
                                     np.asarray(dv_sum, dtype=float), self.T, self.k1,
                                     self.k2, self.itg, self.ita, self._noise, SCALE))
        return self

    def _set_model(self, T, noise, baro_gains, baro_q, nsub) -> None:
        self.T, self.noise, self.nsub = float(T), noise, int(nsub)
        self.baro_q = float(baro_q)
        self.k1, self.k2, self.itg, self.ita, self._noise = model_constants(noise, baro_gains,
                                                                            baro_q)

    def _set_nominal(self, params, C0, Phi, Qd, nom: Nominal | None = None) -> None:
        self._params, self._C0, self.Phi, self.Qd = params, C0, Phi, Qd
        self.rm, self.rn = params[8], params[9]
        self.nom = nom if nom is not None else Nominal(
            lat=params[0], h=params[1], vel=params[2:5].copy(), C=C0, fn=params[5:8].copy())

    # ------------------------------------------------------------------ SI models
    def F_si(self) -> np.ndarray:
        """Continuous-time linear error dynamics (SI units)."""
        return _F(self._params, self._C0)

    def Qc_si(self) -> np.ndarray:
        """Continuous process-noise spectral density (SI units)."""
        return _Qc(self._params, self._C0, self._noise)

    # ------------------------------------------------------------ filter interface
    def transition(self, X: np.ndarray) -> np.ndarray:
        """Nonlinear propagation of state rows ``X`` (S, 18) in filter units over T."""
        X = np.ascontiguousarray(np.atleast_2d(X), dtype=float)
        return _transition(X, self.T, self.nsub, self._params, self._C0, SCALE)

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


def interval_process(s0, s1, dv_sum, T: float, noise: ImuNoiseModel, baro_gains=(0.0, 0.0),
                     baro_q: float = 0.0, nsub: int = 2) -> ErrorProcess:
    """The error model over one filter interval of the strapdown INS, linearised at the
    interval's midpoint: ``s0``, ``s1`` the INS state (:mod:`fednav.strapdown` layout)
    at its start and end, ``dv_sum`` the compensated velocity increments summed over it
    (body, m/s).  One compiled call builds the nominal point, Phi and Qd."""
    return ErrorProcess.of_interval(s0, s1, dv_sum, T, noise, baro_gains, baro_q, nsub)


@numba.njit(cache=True)
def _nominal_params(lat, h, ve, vn, vu, fe, fn, fu, k1, k2, itg, ita):
    """The nominal-point vector the compiled model functions read (see ErrorProcess)."""
    rm, rn = earth.radii_nb(lat)
    return np.array([lat, h, ve, vn, vu, fe, fn, fu, rm, rn, k1, k2, itg, ita,
                     earth.gravity_nb(lat, h)])


@numba.njit(cache=True)
def _interval(s0, s1, dv_sum, T, k1, k2, itg, ita, noise, scale):
    """Nominal parameters, C_b^n, Phi and Qd of one INS interval (see interval_process)."""
    qm = s0[0:4] + s1[0:4]
    Cm = _quat_to_dcm(qm / np.sqrt(qm @ qm))
    lat = 0.5 * (s0[7] + s1[7])
    h = 0.5 * (s0[9] + s1[9])
    f = Cm @ dv_sum / T
    params = _nominal_params(lat, h, 0.5 * (s0[4] + s1[4]), 0.5 * (s0[5] + s1[5]),
                             0.5 * (s0[6] + s1[6]), f[0], f[1], f[2], k1, k2, itg, ita)
    Phi, Qd = _discretize(params, Cm, noise, T, scale)
    return params, Cm, Phi, Qd


def apply_feedback(ins, dx) -> tuple[np.ndarray, np.ndarray]:
    """Remove the estimated errors ``dx`` (filter units) from the INS ``ins``; returns the
    gyro [rad/s] and accelerometer [m/s^2] corrections to add to the IMU compensation."""
    d = to_si(dx)
    ins.correct(d[PHI], d[DV], d[DP])
    return d[EPS_C] + d[EPS_R], d[NABLA]
