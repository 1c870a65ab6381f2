import numpy as np
import pytest

from fednav.filters import (
    FederatedFilter,
    FilterError,
    KalmanFilter,
    LinearModel,
    ParticleFilter,
    make_filter,
    systematic_resample,
)


class _Linear:
    def __init__(self, Phi, Qd):
        self.Phi, self.Qd = Phi, Qd

    def transition(self, X):
        return X @ self.Phi.T


PHI = np.array([[1.0, 0.5], [0.0, 1.0]])
QD = np.diag([0.01, 0.04])
H = LinearModel(np.array([[1.0, 0.0]]))
R = np.array([[0.25]])


def test_linear_gaussian_matches_kalman():
    """For large N the PF's mean and covariance equal the Kalman filter's within the
    Monte Carlo error of N particles."""
    rng = np.random.default_rng(7)
    x0, P0 = np.array([1.0, -0.5]), np.diag([1.0, 0.5])
    kf = KalmanFilter(x0, P0)
    N = 40_000
    pf = ParticleFilter(x0, P0, n_particles=N, rng=rng, resample_threshold=0.5)
    proc = _Linear(PHI, QD)
    for k in range(15):
        kf.predict(proc)
        pf.predict(proc)
        y = np.array([np.sin(0.3 * k)])
        ik = kf.update(y, H, None, R)
        ip = pf.update(y, H, None, R)
        sd = np.sqrt(np.diag(kf.P))
        assert np.all(np.abs(pf.x - kf.x) < 5 * sd / np.sqrt(pf.ess_log[-1]))
        assert np.allclose(pf.P, kf.P, rtol=0.08, atol=0)
        assert abs(ip.nis - ik.nis) < 0.1 * max(ik.nis, 1.0) + 0.05
    assert pf.resamples > 0


def test_systematic_resampling_is_unbiased():
    rng = np.random.default_rng(1)
    w = rng.random(20) ** 3
    w /= w.sum()
    N = len(w)
    counts = np.zeros(N)
    for _ in range(20_000):
        idx = systematic_resample(w, rng.random())
        c = np.bincount(idx, minlength=N)
        # Systematic: each count is floor or ceil of N w.
        assert np.all(c >= np.floor(N * w) - 1e-9) and np.all(c <= np.ceil(N * w) + 1e-9)
        counts += c
    assert np.allclose(counts / 20_000, N * w, atol=0.02)


def test_set_x_shifts_and_set_p_redraws():
    pf = ParticleFilter(np.zeros(2), np.eye(2), n_particles=500, rng=3)
    pf.predict(_Linear(np.eye(2), np.zeros((2, 2))))
    before = pf.particles.copy()
    pf.x = pf.x + np.array([2.0, -1.0])
    assert np.allclose(pf.particles - before, [2.0, -1.0])
    pf.P = 1e-4 * np.eye(2)
    pf.predict(_Linear(np.eye(2), np.zeros((2, 2))))
    assert np.allclose(pf.particles.mean(axis=0), pf.x, atol=1e-3)
    assert np.all(pf.particles.std(axis=0) < 0.02)


def test_same_seed_same_result():
    def run(seed):
        pf = ParticleFilter(np.zeros(2), np.eye(2), n_particles=300, rng=seed)
        for k in range(5):
            pf.predict(_Linear(PHI, QD))
            pf.update([0.1 * k], H, None, R)
        return pf.x
    assert np.array_equal(run(4), run(4)) and not np.array_equal(run(4), run(5))


def test_zero_likelihood_is_an_error_not_nan():
    class Bounded(LinearModel):
        def loglik(self, y, X, nav, R):
            return np.where(np.abs(y[0] - X[:, 0]) < 1.0, 0.0, -np.inf)

    pf = ParticleFilter(np.zeros(2), np.eye(2), n_particles=200, rng=0)
    with pytest.raises(FilterError, match="every particle weight is zero"):
        pf.update([50.0], Bounded(H.Hmat), None, R)


def test_collapse_is_reported():
    # Every update keeps ~20 effective particles of 200: below the 50 % rule 3 times.
    pf = ParticleFilter(np.zeros(2), 100 * np.eye(2), n_particles=200, rng=0,
                        collapse_fraction=0.5, max_collapsed=3, resample_threshold=1.0,
                        roughening=0.2)
    proc = _Linear(np.eye(2), 100 * np.eye(2))
    with pytest.raises(FilterError, match="degenerate — effective sample size below 100"):
        for _ in range(10):
            pf.predict(proc)
            pf.update([0.0], H, None, np.array([[1.0]]))
    assert len(pf.ess_log) == 3


