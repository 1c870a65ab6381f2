import numpy as np

from fednav.core import attitude as att
from fednav.core.kernels import cholesky_lower, rotvec_to_dcm


def test_rotvec_to_dcm_matches_attitude():
    out = np.empty((3, 3))
    for r in ([0.3, -0.2, 1.1], [1e-9, 2e-9, -1e-9], [0.0, 0.0, 0.0]):
        rotvec_to_dcm(*r, out)
        np.testing.assert_allclose(out, att.rotvec_to_dcm(r), atol=1e-15)


def test_cholesky_lower():
    rng = np.random.default_rng(0)
    A = rng.standard_normal((18, 18))
    S = A @ A.T + 18 * np.eye(18)
    L, ok = cholesky_lower(S)
    assert ok
    np.testing.assert_allclose(L, np.linalg.cholesky(S), atol=1e-12)
    _, ok = cholesky_lower(np.array([[1.0, 2.0], [2.0, 1.0]]))
    assert not ok
    _, ok = cholesky_lower(np.array([[np.nan, 0.0], [0.0, 1.0]]))
    assert not ok


def test_compiled_euler_to_dcm_matches_attitude():
    from fednav.core.kernels import euler_to_dcm

    for e in ([0.3, -0.2, 4.0], [1.5, 3.0, 0.1], [0.0, 0.0, 0.0]):
        np.testing.assert_allclose(euler_to_dcm(*e), att.euler_to_dcm(e), atol=1e-15)


def test_one_source_for_the_attitude_conversions():
    """The array functions of fednav.core.attitude and the compiled ones of kernels are the
    same code: equal to the last bit where no transcendental function is involved."""
    from fednav.core import kernels as k

    rng = np.random.default_rng(1)
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for i in range(20):
        np.testing.assert_array_equal(k.quat_to_dcm(q[i]), att.quat_to_dcm(q)[i])
        np.testing.assert_array_equal(k.quat_mul(q[i], q[19 - i]), att.quat_mul(q, q[::-1])[i])
        np.testing.assert_array_equal(k.quat_to_rotvec(q[i]), att.quat_to_rotvec(q)[i])
    r = rng.normal(size=(20, 3)) * np.logspace(-12, 0.4, 20)[:, None]
    for i in range(20):
        np.testing.assert_array_equal(k.rotvec_to_quat(r[i]), att.rotvec_to_quat(r)[i])


def test_rotation_vector_round_trip_at_every_angle_up_to_pi():
    rng = np.random.default_rng(2)
    for a in (1e-12, 1e-9, 1e-5, 1e-3, 0.1, 1.0, 2.8, 3.0, 3.14159, np.pi - 1e-9):
        r = rng.normal(size=(30, 3))
        r *= a / np.linalg.norm(r, axis=1, keepdims=True)
        back = att.dcm_to_rotvec(att.rotvec_to_dcm(r))
        np.testing.assert_allclose(back, r, rtol=0, atol=4e-15 + 1e-15 * a)
