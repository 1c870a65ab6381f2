"""The launch error model against its truth-based definition: two strapdown runs (one
perturbed, one ideal) over a filter interval give the error the transition must predict."""

import numpy as np
import pytest

from fednav.core import attitude, units
from fednav.launch.errors import (
    SCALE,
    GnssPositionLI,
    ImuNoise,
    LaunchProcess,
    StarAttitudeLI,
    gravity_gradient,
)
from fednav.launch.frame import LaunchFrame
from fednav.launch.strapdown import LaunchStrapdown
from fednav.launch.trajectory import AscentProfile, Burn, Manoeuvre, generate

d = units.deg
NOISE = ImuNoise(1e-6, 1e-5, 1e-9, 1e-7)


@pytest.fixture(scope="module")
def flight():
    fr = LaunchFrame((d(32.0), d(118.0), 0.0), d(90.0))
    prof = AscentProfile(fr, 40.0, burns=(Burn(0, 40, 20.0, 0.6),),
                         pitch=(Manoeuvre(5, 30, d(-20)),), yaw=(Manoeuvre(10, 20, d(3)),))
    return generate(prof, 0.02)


def _interval(tr, x0, k0=1000, n=50):
    """Actual error after one interval from error x0 (filter units) at sample k0."""
    xs = x0 * SCALE
    C_hat = attitude.rotvec_to_dcm(-xs[0:3]) @ tr.C[k0]
    nom = LaunchStrapdown(tr.frame, attitude.dcm_to_quat(C_hat), tr.v[k0] + xs[6:9],
                          tr.r[k0] + xs[3:6], tr.dt)
    sl = slice(k0, k0 + n)
    aux = nom.interval(tr.dtheta[sl] + xs[9:12] * tr.dt, tr.dv[sl] + xs[12:15] * tr.dt)
    ref = LaunchStrapdown(tr.frame, attitude.dcm_to_quat(tr.C[k0]), tr.v[k0], tr.r[k0],
                          tr.dt)
    ref.interval(tr.dtheta[sl], tr.dv[sl])
    C1, Ch1 = attitude.quat_to_dcm(ref.q), attitude.quat_to_dcm(nom.q)
    x1 = np.concatenate([attitude.misalignment(C1, Ch1), nom.r - ref.r, nom.v - ref.v,
                         xs[9:15]]) / SCALE
    return aux, x1


@pytest.mark.parametrize("att_deg", [0.01, 5.0, 30.0])
def test_particle_transition_is_exact(flight, att_deg):
    rng = np.random.default_rng(1)
    x0 = np.concatenate([rng.normal(0, att_deg * 3600, 3), rng.normal(0, 20, 3),
                         rng.normal(0, 0.5, 3), rng.normal(0, 50, 3), rng.normal(0, 5, 3)])
    aux, x1 = _interval(flight, x0)
    proc = LaunchProcess(flight.frame, aux, 1.0, NOISE)
    pred = proc.transition(x0[None])[0]
    # attitude to 0.01", position to 1 mm, velocity to 0.1 mm/s whatever the error size
    assert np.allclose(pred[0:3], x1[0:3], atol=0.01)
    assert np.allclose(pred[3:6], x1[3:6], atol=1e-3)
    assert np.allclose(pred[6:9], x1[6:9], atol=1e-4)
    lin = proc.Phi @ x0
    if att_deg < 0.1:   # the EKF's linear model agrees for small errors ...
        assert np.allclose(lin[6:9], x1[6:9], atol=1e-3)
    else:               # ... and is off by ~phi^2/2 * dv for large ones
        assert np.abs(lin[6:9] - x1[6:9]).max() > 100 * np.abs(pred[6:9] - x1[6:9]).max()


def test_phi_is_jacobian_of_transition(flight):
    aux, _ = _interval(flight, np.zeros(15))
    proc = LaunchProcess(flight.frame, aux, 1.0, NOISE)
    h = np.concatenate([np.full(3, 1.0), np.full(3, 1.0), np.full(3, 1e-3), np.full(6, 1e-2)])
    J = np.column_stack([(proc.transition((h[j] * e)[None])[0]
                          - proc.transition((-h[j] * e)[None])[0]) / (2 * h[j])
                         for j, e in enumerate(np.eye(15))])
    assert np.allclose(proc.Phi, J, atol=2e-5, rtol=1e-4)
    assert np.allclose(proc.Qd, proc.Qd.T) and np.linalg.eigvalsh(proc.Qd).min() > -1e-15


def test_gravity_gradient_central_field():
    fr = LaunchFrame((d(32.0), d(118.0), 0.0), d(90.0))
    G = gravity_gradient(fr, np.zeros(3))
    # Near the surface: -g/R horizontally, +2 g/R vertically (LI y is up at the pad).
    assert abs(G[1, 1] - 2 * 9.79 / 6.37e6) < 2e-8 and abs(G[0, 0] + 9.79 / 6.37e6) < 2e-8


def test_star_observation_and_exact_likelihood():
    C = attitude.euler_to_dcm([0.3, -0.2, 1.0])
    phi = units.arcsec(np.array([400.0, -300.0, 250.0]))
    n = units.arcsec(np.array([15.0, -20.0, 5.0]))
    C_hat = attitude.misalignment_dcm(phi) @ C
    C_star = attitude.rotvec_to_dcm(n) @ C
    y = StarAttitudeLI.observe(C_hat, C_star)
    assert np.allclose(y, units.to_arcsec(phi + n), atol=0.05)   # = phi + n to first order
    X = np.zeros((2, 15))
    X[0, 0:3] = units.to_arcsec(phi)          # the true error: residual = the noise n
    X[1, 0:3] = y                             # first-order guess
    R = np.eye(3) * 21.0**2
    ll = StarAttitudeLI().loglik(y, X, None, R)
    assert np.isclose(ll[0], -0.5 * units.to_arcsec(n) @ units.to_arcsec(n) / 21.0**2,
                      rtol=1e-6)
    # The first-order guess phi = y is off by the second-order composition term only.
    assert -1e-3 < ll[1] < 0.0


def test_gnss_mixture_likelihood():
    m = GnssPositionLI(0.05, 20.0)
    R = np.eye(3) * 15.0**2
    X = np.zeros((2, 15))
    X[1, 3:6] = [300.0, 0.0, 0.0]
    ll = m.loglik(np.zeros(3), X, None, R)
    g = GnssPositionLI()
    assert not hasattr(g, "loglik")
    # Far from the fix the mixture's tail keeps the weight from vanishing.
    assert ll[0] - ll[1] < 15.0 and 0.5 * (300 / 15) ** 2 > 150
