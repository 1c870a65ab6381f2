"""Unscented Kalman filter: scaled symmetric sigma points, additive noise.

Sigma points ``x``, ``x +- sqrt((n + lam) P)_i`` (columns of the lower Cholesky factor),
``lam = alpha^2 (n + kappa) - n``; weights ``Wm0 = lam / (n + lam)``,
``Wc0 = Wm0 + 1 - alpha^2 + beta``, ``Wi = 1 / (2 (n + lam))`` (paper 002, section 1.2).

The measurement update redraws its sigma points from the predicted (x, P), so the
process noise Q is seen by the measurement (as FilterPy >= 1.4 does).
"""

from __future__ import annotations

import numpy as np

from .base import Filter, Innovation, chol, solve_spd


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
        x = self.x if x is None else x
        P = self.P if P is None else P
        L = chol(self.c * P, self._who(phase))
        return np.vstack([x, x + L.T, x - L.T])

    def _moments(self, Y):
        y = self.Wm @ Y
        d = Y - y
        return y, d, (d * self.Wc[:, None]).T @ d

    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        X = self.sigma_points(phase="predict")
        Xf = process.transition(X)
        self.x, _, P = self._moments(Xf)
        self.P = P + q_scale * process.Qd
        self._finish("predict")

    def update(self, y, model, nav=None, R=None) -> Innovation:
        X = self.sigma_points(phase="update")
        Z = model.h(X, nav)
        z_hat, dz, Pzz = self._moments(Z)
        Pzz = Pzz + R
        Pzz = 0.5 * (Pzz + Pzz.T)
        dx = X - self.Wm @ X
        Pxz = (dx * self.Wc[:, None]).T @ dz
        K = solve_spd(Pzz, Pxz.T, self._who("update")).T
        r = np.asarray(y, dtype=float) - z_hat
        self.x = self.x + K @ r
        self.P = self.P - K @ Pzz @ K.T
        self._finish("update")
        return Innovation(r, Pzz, float(r @ solve_spd(Pzz, r, self._who("update"))))
