"""Adaptive and robust filters: Sage–Husa EKF (AEKF) and robust adaptive UKF (RAUKF).

**Sage–Husa measurement-noise estimation** (Sage & Husa, "Adaptive filtering with unknown
prior statistics", JACC 1969; fading-memory form as in Gao et al. and most INS texts).
For each measurement type (``model.kind``), at its k-th update, with innovation
``r = y - y_hat`` and predicted measurement covariance ``H P H'`` (UKF: ``Pzz - R``)::

    d_k = (1 - b) / (1 - b^(k+1))                  fading factor b (default 0.97)
    R_k = (1 - d_k) R_(k-1) + d_k (r r' - H P H')

Safeguard (the difference can make ``R_k`` indefinite): ``R_k`` is kept at least
``r_floor`` (default 0.1) times the nominal R, in the nominal R's own metric — with
``L L' = R_nominal``, every eigenvalue of ``L^-1 R_k L^-T`` raised to at least
``r_floor`` — so R stays positive definite and no component falls below ``r_floor`` of
its nominal variance.  (A floor of ``r_floor`` times the nominal R's *smallest*
eigenvalue, used before, let the metres² of a GNSS position fall to 0.1 × (0.05 m/s)²
when R also held velocities: position NEES of hundreds in ``fednav certify``.)  R starts
from the nominal R the caller passes.

**Sage–Husa process-noise estimation** (optional, ``adapt_q=True``; same fading weights,
one step per filter cycle)::

    Q_k = (1 - d_k) Q_(k-1) + d_k (K r r' K' + P_k - (P_k|k-1 - Q_(k-1)))

with ``K r = x_k - x_k|k-1`` (the correction the cycle's updates applied), ``P_k`` the
updated covariance and ``P_k|k-1 - Q_(k-1)`` the propagated covariance without the noise
(so the rule works for the EKF and the sigma-point filters alike).  ``Q`` starts from the
process model's ``Qd``; the estimate is kept symmetric positive semi-definite (negative
eigenvalues clipped to 0).  It estimates the noise actually driving the filter's error —
the classic use is a mis-specified ``Q``.  Q and R cannot both be estimated from the same
innovations in general (a too-small Q and a too-large R explain them equally well): with
``adapt_q``, fix the noise you know with ``adapt_r=False``.

**Robust adaptive UKF** — the UKF with the adapted R, made robust by IGG-III equivalent
weights (Yang, Song & Xu, "Robust estimator for correlated observations based on
bifactor equivalent weights", J. Geodesy 76, 2002): each innovation component is
standardized, ``v_i = |r_i| / sqrt(S_ii)``, and its noise variance divided by ::

    w_i = 1                                   v_i <= k0
    w_i = (k0 / v_i) ((k1 - v_i) / (k1 - k0))^2   k0 < v_i <= k1
    w_i = 1e-8 (practically rejected)         v_i > k1          (k0 = 1.5, k1 = 4.5)

(``R_eq = W^-1/2 R W^-1/2``).  The Sage–Husa step uses the raw innovation, and is
skipped when a component exceeds ``k1`` (an outlier must not inflate R).  Feeding it the
down-weighted innovation instead biases R low, which down-weights ever more innovations:
on the airship scenario that feedback tripled the position error (found and fixed while
reproducing paper 000).
"""

from __future__ import annotations

import numpy as np

from ..core.kernels import cholesky_lower
from .base import Innovation
from .kf import KalmanFilter
from .ukf import UnscentedKalmanFilter


def igg3_weights(v, k0: float = 1.5, k1: float = 4.5) -> np.ndarray:
    """IGG-III equivalent-weight factors for standardized residuals ``v`` (>= 0)."""
    v = np.abs(np.asarray(v, dtype=float))
    w = np.ones_like(v)
    mid = (v > k0) & (v <= k1)
    w[mid] = (k0 / v[mid]) * ((k1 - v[mid]) / (k1 - k0)) ** 2
    w[v > k1] = 1e-8
    return np.maximum(w, 1e-8)


