import numpy as np
import pytest
from scipy.linalg import expm

from fednav.core import attitude as att
from fednav.core import units
from fednav.ins import error_model as em


def make_process(nsub=20, baro=(0.2, 0.0101), T=1.0):
    nom = em.Nominal(lat=units.deg(39.0), h=5000.0, vel=np.array([283.0, 282.0, 15.0]),
                     C=att.euler_to_dcm([0.05, 0.1, units.deg(45)]),
                     fn=np.array([0.3, -0.2, 9.8]))
    noise = em.ImuNoiseModel(gyro_markov_sigma=units.deg_per_h(0.001), gyro_markov_tau=1800.0)
    return em.ErrorProcess(nom, T, noise, baro_gains=baro, nsub=nsub)


def numerical_jacobian(f, n, eps=1e-3):
    J = np.empty((n, n))
    for i in range(n):
        d = np.zeros(n)
        d[i] = eps
        J[:, i] = (f(d[None])[0] - f(-d[None])[0]) / (2 * eps)
    return J


def phi_of_F(p):
    """``expm(F T)`` of the process ``p`` in its filter units: what the transition's
    Jacobian must be."""
    s = p.scale
    return expm(p.F_si() * p.T) * s[None, :] / s[:, None]


def test_F_is_jacobian_of_nonlinear_model():
    p = make_process()
    J = numerical_jacobian(p.transition, em.N_STATES)
    expected = phi_of_F(p)
    np.testing.assert_allclose(J, expected, atol=2e-6, rtol=1e-5)
    np.testing.assert_allclose(p.Phi, expected, atol=2e-5, rtol=1e-4)


def test_points_propagate_independently_to_the_bit():
    """The transition propagates all points together (one column each, branch-free where
    every point takes the series forms): each row must come out exactly as it does alone,
    whether its neighbours take the series or the library trigonometry."""
    p = make_process(nsub=2)
    rng = np.random.default_rng(7)
    X = rng.normal(size=(37, 18))
    X[5, 7] = 1e4      # 10 km north error: latitude offset above the series range
    X[9, 0:3] = 200.0  # 200 arcmin misalignment: rotation above the series range
    both = p.transition(X)
    for i in (0, 5, 9, 36):
        assert np.array_equal(p.transition(X[i:i + 1])[0], both[i])
    small = np.delete(X, [5, 9], axis=0)
    assert np.array_equal(p.transition(small), np.delete(both, [5, 9], axis=0))


def test_zero_error_stays_zero_and_large_errors_are_nonlinear():
    p = make_process(nsub=4)
    np.testing.assert_allclose(p.transition(np.zeros((1, 18))), 0.0, atol=1e-12)
    x = np.zeros(18)
    x[0:3] = units.to_arcmin(units.deg(5.0))  # 5 deg misalignment: far from linear
    lin = p.linear_transition(x[None])[0]
    nl = p.transition(x[None])[0]
    assert np.abs(nl[3:6] - lin[3:6]).max() > 1e-3


def test_attitude_error_grows_with_gyro_drift():
    p = make_process(baro=(0.0, 0.0))
    x = np.zeros(18)
    x[em.EPS_C][2] = 1.0  # 1 deg/h about body z
    out = p.transition(x[None])[0]
    # phi_dot = -C eps: after 1 s, phi = -C[:, 2] * 1 deg/h.
    expected = -p.nom.C[:, 2] * units.deg_per_h(1.0) / units.ARCMIN
    np.testing.assert_allclose(out[0:3], expected, atol=2e-3 * np.abs(expected).max())


def test_Qd_symmetric_psd():
    p = make_process()
    assert np.allclose(p.Qd, p.Qd.T)
    assert np.linalg.eigvalsh(p.Qd).min() > -1e-12 * np.abs(p.Qd).max()
    assert p.Qd[12, 12] == pytest.approx(
        2 * 1.0e-6 / 1800.0 * (1.0), rel=1e-2)  # (0.001 deg/h)^2 * 2/tau in (deg/h)^2


def test_si_conversions_and_noise_density():
    p = make_process()
    Qc = p.Qc_si()
    assert np.allclose(Qc, Qc.T) and Qc[12, 12] > 0  # Markov drift driving noise
    P = np.diag(np.arange(1.0, 19.0))
    np.testing.assert_allclose(np.diag(em.cov_to_si(P)), np.arange(1.0, 19.0) * em.SCALE**2)
    np.testing.assert_allclose(em.from_si(em.to_si(np.ones(18))), 1.0)
