"""Square-root (Cholesky-factor) forms of every Gaussian filter (``form: square_root``).

Each filter of the registry but the particle filter has a factored twin: the same class
with its covariance kept as a lower-triangular factor ``S`` (``P = S S'``, positive
diagonal).  ``P`` stays a property (``S S'``, exactly symmetric; setting it factors it),
so the federated fusion, the smoother, the navigator and the health checks see the same
interface.  The numerics are the compiled kernels of :mod:`fednav.filters.sr_kernels`:

* **KF / EKF** (``kf``, ``ekf``): time update ``S- = tria([Phi S, sqrt(q) sqrt(Q)])``;
  measurement update the array (Joseph-equivalent) form, the lower-triangularized
  pre-array ``[[sqrt(R), H S], [0, S]]`` -> ``[[Se, 0], [K Se, S+]]``: no subtraction of
  covariances, ``S+ S+'`` is ``(I - K H) P (I - K H)' + K R K'`` to rounding.
* **UKF, simplified UKF** (``ukf``, ``sukf``; van der Merwe & Wan, "The square-root
  unscented Kalman filter", ICASSP 2001): one triangularization of the weighted
  deviations and ``sqrt(Q)``.  The deviations are taken from the zeroth point, so the
  zeroth weight enters as a rank-1 term of weight ``beta - alpha^2`` (an *update* for the
  default ``beta = 2``; a Cholesky *downdate* when it is negative) — never the
  ``Wc_0 ~ -1e6`` of ``alpha = 1e-3``.  The measurement update triangularizes the joint
  deviations of the measurement and the state with ``sqrt(R)``: its factor is
  ``[[Se, 0], [Pxz Se^-T, S+]]`` — no downdate by ``K Se`` as in the original paper.
  ``sukf`` has the UKF time update and the KF array update.
* **Sparse-grid filters** (``sghqf``, ``aasghqf``): negative quadrature weights.  The
  positive-weight points and ``sqrt(Q)`` (``sqrt(R)`` in the update) are
  triangularized, then one rank-1 Cholesky downdate per negative weight and one for the
  mean (``-m m'``, weights summing to 1).  A downdate that leaves the matrix not
  positive definite raises a :class:`~fednav.filters.base.FilterError` naming the filter,
  the step and the downdate — the case where the standard form reports a covariance
  that is not positive definite after the quadrature.
* **CUKF / CEKF** (``cukf``, ``cekf``): the projection onto ``D x = d`` with covariance
  ``R_d`` is the array update with ``D``, ``R_d`` (the projection's covariance is the
  Joseph form of a measurement update), applied on the factor.
* **Adaptive filters** (``aekf``, ``raukf``, ``aasghqf``): the Sage–Husa R and Q
  estimates are kept positive (semi-)definite as in the standard form and enter through
  their factor (:func:`~fednav.filters.sr_kernels.psd_sqrt`); an estimate that is not
  positive semi-definite raises a :class:`FilterError` naming the noise.

Noise covariances may be singular (states without process noise): they are factored by a
Cholesky factorization that takes pivots at or below 1e-13 of their diagonal entry as
zero.  Build a factored filter with :func:`fednav.filters.make_filter` (``form=
"square_root"``) or from a system description (``filter.form`` / ``filter.locals.<sensor>.
form``).  The navigator's compiled engine (:mod:`fednav.navigator.engine`) flies the
factored ``kf``, ``ekf``, ``ukf`` and ``sukf`` with the same kernels, in the same order.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.kernels import cholesky_lower
from . import sr_kernels as srk
from .adaptive import RobustAdaptiveUKF, SageHusaEKF
from .base import FilterError, Innovation, chol, not_pd_error
from .constrained import ConstrainedEKF, ConstrainedUKF
from .kf import KalmanFilter
from .quadrature import AdaptiveSparseGridFilter, SparseGridFilter
from .ukf import SimplifiedUKF, UnscentedKalmanFilter

#: Why a kernel failed, by its code (:mod:`fednav.filters.sr_kernels`).
#: The noises a factored filter factors, and what it says when one is not positive
#: semi-definite (:func:`not_psd`; the compiled engine says the same).
NOISE_Q, NOISE_R, NOISE_RD = "process noise Q", "measurement noise R", "constraint covariance R_d"


def not_psd(what: str) -> str:
    """The reason a factored filter gives for a noise it cannot factor.

    Parameters
    ----------
    what : str
        The noise (:data:`NOISE_Q`, :data:`NOISE_R`, :data:`NOISE_RD`).

    Returns
    -------
    str
        ``"<what> is not positive semi-definite"``.
    """
    return f"{what} is not positive semi-definite"


REASONS = {srk.NOT_FINITE: "state or covariance became NaN/inf",
           srk.DOWNDATE: "a rank-1 Cholesky downdate (negative weight) left the covariance not "
                     "positive definite",
           srk.INNOVATION: "innovation covariance not positive definite",
           srk.NOT_PD: "covariance is not positive definite (its factor has a zero on the "
                       "diagonal: the update shrank a standard deviation by more than "
                       "double precision resolves)"}


class SquareRootForm:
    """Mixin: the covariance kept as its lower Cholesky factor ``S`` (``P = S S'``).

    Attributes
    ----------
    S : ndarray, shape (n, n)
        Lower triangular, positive diagonal, in the filter's units (the state's).
    P : ndarray, shape (n, n)
        Property: ``S S'`` (a new, exactly symmetric array; setting it factors it, a
        :class:`~fednav.filters.base.FilterError` when it is not positive definite).
    form : str
        ``"square_root"``.
    """

    form = "square_root"

    @property
    def P(self) -> np.ndarray:
        """The covariance ``S S'`` (a new, exactly symmetric array)."""
        return srk.factor_product(self.S)

    @P.setter
    def P(self, P) -> None:
        P = np.array(P, dtype=float)
        name = getattr(self, "name", type(self).__name__)
        if P.ndim != 2 or P.shape[0] != P.shape[1] or not np.all(np.isfinite(P)):
            raise ValueError(f"{name}: a covariance must be a finite square matrix; got "
                             f"shape {P.shape}")
        L, ok = cholesky_lower(np.ascontiguousarray(0.5 * (P + P.T)))
        if not ok:
            raise not_pd_error(P, f"{name} covariance set at step {getattr(self, 'step', 0)}")
        self.S = L

    def inflate(self, s: float) -> None:
        """Scale the covariance by ``s`` > 0: the factor by ``sqrt(s)``."""
        self.S = self.S * math.sqrt(s)

    def _finish(self, phase: str, symmetrize: bool = True, check_pd: bool = False) -> None:
        if not math.isfinite(self.x.sum() + self.S.sum()):
            raise FilterError(f"{self._who(phase)}: state or covariance became NaN/inf")
        if check_pd and not np.min(np.diagonal(self.S)) > 0.0:
            raise FilterError(f"{self._who(phase)}: covariance is not positive definite "
                              f"(its factor has a zero on the diagonal)")

    def _noise_factor(self, M, what: str, phase: str) -> np.ndarray:
        """A lower square root of the noise covariance ``M`` (positive semi-definite; the
        last one of each kind is kept: a constant noise is factored once)."""
        M = np.ascontiguousarray(M, dtype=float)
        memo = self.__dict__.setdefault("_noise_memo", {})
        hit = memo.get(what)
        if hit is not None and hit[0].shape == M.shape and srk.same(hit[0], M):
            return hit[1]
        L, ok = srk.psd_sqrt(M)
        if not ok:
            raise FilterError(f"{self._who(phase)}: {not_psd(what)}")
        memo[what] = (M.copy(), L)
        return L

    def _sr_accept(self, x, S, r, Pzz, nis, code, gate) -> Innovation:
        """Finish a factored update: a clear error, the gate, the new estimate."""
        if code != srk.OK or not math.isfinite(nis):
            raise FilterError(f"{self._who('update')}: "
                              f"{REASONS.get(code, REASONS[srk.INNOVATION])}")
        if gate is not None and nis > gate:
            return Innovation(r, Pzz, float(nis), False)
        self.x, self.S = x, S   # finite, positive diagonal: checked by the kernel
        return Innovation(r, Pzz, float(nis))


