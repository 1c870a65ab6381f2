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

import numba
import numpy as np


def rts_errors(P_post, Phi, Q, dx) -> tuple[np.ndarray, np.ndarray]:
    """Smoothed errors and covariances of a closed-loop error-state filter.

    ``P_post`` (N+1, n, n): a-posteriori covariances at epochs 0..N; ``Phi``, ``Q``
    (N+1, n, n): transition and process noise from epoch k-1 to k (entry 0 unused);
    ``dx`` (N+1, n): the correction removed from the solution at epoch k (zero where
    nothing was measured).  Returns ``e`` (N+1, n) and ``Ps`` (N+1, n, n).
    """
    e, Ps, _ = rts_smooth(P_post, Phi, Q, dx)
    return e, Ps


def noise_moments(P_post, Phi, Q, dx, rows=None, smoothed=None) -> np.ndarray:
    """The expected outer product of each interval's process noise given every
    measurement (the E-step of Shumway & Stoffer's EM, 1982), ``W`` (N, n, n).

    The noise of interval k -> k+1 is ``w_k = x-_{k+1} - Phi_{k+1} x+_k`` with the
    smoothed errors ``x+_k = e_k`` and ``x-_{k+1} = e_{k+1} + dx_{k+1}`` and their lag-one
    covariance ``Cov(x_{k+1}, x_k) = Ps_{k+1} A_k'``::

        W_k = r r' + Ps_{k+1} - Ps_{k+1} A_k' Phi' - Phi A_k Ps_{k+1} + Phi Ps_k Phi'

    with ``r = e_{k+1} + dx_{k+1} - Phi e_k``.  ``W_k`` set against ``Q_{k+1}`` tells how
    much noise the data put where the model put ``Q`` (their ratio is 1 on average for a
    right model).  Arguments as :func:`rts_errors`; ``rows`` (indices): only those rows
    and columns of ``W`` (N, len(rows), len(rows)); ``smoothed``: :func:`rts_smooth`'s
    result on these arguments when it is at hand.  Filter units.
    """
    dx = np.asarray(dx, dtype=float)
    e, Ps, A = rts_smooth(P_post, Phi, Q, dx) if smoothed is None else smoothed
    Phi = np.asarray(Phi, dtype=float)[1:]
    d = np.arange(Phi.shape[1]) if rows is None else np.asarray(rows)
    Pd = Phi[:, d, :]
    r = e[1:, d] + dx[1:, d] - np.einsum("kij,kj->ki", Pd, e[:-1])
    C = Ps[1:][:, d, :] @ np.swapaxes(Pd @ A, 1, 2)
    W = (r[:, :, None] * r[:, None, :] + Ps[1:][:, d][:, :, d] - C - np.swapaxes(C, 1, 2)
         + Pd @ Ps[:-1] @ np.swapaxes(Pd, 1, 2))
    return 0.5 * (W + np.swapaxes(W, 1, 2))


def rts_smooth(P_post, Phi, Q, dx) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`rts_errors` with the smoother's gains ``A`` (N, n, n) beside."""
    P_post = np.asarray(P_post, dtype=float)
    Phi = np.asarray(Phi, dtype=float)
    Q = np.asarray(Q, dtype=float)
    dx = np.asarray(dx, dtype=float)
    N = len(P_post) - 1
    P_prior = Phi[1:] @ P_post[:-1] @ np.swapaxes(Phi[1:], 1, 2) + Q[1:]
    P_prior = 0.5 * (P_prior + np.swapaxes(P_prior, 1, 2))
    # A_k = P+_k Phi' (P-)^-1  <=>  P- A_k' = Phi P+_k  (P- symmetric), batched.
    try:
        np.linalg.cholesky(P_prior)  # every predicted covariance must be PD
    except np.linalg.LinAlgError:
        bad = next(k for k in range(N) if np.linalg.eigvalsh(P_prior[k])[0] <= 0)
        raise np.linalg.LinAlgError(f"RTS smoother: predicted covariance at epoch {bad + 1} "
                                    f"is not positive definite") from None
    A = np.ascontiguousarray(np.swapaxes(np.linalg.solve(P_prior, Phi[1:] @ P_post[:-1]),
                                         1, 2))
    e, Ps = backward_nb(A, np.ascontiguousarray(P_post), np.ascontiguousarray(P_prior),
                        np.ascontiguousarray(dx))
    return e, Ps, A


def backward(A, P_post, P_prior, dx):
    """The RTS recursion from the last epoch back (module docstring): smoothed errors
    ``e`` (N+1, n) and covariances ``Ps`` (N+1, n, n) from the gains ``A`` (N, n, n),
    the a-posteriori and predicted covariances and the corrections fed back."""
    N = P_post.shape[0] - 1
    n = P_post.shape[1]
    e = np.zeros((N + 1, n))
    Ps = np.empty_like(P_post)
    Ps[N] = P_post[N]
    for k in range(N - 1, -1, -1):
        e[k] = A[k] @ (e[k + 1] + dx[k + 1])
        Pk = P_post[k] + A[k] @ (Ps[k + 1] - P_prior[k]) @ A[k].T
        Ps[k] = 0.5 * (Pk + Pk.T)
    return e, Ps


#: :func:`backward` compiled (one source)
backward_nb = numba.njit(cache=True)(backward)
