"""Numerical soak: run a filter for many cycles on the 18-state INS error model under
hostile conditions and check that its numerics hold.

Conditions (all at once, filter units of :mod:`fednav.ins.error_model`):

* initial covariance ``huge_p`` (1e6) times the identity;
* process noise scaled by ``tiny_q`` (1e-12): the covariance may collapse;
* a 6-row measurement (attitude and position errors) whose noise covariance has one
  variance ``small_r`` (1e-12) and the others 1 (condition number 1e12);
* every ``outlier_every`` cycles a measurement 1e6 sigma off;
* constrained filters get a constraint every 10 cycles (velocity error = 0);
* optionally (``gate_alpha``) chi-square gating of the measurement, which is how a
  navigation filter meets the outliers (the federated filter's ``fdi_alpha``).

After every cycle: the state is finite, the covariance symmetric (to 1e-9 relative) and
positive definite (Cholesky).  For a factored filter (``form="square_root"``) the
covariance ``P = S S'`` is positive definite exactly when its lower-triangular factor ``S``
has a positive diagonal — that is what is checked, and its eigenvalues are the squared
singular values of ``S`` (resolved far below ``eps * max eig``, where the eigenvalues or
the Cholesky factorization of the formed ``S S'`` stop meaning anything: a covariance
with a 1e6 and a 1e-12 variance has a condition number of 1e18).  A filter may stop with
a :class:`FilterError` — a divergence reported with the filter, the step and the reason
is the accepted way to fail; a NaN or a silently indefinite covariance is not.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..core.kernels import cholesky_lower
from .base import FilterError, LinearModel


@dataclass
class SoakResult:
    """``cycles`` completed; ``error`` the FilterError text if one stopped the run;
    ``max_asymmetry`` max |P - P'| / max|P|; ``min_eig``/``max_cond`` over the checks
    (eigenvalues every ``eig_every`` cycles); ``seconds``; ``readmissions`` after
    rejections in a row (with a gate)."""

    name: str
    cycles: int
    error: str | None
    max_asymmetry: float
    min_eig: float
    max_cond: float
    seconds: float
    readmissions: int = 0


class _ConstantProcess:
    def __init__(self, proc, q_scale, linear: bool = False):
        self._p, self.Phi, self.Qd = proc, proc.Phi, proc.Qd * q_scale
        self.linear = linear

    def transition(self, X):
        if self.linear:
            return np.atleast_2d(X) @ self.Phi.T
        return self._p.transition(X)


class _Constraint(LinearModel):
    constraint = True


def cruise_process():
    """The error process of one second of level cruise at 250 m/s, 32 deg N."""
    from ..ins import error_model as em
    from ..ins.error_model import ImuNoiseModel
    from ..ins.strapdown import Strapdown

    ins = Strapdown(np.array([np.radians(32.0), np.radians(118.0), 1000.0]),
                    np.array([250.0, 0.0, 0.0]), np.array([0.0, 0.0, np.radians(90.0)]), 0.01)
    s0 = ins.state.copy()
    f = np.tile([0.0, 0.0, 9.79 * 0.01], (100, 1))
    ins.run(np.zeros((100, 3)), f, record=False)
    noise = ImuNoiseModel(gyro_arw=1e-5, accel_vrw=1e-4, gyro_markov_sigma=1e-6,
                          gyro_markov_tau=3600.0, accel_markov_sigma=1e-4,
                          accel_markov_tau=3600.0)
    return em.interval_process(s0, ins.state, f.sum(axis=0), 1.0, noise)


def soak(name: str, cycles: int, seed: int = 0, huge_p: float = 1e6, tiny_q: float = 1e-12,
         small_r: float = 1e-12, outlier_every: int = 97, eig_every: int = 100,
         form: str = "standard", gate_alpha: float | None = None, readmit_after: int = 3,
         linear: bool = False, **options) -> SoakResult:
    """Soak the registry filter ``name`` for ``cycles`` cycles (see the module docstring).

    ``form``: the filter's covariance form (``standard`` or ``square_root``);
    ``gate_alpha``: chi-square gating of the 6-row measurement at this level (None: every
    measurement, outliers included, is applied), with re-admission as the federated
    filter does it (:func:`fednav.filters.federated._inflation`): after ``readmit_after``
    rejections in a row the filter, not the sensor, is wrong (an isolated outlier is one
    rejection) — its covariance is inflated by the factor that gives the residual its
    expected statistic and the measurement applied.  ``linear``: the state propagates
    by ``Phi x`` instead of the nonlinear error model (the model the Kalman filter's
    covariance assumes; with the nonlinear mean and errors of the 1e3 the huge P0 allows,
    an EKF's covariance does not describe its error, whatever its numerics)."""
    from ..core.stats import chi2_ppf
    from . import make_filter
    from .federated import _inflation

    rng = np.random.default_rng(seed)
    proc = _ConstantProcess(cruise_process(), tiny_q, linear)
    n = proc.Phi.shape[0]
    H = np.zeros((6, n))
    H[[0, 1, 2], [0, 1, 2]] = 1.0   # attitude errors
    H[[3, 4, 5], [6, 7, 8]] = 1.0   # position errors
    R = np.diag([small_r, 1.0, 1.0, 1.0, 1.0, 1.0])
    sd = np.sqrt(np.diag(R))
    meas = LinearModel(H)
    D = np.zeros((3, n))
    D[[0, 1, 2], [3, 4, 5]] = 1.0
    cons = _Constraint(D)
    f = make_filter(name, np.zeros(n), huge_p * np.eye(n), form=form, **options)
    gate = None if gate_alpha is None else float(chi2_ppf(1.0 - gate_alpha, 6))
    factored = f.form == "square_root"
    asym, min_eig, max_cond = 0.0, np.inf, 0.0
    t0 = time.perf_counter()
    done, error, rejected, readmitted = 0, None, 0, 0
    try:
        for k in range(cycles):
            f.predict(proc)
            y = sd * rng.standard_normal(6)
            if outlier_every and k % outlier_every == outlier_every - 1:
                y = y + 1e6 * sd
            inn = f.update(y, meas, None, R, gate)
            rejected = 0 if inn.accepted else rejected + 1
            if rejected >= readmit_after:
                s = _inflation(inn.r, inn.S, R, inn.nis)
                f.inflate(s)
                f.update(y, meas, None, R)
                rejected = 0
                readmitted += 1
            if name in ("cukf", "cekf") and k % 10 == 9:
                f.update(np.zeros(3), cons, None, 1e-6 * np.eye(3))
            x, P = f.x, f.P
            if not np.all(np.isfinite(x)) or not np.all(np.isfinite(P)):
                raise AssertionError(f"{name}: NaN/inf at cycle {k} without a FilterError")
            scale = float(np.max(np.abs(P)))
            asym = max(asym, float(np.max(np.abs(P - P.T))) / scale)
            if factored:
                S = f.S
                if not (np.all(np.isfinite(S)) and np.min(np.diagonal(S)) > 0.0
                        and not np.any(np.triu(S, 1))):
                    raise AssertionError(f"{name}: covariance factor singular or not lower "
                                         f"triangular at cycle {k} without a FilterError")
            elif not cholesky_lower(np.ascontiguousarray(P))[1]:
                raise AssertionError(f"{name}: covariance not positive definite at cycle {k} "
                                     f"without a FilterError")
            if k % eig_every == 0 or k == cycles - 1:
                if factored:  # eigenvalues of S S': the squared singular values of S
                    ev = np.linalg.svd(f.S, compute_uv=False)[::-1] ** 2
                else:
                    ev = np.linalg.eigvalsh(0.5 * (P + P.T))
                min_eig = min(min_eig, float(ev[0]))
                max_cond = max(max_cond, float(ev[-1] / ev[0]))
            done = k + 1
    except FilterError as e:
        error = str(e)
    return SoakResult(name, done, error, asym, min_eig, max_cond, time.perf_counter() - t0,
                      readmitted)
