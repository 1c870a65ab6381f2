import numpy as np
import pytest

from fednav.ins.observability import (
    covariance_degree,
    stripped_observability_matrix,
    svd_degree,
)

# Position-velocity-acceleration chain, position measured.
F = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
H = np.array([[1.0, 0.0, 0.0]])


def test_stripped_matrix_of_piecewise_constant_system():
    O = stripped_observability_matrix([F, F], [H, H])
    assert O.shape == (6, 3)
    assert np.allclose(O[:3], [[1, 0, 0], [0, 1, 0], [0, 0, 1]])
    assert np.linalg.matrix_rank(O) == 3
    # Measuring only acceleration: position and velocity unobservable in every segment.
    Oa = stripped_observability_matrix([F], [np.array([[0.0, 0.0, 1.0]])])
    assert np.linalg.matrix_rank(Oa) == 1
    with pytest.raises(ValueError):
        stripped_observability_matrix([F], [np.ones((1, 2))])


def test_svd_degree_attribution_and_reference():
    O = stripped_observability_matrix([F], [H])
    deg, assign = svd_degree(O, reference=1)
    assert deg[1] == 1.0 and len(assign) == 3
    assert sorted(k for _, k in assign) == [0, 1, 2]
    # Unobservable state: no singular value reaches it.
    Oa = stripped_observability_matrix([F], [np.array([[0.0, 0.0, 1.0]])])
    d, _ = svd_degree(Oa)
    assert d[2] > 0 and d[0] == 0 and d[1] == 0


def test_svd_degree_depends_on_units_covariance_degree_does_not():
    """Express the velocity in km/s instead of m/s: the SVD degree of every state moves,
    the covariance degree sigma(0)/sigma(T) does not."""
    S = np.diag([1.0, 1000.0, 1.0])          # new unit -> old unit
    Si = np.linalg.inv(S)
    d1, _ = svd_degree(stripped_observability_matrix([F], [H]))
    d2, _ = svd_degree(stripped_observability_matrix([Si @ F @ S], [H @ S]))
    assert not np.allclose(d1, d2, rtol=0.1)
    T = 1.0
    Phi = np.eye(3) + F * T + F @ F * T**2 / 2
    Q = np.diag([0.0, 0.0, 1e-4])
    P0 = np.diag([100.0, 1.0, 0.01])
    R = np.array([[4.0]])
    c1 = covariance_degree(P0, [(Phi, Q, [(H, R)])] * 50)
    c2 = covariance_degree(Si @ P0 @ Si, [(Si @ Phi @ S, Si @ Q @ Si, [(H @ S, R)])] * 50)
    assert np.allclose(c1, c2, rtol=1e-9)
    assert np.all(c1 > 1.0)


def test_covariance_degree_flags_an_unobservable_state():
    # Two constants, only the first measured.
    steps = [(np.eye(2), np.zeros((2, 2)), [(np.array([[1.0, 0.0]]), np.array([[1.0]]))])]
    c = covariance_degree(np.eye(2), steps * 100)
    assert c[0] > 9.0 and abs(c[1] - 1.0) < 1e-12
