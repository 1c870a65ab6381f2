"""Each measurement model against its truth-based definition.

The INS solution is the truth perturbed by a small error state dx; the noise-free sensor
measures the truth; the model's residual must equal H dx to first order and h(dx) to
second order.
"""

import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.ins import error_model as em
from fednav.sensors import BaroHeight, NavSnapshot, SarFix, StarAttitude


def perturbed_nav(euler, dx_si, lla=(0.68, 2.04, 3000.0), vel=(200.0, 150.0, 5.0)):
    lla = np.array(lla)
    C = att.euler_to_dcm(euler)
    rm, rn = earth.radii(lla[0])
    dp = dx_si[em.DP]
    nav = NavSnapshot(
        lla=lla + [dp[1] / (rm + lla[2]), dp[0] / ((rn + lla[2]) * np.cos(lla[0])), dp[2]],
        vel=np.array(vel) + dx_si[em.DV],
        C=att.apply_misalignment(C, dx_si[em.PHI]),
    )
    return lla, C, nav


EULERS = [[0.1, -0.2, units.deg(45)], [0.0, 0.0, units.deg(359.99)],
          [units.deg(60), 0.3, units.deg(0.01)], [-0.4, 2.9, units.deg(200)]]


@pytest.mark.parametrize("euler", EULERS)
def test_star_model_matches_truth(euler):
    rng = np.random.default_rng(0)
    dx = np.zeros(18)
    dx[em.PHI] = units.arcsec(rng.uniform(-30, 30, 3))
    lla, C, nav = perturbed_nav(euler, dx)
    z = att.dcm_to_euler(C)  # perfect star sensor
    m = StarAttitude()
    y = m.residual(nav, z)
    xf = em.from_si(dx)
    np.testing.assert_allclose(m.h(xf[None], nav)[0], y, atol=1e-9)
    lin = m.H(nav) @ xf
    assert np.abs(lin - y).max() < 1e-3 * np.abs(y).max()


