import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints
from filterpy.kalman import UnscentedKalmanFilter as FPUKF

from fednav.filters import (
    FederatedFilter,
    FilterError,
    FunctionModel,
    FunctionProcess,
    KalmanFilter,
    LinearModel,
    UnscentedKalmanFilter,
    make_filter,
    sharing_factors,
)

DT = 0.1


def fx(x):
    # Nonlinear toy: pendulum-like 2-D system with coupling.
    return np.array([x[0] + DT * x[1], x[1] - DT * np.sin(x[0]) + 0.01 * x[2] ** 2, 0.99 * x[2]])


def hx(x):
    return np.array([np.hypot(x[0], 2.0), np.arctan2(x[2], 3.0)])


Q = np.diag([1e-4, 2e-4, 1e-4])
R = np.diag([0.01, 0.02])


def test_ukf_matches_filterpy():
    rng = np.random.default_rng(3)
    x0 = np.array([0.3, -0.1, 0.5])
    P0 = np.diag([0.1, 0.2, 0.3])
    pts = MerweScaledSigmaPoints(3, alpha=0.5, beta=2.0, kappa=0.0)
    ref = FPUKF(dim_x=3, dim_z=2, dt=DT, hx=hx, fx=lambda x, dt: fx(x), points=pts)
    ref.x, ref.P, ref.Q, ref.R = x0.copy(), P0.copy(), Q, R
    ukf = UnscentedKalmanFilter(x0, P0, alpha=0.5, beta=2.0, kappa=0.0)
    proc = FunctionProcess(fx, np.eye(3), Q)
    model = FunctionModel(hx)
    for _ in range(20):
        z = hx(ref.x) + rng.normal(0, 0.1, 2)
        ref.predict()
        ref.update(z)
        ukf.predict(proc)
        ukf.update(z, model, R=R)
        np.testing.assert_allclose(ukf.x, ref.x, atol=1e-9)
        np.testing.assert_allclose(ukf.P, ref.P, atol=1e-9)


def linear_problem(seed=0, n=4, m=2):
    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.05 * rng.standard_normal((n, n))
    H = rng.standard_normal((m, n))
    return A, H