class _SageHusa:
    """Per-measurement-type fading-memory estimate of R."""

    def __init__(self, fading: float = 0.97, r_floor: float = 0.1):
        if not 0.0 < fading < 1.0:
            raise ValueError(f"Sage-Husa fading factor must be in (0, 1), got {fading}")
        self.b, self.floor = fading, r_floor
        self.R: dict = {}
        self.k: dict = {}
        self._chol: dict = {}

    def current(self, key, R_nominal) -> np.ndarray:
        return self.R.get(key, np.asarray(R_nominal, dtype=float))

    def _factor(self, key, R_nominal) -> np.ndarray | None:
        """``L`` with ``L L' = R_nominal`` (cached per key; None when the nominal R is not
        positive definite)."""
        tag = R_nominal.tobytes()
        hit = self._chol.get(key)
        if hit is None or hit[0] != tag:
            L, ok = cholesky_lower(np.ascontiguousarray(R_nominal))
            hit = (tag, L if ok else None)
            self._chol[key] = hit
        return hit[1]

    def adapt(self, key, R_nominal, r, HPHt) -> np.ndarray:
        R_nominal = np.asarray(R_nominal, dtype=float)
        k = self.k.get(key, 0)
        d = (1.0 - self.b) / (1.0 - self.b ** (k + 1))
        R = (1.0 - d) * self.current(key, R_nominal) + d * (np.outer(r, r) - HPHt)
        R = 0.5 * (R + R.T)
        # R >= r_floor R_nominal exactly when R - r_floor R_nominal has a Cholesky
        # factor: project (in the nominal R's metric) only when the floor is active.
        if not cholesky_lower(R - self.floor * R_nominal)[1]:
            L = self._factor(key, R_nominal)
            if L is None:  # a singular nominal R: floor the eigenvalues at zero
                w, V = np.linalg.eigh(R)
                R = (V * np.maximum(w, 0.0)) @ V.T
            else:
                A = np.linalg.solve(L, np.linalg.solve(L, R).T)  # L^-1 R L^-T
                w, V = np.linalg.eigh(0.5 * (A + A.T))
                LV = L @ V
                R = (LV * np.maximum(w, self.floor)) @ LV.T
            R = 0.5 * (R + R.T)
        self.R[key], self.k[key] = R, k + 1
        return R


def adapt_r(sh: _SageHusa, model, R, r, HPHt) -> np.ndarray:
    """Sage–Husa's R for one measurement of ``model``: one estimate per measurement type
    (its ``kind``), or, for a model whose rows differ from one measurement to the next
    (``row_keys``: a raw GNSS epoch's satellites), one per row's key, on its diagonal."""
    keys = getattr(model, "row_keys", None)
    if keys is None:
        return sh.adapt(getattr(model, "kind", type(model).__name__), R, r, HPHt)
    R = np.array(R, dtype=float)
    out = R.copy()
    for i, k in enumerate(keys):
        out[i, i] = sh.adapt(k, R[i:i + 1, i:i + 1], r[i:i + 1], HPHt[i:i + 1, i:i + 1])[0, 0]
    return out


def current_r(sh: _SageHusa, model, R) -> np.ndarray:
    """The current R estimate of :func:`adapt_r` without adapting it."""
    keys = getattr(model, "row_keys", None)
    if keys is None:
        return sh.current(getattr(model, "kind", type(model).__name__), R)
    out = np.array(R, dtype=float)
    for i, k in enumerate(keys):
        out[i, i] = sh.current(k, out[i:i + 1, i:i + 1])[0, 0]
    return out


class _ProcessWithQ:
    """A process model with its noise replaced by the current estimate."""

    def __init__(self, process, Q):
        self._p, self.Qd = process, Q
        self.Phi = process.Phi

    def transition(self, X):
        return self._p.transition(X)


