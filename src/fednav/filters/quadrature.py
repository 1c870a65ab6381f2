"""Sparse-grid Gauss–Hermite quadrature filters: SGHQF and AASGHQF (paper 002, Table 4).

Both are Gaussian filters like the UKF: every Gaussian expectation of the time and
measurement updates is a quadrature over points ``x + L xi_k`` (``L L' = P``, lower
Cholesky factor) with the weights ``w_k`` of a sparse grid
(:mod:`fednav.filters.sparse_grid`); the process and measurement models are called once
per step on all points, and the moment and update algebra is the UKF's compiled kernels
with ``Wm = Wc = w``.  The weights can be negative; the covariance is the quadrature of
``(y - y_bar)(y - y_bar)'`` with those weights (no clipping, which would bias it), and a
result that is not positive definite is reported as a :class:`FilterError` naming the
step.

* :class:`SparseGridFilter` (``sghqf``) — isotropic grid of accuracy level ``level``
  (default 3: exact for polynomials of total degree <= 5, Jia, Xin & Cheng 2012;
  ``2 n^2 + ...`` points: 721 for n = 18).  Level 2 is a cubature of degree 3 with the
  ``2 n + 1`` points of a unit-spread UKF.
* :class:`AdaptiveSparseGridFilter` (``aasghqf``).  Paper 002 names it without defining
  it and cites a thesis on robust adaptive sparse-grid filtering for CNS/SAR/SINS.
  fednav's reading, from its Table 4 (cheaper than SGHQF, slightly more accurate):
  an **anisotropic** grid (Jia, Xin & Cheng, "Anisotropic sparse Gauss–Hermite
  quadrature filter", J. Guidance Control Dyn. 35(3), 2012) — the designated
  ``nonlinear_states`` (default the three attitude errors, where the error model is
  nonlinear) at ``level``, every other state at level 2 (degree-3 accuracy, enough for
  a linear map), 61 points for n = 18 — **plus Sage–Husa adaptive noise estimation**
  (R per measurement type; Q with ``adapt_q``), as in
  :class:`~fednav.filters.adaptive.SageHusaEKF`.
"""

from __future__ import annotations

import numpy as np

from .adaptive import QAdaptation, _SageHusa, adapt_r
from .base import Filter, Innovation, chol
from .sparse_grid import sparse_grid
from .ukf import UnscentedKalmanFilter


class SparseGridFilter(UnscentedKalmanFilter):
    """Sparse-grid Gauss–Hermite quadrature filter (SGHQF)."""

    def __init__(self, x0, P0, name: str = "sghqf", level: int = 3,
                 dim_weights: tuple[float, ...] | None = None):
        Filter.__init__(self, x0, P0, name)
        self.level = int(level)
        self.grid, W = sparse_grid(self.n, self.level,
                                   None if dim_weights is None else tuple(dim_weights))
        self.Wm = np.array(W)
        self.Wc = self.Wm

    @property
    def n_points(self) -> int:
        return len(self.Wm)

    def sigma_points(self, x=None, P=None, phase: str = "quadrature points") -> np.ndarray:
        x = self.x if x is None else np.asarray(x, dtype=float)
        P = self.P if P is None else np.asarray(P, dtype=float)
        L = chol(P, self._who(phase))
        return x + self.grid @ L.T

    def predict(self, process, q_scale: float = 1.0) -> None:
        super().predict(process, q_scale)
        chol(self.P, self._who("predict (quadrature covariance with negative weights)"))


class AdaptiveSparseGridFilter(QAdaptation, SparseGridFilter):
    """Anisotropic sparse-grid filter with Sage–Husa noise adaptation (AASGHQF)."""

    def __init__(self, x0, P0, name: str = "aasghqf", level: int = 3,
                 nonlinear_states=(0, 1, 2), fading: float = 0.97, r_floor: float = 0.1,
                 adapt_q: bool = False):
        n = len(np.atleast_1d(x0))
        nl = set(int(i) for i in nonlinear_states)
        if not nl or min(nl) < 0 or max(nl) >= n:
            raise ValueError(f"{name}: nonlinear_states must be indices in [0, {n})")
        weights = tuple(1.0 if i in nl else float(max(level - 1, 1)) for i in range(n))
        super().__init__(x0, P0, name, level, weights)
        self.nonlinear_states = tuple(sorted(nl))
        self.sh = _SageHusa(fading, r_floor)
        self._init_q(adapt_q, fading)

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        X = self.sigma_points(phase="update")
        Z = np.ascontiguousarray(model.h(X, nav), dtype=float)
        z_hat = self.Wm @ Z
        dZ = Z - z_hat
        Pzz0 = (dZ * self.Wc[:, None]).T @ dZ
        y = np.asarray(y, dtype=float)
        Ra = adapt_r(self.sh, model, R, y - z_hat, Pzz0)
        # The UKF update with the points and predicted measurements already at hand.
        inn = self._sigma_update(X, Z, y, Ra, gate)
        if inn.accepted:
            self._adapt_q_after_update()
        return inn
