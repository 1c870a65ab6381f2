import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import units
from fednav.ins.strapdown import Strapdown
from fednav.ins.total_state import attitude_innovation, boxminus, boxplus
from fednav.sensors.star import StarTotal


def ins_at(euler, lla=(0.5, 2.0, 100.0), vel=(10.0, 20.0, 1.0)):
    return Strapdown(np.array(lla), np.array(vel), np.array(euler), 0.02)


@pytest.mark.parametrize("euler", [[0.1, 0.2, units.deg(359.9)], [0.0, 0.0, units.deg(0.05)],
                                   [units.deg(89.99), 0.3, 1.0], [units.deg(-89.99), -2.0, 4.0]])
def test_boxplus_boxminus_round_trip(euler):
    x = ins_at(euler).state
    rng = np.random.default_rng(1)
    d = rng.normal(0, 1, (5, 9)) * [30, 30, 30, 0.1, 0.1, 0.1, 5, 5, 5]  # arcmin, m/s, m
    y = boxplus(np.tile(x, (5, 1)), d)
    np.testing.assert_allclose(boxminus(y, x), d, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("heading, pitch, axis", [(359.999, 5.0, 2), (0.001, 5.0, 2),
                                                  (180.0, 89.999, 1), (45.0, -89.999, 1)])
def test_attitude_innovation_where_euler_subtraction_fails(heading, pitch, axis):
    """A small rotation that carries the heading across north (about up) or tips the
    attitude over the pitch singularity (about north): the DCM innovation recovers it,
    Euler subtraction does not."""
    e = np.array([units.deg(pitch), 0.1, units.deg(heading)])
    C = att.euler_to_dcm(e)
    phi = np.zeros(3)
    phi[axis] = units.deg(0.002) * (1 if heading < 180 else -1)
    C_meas = att.rotvec_to_dcm(phi) @ C
    np.testing.assert_allclose(attitude_innovation(C_meas, C), phi, atol=1e-12)
    naive = att.dcm_to_euler(C_meas) - e
    assert np.abs(naive).max() > 10 * np.abs(phi).max()  # what the DCM form avoids


def test_star_residual_and_noise_mapping():
    e = np.array([0.1, -0.2, units.deg(359.95)])
    x = ins_at(e).state
    m = StarTotal()
    np.testing.assert_allclose(m.residual(x, att.quat_to_euler(x[0:4])), 0.0, atol=1e-9)
    R = m.R_at(x, np.full(3, units.arcsec(300.0)))
    # Monte Carlo of Euler-angle noise mapped through the residual has covariance R.
    rng = np.random.default_rng(2)
    zs = att.quat_to_euler(x[0:4]) + rng.normal(0, units.arcsec(300.0), (4000, 3))
    r = np.array([m.residual(x, z) for z in zs])
    np.testing.assert_allclose(np.cov(r.T), R, rtol=0.1, atol=0.02 * np.abs(R).max())


def test_time_update_matches_linear_error_model():
    """Covariance through the total-state UKF == Phi P Phi' of the error model (9x9 block)."""
    from fednav.ins import error_model as em
    from fednav.ins.total_state import TotalStateUKF
    from fednav.sim.trajectory import Segment, generate

    tr = generate([0.5, 2.0, 1000.0], 150.0, [0.05, 0.2, 1.0],
                  [Segment(1.0, accel=1.0, pitch_rate=0.01, heading_rate=0.02)], 0.02)
    ins = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt)
    sd = np.array([5.0, 5.0, 20.0, 0.1, 0.1, 0.1, 5.0, 5.0, 5.0])  # arcmin, m/s, m
    P0 = np.diag(np.r_[sd**2, np.full(6, 1e-12)])
    f = TotalStateUKF(ins, P0, np.zeros((6, 6)))
    f.predict(tr.dtheta, tr.dv)
    # Linear model on the same nominal (mid-interval truth).
    C = att.euler_to_dcm(tr.euler[25])
    nom = em.Nominal(lat=tr.lla[25, 0], h=tr.lla[25, 2], vel=tr.vel[25], C=C,
                     fn=C @ tr.dv.sum(axis=0))
    # Tangent d = true [-] computed = S x_err: attitude keeps its sign, v and p flip.
    S = np.diag(np.r_[np.ones(3), -np.ones(6)])
    Phi = S @ em.ErrorProcess(nom, 1.0, em.ImuNoiseModel()).Phi[:9, :9] @ S
    expected = Phi @ P0[:9, :9] @ Phi.T
    # Tight enough to see the sign of the attitude-velocity cross terms (~0.07 here).
    np.testing.assert_allclose(f.P[:9, :9], expected, rtol=2e-3, atol=2e-3)
    assert np.abs(expected[0:3, 3:6]).max() > 0.02
    # The mean is the INS flown over the interval (sigma-point mean deviation ~ 0).
    ref = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt)
    ref.run(tr.dtheta, tr.dv, record=False)
    np.testing.assert_allclose(f.ins.lla, ref.lla, atol=1e-9)


def test_bias_states_propagate_like_the_error_model():
    """Gyro/accelerometer error states: their effect on attitude and velocity over one
    interval matches the error model's Phi (the -C eps and C nabla blocks)."""
    from fednav.ins import error_model as em
    from fednav.ins.total_state import TotalStateUKF
    from fednav.sim.trajectory import Segment, generate

    tr = generate([0.5, 2.0, 1000.0], 150.0, [0.05, 0.2, 1.0], [Segment(1.0)], 0.02)
    P0 = np.diag(np.r_[np.full(9, 1e-8), np.full(6, 1.0)])  # 1 deg/h, 1 mg
    f = TotalStateUKF(Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt), P0,
                      np.zeros((6, 6)))
    f.predict(tr.dtheta, tr.dv)
    C = att.euler_to_dcm(tr.euler[25])
    nom = em.Nominal(lat=tr.lla[25, 0], h=tr.lla[25, 2], vel=tr.vel[25], C=C,
                     fn=C @ tr.dv.sum(axis=0))
    Phi = em.ErrorProcess(nom, 1.0, em.ImuNoiseModel()).Phi
    cols = np.r_[9:12, 15:18]
    # Cross-covariance nav x bias = S Phi[nav, bias] P_bb with S = diag(+1 x3, -1 x6):
    # tangent d = true [-] computed keeps the attitude sign and flips v and p.
    S = np.r_[np.ones(3), -np.ones(6)][:, None]
    # (2e-6-level second-order terms, accelerometer bias -> velocity -> transport rate ->
    # attitude within the same second, are below what one coarse step represents.)
    np.testing.assert_allclose(f.P[:9, 9:], S * Phi[:9, cols], rtol=0.02, atol=1e-5)
    assert np.abs(Phi[:9, cols]).max() > 1e-2
