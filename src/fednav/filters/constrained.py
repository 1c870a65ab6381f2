"""Linear equality constraints ``D x = d`` by estimate projection (paper 000, CUKF step 5).

``x~ = argmin (x - x^)' Sigma^-1 (x - x^)  s.t.  D x = d``, with ``Sigma = P``::

    K  = P D' (D P D')^-1
    x~ = x^ - K (D x^ - d)                                  (paper 000, eq. 27)
    P~ = (I - K D) P (I - K D)' + K R_d K'

Theorem 1 of the paper: ``x~`` is unbiased when the constraint holds for the truth.
Theorem 2: with an exact constraint (``R_d = 0``) ``P~ = P - K D P <= P`` (singular along
``D``).  When ``d`` is computed from noisy data (air data and a wind estimate, covariance
``R_d``) the second term is the covariance that goes with the projection; it also keeps
``P~`` positive definite for the next sigma-point draw and for the federated fusion.
Both theorems are tested (``tests/filters/test_constrained.py``).

The projection is a filter *feature*: :class:`ConstrainedUKF` (``cukf``) and
:class:`ConstrainedEKF` (``cekf``) apply it when ``update`` receives a model flagged
``constraint = True`` (``D = model.H(nav)``, ``d = y``, ``R = R_d``); every other model
is an ordinary measurement.  The federation code sees only ``update``.
"""

from __future__ import annotations

import numpy as np

from ..core.kernels import spd_inverse
from .base import FilterError, Innovation
from .kf import KalmanFilter
from .ukf import UnscentedKalmanFilter


def project(x, P, D, d, Rd=None) -> tuple[np.ndarray, np.ndarray]:
    """Project the estimate ``(x, P)`` onto ``D x = d`` (eq. 27); covariance as above."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    D = np.atleast_2d(np.asarray(D, dtype=float))
    d = np.atleast_1d(np.asarray(d, dtype=float))
    if D.shape != (d.shape[0], x.shape[0]):
        raise ValueError(f"constraint: D must be ({d.shape[0]}, {x.shape[0]}), got {D.shape}")
    S = D @ P @ D.T
    Sinv, ok = spd_inverse(np.ascontiguousarray(0.5 * (S + S.T)))
    if not ok:
        raise FilterError("constraint: D P D' is not positive definite (the constraint is "
                          "not informative about the state, or D has dependent rows)")
    K = P @ D.T @ Sinv
    xt = x - K @ (D @ x - d)
    IKD = np.eye(x.shape[0]) - K @ D
    Pt = IKD @ P @ IKD.T
    if Rd is not None:
        Pt = Pt + K @ np.asarray(Rd, dtype=float) @ K.T
    return xt, 0.5 * (Pt + Pt.T)


class _ConstraintMixin:
    """``update`` with a ``constraint`` model projects instead of filtering."""

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        if not getattr(model, "constraint", False):
            return super().update(y, model, nav, R, gate)
        D = np.asarray(model.H(nav), dtype=float)
        r = np.asarray(y, dtype=float) - D @ self.x
        S = D @ self.P @ D.T
        if R is not None:
            S = S + R
        Sinv, ok = spd_inverse(np.ascontiguousarray(0.5 * (S + S.T)))
        nis = float(r @ Sinv @ r) if ok else float("nan")
        self.x, self.P = project(self.x, self.P, D, y, R)
        # with a noise R_d the projected covariance must be positive definite (an exact
        # constraint, R_d None, leaves it singular along D: theorem 2)
        self._finish("constraint", symmetrize=False, check_pd=R is not None)
        return Innovation(r, S, nis)


class ConstrainedUKF(_ConstraintMixin, UnscentedKalmanFilter):
    """UKF with estimate projection onto linear equality constraints (CUKF)."""


class ConstrainedEKF(_ConstraintMixin, KalmanFilter):
    """EKF with estimate projection onto linear equality constraints."""
