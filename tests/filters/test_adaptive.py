"""Sage–Husa AEKF and robust adaptive UKF."""

import numpy as np

from fednav.filters import (
    LinearModel,
    RobustAdaptiveUKF,
    SageHusaEKF,
    UnscentedKalmanFilter,
    igg3_weights,
)
from fednav.filters.base import FunctionProcess


class Pos(LinearModel):
    kind = "pos"


def _random_walk(filter_cls, R_true, R_nominal, n=3000, seed=0, outliers=()):
    rng = np.random.default_rng(seed)
    f = filter_cls(np.zeros(1), np.eye(1))
    proc = FunctionProcess(lambda x: x, np.eye(1), np.array([[1e-4]]))
    x = 0.0
    errs = []
    for k in range(n):
        x += rng.normal(0, 1e-2)
        f.predict(proc)
        y = x + rng.normal(0, np.sqrt(R_true)) + (50.0 if k in outliers else 0.0)
        f.update(np.array([y]), Pos(np.eye(1)), R=np.array([[R_nominal]]))
        errs.append(f.x[0] - x)
    return f, np.array(errs)


def test_sage_husa_learns_the_measurement_noise():
    f, _ = _random_walk(SageHusaEKF, R_true=4.0, R_nominal=1.0)
    assert abs(f.sh.R["pos"][0, 0] - 4.0) < 1.0


def test_sage_husa_keeps_R_positive_definite():
    """Zero innovations push r r' - H P H' negative: the floor must hold."""
    f = SageHusaEKF(np.zeros(2), 10.0 * np.eye(2))
    m = Pos(np.eye(2))
    for _ in range(200):
        f.update(np.zeros(2), m, R=np.eye(2))
        assert np.linalg.eigvalsh(f.sh.R["pos"]).min() >= 0.1 - 1e-12


def test_sage_husa_floor_is_in_the_nominal_metric():
    """An R of metres and m/s (1.5 m, 0.05 m/s) driven down by zero innovations stays
    at least r_floor times the nominal R in every component: the metres may not fall to
    0.1 x (0.05 m/s)^2, as a floor of the smallest eigenvalue let them."""
    R0 = np.diag([1.5**2, 1.5**2, 0.05**2])
    f = SageHusaEKF(np.zeros(3), np.diag([100.0, 100.0, 1.0]))
    m = Pos(np.eye(3))
    for _ in range(300):
        f.update(np.zeros(3), m, R=R0)
    R = f.sh.R["pos"]
    L = np.linalg.cholesky(R0)
    A = np.linalg.solve(L, np.linalg.solve(L, R).T)
    assert np.linalg.eigvalsh(A).min() >= 0.1 - 1e-9
    np.testing.assert_allclose(np.diag(R), 0.1 * np.diag(R0), rtol=1e-6)


def test_igg3_weights():
    w = igg3_weights([0.0, 1.5, 3.0, 4.5, 10.0])
    np.testing.assert_allclose(w[:2], 1.0)
    assert 0 < w[2] < 1 and w[3] <= 1e-8 + 1e-12 and w[4] == 1e-8
    v = np.linspace(1.5, 4.5, 50)
    assert np.all(np.diff(igg3_weights(v)) <= 1e-12)  # non-increasing


def test_raukf_rejects_outliers_that_pull_the_plain_ukf():
    bad = set(range(1000, 3000, 97))
    _, e_r = _random_walk(RobustAdaptiveUKF, 1.0, 1.0, outliers=bad)
    _, e_u = _random_walk(UnscentedKalmanFilter, 1.0, 1.0, outliers=bad)
    assert np.sqrt(np.mean(e_r[1000:] ** 2)) < 0.5 * np.sqrt(np.mean(e_u[1000:] ** 2))
