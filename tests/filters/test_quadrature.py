import numpy as np
import pytest

from fednav.filters import (
    AdaptiveSparseGridFilter,
    FederatedFilter,
    FilterError,
    KalmanFilter,
    LinearModel,
    SageHusaEKF,
    SparseGridFilter,
    UnscentedKalmanFilter,
    make_filter,
)


class _Linear:
    def __init__(self, Phi, Qd):
        self.Phi, self.Qd = Phi, Qd

    def transition(self, X):
        return np.atleast_2d(X) @ self.Phi.T


class _Model(LinearModel):
    kind = "pos"


RNG = np.random.default_rng(4)
N = 6
PHI = np.eye(N) + 0.1 * np.diag(np.ones(N - 1), 1)
Q = 0.01 * np.eye(N)
H = _Model(RNG.normal(size=(2, N)))
R = 0.3 * np.eye(2)


@pytest.mark.parametrize("make", [lambda x, P: SparseGridFilter(x, P, level=3),
                                  lambda x, P: SparseGridFilter(x, P, level=2),
                                  lambda x, P: AdaptiveSparseGridFilter(
                                      x, P, fading=0.999999, r_floor=1.0,
                                      nonlinear_states=(0, 1))])
def test_equals_kalman_filter_on_a_linear_model(make):
    x0, P0 = RNG.normal(size=N), np.diag(RNG.uniform(0.5, 2.0, N))
    kf, f = KalmanFilter(x0, P0), make(x0, P0)
    for k in range(10):
        kf.predict(_Linear(PHI, Q))
        f.predict(_Linear(PHI, Q))
        y = np.array([np.sin(k), np.cos(k)])
        kf.update(y, H, None, R)
        f.update(y, H, None, R if not isinstance(f, AdaptiveSparseGridFilter)
                 else f.sh.current("pos", R))
        if isinstance(f, AdaptiveSparseGridFilter):
            continue  # adapts R: compare only its prediction below
        assert np.allclose(f.x, kf.x, atol=1e-9) and np.allclose(f.P, kf.P, atol=1e-9)


def test_nonlinear_expectation_more_accurate_than_ukf():
    """y = sin(x0) * x1^2: the level-3 grid (degree 5) beats the degree-3 UKF."""
    P = np.diag([0.5, 0.8])

    class Proc:
        Phi = np.eye(2)
        Qd = np.zeros((2, 2))

        def transition(self, X):
            return np.column_stack([np.sin(X[:, 0]) * X[:, 1] ** 2, X[:, 1]])

    rng = np.random.default_rng(0)
    S = rng.multivariate_normal([0.3, 1.0], P, 2_000_000)
    truth = (np.sin(S[:, 0]) * S[:, 1] ** 2).mean()
    sg = SparseGridFilter([0.3, 1.0], P, level=3)
    uk = UnscentedKalmanFilter([0.3, 1.0], P, alpha=1.0, kappa=1.0)
    sg.predict(Proc())
    uk.predict(Proc())
    assert abs(sg.x[0] - truth) < 0.5 * abs(uk.x[0] - truth)


def test_plugs_into_federated_filter_like_the_ukf():
    x0, P0 = np.zeros(N), np.eye(N)
    H2 = _Model(RNG.normal(size=(2, N)))
    res = {}
    for kind in ("kf", "ukf", "sghqf"):
        f = FederatedFilter({"a": make_filter(kind, x0, P0), "b": make_filter(kind, x0, P0)},
                            master=make_filter(kind, x0, P0), sharing="adaptive")
        for k in range(5):
            f.predict(_Linear(PHI, Q))
            f.update("a", [0.1 * k, 0.2], H, None, R)
            f.update("b", [0.0, -0.1 * k], H2, None, R)
            f.fuse()
        res[kind] = f.x
    assert np.allclose(res["sghqf"], res["kf"], atol=1e-8)
    assert np.allclose(res["ukf"], res["kf"], atol=1e-6)


def test_adaptive_grid_is_smaller_and_sage_husa_r_converges():
    f = AdaptiveSparseGridFilter(np.zeros(18), np.eye(18))
    assert f.n_points == 61 and SparseGridFilter(np.zeros(18), np.eye(18)).n_points == 721
    # Known measurement noise 4x the nominal: the estimate converges to it.
    rng = np.random.default_rng(1)
    n = 2
    g = AdaptiveSparseGridFilter(np.zeros(n), np.eye(n), nonlinear_states=(0,), fading=0.99)
    Hm = _Model(np.eye(n))
    x = np.zeros(n)
    R_nom, R_true = 0.25 * np.eye(n), 1.0 * np.eye(n)
    est = []
    for _ in range(3000):
        x = x + rng.normal(0, 0.1, n)
        g.predict(_Linear(np.eye(n), 0.01 * np.eye(n)))
        g.update(x + rng.multivariate_normal(np.zeros(n), R_true), Hm, None, R_nom)
        est.append(np.diag(g.sh.current("pos", R_nom)))
    assert np.allclose(np.mean(est[1000:], axis=0), 1.0, rtol=0.15)


def test_sage_husa_q_converges_on_known_process_noise():
    rng = np.random.default_rng(3)
    q_true, r = 0.5, 1.0
    f = SageHusaEKF([0.0], [[1.0]], fading=0.995, adapt_q=True, adapt_r=False)
    x, est = 0.0, []
    for _ in range(8000):
        x += rng.normal(0, np.sqrt(q_true))
        f.predict(_Linear(np.eye(1), np.array([[0.01]])))   # nominal Q 50x too small
        f.update([x + rng.normal(0, np.sqrt(r))], _Model(np.eye(1)), None, [[r]])
        est.append(f.Qhat[0, 0])
    assert abs(np.mean(est[3000:]) - q_true) < 0.15 * q_true
    fixed = SageHusaEKF([0.0], [[1.0]])
    fixed.predict(_Linear(np.eye(1), np.array([[0.01]])))
    assert fixed.Qhat is None          # off by default


def test_negative_weight_covariance_not_pd_is_reported():
    """A function seen only by the origin, whose weight is negative: the quadrature of
    the variance is w0 (1 - w0) < 0. Reported, not clipped, not NaN."""
    class Spike:
        Phi = np.eye(3)
        Qd = np.zeros((3, 3))

        def transition(self, X):
            Y = X.copy()
            Y[:, 0] = np.where(np.all(X == 0.0, axis=1), 10.0, 0.0)
            return Y

    f = SparseGridFilter(np.zeros(3), np.eye(3), level=3)
    assert f.Wm[np.all(f.grid == 0, axis=1)][0] < 0
    with pytest.raises(FilterError, match="sghqf predict"):
        f.predict(Spike())