class SquareRootKalmanFilter(SquareRootForm, KalmanFilter):
    """KF / EKF on the Cholesky factor (module docstring)."""

    def _hph(self, H) -> np.ndarray:
        HS = H @ self.S
        return HS @ HS.T

    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        self.x = process.transition(self.x[None])[0]
        Lq = self._noise_factor(process.Qd, NOISE_Q, "predict")
        S, ok = srk.sr_propagate(np.ascontiguousarray(process.Phi, dtype=float), self.S, Lq,
                             math.sqrt(q_scale))
        if not ok or not np.all(np.isfinite(self.x)):
            raise FilterError(f"{self._who('predict')}: state or covariance became NaN/inf")
        self.S = S

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        H = np.ascontiguousarray(model.H(nav), dtype=float)
        yhat = H @ self.x if getattr(model, "linear", False) else model.h(self.x[None], nav)[0]
        r = np.asarray(y, dtype=float) - yhat
        Rs = self._noise_factor(R, NOISE_R, "update")
        x, S, Pzz, nis, code = srk.sr_kf_update(self.x, self.S, H, r, Rs)
        return self._sr_accept(x, S, r, Pzz, nis, code, gate)


class SquareRootSigma(SquareRootForm):
    """Mixin: the sigma-point / quadrature time and measurement updates on the factor.
    The points are ``x + G S'`` for unit points ``G`` whose row 0 is the origin."""

    def _unit_points(self) -> np.ndarray:
        G = getattr(self, "_G", None)
        if G is None:
            n = self.n
            if isinstance(self, SparseGridFilter):
                G, W = np.array(self.grid), np.array(self.Wm)
                o = np.flatnonzero(np.all(G == 0.0, axis=1))
                if len(o) != 1:
                    raise ValueError(f"{self.name}: the square-root form needs the origin "
                                     f"among the grid's points")
                order = np.r_[o, np.delete(np.arange(len(W)), o)]
                G, W = G[order], W[order]
                self.Wm = W
                self.Wc = W
            else:
                sc = self._sc = math.sqrt(self.c)
                G = np.vstack([np.zeros((1, n)), sc * np.eye(n), -sc * np.eye(n)])
            if not np.array_equal(self.Wm[1:], self.Wc[1:]):
                raise ValueError(f"{self.name}: the square-root form needs equal mean and "
                                 f"covariance weights past the zeroth")
            self._G = G
        return G

    def sigma_points(self, x=None, P=None, phase: str = "sigma points") -> np.ndarray:
        x = self.x if x is None else np.asarray(x, dtype=float)
        S = self.S if P is None else chol(np.asarray(P, dtype=float), self._who(phase))
        G = self._unit_points()
        if isinstance(self, SparseGridFilter):
            dX = G @ S.T
            X = x + dX
        else:
            X, dX = srk.ukf_points(x, S, self._sc)
        self._last = (X, dX)
        return X

    def predict(self, process, q_scale: float = 1.0) -> None:
        self.step += 1
        X = self.sigma_points(phase="predict")
        Y = np.ascontiguousarray(process.transition(X), dtype=float)
        Lq = self._noise_factor(process.Qd, NOISE_Q, "predict")
        if isinstance(self, SparseGridFilter):
            x, S, code = srk.sr_grid_predict(Y, self._unit_points(), self.Wm, Lq,
                                             math.sqrt(q_scale))
        else:
            x, S, code = srk.sr_sigma_predict(Y, self.Wm, self.Wc, Lq, math.sqrt(q_scale))
        if code != srk.OK:
            raise FilterError(f"{self._who('predict')}: {REASONS[code]}")
        self.x, self.S = x, S

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        X = self.sigma_points(phase="update")
        Z = np.ascontiguousarray(model.h(X, nav), dtype=float)
        return self._sigma_update(X, Z, y, R, gate)

    def _sigma_update(self, X, Z, y, R, gate) -> Innovation:
        last = getattr(self, "_last", None)
        drawn = last is not None and last[0] is X   # X = x + G S' with this S
        Rs = self._noise_factor(R, NOISE_R, "update")
        y = np.asarray(y, dtype=float)
        if drawn and isinstance(self, SparseGridFilter):
            x, S, Pzz, nis, code, r = srk.sr_grid_update(Z, self._unit_points(), self.Wm,
                                                         self.S, self.x, y, Rs)
        elif drawn:
            x, S, Pzz, nis, code, r = srk.sr_ukf_update(Z, self.S, self.Wm[1],
                                                        self.Wc.sum() - 2.0, self.x, y, Rs)
        else:
            dX = last[1] if drawn else X - X[0]
            x, S, Pzz, nis, code, r = srk.sr_sigma_update(np.ascontiguousarray(dX), Z, self.Wm,
                                                      self.Wc, self.x, y, Rs)
        return self._sr_accept(x, S, r, Pzz, nis, code, gate)


