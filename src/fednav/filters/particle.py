"""SIR particle filter (paper 001, section 1.2) behind the common filter interface.

* **Time update** — every particle is drawn from the transition prior:
  ``x_k^i = f(x_{k-1}^i) + w^i``, ``w^i ~ N(0, q_scale Qd)``; ``f`` is
  ``process.transition`` called once on the whole particle set (a compiled kernel for the
  navigation models).  The draws ``w^i`` have exact sample moments (mean 0, covariance
  ``q_scale Qd``, no sample covariance with the particles they move:
  :func:`matched_normal`), so a set of equal weights (after a redraw or a resampling:
  every cycle of a federated filter with reset) grows by exactly ``Qd``.
* **Measurement update** — ``log w_k^i = log w_{k-1}^i + log p(y | x_k^i)`` in the log
  domain (normalised by log-sum-exp, so no weight underflows to zero unless every
  likelihood is exactly zero).  The likelihood is Gaussian in ``y - h(x)`` with ``R``, or
  ``model.loglik(y, X, nav, R)`` when the measurement model supplies one (a heavy-tailed
  sensor, or an exact residual on a manifold).
* **Estimate** ``x = sum w^i x^i``, ``P = sum w^i (x^i - x)(x^i - x)' / (1 - sum w_i^2)``
  (the unbiased weighted covariance; Bessel's correction for equal weights) — taken
  *before* resampling (lower variance).
* **Resampling** — systematic, when the effective sample size ``1 / sum w_i^2`` falls below
  ``resample_threshold * N``; optional **roughening** (Gordon, Salmond & Smith 1993):
  after resampling, every component ``j`` is jittered by ``N(0, (K E_j N^(-1/n))^2)``
  with ``E_j`` the spread of the particles in that component and ``K = roughening``.
* **Progressive correction** (optional; Musso, Oudjane & Le Gland 2001, "Improving
  regularised particle filters"): when one update would leave fewer than
  ``progressive_ess * N`` effective particles (a precise measurement meeting a wide
  cloud: the first star fix after a long period of large attitude uncertainty), the
  likelihood is applied in tempered stages ``p(y|x)^lambda_s`` with ``sum lambda_s = 1``,
  each ``lambda_s`` the largest that keeps the effective sample size at that level
  (bisection); between stages the set is resampled and moved with the Liu–West shrinkage
  kernel ``x <- a x + (1 - a) x_bar + h L eps`` (``a = sqrt(1 - h^2)``, ``L L' =`` the
  weighted covariance, ``h`` the regularised-PF bandwidth ``(4 / (N (n + 2)))^(1/(n+4))``),
  which keeps the weighted mean and covariance, so states the measurement does not
  inform are not inflated.  The number of stages is recorded in :attr:`stage_log`.
* **Covariance for fusion** — the estimate's covariance is a weighted *sample*
  covariance; :attr:`covariance_dof` (from Kish's effective sample size of the estimate,
  and whether the set was drawn with exact moments) tells a federated filter how noisy
  it is, so the fusion can remove the bias that inverting noisy covariances introduces
  (:func:`~fednav.filters.federated.fuse`).
* **Setting the estimate from outside** (federated fusion and reset, feedback): assigning
  ``x`` shifts the particle cloud rigidly; assigning ``P`` marks the set for redrawing
  from ``N(x, P)`` before its next use — the paper's step "re-sample every local filter's
  particle set from the fused result" — with draws whose sample mean and covariance are
  exactly ``x`` and ``P`` (:func:`matched_normal`; with plain draws the sampling error of
  every redraw compounded over the fusion-reset cycles, and the set collapsed).
* **Degeneracy** is reported, never turned into NaN: a :class:`FilterError` when every
  likelihood is zero (or not finite), when the effective sample size has stayed below
  ``collapse_fraction * N`` for ``max_collapsed`` updates in a row, or when the particle
  covariance is not positive definite (an impoverished set); :attr:`ess_log` keeps the
  effective sample size of every update.

Attitude-carrying models keep particles on the tangent space of the navigation
solution (error states), so every particle is a valid rotation by construction (see
:mod:`fednav.launch.errors`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.linalg import solve_triangular

from ..core.kernels import cholesky_lower
from .base import Filter, FilterError, Innovation, chol


@numba.njit(cache=True)
def systematic_resample(w, u0):
    """Indices of a systematic resampling of normalised weights ``w`` (N,) with the offset
    ``u0`` in [0, 1): particle i is copied floor(N w_i) or ceil(N w_i) times."""
    n = w.shape[0]
    idx = np.empty(n, dtype=np.int64)
    c = w[0]
    j = 0
    for i in range(n):
        u = (u0 + i) / n
        while u > c and j < n - 1:
            j += 1
            c += w[j]
        idx[i] = j
    return idx


def weighted_moments(X: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean (n,) and covariance ``sum w (x - x_bar)(x - x_bar)'`` (n, n) of the
    particles X (N, n) with normalised weights w (two BLAS products: faster than a
    compiled loop at these sizes)."""
    x = w @ X
    D = X - x
    P = (D * w[:, None]).T @ D
    return x, 0.5 * (P + P.T)