@pytest.mark.parametrize("alpha", [1e-3, 0.5, 1.0])
def test_ukf_reduces_to_kf_on_linear_problem(alpha):
    A, H = linear_problem()
    Qd, Rm = 0.01 * np.eye(4), 0.1 * np.eye(2)
    proc = FunctionProcess(lambda x: A @ x, A, Qd)
    model = FunctionModel(lambda x: H @ x, H)
    x0, P0 = np.ones(4), np.eye(4)
    kf = KalmanFilter(x0, P0)
    ukf = UnscentedKalmanFilter(x0, P0, alpha=alpha)
    rng = np.random.default_rng(1)
    for _ in range(30):
        z = rng.standard_normal(2)
        kf.predict(proc)
        ukf.predict(proc)
        i1 = kf.update(z, model, R=Rm)
        i2 = ukf.update(z, model, R=Rm)
        assert i1.nis == pytest.approx(i2.nis, rel=1e-6)
    np.testing.assert_allclose(ukf.x, kf.x, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(ukf.P, kf.P, rtol=1e-6, atol=1e-8)


def test_kf_joseph_keeps_psd_with_tiny_R():
    A, H = linear_problem(2)
    proc = FunctionProcess(lambda x: A @ x, A, 1e-6 * np.eye(4))
    model = FunctionModel(lambda x: H @ x, H)
    kf = KalmanFilter(np.zeros(4), 1e4 * np.eye(4))
    for _ in range(50):
        kf.predict(proc)
        kf.update(np.zeros(2), model, R=1e-10 * np.eye(2))
        assert np.allclose(kf.P, kf.P.T)
        assert np.linalg.eigvalsh(kf.P).min() > -1e-12


def test_clear_errors():
    with pytest.raises(FilterError, match="ukf .*not positive definite"):
        UnscentedKalmanFilter(np.zeros(2), np.array([[1.0, 2.0], [2.0, 1.0]]), name="ukf")
    with pytest.raises(ValueError, match="NaN"):
        KalmanFilter(np.array([np.nan, 0.0]), np.eye(2))
    with pytest.raises(ValueError, match="unknown filter 'pf2'"):
        make_filter("pf2", np.zeros(2), np.eye(2))
    ukf = UnscentedKalmanFilter(np.zeros(2), np.eye(2), name="local-1")
    bad = FunctionProcess(lambda x: x, np.eye(2), -10 * np.eye(2))
    ukf.predict(bad)
    with pytest.raises(FilterError, match="local-1 predict at step 2"):
        ukf.predict(bad)


def test_sharing_factor_rules():
    covs = {"a": np.eye(2), "b": 2 * np.eye(2), "m": 4 * np.eye(2)}
    eq = sharing_factors(covs, "equal")
    assert all(v == pytest.approx(1 / 3) for v in eq.values())
    fx_ = sharing_factors(covs, "fixed", {"a": 2, "b": 1, "m": 1})
    assert fx_ == pytest.approx({"a": 0.5, "b": 0.25, "m": 0.25})
    ad = sharing_factors(covs, "adaptive")
    # tr(P^-1) = 2, 1, 0.5
    assert ad == pytest.approx({"a": 2 / 3.5, "b": 1 / 3.5, "m": 0.5 / 3.5})
    with pytest.raises(ValueError, match="unknown sharing rule"):
        sharing_factors(covs, "magic")


@pytest.mark.parametrize("sharing", ["equal", "adaptive"])
@pytest.mark.parametrize("with_master", [True, False])
def test_federated_reset_equals_centralized(sharing, with_master):
    rng = np.random.default_rng(5)
    n = 4
    A, _ = linear_problem(3, n)
    H1, H2 = rng.standard_normal((2, n)), rng.standard_normal((1, n))
    R1, R2 = np.diag([0.2, 0.3]), np.array([[0.1]])
    Qd = 0.02 * np.eye(n)
    proc = FunctionProcess(lambda x: A @ x, A, Qd)
    m1, m2 = FunctionModel(lambda x: H1 @ x, H1), FunctionModel(lambda x: H2 @ x, H2)
    mc = FunctionModel(lambda x: np.r_[H1 @ x, H2 @ x], np.vstack([H1, H2]))
    Rc = np.diag([0.2, 0.3, 0.1])
    x0, P0 = rng.standard_normal(n), np.eye(n)
    central = KalmanFilter(x0, P0)
    fed = FederatedFilter({"one": KalmanFilter(x0, P0), "two": KalmanFilter(x0, P0)},
                          master=KalmanFilter(x0, P0) if with_master else None,
                          sharing=sharing)
    for _ in range(25):
        z1, z2 = rng.standard_normal(2), rng.standard_normal(1)
        central.predict(proc)
        central.update(np.r_[z1, z2], mc, R=Rc)
        fed.predict(proc)
        fed.update("one", z1, m1, R=R1)
        fed.update("two", z2, m2, R=R2)
        fed.fuse()
    np.testing.assert_allclose(fed.x, central.x, atol=1e-10)
    np.testing.assert_allclose(fed.P, central.P, atol=1e-10)
    assert sum(fed.beta.values()) == pytest.approx(1.0)


@pytest.mark.parametrize("with_master", [True, False])
def test_a_measurement_shared_by_every_local_filter_counts_once(with_master):
    """One measurement given to every local filter with ``share = beta_i / sum beta_j``
    (R / share in each): the fusion equals the centralized filter that uses it once (the
    wind constraint's rule), and the logged statistic is the centralized NIS (not share
    times it: the health monitor and the gate read it)."""
    rng = np.random.default_rng(7)
    n = 4
    A, _ = linear_problem(3, n)
    H = rng.standard_normal((2, n))
    R = np.diag([0.2, 0.3])
    proc = FunctionProcess(lambda x: A @ x, A, 0.02 * np.eye(n))
    m = FunctionModel(lambda x: H @ x, H)
    x0, P0 = rng.standard_normal(n), np.eye(n)
    central = KalmanFilter(x0, P0)
    names = ("one", "two", "three")
    fed = FederatedFilter({k: KalmanFilter(x0, P0) for k in names},
                          master=KalmanFilter(x0, P0) if with_master else None,
                          sharing="equal")
    for _ in range(20):
        z = rng.standard_normal(2)
        central.predict(proc)
        inn = central.update(z, m, R=R)
        fed.predict(proc)
        total = sum(fed.beta[k] for k in names)
        for k in names:
            fed.update(k, z, m, R=R, readmit=False, share=fed.beta[k] / total)
        if not with_master:  # (with a master the locals' prior is P / beta_i, not P)
            assert [e[2] for e in fed.log[-3:]] == pytest.approx([inn.nis] * 3, rel=1e-9)
        fed.fuse()
    np.testing.assert_allclose(fed.x, central.x, atol=1e-10)
    np.testing.assert_allclose(fed.P, central.P, atol=1e-10)
    with pytest.raises(ValueError, match="explicit R"):
        fed.update("one", z, m, share=0.5, readmit=False)


def test_federated_feedback_zeroes_state():
    fed = FederatedFilter({"a": KalmanFilter(np.ones(2), np.eye(2))}, sharing="equal")
    dx = fed.feedback()
    np.testing.assert_allclose(dx, 1.0)
    np.testing.assert_allclose(fed.locals["a"].x, 0.0)
    with pytest.raises(ValueError, match="no local filter named 'zz'"):
        fed.update("zz", [0.0], None)


def test_federated_no_reset_keeps_local_estimates():
    A, _ = linear_problem(4, 2)
    H = np.array([[1.0, 0.0]])
    proc = FunctionProcess(lambda x: A @ x, A, 0.01 * np.eye(2))
    m = FunctionModel(lambda x: H @ x, H)
    a, b = KalmanFilter(np.zeros(2), np.eye(2)), KalmanFilter(np.ones(2), 2 * np.eye(2))
    fed = FederatedFilter({"a": a, "b": b}, sharing="equal", reset=False)
    fed.predict(proc)
    fed.update("a", [0.5], m, R=np.array([[0.1]]))
    xa, Pa, xb, Pb = a.x.copy(), a.P.copy(), b.x.copy(), b.P.copy()
    xg, Pg = fed.fuse()
    # Locals untouched; the fused estimate is their information-weighted combination.
    np.testing.assert_array_equal(a.x, xa)
    np.testing.assert_array_equal(b.P, Pb)
    Ia, Ib = np.linalg.inv(Pa), np.linalg.inv(Pb)
    np.testing.assert_allclose(Pg, np.linalg.inv(Ia + Ib), rtol=1e-12)
    np.testing.assert_allclose(xg, Pg @ (Ia @ xa + Ib @ xb), rtol=1e-12)
    # Feedback moves every local estimate by the fed-back correction.
    dx = fed.feedback()
    np.testing.assert_allclose(a.x, xa - dx)
    np.testing.assert_allclose(b.x, xb - dx)


@pytest.mark.parametrize("cls", [KalmanFilter, UnscentedKalmanFilter])
def test_gate_rejects_outlier_without_changing_state(cls):
    H = np.eye(2)
    m = FunctionModel(lambda x: H @ x, H)
    f = cls(np.zeros(2), np.eye(2))
    x0, P0 = f.x.copy(), f.P.copy()
    inn = f.update([10.0, 0.0], m, R=np.eye(2), gate=10.0)  # T = 100 / 2 = 50 > 10
    assert not inn.accepted and inn.nis == pytest.approx(50.0)
    np.testing.assert_array_equal(f.x, x0)
    np.testing.assert_array_equal(f.P, P0)
    inn = f.update([1.0, 0.0], m, R=np.eye(2), gate=10.0)  # T = 0.5 passes
    assert inn.accepted and f.x[0] == pytest.approx(0.5)


def test_chi_square_thresholds_of_paper_003():
    fed = FederatedFilter({"a": KalmanFilter(np.zeros(2), np.eye(2))}, fdi_alpha=0.005)
    assert fed.threshold(6) == pytest.approx(18.55, abs=0.01)  # paper: 18.5 (GNSS)
    assert fed.threshold(3) == pytest.approx(12.84, abs=0.01)  # paper: 12.8 (CNS)
    assert np.isnan(FederatedFilter({"a": KalmanFilter(np.zeros(2), np.eye(2))}).threshold(3))
    with pytest.raises(ValueError, match="fdi_alpha"):
        FederatedFilter({"a": KalmanFilter(np.zeros(2), np.eye(2))}, fdi_alpha=1.5)


def test_federated_isolates_faulty_local_and_returns():
    """A biased sensor is isolated while the bias is on and taken back when it ends; the
    fused estimate stays with the healthy sensor."""
    rng = np.random.default_rng(8)
    A = np.eye(2)
    proc = FunctionProcess(lambda x: A @ x, A, 1e-4 * np.eye(2))
    H = np.eye(2)
    m = FunctionModel(lambda x: H @ x, H)
    R = 0.01 * np.eye(2)
    fed = FederatedFilter({"good": KalmanFilter(np.zeros(2), np.eye(2)),
                           "bad": KalmanFilter(np.zeros(2), np.eye(2))},
                          sharing="equal", fdi_alpha=0.005)
    truth = np.array([1.0, -1.0])
    for k in range(60):
        fed.predict(proc)
        fed.update("good", truth + rng.normal(0, 0.1, 2), m, R=R, t=k)
        bias = 5 * 0.1 if 20 <= k < 40 else 0.0
        fed.update("bad", truth + bias + rng.normal(0, 0.1, 2), m, R=R, t=k)
        fed.fuse()
        if 25 <= k < 40:
            assert np.abs(fed.x - truth).max() < 0.1
    iso = {t: i for t, name, _, _, _, i in fed.log if name == "bad"}
    assert all(iso[k] for k in range(20, 40))  # detected at onset, isolated throughout
    assert not any(iso[k] for k in range(41, 60))  # automatic return
    assert sum(iso[k] for k in range(20)) <= 1  # false alarms near alpha


@pytest.mark.parametrize("alpha", [1e-3, 0.5])
def test_simplified_ukf_equals_full_ukf_for_linear_measurements(alpha):
    from fednav.filters import SimplifiedUKF

    H = np.array([[1.0, 0.0, 0.5], [0.0, 2.0, 0.0]])
    proc = FunctionProcess(fx, np.eye(3), Q)  # nonlinear process
    model = FunctionModel(lambda x: H @ x, H)  # linear measurement
    x0, P0 = np.array([0.3, -0.1, 0.5]), np.diag([0.1, 0.2, 0.3])
    full, simple = UnscentedKalmanFilter(x0, P0, alpha=alpha), SimplifiedUKF(x0, P0, alpha=alpha)
    rng = np.random.default_rng(6)
    for _ in range(25):
        z = rng.normal(0, 0.3, 2)
        full.predict(proc)
        simple.predict(proc)
        a, b = full.update(z, model, R=R), simple.update(z, model, R=R)
        assert a.nis == pytest.approx(b.nis, rel=1e-6)
    np.testing.assert_allclose(simple.x, full.x, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(simple.P, full.P, rtol=1e-6, atol=1e-10)
    assert make_filter("sukf", x0, P0).__class__ is SimplifiedUKF


def test_share_then_update_equals_centralized():
    """Master time update + share (paper 003) + local linear updates + fusion = central KF."""
    rng = np.random.default_rng(9)
    P = np.diag([1.0, 2.0, 3.0])
    H1, H2 = np.array([[1.0, 0, 0], [0, 1.0, 0]]), np.array([[0, 0, 1.0]])
    R1, R2 = np.diag([0.2, 0.3]), np.array([[0.4]])
    z1, z2 = rng.normal(size=2), rng.normal(size=1)
    central = KalmanFilter(np.zeros(3), P)
    central.update(np.r_[z1, z2], FunctionModel(lambda x: np.r_[H1 @ x, H2 @ x],
                                                np.vstack([H1, H2])), R=np.diag([0.2, 0.3, 0.4]))
    fed = FederatedFilter({"a": KalmanFilter(np.zeros(3), P), "b": KalmanFilter(np.zeros(3), P)},
                          sharing="equal")
    fed.share(np.zeros(3), P)
    fed.update("a", z1, FunctionModel(lambda x: H1 @ x, H1), R=R1)
    fed.update("b", z2, FunctionModel(lambda x: H2 @ x, H2), R=R2)
    x, Pg = fed.fuse()
    np.testing.assert_allclose(x, central.x, atol=1e-12)
    np.testing.assert_allclose(Pg, central.P, atol=1e-12)


def test_fdi_recovery_needs_consecutive_passes():
    H = np.eye(1)
    m = FunctionModel(lambda x: H @ x, H)
    fed = FederatedFilter({"a": KalmanFilter(np.zeros(1), np.eye(1))}, sharing="equal",
                          fdi_alpha=0.005, fdi_recovery=3)
    R = 0.01 * np.eye(1)
    seq = [0.0, 50.0, 0.0, 50.0, 0.0, 0.0, 0.0, 0.0]  # fault, lone pass, fault, 4 passes
    iso = []
    for k, z in enumerate(seq):
        fed.share(np.zeros(1), np.eye(1))
        iso.append(fed.update("a", [z], m, R=R, t=k).accepted is False)
    # The lone pass at k=2 does not bring it back; it returns at the third pass in a row.
    assert iso == [False, True, True, True, True, True, False, False]
    with pytest.raises(ValueError, match="fdi_recovery"):
        FederatedFilter({"a": KalmanFilter(np.zeros(1), np.eye(1))}, fdi_recovery=0)


def test_fdi_level_per_local_filter():
    """Detection on one local filter only: the other applies every measurement."""
    f = {k: KalmanFilter(np.zeros(2), np.eye(2)) for k in ("a", "b")}
    fed = FederatedFilter(f, sharing="equal", fdi_alpha={"b": 0.01})
    model = LinearModel(np.eye(2))
    big = np.array([50.0, -50.0])  # far outside the 1-sigma prior
    assert fed.update("a", big, model, R=np.eye(2) * 0.01).accepted
    assert not fed.update("b", big, model, R=np.eye(2) * 0.01).accepted
    assert np.isnan(fed.threshold(2, "a"))
    assert fed.threshold(2, "b") == pytest.approx(9.21, abs=0.01)
    with pytest.raises(ValueError, match="'c', which is not a local filter"):
        FederatedFilter(f, fdi_alpha={"c": 0.01})