class SquareRootUKF(SquareRootSigma, UnscentedKalmanFilter):
    """Square-root UKF (module docstring)."""


class SquareRootSimplifiedUKF(SquareRootUKF):
    """UKF time update on the factor, KF array measurement update (``sukf``)."""

    update = SquareRootKalmanFilter.update


class SquareRootSparseGridFilter(SquareRootSigma, SparseGridFilter):
    """SGHQF on the factor (negative weights by downdates; module docstring)."""


class SquareRootAdaptiveSparseGridFilter(AdaptiveSparseGridFilter, SquareRootSparseGridFilter):
    """AASGHQF on the factor (Sage–Husa R and Q through their factors)."""


class _ConstraintOnFactor:
    """``update`` with a ``constraint`` model projects on the factor (module docstring)."""

    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation:
        if not getattr(model, "constraint", False):
            return super().update(y, model, nav, R, gate)
        D = np.ascontiguousarray(np.atleast_2d(model.H(nav)), dtype=float)
        y = np.atleast_1d(np.asarray(y, dtype=float))
        if D.shape != (y.shape[0], self.n):
            raise ValueError(f"constraint: D must be ({y.shape[0]}, {self.n}), got {D.shape}")
        r = y - D @ self.x
        Rs = (np.zeros((len(y), len(y))) if R is None
              else self._noise_factor(R, NOISE_RD, "constraint"))
        x, S, Pzz, nis, code = srk.sr_project(self.x, self.S, D, r, Rs)
        if code != srk.OK:
            why = ("D P D' is not positive definite (the constraint is not informative "
                   "about the state, or D has dependent rows)" if code == srk.INNOVATION
                   else REASONS[code])
            raise FilterError(f"{self._who('constraint')}: {why}")
        self.x, self.S = x, S
        self._finish("constraint", check_pd=R is not None)
        return Innovation(r, Pzz, float(nis))


