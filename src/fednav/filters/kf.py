"""Linear / extended Kalman filter with the Joseph-form covariance update."""

from __future__ import annotations

import numpy as np

from .base import Filter, Innovation, solve_spd


class KalmanFilter(Filter):
    """KF / EKF.

    The mean goes through ``process.transition`` and ``model.h`` (so a nonlinear model
    gives the EKF and a linear one the KF); the covariance through ``Phi`` and ``H``.
    Update: ``K = P H' S^-1``, ``P = (I - K H) P (I - K H)' + K R K'`` (Joseph form).
    """

    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        self.x = process.transition(self.x[None])[0]
        Phi = process.Phi
        self.P = Phi @ self.P @ Phi.T + q_scale * process.Qd
        self._finish("predict")

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        H = model.H(nav)
        y_hat = model.h(self.x[None], nav)[0]
        r = np.asarray(y, dtype=float) - y_hat
        PHt = self.P @ H.T
        S = H @ PHt + R
        S = 0.5 * (S + S.T)
        who = self._who("update")
        nis = float(r @ solve_spd(S, r, who))
        if gate is not None and nis > gate:
            return Innovation(r, S, nis, False)
        K = solve_spd(S, PHt.T, who).T
        self.x = self.x + K @ r
        IKH = np.eye(self.n) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self._finish("update")
        return Innovation(r, S, nis)
