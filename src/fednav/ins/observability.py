"""Observability analysis of a linear(ised) error model along a flight.

**SVD observability degree of a piecewise-constant system** (Goshen-Meskin &
Bar-Itzhack, IEEE TAES 28(4), 1992; the singular-value degree as in paper 002, section 2).
Over segments ``j = 1..r`` the error model is taken constant, ``(F_j, H_j)``; the
stripped observability matrix ::

    O = [O_1; O_2; ...; O_r],   O_j = [H_j; H_j F_j; ...; H_j F_j^(n-1)]

is decomposed ``O = U S V'``.  Paper 002's rule credits the singular value ``s_i`` to
the state ``k`` with the largest component ``|V[k, i]|`` (it skips forming the initial
state from the measurements), and its Table 1 gives each of its 16 states one value.
Read literally the rule can credit two singular values to one state and none to
another: where several singular values are (nearly) equal their vectors are any
rotation within their subspace, and which state a vector's largest component falls on
is decided by rounding.  fednav therefore **assigns** the singular values to the states
one to one: the permutation that maximises ``sum_i V[k(i), i]**2`` (the share of each
singular vector on the state it is credited to; ``V**2`` is doubly stochastic), solved by
:func:`scipy.optimize.linear_sum_assignment`.  Wherever the largest-component rule is
already one to one, it is this optimum (each term is its row's largest), so the paper's
rule is kept where it is well defined; a collision goes to the vector with the larger
share and the other vector to its next state.  With fewer singular values than states
(fewer rows than columns in ``O``) the states left over get 0.  Degrees are normalised
to a reference state (the paper: velocity error = 1) — to its own singular value, or,
when it got none, to the singular value whose right vector has its largest component.

**The SVD degree depends on the units of the states.**  Scaling a state (arc-seconds
instead of radians, metres instead of radians of latitude) scales its column of ``O`` and
changes both the singular values and which state wins a singular vector.  The numbers
are therefore a property of the model *and its units*; fednav computes them in SI (rad,
m/s, m, rad/s, m/s^2) and shows the filter-unit version beside them.

**Covariance degree** (unit-free): run the covariance recursion of the Kalman filter
(``Phi``, ``Qd`` and every measurement's ``H``, ``R``) along the flight from ``P0`` and
report ``sigma_k(0) / sigma_k(T)`` per state — how many times the uncertainty of each
state shrank.  It is invariant to state scaling and accounts for the noise; a ratio near
1 means the measurements taught the filter nothing about that state.
"""

from __future__ import annotations

import numpy as np


def stripped_observability_matrix(F_list, H_list, powers: int | None = None) -> np.ndarray:
    """``O`` of a piecewise-constant system from per-segment ``F_j`` (n, n) and ``H_j``
    (m_j, n); ``powers`` terms per segment (default n)."""
    if len(F_list) != len(H_list) or not F_list:
        raise ValueError("observability: need one H per F, at least one segment")
    n = F_list[0].shape[0]
    powers = n if powers is None else int(powers)
    blocks = []
    for F, H in zip(F_list, H_list, strict=True):
        F, M = np.asarray(F, dtype=float), np.asarray(H, dtype=float)
        if F.shape != (n, n) or M.ndim != 2 or M.shape[1] != n:
            raise ValueError(f"observability: F must be ({n}, {n}) and H (m, {n}); got "
                             f"{F.shape} and {M.shape}")
        for _ in range(powers):
            blocks.append(M)
            M = M @ F
    return np.vstack(blocks)


def svd_degree(O, reference: int | None = None) -> tuple[np.ndarray, list[tuple]]:
    """Per-state SVD observability degree: paper 002's largest-component rule made one to
    one (module docstring).

    ``O`` (m, n): the stripped observability matrix (any consistent state units).  Returns
    the degrees (n,) — the singular value assigned to each state, in the units of ``O``,
    or divided by the reference state's one when ``reference`` (a state index) is given —
    and the attribution ``[(singular value, state index), ...]`` in decreasing order of
    the singular values, each state at most once.
    """
    from scipy.optimize import linear_sum_assignment

    O = np.asarray(O, dtype=float)
    if O.ndim != 2:
        raise ValueError(f"observability: O must be a 2-D matrix; got shape {O.shape}")
    _, s, Vt = np.linalg.svd(O, full_matrices=False)
    n = O.shape[1]
    rows, states = linear_sum_assignment(Vt**2, maximize=True)
    deg = np.zeros(n)
    deg[states] = s[rows]
    assign = [(float(s[i]), int(k)) for i, k in sorted(zip(rows, states, strict=True))]
    if reference is not None:
        if not 0 <= reference < n:
            raise ValueError(f"observability: reference state {reference} is not one of "
                             f"the {n} states")
        ref = deg[reference]
        if ref <= 0:
            # The reference state got no singular value (fewer of them than states): use
            # the one whose vector has the largest component along it.
            ref = s[int(np.argmax(np.abs(Vt[:, reference])))]
        deg = deg / ref
    return deg, assign


def covariance_degree(P0, steps) -> np.ndarray:
    """``sigma(0) / sigma(T)`` per state after the Kalman covariance recursion over
    ``steps``: an iterable of ``(Phi, Qd, [(H, R), ...])`` (time update, then the
    measurements of that step).  Joseph form; units as given (the ratio is unit-free)."""
    P = np.array(P0, dtype=float)
    s0 = np.sqrt(np.diag(P))
    n = P.shape[0]
    for Phi, Qd, meas in steps:
        P = Phi @ P @ Phi.T + Qd
        for H, R in meas:
            S = H @ P @ H.T + R
            K = np.linalg.solve(S, H @ P).T
            A = np.eye(n) - K @ H
            P = A @ P @ A.T + K @ R @ K.T
        P = 0.5 * (P + P.T)
    return s0 / np.sqrt(np.diag(P))