class SquareRootConstrainedUKF(_ConstraintOnFactor, SquareRootUKF):
    """CUKF on the factor."""


class SquareRootConstrainedEKF(_ConstraintOnFactor, SquareRootKalmanFilter):
    """CEKF on the factor."""


class SquareRootSageHusaEKF(SageHusaEKF, SquareRootKalmanFilter):
    """AEKF on the factor."""


class SquareRootRobustAdaptiveUKF(RobustAdaptiveUKF, SquareRootUKF):
    """RAUKF on the factor."""


#: standard class -> its factored class (every Gaussian filter; the particle filter has
#: none).  By class, not by name: the registry (:data:`fednav.filters.registry.FILTERS`)
#: holds the names.
FACTORED = {
    KalmanFilter: SquareRootKalmanFilter, UnscentedKalmanFilter: SquareRootUKF,
    SimplifiedUKF: SquareRootSimplifiedUKF, ConstrainedUKF: SquareRootConstrainedUKF,
    ConstrainedEKF: SquareRootConstrainedEKF, SageHusaEKF: SquareRootSageHusaEKF,
    RobustAdaptiveUKF: SquareRootRobustAdaptiveUKF, SparseGridFilter: SquareRootSparseGridFilter,
    AdaptiveSparseGridFilter: SquareRootAdaptiveSparseGridFilter,
}


def __getattr__(name: str):
    """``SQUARE_ROOT``: registry name -> factored class, from the registry as it is now."""
    if name == "SQUARE_ROOT":
        from .registry import FILTERS

        return {k: FACTORED[c] for k, c in FILTERS.items() if c in FACTORED}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
