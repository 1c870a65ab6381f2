"""Linear / extended Kalman filter with the Joseph-form covariance update."""

from __future__ import annotations

import numba
import numpy as np

from ..core.kernels import spd_inverse
from .base import Filter, FilterError, Innovation, chol


@numba.njit(cache=True)
def propagate_cov(Phi, P, Q, q_scale):
    """Phi P Phi' + q_scale Q, symmetrised; ok False if it is not finite."""
    Pn = Phi @ P @ Phi.T + q_scale * Q
    Pn = 0.5 * (Pn + Pn.T)
    return Pn, np.isfinite(Pn.sum())


@numba.njit(cache=True)
def joseph_update(x, P, H, r, R):
    """K = P H' S^-1, x + K r, P = (I - K H) P (I - K H)' + K R K'; returns
    (x, P, S, r' S^-1 r, ok)."""
    PHt = P @ H.T
    S = H @ PHt + R
    S = 0.5 * (S + S.T)
    Sinv, ok = spd_inverse(S)
    if not ok:
        return x, P, S, 0.0, False
    K = PHt @ Sinv
    IKH = np.eye(x.shape[0]) - K @ H
    Pn = IKH @ P @ IKH.T + K @ R @ K.T
    return x + K @ r, 0.5 * (Pn + Pn.T), S, r @ Sinv @ r, True


class KalmanFilter(Filter):
    """KF / EKF.

    The mean goes through ``process.transition`` and ``model.h`` (so a nonlinear model
    gives the EKF and a linear one the KF); the covariance through ``Phi`` and ``H``.
    Update: ``K = P H' S^-1``, ``P = (I - K H) P (I - K H)' + K R K'`` (Joseph form).
    """

    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        self.x = process.transition(self.x[None])[0]
        self.P, ok = propagate_cov(np.ascontiguousarray(process.Phi, dtype=float), self.P,
                                np.ascontiguousarray(process.Qd, dtype=float), q_scale)
        if not ok or not np.all(np.isfinite(self.x)):
            raise FilterError(f"{self._who('predict')}: state or covariance became NaN/inf")
        chol(self.P, self._who("predict"))  # (a gated update that is not applied checks
        # nothing: an indefinite prediction is said here)

    def _hph(self, H) -> np.ndarray:
        """``H P H'`` (the square-root form computes it from its factor)."""
        return H @ self.P @ H.T

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        H = np.ascontiguousarray(model.H(nav), dtype=float)
        # a linear model (h(x) = H x) needs no second evaluation of its Jacobian
        yhat = H @ self.x if getattr(model, "linear", False) else model.h(self.x[None], nav)[0]
        r = np.asarray(y, dtype=float) - yhat
        x, P, S, nis, ok = joseph_update(self.x, self.P, H, r, np.asarray(R, dtype=float))
        if not ok:
            raise FilterError(f"{self._who('update')}: innovation covariance not positive "
                              f"definite")
        if gate is not None and nis > gate:
            return Innovation(r, S, nis, False)
        self.x, self.P = x, P
        self._finish("update", symmetrize=False, check_pd=True)
        return Innovation(r, S, nis)