@pytest.mark.parametrize("euler", EULERS)
def test_sar_model_matches_truth(euler):
    dx = np.zeros(18)
    dx[em.PHI] = units.arcsec([20.0, -10.0, 40.0])
    dx[em.DP] = [12.0, -7.0, 3.0]
    lla, C, nav = perturbed_nav(euler, dx)
    z = np.array([lla[0], lla[1], att.dcm_to_euler(C)[2]])
    m = SarFix()
    y = m.residual(nav, z)
    xf = em.from_si(dx)
    np.testing.assert_allclose(m.h(xf[None], nav)[0], y, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(m.H(nav) @ xf, y, rtol=1e-3, atol=1e-4)


def test_baro_model_matches_truth():
    dx = np.zeros(18)
    dx[8] = 4.5
    lla, C, nav = perturbed_nav([0, 0, 0], dx)
    m = BaroHeight()
    y = m.residual(nav, [lla[2]])
    np.testing.assert_allclose(y, [4.5])
    np.testing.assert_allclose(m.H(nav) @ em.from_si(dx), y)
    np.testing.assert_allclose(m.h(em.from_si(dx)[None], nav)[0], y)


def test_heading_residual_wraps_at_north():
    m = StarAttitude()
    nav = NavSnapshot(np.array([0.6, 2.0, 0.0]), np.zeros(3),
                      att.euler_to_dcm([0.0, 0.0, units.deg(0.001)]))
    y = m.residual(nav, [0.0, 0.0, units.deg(359.999)])
    assert y[2] == pytest.approx(units.to_arcmin(units.deg(0.002)), rel=1e-6)


def test_gnss_model_matches_truth():
    from fednav.sensors import GnssPosVel

    dx = np.zeros(18)
    dx[em.DP] = [4.0, -3.0, 2.0]
    dx[em.DV] = [0.1, -0.2, 0.05]
    lla, C, nav = perturbed_nav([0.1, 0.0, 1.0], dx)
    z = np.r_[lla, np.array([200.0, 150.0, 5.0])]  # perfect GNSS: true position, velocity
    m = GnssPosVel()
    y = m.residual(nav, z)
    np.testing.assert_allclose(y, np.r_[dx[em.DP], dx[em.DV]], rtol=1e-6, atol=1e-9)
    xf = em.from_si(dx)
    np.testing.assert_allclose(m.H(nav) @ xf, y, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(m.h(xf[None], nav)[0], y, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(np.diag(m.R([8.0, 7.0, 6.0, 0.2, 0.3, 0.4])),
                               [49.0, 64.0, 36.0, 0.04, 0.09, 0.16])


@pytest.mark.parametrize("euler", EULERS)
def test_gnss_lever_arm_matches_truth(euler):
    """Antenna at a lever arm: the perfect GNSS sees the true antenna position/velocity;
    the INS-derived antenna (with attitude, velocity, position errors) minus it must equal
    H dx to first order — this pins the sign of the attitude coupling."""
    from fednav.sensors import GnssPosVel

    lever = np.array([0.8, -1.5, 0.6])
    w = np.array([0.05, -0.1, 0.3])  # body rate [rad/s]
    dx = np.zeros(18)
    dx[em.PHI] = units.arcmin([3.0, -2.0, 5.0])
    dx[em.DP] = [0.4, -0.3, 0.2]
    dx[em.DV] = [0.01, -0.02, 0.005]
    lla, C, nav = perturbed_nav(euler, dx)
    nav.omega_b = w
    rm, rn = earth.radii(lla[0])
    d = C @ lever
    ant = lla + [d[1] / (rm + lla[2]), d[0] / ((rn + lla[2]) * np.cos(lla[0])), d[2]]
    z = np.r_[ant, np.array([200.0, 150.0, 5.0]) + C @ np.cross(w, lever)]
    m = GnssPosVel(lever)
    y = m.residual(nav, z)
    xf = em.from_si(dx)
    lin = m.H(nav) @ xf
    assert np.abs(lin - y).max() < 2e-3 * np.abs(y).max()
    # Without the attitude column the mismatch is the lever effect: the test would catch
    # a sign error in it.
    H0 = GnssPosVel().H(nav)
    assert np.abs(H0 @ xf - y).max() > 20 * np.abs(lin - y).max()


def test_velocity_sensor_model_matches_truth():
    from fednav.sensors import VelocityENU

    lever = np.array([0.0, 2.0, -0.5])
    w = np.array([0.0, 0.0, 0.4])
    dx = np.zeros(18)
    dx[em.PHI] = units.arcmin([0.0, 0.0, 30.0])
    dx[em.DV] = [0.05, -0.03, 0.01]
    lla, C, nav = perturbed_nav([0.0, 0.0, units.deg(30)], dx)
    nav.omega_b = w
    z = np.array([200.0, 150.0, 5.0]) + C @ np.cross(w, lever)
    m = VelocityENU(lever)
    y = m.residual(nav, z)
    np.testing.assert_allclose(m.H(nav) @ em.from_si(dx), y, rtol=2e-3, atol=1e-7)
    np.testing.assert_allclose(m.R(np.eye(3) * 0.01), np.eye(3) * 0.01)


@pytest.mark.parametrize("euler", [[0.0, 0.0, units.deg(90)], [0.05, -0.1, units.deg(20)],
                                   [0.0, 0.2, units.deg(250)]])
def test_wind_constraint_matches_truth(euler):
    """D dx = d for a perturbed truth with perfect air data and wind (paper 000 eq. 49-50
    in fednav's heading convention)."""
    from fednav.sensors import WindConstraint

    C = att.euler_to_dcm(euler)
    w = np.array([8.0, -3.0, 0.0])
    va = 20.0
    v_air = va * np.array([np.sin(euler[2]), np.cos(euler[2]), 0.0])
    dx = np.zeros(18)
    dx[em.PHI] = units.arcmin([2.0, -3.0, 10.0])
    dx[em.DV] = [0.05, -0.08, 0.01]
    _, _, nav = perturbed_nav(euler, dx, vel=v_air + w)
    z = np.array([va, w[0], w[1]])
    m = WindConstraint(va)
    d = m.residual(nav, z)
    lin = m.H(nav) @ em.from_si(dx)
    np.testing.assert_allclose(lin, d, atol=2e-4)
    assert np.abs(d - dx[3:5]).max() > 0.03  # the heading term matters (catches its sign)
    del C


@pytest.mark.parametrize("euler", [[0.0, 0.0, units.deg(90)], [0.08, -0.1, units.deg(20)],
                                   [-0.05, 0.3, units.deg(250)]])
def test_wind_constraint_with_air_data_angles_matches_truth(euler):
    """With angle of attack and sideslip the true airspeed is directed in the body by
    them: the ground velocity is C (V b) + w, b = [sin beta, cos alpha cos beta,
    -sin alpha cos beta]; D dx = d to first order, and perfect data give d = 0."""
    from fednav.sensors import WindConstraint

    C = att.euler_to_dcm(euler)
    alpha, beta, V = units.deg(4.0), units.deg(-3.0), 30.0
    b = np.array([np.sin(beta), np.cos(alpha) * np.cos(beta), -np.sin(alpha) * np.cos(beta)])
    w = np.array([8.0, -3.0, 0.0])
    v = C @ (V * b) + w
    z = np.array([V, w[0], w[1], alpha, beta])
    m = WindConstraint.of(z)
    _, _, exact = perturbed_nav(euler, np.zeros(18), vel=v)
    np.testing.assert_allclose(m.residual(exact, z), 0.0, atol=1e-9)
    dx = np.zeros(18)
    dx[em.PHI] = units.arcmin([2.0, -3.0, 10.0])
    dx[em.DV] = [0.05, -0.08, 0.01]
    _, _, nav = perturbed_nav(euler, dx, vel=v)
    d = m.residual(nav, z)
    np.testing.assert_allclose(m.H(nav) @ em.from_si(dx), d, atol=2e-4)
    assert np.abs(d - dx[3:5]).max() > 0.03  # the attitude term matters (catches its sign)
    # a file without the angles (NaN) is the horizontal-airspeed model of paper 000
    assert WindConstraint.of([V, 1.0, 2.0, np.nan, np.nan]).b is None


@pytest.mark.parametrize("euler", EULERS)
def test_body_velocity_models_match_truth(euler):
    """Odometer / DVL rows: the INS-derived body velocity of a point at a lever arm minus
    the true one equals H dx to first order (sign and frame of the attitude coupling)."""
    from fednav.sensors.bodyvel import DvlVelocity, OdometerSpeed

    rng = np.random.default_rng(3)
    dx = np.zeros(18)
    dx[em.PHI] = units.arcsec(rng.uniform(-60, 60, 3))
    dx[em.DV] = rng.uniform(-0.2, 0.2, 3)
    lever = np.array([0.4, 1.2, -0.5])
    omega = np.array([0.05, -0.02, 0.3])
    lla, C, nav = perturbed_nav(euler, dx)
    nav.omega_b = omega
    v_true = np.array([200.0, 150.0, 5.0])
    vb = C.T @ v_true + np.cross(omega, lever)   # the truth the sensor measures
    xf = em.from_si(dx)
    for m, z in ((DvlVelocity(lever), vb), (OdometerSpeed(lever), vb[1:2])):
        y = m.residual(nav, z)
        # the residual is what the error state predicts, to second order (|phi|^2 |v|,
        # |phi| |dv|: ~3e-5 m/s here) ...
        np.testing.assert_allclose(m.H(nav) @ xf, y, rtol=2e-3, atol=6e-5)
        np.testing.assert_allclose(m.h(xf[None], nav)[0], m.H(nav) @ xf, atol=1e-12)
        # ... and it is the body-frame difference, not an ENU one
        C_hat = nav.C
        np.testing.assert_allclose(y, (C_hat.T @ nav.vel + np.cross(omega, lever)
                                       )[[0, 1, 2] if m.dim == 3 else [1]] - z, atol=1e-9)
    assert DvlVelocity(lever).linear and OdometerSpeed().dim == 1


def test_zupt_model_is_the_ins_velocity():
    from fednav.sensors.bodyvel import ZeroVelocity

    dx = np.zeros(18)
    dx[em.DV] = [0.1, -0.2, 0.05]
    lla, C, nav = perturbed_nav([0.0, 0.0, 1.0], dx, vel=(0.0, 0.0, 0.0))
    m = ZeroVelocity()
    np.testing.assert_allclose(m.residual(nav, np.zeros(3)), [0.1, -0.2, 0.05])
    np.testing.assert_allclose(m.H(nav) @ em.from_si(dx), [0.1, -0.2, 0.05])
