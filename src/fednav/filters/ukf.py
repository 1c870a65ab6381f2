"""Unscented Kalman filter: scaled symmetric sigma points, additive noise.

Sigma points ``x``, ``x +- sqrt((n + lam) P)_i`` (columns of the lower Cholesky factor),
``lam = alpha^2 (n + kappa) - n``; weights ``Wm0 = lam / (n + lam)``,
``Wc0 = Wm0 + 1 - alpha^2 + beta``, ``Wi = 1 / (2 (n + lam))`` (paper 002, section 1.2).

The measurement update redraws its sigma points from the predicted (x, P), so the
process noise Q is seen by the measurement (as FilterPy >= 1.4 does).  The linear algebra
of both steps runs in numba kernels; only the user's process and measurement functions
(called once per step on all sigma points) run in Python.
"""

from __future__ import annotations

import numba
import numpy as np

from ..core.kernels import cholesky_lower
from .base import Filter, FilterError, Innovation, not_pd_error
from .kf import KalmanFilter


@numba.njit(cache=True)
def sigma_points(x, P, c):
    """Rows: x, x + L[:, i], x - L[:, i] with L L' = c P; empty array if not PD."""
    n = x.shape[0]
    L, ok = cholesky_lower(c * P)
    if not ok:
        return np.empty((0, n))
    X = np.empty((2 * n + 1, n))
    X[0] = x
    for i in range(n):
        for j in range(n):
            X[1 + i, j] = x[j] + L[j, i]
            X[1 + n + i, j] = x[j] - L[j, i]
    return X


@numba.njit(cache=True)
def predict_moments(Y, Wm, Wc, Q):
    y = Wm @ Y
    D = Y - y
    P = (D * Wc.reshape(-1, 1)).T @ D + Q
    P = 0.5 * (P + P.T)
    return y, P, np.isfinite(y.sum() + P.sum())


@numba.njit(cache=True)
def sigma_update(X, Z, Wm, Wc, x, P, y, R):
    """UKF measurement update; returns x, P, r, Pzz, nis and an ok flag."""
    z_hat = Wm @ Z
    dz = Z - z_hat
    dx = X - Wm @ X
    WdZ = dz * Wc.reshape(-1, 1)
    Pzz = WdZ.T @ dz + R
    Pzz = 0.5 * (Pzz + Pzz.T)
    Pxz = (dx * Wc.reshape(-1, 1)).T @ dz
    m = Pzz.shape[0]
    for i in range(m):
        if not (Pzz[i, i] > 0.0):
            return x, P, z_hat, Pzz, 0.0, False
    Linv = np.linalg.inv(np.linalg.cholesky(Pzz))
    Sinv = Linv.T @ Linv
    K = Pxz @ Sinv
    r = y - z_hat
    xn = x + K @ r
    Pn = P - K @ Pzz @ K.T
    Pn = 0.5 * (Pn + Pn.T)
    nis = r @ Sinv @ r
    return xn, Pn, r, Pzz, nis, True


class UnscentedKalmanFilter(Filter):
    def __init__(self, x0, P0, name: str = "ukf", alpha: float = 1e-3, beta: float = 2.0,
                 kappa: float = 0.0):
        super().__init__(x0, P0, name)
        n = self.n
        self.alpha, self.beta, self.kappa = alpha, beta, kappa
        lam = alpha**2 * (n + kappa) - n
        self.c = n + lam
        if self.c <= 0:
            raise ValueError(f"{name}: alpha^2 (n + kappa) must be positive")
        self.Wm = np.full(2 * n + 1, 0.5 / self.c)
        self.Wc = self.Wm.copy()
        self.Wm[0] = lam / self.c
        self.Wc[0] = lam / self.c + 1.0 - alpha**2 + beta

    def sigma_points(self, x=None, P=None, phase: str = "sigma points") -> np.ndarray:
        x = self.x if x is None else np.asarray(x, dtype=float)
        P = self.P if P is None else np.asarray(P, dtype=float)
        X = sigma_points(x, P, self.c)
        if X.shape[0] == 0:
            raise not_pd_error(P, self._who(phase))
        return X

    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        X = self.sigma_points(phase="predict")
        Xf = np.ascontiguousarray(process.transition(X), dtype=float)
        Q = process.Qd if q_scale == 1.0 else q_scale * process.Qd
        self.x, self.P, ok = predict_moments(Xf, self.Wm, self.Wc, np.asarray(Q, dtype=float))
        if not ok:
            raise FilterError(f"{self._who('predict')}: state or covariance became NaN/inf")

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        X = self.sigma_points(phase="update")
        Z = np.ascontiguousarray(model.h(X, nav), dtype=float)
        return self._sigma_update(X, Z, y, R, gate)

    def _sigma_update(self, X, Z, y, R, gate) -> Innovation:
        """The measurement update from the points ``X`` and their predicted measurements
        ``Z`` (the square-root form has its own)."""
        return self._accept(*sigma_update(X, Z, self.Wm, self.Wc, self.x, self.P,
                                     np.asarray(y, dtype=float), np.asarray(R, dtype=float)),
                            gate)

    def _accept(self, x, P, r, Pzz, nis, ok, gate) -> Innovation:
        """Finish an update computed by ``sigma_update``: a clear error if its innovation
        covariance was not positive definite, the gate, then the new estimate (whose
        covariance must be positive definite)."""
        if not ok or not np.isfinite(nis):
            raise FilterError(f"{self._who('update')}: innovation covariance not positive "
                              f"definite")
        if gate is not None and nis > gate:
            return Innovation(r, Pzz, float(nis), False)
        self.x, self.P = x, P
        self._finish("update", symmetrize=False, check_pd=True)
        return Innovation(r, Pzz, float(nis))


class SimplifiedUKF(UnscentedKalmanFilter):
    """UKF time update with the linear Kalman measurement update (paper 003, section 2.1).

    For a linear measurement ``z = H x + v`` the sigma points of the measurement update
    add nothing: ``z_hat = H x``, ``Pzz = H P H' + R``, ``Pxz = P H'`` give the same result
    as the full UKF at the cost of one small matrix product.  Uses ``model.H`` only; the
    covariance update is the Joseph form of :class:`~fednav.filters.kf.KalmanFilter`.
    """

    update = KalmanFilter.update
