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
