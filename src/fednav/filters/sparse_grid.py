"""Sparse-grid Gauss–Hermite quadrature for Gaussian expectations (Smolyak construction).

``E[g(x)]``, ``x ~ N(0, I_n)``, is approximated by ``sum_k w_k g(xi_k)`` with points and
weights built from 1-D Gauss–Hermite rules (probabilists' weight ``exp(-x^2/2)``) by the
Smolyak combination technique (Jia, Xin & Cheng, "Sparse-grid quadrature nonlinear
filtering", Automatica 48(2), 2012)::

    A = sum_{i in I} c_i  (U_{i_1} x ... x U_{i_n}),
    c_i = sum_{z in {0,1}^n, i + z in I} (-1)^|z|

over a downward-closed set ``I`` of multi-indices (``i_j >= 1``).  The 1-D rule of level
``l`` has ``m_l = 2 l - 1`` points (exact to degree ``4 l - 3``).

* **Isotropic** (SGHQF): ``I = {i : sum_j (i_j - 1) <= L - 1}`` — exact for every
  polynomial of total degree ``<= 2 L - 1`` (tested against Gaussian moments).  Level 2
  gives the ``2n + 1`` points of a unit-spread cubature, level 3 ``2n^2 + 2n + 1``.
* **Anisotropic** (the grid of AASGHQF): ``I = {i : sum_j a_j (i_j - 1) <= L - 1}`` with a
  weight ``a_j >= 1`` per dimension — dimensions with a large weight (weakly nonlinear)
  get fewer levels; the grid stays exact on every tensor monomial ``prod x_j^k_j`` with
  ``k_j <= 2 m_{i_j} - 1`` for some ``i`` in ``I`` (tested).  Jia, Xin & Cheng,
  "Anisotropic sparse Gauss–Hermite quadrature filter", J. Guidance, Control, and
  Dynamics 35(3), 2012.

Points that coincide (the origin appears in almost every tensor product) are merged and
their weights summed; the weights can be negative.  Grids are built once per
``(n, level, weights)`` and cached.
"""

from __future__ import annotations

from functools import cache
from math import comb

import numpy as np


@cache
def gauss_hermite_1d(level: int) -> tuple[np.ndarray, np.ndarray]:
    """1-D rule of ``level`` (``2 level - 1`` points) for the standard normal weight."""
    if level < 1:
        raise ValueError(f"Gauss-Hermite level must be >= 1, got {level}")
    x, w = np.polynomial.hermite_e.hermegauss(2 * level - 1)
    w = w / w.sum()
    x[np.abs(x) < 1e-14] = 0.0
    return x, w


def _index_set(n: int, level: int, weights: tuple[float, ...]) -> list[tuple[int, ...]]:
    """Downward-closed multi-indices (1-based) with sum_j a_j (i_j - 1) <= level - 1."""
    budget = level - 1 + 1e-9
    out: list[tuple[int, ...]] = []

    def rec(j, prefix, used):
        if j == n:
            out.append(tuple(prefix))
            return
        k = 0
        while used + weights[j] * k <= budget:
            rec(j + 1, prefix + [k + 1], used + weights[j] * k)
            k += 1

    rec(0, [], 0.0)
    return out


def _coefficients(index_set: list[tuple[int, ...]]) -> dict[tuple[int, ...], int]:
    """Combination coefficients c_i (only the non-zero ones)."""
    members = set(index_set)
    coef = {}
    for i in index_set:
        n = len(i)
        c = 0
        # z in {0,1}^n with i + z in I: grow z one coordinate at a time (sparse support).
        stack = [(0, i, 0)]
        while stack:
            start, cur, nz = stack.pop()
            c += (-1) ** nz
            for j in range(start, n):
                nxt = cur[:j] + (cur[j] + 1,) + cur[j + 1:]
                if nxt in members:
                    stack.append((j + 1, nxt, nz + 1))
        if c:
            coef[i] = c
    return coef


@cache
def sparse_grid(n: int, level: int = 3, weights: tuple[float, ...] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """Points (K, n) and weights (K,) of the sparse-grid rule for ``N(0, I_n)``.

    ``level`` L >= 1 (isotropic accuracy: total degree ``2 L - 1``); ``weights`` one
    ``a_j >= 1`` per dimension for an anisotropic grid (None: isotropic).  The weights of
    the rule sum to 1; points are merged to 1e-12.
    """
    if n < 1:
        raise ValueError(f"sparse grid: dimension must be >= 1, got {n}")
    if level < 1:
        raise ValueError(f"sparse grid: level must be >= 1, got {level}")
    a = (1.0,) * n if weights is None else tuple(float(v) for v in weights)
    if len(a) != n or min(a) < 1.0:
        raise ValueError(f"sparse grid: need {n} dimension weights, each >= 1")
    acc: dict[tuple, float] = {}
    for idx, c in _coefficients(_index_set(n, level, a)).items():
        rules = [gauss_hermite_1d(l) for l in idx]
        active = [j for j, l in enumerate(idx) if l > 1]
        # Dimensions at level 1 contribute the single point 0 with weight 1.
        if active:
            grids = np.meshgrid(*[rules[j][0] for j in active], indexing="ij")
            wgrid = np.ones_like(grids[0])
            for g in np.meshgrid(*[rules[j][1] for j in active], indexing="ij"):
                wgrid = wgrid * g
            pts = np.zeros((wgrid.size, n))
            for g, j in zip(grids, active, strict=True):
                pts[:, j] = g.ravel()
            ws = wgrid.ravel()
        else:
            pts, ws = np.zeros((1, n)), np.ones(1)
        for p, w in zip(np.round(pts, 12), ws, strict=True):
            key = tuple(p)
            acc[key] = acc.get(key, 0.0) + c * w
    keys = [k for k, w in acc.items() if abs(w) > 1e-15]
    X = np.array(keys, dtype=float).reshape(-1, n)
    W = np.array([acc[k] for k in keys])
    X.setflags(write=False)
    W.setflags(write=False)
    return X, W


def points_table(dims=(16, 17, 18), levels=(1, 2, 3, 4)) -> dict[int, dict[int, int]]:
    """Number of points per dimension and level (for the docs)."""
    return {n: {L: len(sparse_grid(n, L)[1]) for L in levels} for n in dims}


def smolyak_coefficient_isotropic(n: int, level: int, q: int) -> int:
    """The classic closed form of c for |i| = n + q (q in [max(0, L - n), L - 1]):
    ``(-1)^(L-1-q) C(n-1, L-1-q)`` — used by the tests to check the general technique."""
    return (-1) ** (level - 1 - q) * comb(n - 1, level - 1 - q)
