"""Rauch–Tung–Striebel smoother for closed-loop error-state filters (post-processing).

The forward filter corrects the INS at every epoch, so its error estimate relative to
the corrected solution ``nav+_k`` is zero with covariance ``P+_k``.  Relative to the
*predicted* solution ``nav-_{k+1}`` (before the correction ``dx_{k+1}`` that the filter
removed) the error is ``e+_{k+1} + dx_{k+1}``.  The RTS recursion on these errors::

    P-_{k+1} = Phi_{k+1} P+_k Phi_{k+1}' + Q_{k+1}
    A_k      = P+_k Phi_{k+1}' (P-_{k+1})^-1
    e_k      = A_k (e_{k+1} + dx_{k+1}),            e_N = 0
    Ps_k     = P+_k + A_k (Ps_{k+1} - P-_{k+1}) A_k'

gives the smoothed error ``e_k`` of ``nav+_k`` (computed minus true), which is then
removed from the stored solution.  All arrays in the filter's units.
"""

from __future__ import annotations

import numpy as np


def rts_errors(P_post, Phi, Q, dx) -> tuple[np.ndarray, np.ndarray]:
    """Smoothed errors and covariances of a closed-loop error-state filter.

    ``P_post`` (N+1, n, n): a-posteriori covariances at epochs 0..N; ``Phi``, ``Q``
    (N+1, n, n): transition and process noise from epoch k-1 to k (entry 0 unused);
    ``dx`` (N+1, n): the correction removed from the solution at epoch k (zero where
    nothing was measured).  Returns ``e`` (N+1, n) and ``Ps`` (N+1, n, n).
    """
    P_post = np.asarray(P_post, dtype=float)
    Phi = np.asarray(Phi, dtype=float)
    Q = np.asarray(Q, dtype=float)
    dx = np.asarray(dx, dtype=float)
    N = len(P_post) - 1
    n = P_post.shape[1]
    P_prior = Phi[1:] @ P_post[:-1] @ np.swapaxes(Phi[1:], 1, 2) + Q[1:]
    P_prior = 0.5 * (P_prior + np.swapaxes(P_prior, 1, 2))
    # A_k = P+_k Phi' (P-)^-1  <=>  P- A_k' = Phi P+_k  (P- symmetric), batched.
    try:
        np.linalg.cholesky(P_prior)  # every predicted covariance must be PD
    except np.linalg.LinAlgError:
        bad = next(k for k in range(N) if np.linalg.eigvalsh(P_prior[k])[0] <= 0)
        raise np.linalg.LinAlgError(f"RTS smoother: predicted covariance at epoch {bad + 1} "
                                    f"is not positive definite") from None
    A = np.swapaxes(np.linalg.solve(P_prior, Phi[1:] @ P_post[:-1]), 1, 2)
    e = np.zeros((N + 1, n))
    Ps = np.empty_like(P_post)
    Ps[N] = P_post[N]
    for k in range(N - 1, -1, -1):
        e[k] = A[k] @ (e[k + 1] + dx[k + 1])
        Pk = P_post[k] + A[k] @ (Ps[k + 1] - P_prior[k]) @ A[k].T
        Ps[k] = 0.5 * (Pk + Pk.T)
    return e, Ps
