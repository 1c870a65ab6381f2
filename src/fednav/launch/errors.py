"""Error-state model of the launch-frame SINS, its exact nonlinear propagation (particle
transition) and linearisation (EKF), and the GNSS and star-sensor measurement models.

State (15, in *filter units* for conditioning; :data:`SCALE` converts to SI):

====  =================================  ===========  ============================
idx   quantity                           filter unit  definition
====  =================================  ===========  ============================
0:3   attitude error phi (LI axes)       arcsec       C_hat = exp(-[phi x]) C
3:6   position error dr (LI)             m            r_hat - r
6:9   velocity error dv (LI)             m/s          v_hat - v
9:12  residual gyro bias eps (body)      deg/h        true bias - compensated bias
12:15 residual accel bias nabla (body)   mg           true bias - compensated bias
====  =================================  ===========  ============================

With ``E = C_hat C' = exp(-[phi x])`` and the compensated IMU outputs
``omega_used = omega + eps + w_g``, ``f_used = f + nabla + w_a`` (LI is inertial: no
Earth or transport rate) the exact error dynamics are::

    E'   = [u x] E,                u = C_hat (eps + w_g)
    dv'  = (I - E') C_hat f_used + E' C_hat (nabla + w_a) + g(r_hat) - g(r_hat - dr)
    dr'  = dv,    eps' = w_eps,    nabla' = w_nabla

(``E'`` on the right is the transpose).  Over one filter interval ``T`` the particle
transition integrates them with the nominal SINS's summed LI specific-force increment
``int C_hat f_used dt`` (and its integral, for position) and its attitude and position at
the interval's middle: the
attitude error is composed as a rotation (every particle stays a valid rotation, any
size), the velocity term keeps ``I - E'`` exact and the gravitation difference is the
full zonal model.  Linearising (``E ~ I - [phi x]``) gives the EKF's
``phi' = -C_hat eps``, ``dv' = [f_li x] phi + G dr + C_hat nabla`` with the gravity
gradient ``G``.  The two filters therefore share one model and differ only in the
linearisation — the question paper 001 asks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from ..core import units
from ..core.kernels import dcm_to_rotvec, quat_to_dcm, quat_to_dcm_s
from ..core.kernels import quat_mul_s as _qmul
from ..core.kernels import quat_to_rotvec_s as _q2rv
from ..core.kernels import rotvec_to_quat_s as _rv2q
from .frame import LaunchFrame, gravitation_li_xyz

N_STATES = 15
PHI, POS, VEL, GYRO, ACC = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12),
                            slice(12, 15))
#: Filter unit -> SI multiplier of each state.
SCALE = np.concatenate([np.full(3, units.ARCSEC), np.ones(3), np.ones(3),
                        np.full(3, float(units.deg_per_h(1.0))),
                        np.full(3, float(units.milli_g(1.0)))])
STATE_NAMES = ("phi_x", "phi_y", "phi_z", "dr_x", "dr_y", "dr_z", "dv_x", "dv_y", "dv_z",
               "eps_x", "eps_y", "eps_z", "nabla_x", "nabla_y", "nabla_z")


@numba.njit(cache=True)
def _transition(X, S, C, dvli, dsli, r_mid, T, r0, Ce, degree):
    """Exact interval propagation of every particle (rows of X, filter units)."""
    n = X.shape[0]
    out = np.empty_like(X)
    g0, g1, g2 = gravitation_li_xyz(r_mid[0], r_mid[1], r_mid[2], r0, Ce, degree)
    for i in range(n):
        # Rotation increment of E in LI: u = C_hat eps T; E(t0) = exp(-[phi x]).
        e0, e1, e2 = X[i, 9] * S[9], X[i, 10] * S[10], X[i, 11] * S[11]
        u0 = T * (C[0, 0] * e0 + C[0, 1] * e1 + C[0, 2] * e2)
        u1 = T * (C[1, 0] * e0 + C[1, 1] * e1 + C[1, 2] * e2)
        u2 = T * (C[2, 0] * e0 + C[2, 1] * e1 + C[2, 2] * e2)
        a0, a1, a2, a3 = _rv2q(-X[i, 0] * S[0], -X[i, 1] * S[1], -X[i, 2] * S[2])
        b0, b1, b2, b3 = _rv2q(u0, u1, u2)
        c0, c1, c2, c3 = _qmul(b0, b1, b2, b3, a0, a1, a2, a3)       # E(t1)
        p0, p1, p2 = _q2rv(c0, c1, c2, c3)
        b0, b1, b2, b3 = _rv2q(0.5 * u0, 0.5 * u1, 0.5 * u2)
        w, x, y, z = _qmul(b0, b1, b2, b3, a0, a1, a2, a3)             # E at the middle
        m00, m01, m02, m10, m11, m12, m20, m21, m22 = quat_to_dcm_s(w, x, y, z)
        # C_hat nabla T (LI).
        n0, n1, n2 = X[i, 12] * S[12], X[i, 13] * S[13], X[i, 14] * S[14]
        f0 = T * (C[0, 0] * n0 + C[0, 1] * n1 + C[0, 2] * n2)
        f1 = T * (C[1, 0] * n0 + C[1, 1] * n1 + C[1, 2] * n2)
        f2 = T * (C[2, 0] * n0 + C[2, 1] * n1 + C[2, 2] * n2)
        # (I - Em') dvli + Em' (C_hat nabla T)
        d0 = dvli[0] - f0
        d1 = dvli[1] - f1
        d2 = dvli[2] - f2
        k0 = dvli[0] - (m00 * d0 + m10 * d1 + m20 * d2)
        k1 = dvli[1] - (m01 * d0 + m11 * d1 + m21 * d2)
        k2 = dvli[2] - (m02 * d0 + m12 * d1 + m22 * d2)
        # The same for position: (I - Em') int int C_hat f + Em' C_hat nabla T^2 / 2.
        d0 = dsli[0] - 0.5 * T * f0
        d1 = dsli[1] - 0.5 * T * f1
        d2 = dsli[2] - 0.5 * T * f2
        s0 = dsli[0] - (m00 * d0 + m10 * d1 + m20 * d2)
        s1 = dsli[1] - (m01 * d0 + m11 * d1 + m21 * d2)
        s2 = dsli[2] - (m02 * d0 + m12 * d1 + m22 * d2)
        # Gravitation difference at the middle of the interval.
        q0 = X[i, 3] + 0.5 * T * X[i, 6]
        q1 = X[i, 4] + 0.5 * T * X[i, 7]
        q2 = X[i, 5] + 0.5 * T * X[i, 8]
        h0, h1, h2 = gravitation_li_xyz(r_mid[0] - q0, r_mid[1] - q1, r_mid[2] - q2,
                                        r0, Ce, degree)
        v0 = X[i, 6] + k0 + (g0 - h0) * T
        v1 = X[i, 7] + k1 + (g1 - h1) * T
        v2 = X[i, 8] + k2 + (g2 - h2) * T
        out[i, 0], out[i, 1], out[i, 2] = -p0 / S[0], -p1 / S[1], -p2 / S[2]
        out[i, 3] = X[i, 3] + T * X[i, 6] + s0 + 0.5 * T * T * (g0 - h0)
        out[i, 4] = X[i, 4] + T * X[i, 7] + s1 + 0.5 * T * T * (g1 - h1)
        out[i, 5] = X[i, 5] + T * X[i, 8] + s2 + 0.5 * T * T * (g2 - h2)
        out[i, 6], out[i, 7], out[i, 8] = v0, v1, v2
        for j in range(9, 15):
            out[i, j] = X[i, j]
    return out


@numba.njit(cache=True)
def _gravity_gradient(r, r0, Ce, degree, step):
    G = np.empty((3, 3))
    for j in range(3):
        a = r.copy()
        b = r.copy()
        a[j] += step
        b[j] -= step
        ga = gravitation_li_xyz(a[0], a[1], a[2], r0, Ce, degree)
        gb = gravitation_li_xyz(b[0], b[1], b[2], r0, Ce, degree)
        for i in range(3):
            G[i, j] = (ga[i] - gb[i]) / (2.0 * step)
    return G


def gravity_gradient(frame: LaunchFrame, r_li, step: float = 10.0) -> np.ndarray:
    """d g_li / d r_li (3, 3) [1/s^2] by central differences of the zonal model."""
    return _gravity_gradient(np.ascontiguousarray(r_li, dtype=float),
                             np.ascontiguousarray(frame.r0_eci),
                             np.ascontiguousarray(frame.C_eci_li), int(frame.degree),
                             float(step))


@numba.njit(cache=True)
def misalignment_nb(C_true, C_hat):
    """phi with C_hat = exp(-[phi x]) C_true [rad] for one attitude, compiled (the
    rotation of :func:`fednav.core.kernels.dcm_to_rotvec`, as
    :func:`fednav.core.attitude.misalignment` for arrays)."""
    M = C_hat @ C_true.T
    out = np.empty(3)
    dcm_to_rotvec(M, out)
    return -out


@dataclass(frozen=True)
class ImuNoise:
    """Continuous noise densities (SI): gyro ARW [rad/sqrt(s)], accel VRW [m/s/sqrt(s)],
    bias random walks [rad/s/sqrt(s)], [m/s^2/sqrt(s)]."""

    gyro_arw: float
    accel_vrw: float
    gyro_bias_rw: float
    accel_bias_rw: float


class LaunchProcess:
    """Time update over one filter interval ``T`` [s] around the nominal SINS.

    ``aux``: the nominal's interval summary (:meth:`LaunchStrapdown.interval`).
    ``transition(X)`` propagates particles (rows, filter units) exactly; ``Phi`` and
    ``Qd`` are the EKF's transition matrix and discrete noise (filter units).
    """

    def __init__(self, frame: LaunchFrame, aux: np.ndarray, T: float, noise: ImuNoise):
        self.frame, self.T = frame, float(T)
        self.dvli = np.ascontiguousarray(aux[0:3])
        self.dsli = np.ascontiguousarray(aux[13:16])
        self.C = quat_to_dcm(np.ascontiguousarray(aux[3:7]))
        self.r_mid = np.ascontiguousarray(aux[7:10])
        self._consts = (np.ascontiguousarray(frame.r0_eci),
                        np.ascontiguousarray(frame.C_eci_li), int(frame.degree))
        F = np.zeros((N_STATES, N_STATES))
        F[PHI, GYRO] = -self.C
        F[VEL, PHI] = _skew(self.dvli / self.T)
        F[VEL, POS] = gravity_gradient(frame, self.r_mid)
        F[VEL, ACC] = self.C
        F[POS, VEL] = np.eye(3)
        Ff = F * SCALE[None, :] / SCALE[:, None]
        A = Ff * self.T
        self.Phi = np.eye(N_STATES) + A + A @ A / 2.0 + A @ A @ A / 6.0
        # Attitude coupling from the interval's actual specific force (not its average).
        self.Phi[POS, PHI] = _skew(self.dsli) * SCALE[PHI][None, :] / SCALE[POS][:, None]
        q = np.zeros(N_STATES)
        q[PHI] = noise.gyro_arw**2
        q[VEL] = noise.accel_vrw**2
        q[GYRO] = noise.gyro_bias_rw**2
        q[ACC] = noise.accel_bias_rw**2
        Gn = np.eye(N_STATES)
        Gn[PHI, PHI] = -self.C
        Gn[VEL, VEL] = self.C
        Qc = (Gn * q) @ Gn.T / np.outer(SCALE, SCALE)
        Qd = 0.5 * (self.Phi @ Qc @ self.Phi.T + Qc) * self.T
        self.Qd = 0.5 * (Qd + Qd.T)

    def transition(self, X) -> np.ndarray:
        X = np.ascontiguousarray(X, dtype=float)
        return _transition(X, SCALE, self.C, self.dvli, self.dsli, self.r_mid, self.T,
                           *self._consts)


def _skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


# --- measurement models ------------------------------------------------------------------
class GnssPositionLI:
    """GNSS position converted to LI: ``y = r_hat - r_gnss`` [m] = dr + noise.

    ``outlier_probability`` p and ``outlier_scale`` k: the particle filter's likelihood is
    the mixture ``(1 - p) N(0, R) + p N(0, k^2 R)`` (a heavy-tailed receiver); p = 0 is
    the Gaussian likelihood every filter uses.
    """

    Hmat = np.zeros((3, N_STATES))
    Hmat[:, POS] = np.eye(3)

    def __init__(self, outlier_probability: float = 0.0, outlier_scale: float = 1.0):
        self.p, self.k = float(outlier_probability), float(outlier_scale)
        if self.p > 0:
            self.loglik = self._mixture

    @staticmethod
    def residual(state, z) -> np.ndarray:
        """``y`` from the INS state (:mod:`fednav.launch.strapdown` layout) and the fix in
        LI [m]."""
        return state[7:10] - z

    def h(self, X, nav=None):
        return np.atleast_2d(X)[:, POS]

    def H(self, nav=None):
        return self.Hmat

    def _mixture(self, y, X, nav, R):
        L = np.linalg.cholesky(R)
        E = np.linalg.solve(L, (y - X[:, POS]).T)
        d2 = (E * E).sum(axis=0)
        m = len(y)
        a = np.log1p(-self.p) - 0.5 * d2
        b = math.log(self.p) - m * math.log(self.k) - 0.5 * d2 / self.k**2
        return np.logaddexp(a, b)


@numba.njit(cache=True)
def _star_loglik(y, X, S, Rinv):
    """Exact star-sensor log-likelihood: the noise rotation n with
    exp(-[n x]) = exp([phi_i x]) exp(-[y x]) for every particle, Gaussian with R."""
    n = X.shape[0]
    out = np.empty(n)
    b0, b1, b2, b3 = _rv2q(-y[0] * S[0], -y[1] * S[1], -y[2] * S[2])
    for i in range(n):
        a0, a1, a2, a3 = _rv2q(X[i, 0] * S[0], X[i, 1] * S[1], X[i, 2] * S[2])
        c0, c1, c2, c3 = _qmul(a0, a1, a2, a3, b0, b1, b2, b3)
        r0, r1, r2 = _q2rv(c0, c1, c2, c3)
        r0, r1, r2 = r0 / S[0], r1 / S[1], r2 / S[2]
        out[i] = -0.5 * (r0 * (Rinv[0, 0] * r0 + Rinv[0, 1] * r1 + Rinv[0, 2] * r2)
                         + r1 * (Rinv[1, 0] * r0 + Rinv[1, 1] * r1 + Rinv[1, 2] * r2)
                         + r2 * (Rinv[2, 0] * r0 + Rinv[2, 1] * r1 + Rinv[2, 2] * r2))
    return out


class StarAttitudeLI:
    """Star-sensor attitude in LI: ``y = phi_obs`` [arcsec] with
    ``C_hat = exp(-[phi_obs x]) C_star`` (= phi + noise to first order); the particle filter
    evaluates the exact rotation-composed likelihood (:func:`_star_loglik`)."""

    Hmat = np.zeros((3, N_STATES))
    Hmat[:, PHI] = np.eye(3)

    @staticmethod
    def observe(C_hat, C_star) -> np.ndarray:
        """The observation ``phi_obs`` [arcsec] from the INS and star-sensor attitudes."""
        return misalignment_nb(np.ascontiguousarray(C_star, dtype=float),
                               np.ascontiguousarray(C_hat, dtype=float)) / units.ARCSEC

    @classmethod
    def residual(cls, state, z) -> np.ndarray:
        """``y`` from the INS state and the star sensor's C_b^li (row-major, 9 values)."""
        return cls.observe(quat_to_dcm(np.ascontiguousarray(state[0:4])), z.reshape(3, 3))

    def h(self, X, nav=None):
        return np.atleast_2d(X)[:, PHI]

    def H(self, nav=None):
        return self.Hmat

    def loglik(self, y, X, nav, R):
        return _star_loglik(np.ascontiguousarray(y, dtype=float),
                            np.ascontiguousarray(X, dtype=float), SCALE,
                            np.linalg.inv(R))


def __getattr__(name: str):
    """0.1's name of the GNSS model, for one more release."""
    if name == "GpsPosition":
        import warnings

        warnings.warn("fednav.launch.errors.GpsPosition is now GnssPositionLI",
                      FutureWarning, stacklevel=2)
        return GnssPositionLI
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