def test_weight_collapse_without_resampling_is_reported():
    pf = ParticleFilter(np.zeros(2), 100 * np.eye(2), n_particles=200, rng=0,
                        resample_threshold=0.0)
    with pytest.raises(FilterError, match="effective sample size 1.00 of 200"):
        pf.update([0.0], H, None, np.array([[1e-10]]))


def test_roughening_keeps_impoverished_set_usable():
    # A very precise measurement leaves ~1 distinct particle after resampling; with
    # roughening the set still has a positive-definite covariance.
    pf = ParticleFilter(np.zeros(2), np.eye(2), n_particles=300, rng=2, roughening=0.2,
                        resample_threshold=1.0)
    pf.update([0.3], H, None, np.array([[1e-6]]))
    assert len(np.unique(pf.particles, axis=0)) == 300
    bare = ParticleFilter(np.zeros(2), np.eye(2), n_particles=300, rng=2,
                          resample_threshold=1.0)
    bare.update([0.3], H, None, np.array([[1e-6]]))
    assert len(np.unique(bare.particles, axis=0)) < 30


def test_gate_leaves_weights_alone():
    pf = ParticleFilter(np.zeros(2), np.eye(2), n_particles=500, rng=0)
    pf.predict(_Linear(np.eye(2), np.zeros((2, 2))))
    w = pf.weights.copy()
    inn = pf.update([100.0], H, None, R, gate=10.0)
    assert not inn.accepted and np.array_equal(pf.weights, w)


def test_federated_pf_equals_federated_kf_for_large_n():
    x0, P0 = np.zeros(2), np.eye(2)
    proc = _Linear(PHI, QD)
    H2 = LinearModel(np.array([[0.0, 1.0]]))

    def fed(kind):
        opts = {"n_particles": 20_000, "rng": 11} if kind == "pf" else {}
        locs = {"a": make_filter(kind, x0, P0, **opts),
                "b": make_filter(kind, x0, P0, **({**opts, "rng": 12} if opts else {}))}
        f = FederatedFilter(locs, sharing="equal", reset=True)
        for k in range(8):
            f.predict(proc)
            f.update("a", [np.cos(k)], H, None, R)
            f.update("b", [0.2 * k], H2, None, R)
            f.fuse()
        return f.x, f.P

    xk, Pk = fed("kf")
    xp, Pp = fed("pf")
    assert np.allclose(xp, xk, atol=0.03)
    assert np.allclose(Pp, Pk, rtol=0.1)


@pytest.mark.parametrize("bad", [{"n_particles": 1}, {"n_particles": 10.5},
                                 {"resample_threshold": 2.0}, {"roughening": -1.0}])
def test_bad_options(bad):
    with pytest.raises(ValueError):
        ParticleFilter(np.zeros(2), np.eye(2), **bad)


def test_federated_fusion_uses_unbiased_information():
    """Fusing noisy sample covariances every cycle biases the fused covariance low by
    ~(n + 1)/(2 dof) per cycle (here 3.5 %); the fusion's correction removes it, so the
    federated PF's covariance tracks the federated KF's instead of collapsing."""
    n, N, cycles = 6, 100, 30
    x0, P0 = np.zeros(n), np.eye(n)
    proc = _Linear(np.eye(n), 1e-3 * np.eye(n))
    Ha = LinearModel(np.eye(n)[:1])
    Hb = LinearModel(np.eye(n)[1:2])

    def fed(kind, seed=0, fusion=True):
        def mk(s):
            if kind == "kf":
                return KalmanFilter(x0, P0)
            pf = ParticleFilter(x0, P0, n_particles=N, rng=s)
            if not fusion:  # hide the covariance's degrees of freedom from the fusion
                pf.__class__ = type("PlainPF", (ParticleFilter,), {"covariance_dof": None})
            return pf
        f = FederatedFilter({"a": mk(seed), "b": mk(seed + 100)}, sharing="equal",
                            reset=True)
        for _ in range(cycles):
            f.predict(proc)
            f.update("a", [0.0], Ha, None, R)
            f.update("b", [0.0], Hb, None, R)
            f.fuse()
        return np.diag(f.P)

    kf = fed("kf")
    # Mean over seeds of the PF/KF variance ratio of the unobserved states (2..5), where
    # the bias compounds: expected ~1 corrected, 0.965^30 = 0.34 plain.
    corr = np.mean([fed("pf", s)[2:] / kf[2:] for s in range(10)])
    plain = np.mean([fed("pf", s, False)[2:] / kf[2:] for s in range(10)])
    assert 0.8 < corr < 1.25
    assert plain < 0.5
