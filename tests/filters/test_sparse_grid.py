import itertools

import numpy as np
import pytest

from fednav.filters.sparse_grid import (
    _coefficients,
    _index_set,
    gauss_hermite_1d,
    points_table,
    smolyak_coefficient_isotropic,
    sparse_grid,
)


def gaussian_moment(k) -> float:
    """E[prod x_j^k_j] for x ~ N(0, I)."""
    out = 1.0
    for kj in k:
        if kj % 2:
            return 0.0
        out *= np.prod(np.arange(kj - 1, 0, -2)) if kj else 1.0
    return float(out)


def _monomials(n, max_deg):
    for k in itertools.product(range(max_deg + 1), repeat=n):
        if sum(k) <= max_deg:
            yield k


@pytest.mark.parametrize("n, L", [(1, 3), (2, 2), (3, 3), (4, 3), (5, 2), (3, 4)])
def test_exact_for_total_degree_2L_minus_1(n, L):
    X, W = sparse_grid(n, L)
    for k in _monomials(n, 2 * L - 1):
        val = W @ np.prod(X ** np.array(k), axis=1)
        assert abs(val - gaussian_moment(k)) < 1e-9 * max(1.0, gaussian_moment(k)), k


def test_not_exact_beyond_its_degree():
    X, W = sparse_grid(3, 2)
    k = (2, 2, 0)   # degree 4 > 2L - 1 = 3: a cross moment the level-2 grid misses
    assert abs(W @ np.prod(X ** np.array(k), axis=1) - gaussian_moment(k)) > 0.5


def test_agrees_with_tensor_product_rule_in_low_dimension():
    x, w = gauss_hermite_1d(3)
    XX = np.array(list(itertools.product(x, repeat=2)))
    WW = np.array([a * b for a, b in itertools.product(w, repeat=2)])
    X, W = sparse_grid(2, 3)

    def f(P):
        return np.cos(P[:, 0]) * np.exp(0.3 * P[:, 1]) + P[:, 0] ** 3 * P[:, 1] ** 2

    # Both exact for the polynomial part; close for the smooth part.
    assert abs(W @ f(X) - WW @ f(XX)) < 5e-3


def test_general_combination_equals_classic_smolyak_coefficients():
    n, L = 6, 3
    coef = _coefficients(_index_set(n, L, (1.0,) * n))
    for i, c in coef.items():
        assert c == smolyak_coefficient_isotropic(n, L, sum(i) - n)


def test_points_per_level_and_merged_duplicates():
    tab = points_table((16, 17, 18), (2, 3))
    for n in (16, 17, 18):
        assert tab[n][2] == 2 * n + 1
        assert tab[n][3] == 1 + 2 * n + 4 * n + 4 * n * (n - 1) // 2
    X, W = sparse_grid(18, 3)
    assert len(np.unique(np.round(X, 9), axis=0)) == len(X)
    assert abs(W.sum() - 1.0) < 1e-12 and (W < 0).any()


def test_anisotropic_grid_exact_on_its_designated_monomials():
    n, L = 5, 3
    a = (1.0, 1.0, 2.0, 2.0, 2.0)   # dims 0, 1 nonlinear (level 3); 2-4 level 2 only
    X, W = sparse_grid(n, L, a)
    iso = sparse_grid(n, L)[0]
    assert len(X) < len(iso)
    for i in _index_set(n, L, a):
        bounds = [2 * (2 * l - 1) - 1 for l in i]   # k_j <= 2 m_l - 1
        for k in itertools.product(*[range(min(b, 6) + 1) for b in bounds]):
            val = W @ np.prod(X ** np.array(k), axis=1)
            assert abs(val - gaussian_moment(k)) < 1e-8 * max(1.0, gaussian_moment(k)), k
    # ... and, unlike the isotropic grid, not on a cross term between level-2 dimensions.
    k = (0, 0, 2, 2, 0)
    assert abs(W @ np.prod(X ** np.array(k), axis=1) - 1.0) > 0.5


@pytest.mark.parametrize("args", [(0, 3), (3, 0), (3, 3, (1.0, 0.5, 1.0)), (3, 3, (1.0,))])
def test_bad_arguments(args):
    with pytest.raises(ValueError):
        sparse_grid(*args)