def psd_sqrt(Q: np.ndarray) -> np.ndarray:
    """A square root ``L`` with ``L L' = Q`` of a symmetric positive semi-definite matrix
    (Cholesky when it exists, else the eigen-decomposition with negative rounding noise
    clipped) — process noise is often singular (no noise on position)."""
    L, ok = cholesky_lower(np.ascontiguousarray(Q, dtype=float))
    if ok:
        return L
    ev, V = np.linalg.eigh(0.5 * (Q + Q.T))
    if ev.min() < -1e-9 * max(1.0, abs(ev.max())):
        raise FilterError(f"process noise is not positive semi-definite (eigenvalue "
                          f"{ev.min():.3g})")
    return V * np.sqrt(np.clip(ev, 0.0, None))


def matched_normal(rng: np.random.Generator, N: int, n: int,
                   against: np.ndarray | None = None) -> np.ndarray:
    """``N`` draws (N, n) of a standard normal vector whose sample moments are exact: mean
    0 and covariance ``Z' Z / (N - 1) = I``, and, given ``against`` (N, m), no sample
    covariance with its columns (noise uncorrelated with the particles it moves, in the
    sample as in expectation).  The draws are projected off the span of a column of ones
    (and ``against``), then whitened by the Cholesky factor of their sample covariance.
    Plain draws where ``N`` is too small for that (``N <= n + m + 1``).

    Why: a particle set redrawn every cycle from ``N(x, P)`` with plain draws carries
    ``P``'s sampling error into the next cycle, and the errors compound — the log-
    determinant of a sample covariance is biased low by about ``n (n + 1) / (2 N)`` per
    draw, so over a thousand fusion-reset cycles the set collapses in the directions no
    measurement restores (NEES per dof 20-3 000 in the consistency certificate)."""
    Z = rng.standard_normal((N, n))
    B = np.ones((N, 1)) if against is None else np.column_stack(
        [np.ones(N), against - against.mean(axis=0)])  # (centred: a large offset kept)
    if N <= n + B.shape[1]:
        return Z
    Qb = np.linalg.qr(B)[0]
    Z -= Qb @ (Qb.T @ Z)
    L, ok = cholesky_lower(Z.T @ Z / (N - 1))
    if not ok:  # (not reached with N > n + m + 1 normal draws, but never a NaN)
        return rng.standard_normal((N, n))
    return solve_triangular(L, Z.T, lower=True).T


#: The progressive correction's level: an update that would leave fewer than this fraction
#: of the particles effective is applied in stages that each keep it (``progressive_ess``).
PROGRESSIVE_ESS = 0.5


