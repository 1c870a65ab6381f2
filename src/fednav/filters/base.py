"""The filter interface every estimator implements.

A filter holds a state ``x`` (n,) and covariance ``P`` (n, n) and offers

* ``predict(process, q_scale=1.0)`` — time update over one interval.  ``process`` gives
  ``transition(X)`` (rows of X propagated, nonlinear), ``Phi`` (its Jacobian) and ``Qd``
  (discrete process noise); ``q_scale`` multiplies ``Qd`` (federated sharing, 1/beta);
* ``update(y, model, nav, R, gate=None)`` — measurement update with the observed ``y``;
  ``model`` gives ``h(X, nav)`` (rows) and ``H(nav)``; returns an :class:`Innovation`.
  With a ``gate``, a measurement whose statistic ``r' S^-1 r`` exceeds it is not applied
  (chi-square fault detection; the innovation is still returned).

Covariances are kept symmetric; a covariance that is not positive definite raises
:class:`FilterError` naming the filter and the step.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..core.errors import FednavError
from ..core.kernels import cholesky_lower


class FilterError(FednavError, RuntimeError):
    """Numerical failure inside a filter (names the filter and the step)."""


class Innovation(NamedTuple):
    """Residual ``r = y - y_hat``, its covariance ``S``, the statistic ``r' S^-1 r`` and
    whether the update was applied (False when the statistic exceeded the gate)."""

    r: np.ndarray
    S: np.ndarray
    nis: float
    accepted: bool = True
    #: the rows of the measurement the update used when fault detection left a unit out
    #: (:meth:`fednav.filters.federated.FederatedFilter.update`); None: every row
    rows: np.ndarray | None = None


@dataclass
class FunctionProcess:
    """A process model from plain functions: ``f(x) -> x`` (one state), Jacobian ``F``, ``Q``."""

    f: object
    Phi: np.ndarray
    Qd: np.ndarray

    def transition(self, X):
        return np.array([self.f(x) for x in np.atleast_2d(X)])


@dataclass
class FunctionModel:
    """A measurement model from plain functions: ``h(x) -> z`` and its Jacobian ``H``."""

    hx: object
    Hmat: np.ndarray | None = None

    def h(self, X, nav=None):
        return np.array([np.atleast_1d(self.hx(x)) for x in np.atleast_2d(X)])

    def H(self, nav=None):
        return self.Hmat


@dataclass
class LinearModel:
    """A linear measurement model ``y = H x``, batched over the rows of X."""

    Hmat: np.ndarray

    def h(self, X, nav=None):
        return np.atleast_2d(X) @ self.Hmat.T

    def H(self, nav=None):
        return self.Hmat


def not_pd_error(P: np.ndarray, who: str) -> FilterError:
    """The error for a covariance that is not positive definite (with its smallest
    eigenvalue, for diagnosis)."""
    ev = np.linalg.eigvalsh(0.5 * (P + P.T)) if np.all(np.isfinite(P)) else [np.nan]
    return FilterError(f"{who}: covariance is not positive definite "
                       f"(smallest eigenvalue {np.min(ev):.3g})")


def chol(P: np.ndarray, who: str) -> np.ndarray:
    """Lower Cholesky factor of P, or a :class:`FilterError` naming ``who``."""
    L, ok = cholesky_lower(np.ascontiguousarray(P, dtype=float))
    if not ok:
        raise not_pd_error(P, who)
    return L


class Filter(ABC):
    """Common state, bookkeeping and checks of all estimators."""

    #: ``standard`` (the covariance ``P`` itself) or ``square_root`` (a Cholesky factor,
    #: :mod:`fednav.filters.square_root`)
    form = "standard"
    #: the name it is registered under (:func:`fednav.filters.registry.make_filter` sets
    #: it: ``kf`` and ``ekf`` are one class); "" for a filter built by hand
    kind = ""

    def __init__(self, x0, P0, name: str = "filter"):
        self.x = np.array(x0, dtype=float)
        self.P = np.array(P0, dtype=float)
        n = self.x.shape[0]
        if self.x.ndim != 1 or self.P.shape != (n, n):
            raise ValueError(f"{name}: x0 must be (n,) and P0 (n, n); got {self.x.shape} and "
                             f"{self.P.shape}")
        if not (np.all(np.isfinite(self.x)) and np.all(np.isfinite(self.P))):
            raise ValueError(f"{name}: initial state or covariance contains NaN/inf")
        self.name = name
        self.step = 0
        chol(self.P, f"{name} (initial covariance)")

    @property
    def n(self) -> int:
        return self.x.shape[0]

    def _who(self, phase: str) -> str:
        return f"{self.name} {phase} at step {self.step}"

    def inflate(self, s: float) -> None:
        """Scale the covariance by ``s`` > 0 (re-admission after a lockout)."""
        self.P = self.P * s

    def _finish(self, phase: str, symmetrize: bool = True, check_pd: bool = False) -> None:
        if symmetrize:
            self.P = 0.5 * (self.P + self.P.T)
        # A sum propagates any NaN/inf: one cheap check for the whole state.
        if not math.isfinite(self.x.sum() + self.P.sum()):
            raise FilterError(f"{self._who(phase)}: state or covariance became NaN/inf")
        if check_pd and not cholesky_lower(np.ascontiguousarray(self.P))[1]:
            raise not_pd_error(self.P, self._who(phase))

    @abstractmethod
    def predict(self, process, q_scale: float = 1.0) -> None: ...

    @abstractmethod
    def update(self, y, model, nav=None, R=None, gate: float | None = None) -> Innovation: ...
