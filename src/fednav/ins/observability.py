"""Observability analysis of a linear(ised) error model along a flight.

**SVD observability degree of a piecewise-constant system** (Goshen-Meskin &
Bar-Itzhack, IEEE TAES 28(4), 1992; the singular-value degree as in paper 002, section 2).
Over segments ``j = 1..r`` the error model is taken constant, ``(F_j, H_j)``; the
stripped observability matrix ::

    O = [O_1; O_2; ...; O_r],   O_j = [H_j; H_j F_j; ...; H_j F_j^(n-1)]

is decomposed ``O = U S V'``.  Paper 002's attribution rule credits the singular value
``s_i`` to the state ``k`` with the largest ``|V[k, i]|`` (it skips forming the initial
state from the measurements); a state credited with several values keeps the largest,
one credited with none gets 0 (not observable by this measure).  Degrees are normalised
to a reference state (the paper: velocity error = 1) — to its own singular value, or,
when it won none, to the singular value whose right vector has its largest component.

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
    """Per-state observability degree by paper 002's rule.

    Returns the degrees (n,) — normalised by the reference state's degree when
    ``reference`` is given — and the attribution ``[(singular value, state index), ...]``.
    """
    O = np.asarray(O, dtype=float)
    _, s, Vt = np.linalg.svd(O, full_matrices=False)
    n = O.shape[1]
    deg = np.zeros(n)
    assign = []
    for i, sv in enumerate(s):
        k = int(np.argmax(np.abs(Vt[i])))
        assign.append((float(sv), k))
        deg[k] = max(deg[k], sv)
    if reference is not None:
        ref = deg[reference]
        if ref <= 0:
            # The reference state won no singular vector: use the singular value whose
            # vector has the largest component along it.
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
