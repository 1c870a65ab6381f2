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


@pytest.mark.parametrize("draws", ["plain", "exact"])
def test_federated_fusion_uses_unbiased_information(draws, monkeypatch):
    """Fusing noisy sample covariances every cycle biases the fused covariance low by
    ~(n + 1)/(2 dof) per cycle (here 3.5 % for plain draws); the fusion's correction
    removes it, so the federated PF's covariance tracks the federated KF's instead of
    collapsing (0.34 of it uncorrected).  With the redraws' exact moments only the
    weights' spread is noise (``covariance_dof``), and the fused covariance tracks with
    the correction and without it."""
    from fednav.filters import particle

    if draws == "plain":  # (the filter before the exact draws)
        monkeypatch.setattr(particle, "matched_normal",
                            lambda rng, N, n, against=None: rng.standard_normal((N, n)))
        materialise = particle.ParticleFilter._materialise

        def plain(self, phase):
            X = materialise(self, phase)
            self._exact = False
            return X

        monkeypatch.setattr(particle.ParticleFilter, "_materialise", plain)
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
    # a bias compounds.
    corr = np.mean([fed("pf", s)[2:] / kf[2:] for s in range(10)])
    plain = np.mean([fed("pf", s, False)[2:] / kf[2:] for s in range(10)])
    assert 0.8 < corr < 1.25
    assert (plain < 0.5) if draws == "plain" else (0.8 < plain < 1.25)


def test_a_systems_particle_filters_take_its_settings_and_streams_of_their_own():
    """``filter.pf`` reaches every local particle filter, each with a random stream of
    its own from ``filter.pf.seed`` (before, every one drew seed 0's stream, and a
    system could set none of its settings)."""
    from fednav import load_system
    from fednav.navigator.loop import build_federation

    def federation(**pf):
        system = load_system({"filter": {"type": "pf", "locals": {"baro": {"type": "kf"}},
                                         "pf": pf}})
        return build_federation(system, ["gnss", "star", "baro"], np.eye(18), 18)

    fed = federation(particles=300, roughening=0.1, progressive_correction=False,
                     resample_threshold=0.7, seed=5)
    a, b = fed.locals["gnss"], fed.locals["star"]
    for f in (a, b):
        assert (f.N, f.roughening, f.progressive, f.resample_threshold) == (300, 0.1, False,
                                                                            0.7)
    assert a.rng.random() != b.rng.random()
    assert not isinstance(fed.locals["baro"], type(a))
    again = federation(particles=300, seed=5).locals["gnss"]
    assert again.progressive  # (the default)
    assert again.rng.random() == federation(seed=5).locals["gnss"].rng.random()
    assert federation(seed=6).locals["gnss"].rng.random() != federation(
        seed=5).locals["gnss"].rng.random()


def test_roughening_that_never_acts_is_named():
    """With the progressive correction at least half the particles stay effective, so a
    resample threshold of 0.5 or less never resamples and roughening never acts: a run
    of recorded data names the key (as every key it does not use)."""
    from fednav import load_system
    from fednav.process.checks import _conditional

    def named(**pf):
        cfg = load_system({"filter": {"type": "pf", "pf": pf}})
        return [k for k in _conditional(cfg) if k.startswith("filter.pf.roughening")]

    assert named(roughening=0.2)
    assert not named(roughening=0.2, resample_threshold=0.8)
    assert not named(roughening=0.2, progressive_correction=False)
    assert not named()


def test_redraws_and_process_noise_keep_the_covariance_exactly():
    """A set redrawn from N(x, P) has sample mean x and covariance P exactly, and a linear
    time update grows it by exactly Qd — so 300 fusion-reset cycles (redraw, predict)
    follow the Kalman filter's covariance to rounding.  Before (plain draws), the sampling
    error of each redraw carried into the next, and the log-determinant of a 6-state set
    of 200 particles fell about 0.1 a cycle: a collapse no measurement was there to stop
    (the certificate's particle filters: NEES per dof 20-3 000)."""
    from fednav.filters.particle import matched_normal

    n, N = 6, 200
    rng = np.random.default_rng(3)
    A = rng.standard_normal((n, n))
    P0 = A @ A.T + np.eye(n)
    Phi = np.eye(n) + 0.05 * rng.standard_normal((n, n))
    proc = _Linear(Phi, 0.01 * np.eye(n))
    kf = KalmanFilter(np.zeros(n), P0)
    pf = ParticleFilter(np.zeros(n), P0, n_particles=N, rng=5)
    X = pf._materialise("test")
    assert np.allclose(X.mean(axis=0), 0.0, atol=1e-12)
    assert np.allclose(np.cov(X.T), P0, rtol=1e-10, atol=1e-12)
    for _ in range(300):
        kf.predict(proc)
        pf.predict(proc)
        pf.P = pf.P  # the fusion-reset's assignment: a redraw
    sign, logdet = np.linalg.slogdet(pf.P)
    assert sign > 0 and abs(logdet - np.linalg.slogdet(kf.P)[1]) < 1e-6
    assert np.allclose(pf.P, kf.P, rtol=1e-6)
    # the draws themselves: exact moments, uncorrelated with what they move; plain
    # where too few to match
    B = rng.standard_normal((50, 3))
    Z = matched_normal(np.random.default_rng(1), 50, 4, B)
    assert np.allclose(Z.T @ Z / 49, np.eye(4)) and np.allclose(Z.sum(axis=0), 0.0)
    assert np.allclose(Z.T @ (B - B.mean(axis=0)), 0.0, atol=1e-10)
    assert matched_normal(np.random.default_rng(1), 5, 4).shape == (5, 4)


def test_the_covariance_dof_counts_the_noise_the_set_has():
    """A set drawn with exact moments is noisy only by its weights' spread: infinite
    degrees of freedom with equal weights, ``1 / (1/ESS - 1/N) - 1`` otherwise; after a
    resampling (plain copies) Kish's ``ESS - 1``."""
    n, N = 4, 400
    pf = ParticleFilter(np.zeros(n), np.eye(n), n_particles=N, rng=2, resample_threshold=0.9)
    pf.predict(_Linear(np.eye(n), 0.01 * np.eye(n)))
    assert pf.covariance_dof == np.inf
    pf.update([0.3], LinearModel(np.eye(n)[:1]), None, np.array([[0.5]]))
    assert pf.resamples == 1  # (ESS below 0.9 N: resampled after its estimate)
    ess = pf._est_ess
    assert pf.covariance_dof == pytest.approx(ess - 1.0)
    pf.P = pf.P  # a redraw: exact again, equal weights
    pf.predict(_Linear(np.eye(n), 0.01 * np.eye(n)))
    assert pf.covariance_dof == np.inf
    pf.update([0.1], LinearModel(np.eye(n)[:1]), None, np.array([[4.0]]))
    assert pf.resamples == 1  # (a wide measurement: no resampling this time)
    ess = 1.0 / float(pf.weights @ pf.weights)
    assert pf.covariance_dof == pytest.approx(1.0 / (1.0 / ess - 1.0 / N) - 1.0)
    assert pf.covariance_dof > 10 * ess


def test_a_negative_particle_seed_is_refused_naming_the_key():
    from fednav import load_system
    from fednav.core.config import ConfigError

    for bad in (-1, [1, -2]):
        with pytest.raises(ConfigError, match="filter.pf.seed"):
            load_system({"filter": {"type": "pf", "pf": {"seed": bad}}})