class QAdaptation:
    """Mixin: Sage–Husa estimation of the process noise Q (module docstring)."""

    def _init_q(self, adapt_q: bool, fading: float) -> None:
        self.adapt_q = bool(adapt_q)
        self.q_fading = fading
        self.Qhat: np.ndarray | None = None
        self._q_cycle: tuple | None = None
        self._q_k = 0

    def predict(self, process, q_scale: float = 1.0) -> None:
        if not self.adapt_q:
            return super().predict(process, q_scale)
        if self.Qhat is None:
            self.Qhat = np.array(process.Qd, dtype=float)
        super().predict(_ProcessWithQ(process, self.Qhat), q_scale)
        # (Q before this cycle, x and P_k|k-1 without the noise, the scale applied)
        self._q_cycle = (self.Qhat.copy(), self.x.copy(), self.P - q_scale * self.Qhat,
                         q_scale)
        self._q_k += 1

    def _adapt_q_after_update(self) -> None:
        if not self.adapt_q or self._q_cycle is None:
            return
        Q0, x_prior, P_noq, q_scale = self._q_cycle
        dx = self.x - x_prior
        Qs = (np.outer(dx, dx) + self.P - P_noq) / q_scale
        d = (1.0 - self.q_fading) / (1.0 - self.q_fading ** self._q_k)
        Q = (1.0 - d) * Q0 + d * 0.5 * (Qs + Qs.T)
        w, V = np.linalg.eigh(Q)
        self.Qhat = (V * np.maximum(w, 0.0)) @ V.T


class SageHusaEKF(QAdaptation, KalmanFilter):
    """EKF whose measurement noise (and, with ``adapt_q``, process noise) is estimated
    online (AEKF); see the module docstring."""

    def __init__(self, x0, P0, name: str = "aekf", fading: float = 0.97,
                 r_floor: float = 0.1, adapt_q: bool = False, adapt_r: bool = True):
        super().__init__(x0, P0, name)
        self.sh = _SageHusa(fading, r_floor)
        self.adapt_r = bool(adapt_r)
        self._init_q(adapt_q, fading)

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        H = np.asarray(model.H(nav), dtype=float)
        r = np.asarray(y, dtype=float) - model.h(self.x[None], nav)[0]
        Ra = adapt_r(self.sh, model, R, r, self._hph(H)) if self.adapt_r else R
        inn = super().update(y, model, nav, Ra, gate)
        if inn.accepted:
            self._adapt_q_after_update()
        return inn


class RobustAdaptiveUKF(QAdaptation, UnscentedKalmanFilter):
    """UKF with IGG-III robust equivalent weights and Sage–Husa R (and, with ``adapt_q``,
    Q) adaptation (RAUKF)."""

    def __init__(self, x0, P0, name: str = "raukf", alpha: float = 1e-3, beta: float = 2.0,
                 kappa: float = 0.0, fading: float = 0.97, r_floor: float = 0.1,
                 k0: float = 1.5, k1: float = 4.5, adapt_q: bool = False):
        super().__init__(x0, P0, name, alpha, beta, kappa)
        self.sh = _SageHusa(fading, r_floor)
        self.k0, self.k1 = k0, k1
        self._init_q(adapt_q, fading)

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        X = self.sigma_points(phase="update")  # raises the not-PD error
        Z = np.asarray(model.h(X, nav), dtype=float)
        z_hat = self.Wm @ Z
        dZ = Z - z_hat
        Pzz0 = (dZ * self.Wc[:, None]).T @ dZ
        r = np.asarray(y, dtype=float) - z_hat
        Rc = current_r(self.sh, model, R)
        v = np.abs(r) / np.sqrt(np.diag(Pzz0 + Rc))
        w = igg3_weights(v, self.k0, self.k1)
        # Adapt R on the raw innovation unless it holds an outlier (a truncated innovation
        # would bias R low, then down-weight ever more: the two must not feed each other).
        Ra = adapt_r(self.sh, model, R, r, Pzz0) if v.max() <= self.k1 else Rc
        s = 1.0 / np.sqrt(w)
        # (the points and their predicted measurements drawn above: not drawn again)
        inn = self._sigma_update(X, np.ascontiguousarray(Z, dtype=float), y,
                                 Ra * np.outer(s, s), gate)
        if inn.accepted:
            self._adapt_q_after_update()
        return inn