class ParticleFilter(Filter):
    """SIR particle filter.

    ``n_particles`` N; ``rng`` a :class:`numpy.random.Generator` or a seed (every draw comes
    from it: runs are reproducible); ``resample_threshold`` resample when ESS < this * N
    (1.0 = every update, 0 = never); ``roughening`` K (0 = off); ``collapse_fraction`` and
    ``max_collapsed`` the degeneracy rule; ``progressive`` (with ``progressive_ess`` and
    ``max_stages``) progressive correction of updates that would collapse the set.
    """

    def __init__(self, x0, P0, name: str = "pf", n_particles: int = 1000,
                 rng: np.random.Generator | int = 0, resample_threshold: float = 0.5,
                 roughening: float = 0.0, collapse_fraction: float = 0.01,
                 max_collapsed: int = 20, progressive: bool = False,
                 progressive_ess: float = PROGRESSIVE_ESS, max_stages: int = 200):
        if int(n_particles) != n_particles or n_particles < 2:
            raise ValueError(f"{name}: n_particles must be an integer >= 2, got {n_particles}")
        if not 0.0 <= resample_threshold <= 1.0:
            raise ValueError(f"{name}: resample_threshold must be in [0, 1], got "
                             f"{resample_threshold}")
        if roughening < 0:
            raise ValueError(f"{name}: roughening must be >= 0, got {roughening}")
        if max_collapsed < 1 or not 0.0 < collapse_fraction < 1.0:
            raise ValueError(f"{name}: need max_collapsed >= 1 and 0 < collapse_fraction < 1")
        self.N = int(n_particles)
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.resample_threshold = float(resample_threshold)
        self.roughening = float(roughening)
        self.collapse_fraction = float(collapse_fraction)
        self.max_collapsed = int(max_collapsed)
        if not 0.0 < progressive_ess < 1.0 or max_stages < 1:
            raise ValueError(f"{name}: need 0 < progressive_ess < 1 and max_stages >= 1")
        self.progressive = bool(progressive)
        self.progressive_ess = float(progressive_ess)
        self.max_stages = int(max_stages)
        #: Number of tempering stages of every update (1 = a plain SIR update).
        self.stage_log: list[int] = []
        self.particles: np.ndarray | None = None
        self.weights = np.full(self.N, 1.0 / self.N)
        self._pending = True
        self._exact = False  # the set's unweighted moments exact (matched draws)
        #: Effective sample size at every measurement update (before any resampling).
        self.ess_log: list[float] = []
        self.resamples = 0
        self._collapsed = 0
        super().__init__(x0, P0, name)

    # --- the estimate, settable from outside ------------------------------------------
    @property
    def x(self) -> np.ndarray:
        return self._x

    @x.setter
    def x(self, value) -> None:
        value = np.array(value, dtype=float)
        if self.particles is not None and not self._pending:
            self.particles += value - self._x
        self._x = value

    @property
    def P(self) -> np.ndarray:
        return self._P

    @P.setter
    def P(self, value) -> None:
        self._P = np.array(value, dtype=float)
        self._pending = True

    @property
    def covariance_dof(self) -> float:
        """Degrees of freedom of the covariance estimate.  Kish's effective sample size
        ``ESS`` minus one for a set of plain draws (after a resampling); for a set drawn
        with exact moments (:func:`matched_normal`: a redraw, then time updates) only the
        weights' spread is noise, ``sum (w_i - 1/N)^2 = 1/ESS - 1/N`` where plain draws
        have ``1/ESS``: ``1 / (1/ESS - 1/N) - 1`` (infinite with equal weights).  The
        federated fusion's sampling-bias correction takes it."""
        # (a nonlinear transition's change of the moments counts as the estimate's, not
        # as sampling noise)
        ess = getattr(self, "_est_ess", float(self.N))
        if not self._exact:
            return ess - 1.0
        excess = 1.0 / ess - 1.0 / self.N
        return math.inf if excess <= 1e-12 / self.N else 1.0 / excess - 1.0

    def _materialise(self, phase: str) -> np.ndarray:
        """The particle set, drawn from N(x, P) (equal weights) if a redraw is pending."""
        if self._pending:
            L = chol(self._P, self._who(phase))
            self.particles = self._x + matched_normal(self.rng, self.N, self.n) @ L.T
            self.weights = np.full(self.N, 1.0 / self.N)
            self._pending = False
            self._exact = self.N > 2 * self.n + 1  # (matched_normal's, in predict too)
            self._est_ess = float(self.N)
        return self.particles

    def _estimate(self, phase: str) -> None:
        x, P = weighted_moments(self.particles, self.weights)
        # Unbiased weighted covariance (reliability weights: divide by 1 - sum w^2).
        sw2 = float(self.weights @ self.weights)
        if sw2 < 1.0 - 1e-12:  # (one particle left: P stays 0, reported as degenerate)
            P = P / (1.0 - sw2)
        self._est_ess = 1.0 / sw2
        if not np.isfinite(x.sum() + P.sum()):
            raise FilterError(f"{self._who(phase)}: particles became NaN/inf")
        self._x, self._P = x, P

    # --- filter interface ---------------------------------------------------------------
    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        X = self._materialise("predict")
        Xf = np.asarray(process.transition(X), dtype=float)
        if Xf.shape != X.shape:
            raise FilterError(f"{self._who('predict')}: transition returned shape "
                              f"{Xf.shape} for particles {X.shape}")
        L = psd_sqrt(q_scale * np.asarray(process.Qd, dtype=float))
        self.particles = Xf + matched_normal(self.rng, self.N, self.n, Xf) @ L.T
        self._estimate("predict")

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        X = self._materialise("update")
        y = np.atleast_1d(np.asarray(y, dtype=float))
        R = np.atleast_2d(np.asarray(R, dtype=float))
        Z = np.asarray(model.h(X, nav), dtype=float).reshape(self.N, -1)
        w = self.weights
        z_hat = w @ Z
        dZ = Z - z_hat
        S = (dZ * w[:, None]).T @ dZ + R
        S = 0.5 * (S + S.T)
        r = y - z_hat
        Ls = chol(S, self._who("update (innovation covariance)"))
        v = np.linalg.solve(Ls, r)
        nis = float(v @ v)
        if gate is not None and nis > gate:
            return Innovation(r, S, nis, False)
        ll = self._loglik(y, X, Z, model, nav, R)
        w, ess = self._reweight(w, ll, nis)
        stages = 1
        if self.progressive and ess < self.progressive_ess * self.N:
            w, ess, stages = self._progressive(y, model, nav, R, ll, nis)
        self.stage_log.append(stages)
        self.weights = w
        self.ess_log.append(ess)
        self._collapsed = self._collapsed + 1 if ess < self.collapse_fraction * self.N else 0
        if self._collapsed >= self.max_collapsed:
            raise FilterError(f"{self._who('update')}: particle set degenerate — effective "
                              f"sample size below {self.collapse_fraction * self.N:.3g} of "
                              f"{self.N} for {self._collapsed} updates in a row (last "
                              f"{ess:.2f}); use more particles, roughening or a broader "
                              f"proposal")
        self._estimate("update")
        if ess < self.resample_threshold * self.N:
            self._resample()
        try:
            chol(self._P, "")
        except FilterError:
            distinct = len(np.unique(self.particles, axis=0))
            raise FilterError(f"{self._who('update')}: particle covariance not positive "
                              f"definite (effective sample size {ess:.2f} of {self.N}, "
                              f"{distinct} distinct particles): degenerate or impoverished "
                              f"set; use more particles or roughening") from None
        return Innovation(r, S, nis)

    def _loglik(self, y, X, Z, model, nav, R) -> np.ndarray:
        if hasattr(model, "loglik"):
            return np.asarray(model.loglik(y, X, nav, R), dtype=float)
        if Z is None:
            Z = np.asarray(model.h(X, nav), dtype=float).reshape(self.N, -1)
        Lr = chol(R, self._who("update (measurement noise)"))
        E = np.linalg.solve(Lr, (y - Z).T)
        return -0.5 * (E * E).sum(axis=0)

    def _reweight(self, w, ll, nis) -> tuple[np.ndarray, float]:
        logw = np.log(w) + ll
        m = np.max(logw)
        if not np.isfinite(m) or np.isnan(logw).any():
            raise FilterError(f"{self._who('update')}: every particle weight is zero or "
                              f"not finite (likelihood underflow: the measurement lies "
                              f"outside the particle cloud, NIS {nis:.3g})")
        w = np.exp(logw - m)
        w /= w.sum()
        return w, 1.0 / float(w @ w)

    def _progressive(self, y, model, nav, R, ll, nis) -> tuple[np.ndarray, float, int]:
        """Tempered update in stages (see the module docstring); returns the final
        weights, their effective sample size and the number of stages."""
        target = self.progressive_ess * self.N
        h = (4.0 / (self.N * (self.n + 2))) ** (1.0 / (self.n + 4))
        a = np.sqrt(1.0 - h * h)
        w = self.weights
        remaining = 1.0
        for stage in range(1, self.max_stages + 1):
            w_full, ess_full = self._reweight(w, remaining * ll, nis)
            if ess_full >= target or stage == self.max_stages:
                if ess_full < target:
                    raise FilterError(
                        f"{self._who('update')}: progressive correction did not converge "
                        f"in {self.max_stages} stages (effective sample size "
                        f"{ess_full:.1f} of {self.N})")
                return w_full, ess_full, stage
            lo, hi = 0.0, remaining
            for _ in range(40):
                mid = 0.5 * (lo + hi)
                if self._reweight(w, mid * ll, nis)[1] >= target:
                    lo = mid
                else:
                    hi = mid
            lam = max(lo, 1e-12 * remaining)
            w, _ = self._reweight(w, lam * ll, nis)
            remaining -= lam
            # Resample, then move with the Liu-West kernel (keeps mean and covariance).
            x_bar, P = weighted_moments(self.particles, w)
            L = psd_sqrt(P)
            X = self.particles[systematic_resample(w, float(self.rng.random()))]
            X = a * X + (1.0 - a) * x_bar + h * self.rng.standard_normal(X.shape) @ L.T
            self.particles = X
            self._exact = False
            w = np.full(self.N, 1.0 / self.N)
            ll = self._loglik(y, X, None, model, nav, R)
        raise AssertionError("unreachable")

    def _resample(self) -> None:
        idx = systematic_resample(self.weights, float(self.rng.random()))
        X = self.particles[idx]
        if self.roughening > 0:
            spread = X.max(axis=0) - X.min(axis=0)
            sig = self.roughening * spread * self.N ** (-1.0 / self.n)
            X = X + self.rng.standard_normal(X.shape) * sig
        self.particles = X
        self._exact = False
        self.weights = np.full(self.N, 1.0 / self.N)
        self.resamples += 1
