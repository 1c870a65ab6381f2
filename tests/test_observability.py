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


#: An orthogonal matrix (its rows are the right singular vectors of diag(s) @ Q) whose
#: rows 0 and 2 both have their largest component on state 1: 160/213 and 140/213.
Q_COLLIDE = np.array([[85.0, 160.0, 112.0], [-160.0, -13.0, 140.0],
                      [112.0, -140.0, 115.0]]) / 213.0


def largest_component_rule(O) -> np.ndarray:
    """The paper's rule read literally (fednav's rule until issue 38): every singular
    value to the state of its vector's largest component, a state credited twice keeps
    the larger value, one credited with none gets 0."""
    _, s, Vt = np.linalg.svd(np.asarray(O, dtype=float), full_matrices=False)
    deg = np.zeros(Vt.shape[1])
    for sv, k in zip(s, np.argmax(np.abs(Vt), axis=1), strict=True):
        deg[k] = max(deg[k], sv)
    return deg


def test_svd_degree_assignment_resolves_a_collision_of_the_largest_components():
    """Two singular vectors with their largest component on the same state: the paper's
    rule read literally leaves state 2 with 0; the assignment gives every state exactly
    one singular value, the weaker claim (row 2) going to its vector's next state."""
    assert np.allclose(Q_COLLIDE @ Q_COLLIDE.T, np.eye(3))
    O = np.diag([3.0, 2.0, 1.0]) @ Q_COLLIDE
    np.testing.assert_allclose(largest_component_rule(O), [2.0, 3.0, 0.0])
    deg, assign = svd_degree(O)
    np.testing.assert_allclose(deg, [2.0, 3.0, 1.0])
    assert [k for _, k in assign] == [1, 0, 2]
    np.testing.assert_allclose([sv for sv, _ in assign], [3.0, 2.0, 1.0])
    # Normalised: the reference state's own singular value is 1.
    np.testing.assert_allclose(svd_degree(O, reference=2)[0], [2.0, 3.0, 1.0])


def test_svd_degree_is_the_largest_component_rule_when_that_is_one_to_one():
    """Where every state wins exactly one singular vector by its largest component, the
    assignment is that same map (random well-separated systems)."""
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(200):
        O = rng.normal(size=(8, 4)) @ np.diag([1.0, 10.0, 0.1, 3.0])
        Vt = np.linalg.svd(O)[2]
        if len(set(np.argmax(np.abs(Vt), axis=1))) < 4:
            continue
        checked += 1
        np.testing.assert_allclose(svd_degree(O)[0], largest_component_rule(O))
    assert checked > 50


def test_svd_degree_with_fewer_singular_values_than_states():
    """A wide O (one measurement, one power): one singular value, one state credited, the
    reference normalised by the value whose vector has its largest component on it."""
    O = np.array([[1.0, 2.0, 0.5]])
    deg, assign = svd_degree(O, reference=0)
    assert len(assign) == 1 and assign[0][1] == 1
    np.testing.assert_allclose(deg, [0.0, 1.0, 0.0])


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


def test_paper002_table1_gives_every_state_one_singular_value():
    """Issue 38: paper 002's SAR fixes measure the position errors δλ, δL directly, yet the
    largest-component rule left δL with degree 0 in SI units and δλ and δL with 0 in
    filter units (velocity and position share a cluster of equal singular values; which
    state a vector's largest component falls on is a matter of rounding).  The assignment
    gives all 18 states one singular value each; velocity and position get the cluster's
    value, the reference δVE's (= 1)."""
    from fednav.ins import error_model as em
    from fednav.scenarios import paper002

    scn = paper002.load_scenario()
    models = paper002.observability_models(scn)
    assert [g for g, _, _ in models] == [g.name for g in scn.segments]
    O = stripped_observability_matrix([F for _, F, _ in models], [H for _, _, H in models])
    n, i = len(em.STATE_NAMES), em.STATE_NAMES.index
    old_si, old_f = largest_component_rule(O), largest_component_rule(O * em.SCALE)
    assert old_si[i("dN")] == 0 and old_f[i("dN")] == 0 and old_f[i("dE")] == 0
    for Ou in (O, O * em.SCALE):
        deg, assign = svd_degree(Ou, reference=i("dvE"))
        assert sorted(k for _, k in assign) == list(range(n))     # a permutation
        assert np.all(deg > 0)
        for name in ("dvE", "dvN", "dE", "dN"):
            assert deg[i(name)] == pytest.approx(1.0, abs=1e-3), name
