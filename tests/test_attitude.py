import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fednav.core import attitude as att

angles = st.tuples(
    st.floats(-1.4, 1.4), st.floats(-3.1, 3.1), st.floats(0.0, 6.28)
)


def scipy_dcm(euler):
    pitch, roll, heading = euler
    return Rotation.from_euler("ZXY", [-heading, pitch, roll]).as_matrix()


def test_body_axes_directions():
    # Heading 90 deg: body forward (y) points east; pitch up raises the nose.
    C = att.euler_to_dcm([0.0, 0.0, np.pi / 2])
    np.testing.assert_allclose(C @ [0, 1, 0], [1, 0, 0], atol=1e-15)
    C = att.euler_to_dcm([0.1, 0.0, 0.0])
    assert (C @ [0, 1, 0])[2] > 0
    # Positive roll puts the right wing (x) down.
    C = att.euler_to_dcm([0.0, 0.2, 0.0])
    assert (C @ [1, 0, 0])[2] < 0


@given(angles)
@settings(max_examples=60, deadline=None)
def test_euler_dcm_against_scipy_and_round_trip(e):
    e = np.array(e)
    C = att.euler_to_dcm(e)
    np.testing.assert_allclose(C, scipy_dcm(e), atol=1e-12)
    e2 = att.dcm_to_euler(C)
    np.testing.assert_allclose(att.euler_difference(e2, e), 0, atol=1e-9)


@given(angles)
@settings(max_examples=60, deadline=None)
def test_quaternion_round_trips(e):
    C = att.euler_to_dcm(np.array(e))
    q = att.dcm_to_quat(C)
    assert np.linalg.norm(q) == pytest.approx(1.0)
    np.testing.assert_allclose(att.quat_to_dcm(q), C, atol=1e-12)
    xyzw = Rotation.from_matrix(C).as_quat()
    sq = np.r_[xyzw[3], xyzw[:3]]
    np.testing.assert_allclose(q, sq * np.sign(sq[0]), atol=1e-12)
    rv = att.quat_to_rotvec(q)
    np.testing.assert_allclose(rv, Rotation.from_matrix(C).as_rotvec(), atol=1e-9)
    np.testing.assert_allclose(att.rotvec_to_dcm(rv), C, atol=1e-12)


def test_quat_mul_composes_like_dcm():
    rng = np.random.default_rng(1)
    a, b = Rotation.random(2, random_state=rng).as_matrix()
    qa, qb = att.dcm_to_quat(a), att.dcm_to_quat(b)
    np.testing.assert_allclose(att.quat_to_dcm(att.quat_mul(qa, qb)), a @ b, atol=1e-12)
    np.testing.assert_allclose(att.quat_to_dcm(att.quat_conj(qa)), a.T, atol=1e-12)


def test_small_rotation_vector_accuracy():
    r = np.array([1e-9, -2e-9, 3e-10])
    np.testing.assert_allclose(att.quat_to_rotvec(att.rotvec_to_quat(r)), r, rtol=1e-9)
    np.testing.assert_allclose(att.rotvec_to_dcm(r), np.eye(3) + att.skew(r), atol=1e-17)


def test_misalignment_small_angle_and_inverse():
    C = att.euler_to_dcm([0.2, -0.3, 1.0])
    phi = np.array([3e-5, -2e-5, 4e-5])
    Ch = att.apply_misalignment(C, phi)
    np.testing.assert_allclose(Ch, (np.eye(3) - att.skew(phi)) @ C, atol=1e-9)
    np.testing.assert_allclose(att.misalignment(C, Ch), phi, atol=1e-14)


@pytest.mark.parametrize("euler", [[0.2, -0.3, 1.0], [-0.5, 0.4, 5.9], [0.0, 0.0, 0.0],
                                   [1.2, 2.5, 3.3]])
def test_euler_error_jacobian_matches_numerical(euler):
    euler = np.array(euler)
    C = att.euler_to_dcm(euler)
    J = att.euler_error_jacobian(euler)
    eps = 1e-7
    for i in range(3):
        phi = np.zeros(3)
        phi[i] = eps
        d = att.euler_difference(att.dcm_to_euler(att.apply_misalignment(C, phi)), euler)
        np.testing.assert_allclose(d / eps, J[:, i], atol=1e-5)


def test_wrap():
    np.testing.assert_allclose(att.wrap_pi([3 * np.pi / 2, -3 * np.pi / 2]),
                               [-np.pi / 2, np.pi / 2])
    assert att.wrap_2pi(-0.1) == pytest.approx(2 * np.pi - 0.1)
