"""Estimate projection (paper 000 CUKF): both theorems, and the filter feature."""

import numpy as np
import pytest

from fednav.filters import ConstrainedEKF, ConstrainedUKF, FilterError, LinearModel, project


def _toy(seed=0):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((4, 4))
    P = A @ A.T + 0.5 * np.eye(4)
    D = np.array([[1.0, 1.0, -1.0, 0.0], [0.0, 2.0, 0.0, 1.0]])
    return rng, P, D


def test_projection_satisfies_the_constraint_and_is_unbiased():
    """Theorem 1: truth satisfies D x = d, the estimate is unbiased -> so is the projection."""
    rng, P, D = _toy()
    L = np.linalg.cholesky(P)
    N = 20000
    xs = rng.standard_normal((N, 4)) @ np.diag([3.0, 1.0, 2.0, 0.5])
    xs[:, 2] = xs[:, 0] + xs[:, 1]          # row 1: x0 + x1 - x2 = 0
    d_rows = D @ xs.T                        # the true constraint values per sample
    err = np.empty((N, 4))
    for i in range(N):
        xhat = xs[i] + L @ rng.standard_normal(4)
        xt, _ = project(xhat, P, D, d_rows[:, i])
        np.testing.assert_allclose(D @ xt, d_rows[:, i], atol=1e-9)
        err[i] = xt - xs[i]
    se = err.std(axis=0) / np.sqrt(N)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * se)
    # Theorem 2: the error covariance is P - K D P, smaller than P
    _, Pt = project(np.zeros(4), P, D, np.zeros(2))
    np.testing.assert_allclose(np.cov(err.T), Pt, atol=0.05 * np.abs(P).max())


def test_projected_covariance_is_smaller():
    _, P, D = _toy(1)
    _, Pt = project(np.zeros(4), P, D, np.zeros(2))
    assert np.linalg.eigvalsh(P - Pt).min() > -1e-12       # P - P~ >= 0
    assert np.linalg.matrix_rank(Pt, tol=1e-9) == 2         # singular along D (exact d)
    _, Pn = project(np.zeros(4), P, D, np.zeros(2), Rd=0.01 * np.eye(2))
    assert np.linalg.eigvalsh(Pn).min() > 0                 # noisy d keeps it PD
    assert np.linalg.eigvalsh(P - Pn).min() > -1e-12


@pytest.mark.parametrize("cls", [ConstrainedUKF, ConstrainedEKF])
def test_filters_project_on_constraint_models_only(cls):
    _, P, D = _toy(2)
    x0 = np.array([1.0, -2.0, 0.5, 3.0])
    f = cls(x0, P)

    class Constraint(LinearModel):
        constraint = True

    d = np.array([0.2, -0.1])
    f.update(d, Constraint(D), R=1e-4 * np.eye(2))
    xt, Pt = project(x0, P, D, d, 1e-4 * np.eye(2))
    np.testing.assert_allclose(f.x, xt, atol=1e-10)
    np.testing.assert_allclose(f.P, Pt, atol=1e-10)
    g = cls(x0, P)  # an ordinary model is an ordinary Kalman update
    R = 0.5 * np.eye(2)
    g.update(d, LinearModel(D), R=R)
    K = P @ D.T @ np.linalg.inv(D @ P @ D.T + R)
    np.testing.assert_allclose(g.x, x0 + K @ (d - D @ x0), atol=1e-8)
    with pytest.raises(FilterError, match="not positive definite"):
        project(x0, P, np.zeros((1, 4)), [0.0])
