"""Compiled kernels of the square-root (Cholesky-factor) filters.

Every covariance is carried as a lower-triangular factor ``S`` (``P = S S'``, positive
diagonal).  The kernels (numba; called from Python by the filters of
:mod:`fednav.filters.square_root`, one source for both) are:

* :func:`tria` — ``L`` lower triangular with ``L L' = A A'`` for a wide ``A`` (an
  orthogonal transformation from the right, Householder reflections applied to the rows:
  the R of a QR of ``A'``, only R formed);
* :func:`chol_downdate` — rank-1 downdate ``L L' - v v'`` (a negative weight);
* :func:`psd_sqrt` — a lower square root of a symmetric positive *semi*-definite matrix
  (process or measurement noise that may be singular);
* :func:`weighted_factor` — the factor of ``sum_i w_i d_i d_i' + c m m' + E E'``: one
  :func:`tria` of the positive terms, then one downdate per negative term;
* :func:`sr_propagate`, :func:`sr_kf_update`, :func:`sr_sigma_predict`,
  :func:`sr_sigma_update` — the time and measurement updates;
* :func:`sr_fuse` — square-root information fusion of k estimates;
* :func:`factor_product` — ``S S'`` exactly symmetric.

The measurement updates are the "array" form (Kailath, Sayed & Hassibi, *Linear
Estimation*, 2000, ch. 12; Carlson 1973): the lower-triangularized pre-array
``[[sqrt(R), H S], [0, S]]`` is ``[[Se, 0], [Kb, S+]]`` with ``Se Se' = H P H' + R``,
``Kb = P H' Se^-T`` (``K = Kb Se^-1``) and ``S+ S+' = P - K Se Se' K'`` — the Joseph-form
covariance, with no subtraction.  The sigma-point forms build the same array from the
weighted joint deviations of the measurement and the state.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.kernels import cholesky_columns, lower_inverse

#: Failure codes of the kernels (0: success), turned into FilterError texts by the filters.
OK, NOT_FINITE, DOWNDATE, INNOVATION, NOT_PD = 0, 1, 2, 3, 4


@numba.njit(cache=True, fastmath=True)
def tria(A):
    """Lower-triangular ``L`` with ``L L' = A A'`` (Householder reflections of the rows).

    Parameters
    ----------
    A : ndarray, shape (p, q)
        Any real matrix (a pre-array of weighted deviations and noise factors; units of
        the covariance's square root).

    Returns
    -------
    L : ndarray, shape (p, p)
        Lower triangular, non-negative diagonal; ``q < p`` leaves trailing zero columns.
    """
    p, q = A.shape
    W = A.copy()
    for i in range(min(p, q)):
        norm2 = 0.0
        for j in range(i, q):
            norm2 += W[i, j] * W[i, j]
        if norm2 == 0.0:
            continue
        norm = math.sqrt(norm2)
        x0 = W[i, i]
        s = norm if x0 >= 0.0 else -norm
        v0 = x0 + s
        den = s * v0
        for k in range(i + 1, p):
            dot = W[k, i] * v0
            for j in range(i + 1, q):
                dot += W[k, j] * W[i, j]
            f = dot / den
            W[k, i] -= f * v0
            for j in range(i + 1, q):
                W[k, j] -= f * W[i, j]
        W[i, i] = -s
        for j in range(i + 1, q):
            W[i, j] = 0.0
        if s > 0.0:  # a positive diagonal: the column's sign is free
            for k in range(i, p):
                W[k, i] = -W[k, i]
    L = np.zeros((p, p))
    for i in range(p):
        for j in range(min(i + 1, q)):
            L[i, j] = W[i, j]
    return L


@numba.njit(cache=True)
def chol_downdate(L, v):
    """Rank-1 Cholesky downdate, in place: ``L`` becomes the factor of ``L L' - v v'``.

    Parameters
    ----------
    L : ndarray, shape (n, n)
        Lower triangular with a positive diagonal (changed in place).
    v : ndarray, shape (n,)
        The vector to remove (same units as ``L``).

    Returns
    -------
    ok : bool
        False when ``L L' - v v'`` is not positive definite (``L`` then partly changed).
    """
    n = v.shape[0]
    w = v.copy()
    for k in range(n):
        Lkk = L[k, k]
        r2 = (Lkk - w[k]) * (Lkk + w[k])
        if not (r2 > 0.0 and Lkk > 0.0):
            return False
        r = math.sqrt(r2)
        c = r / Lkk
        s = w[k] / Lkk
        L[k, k] = r
        for i in range(k + 1, n):
            L[i, k] = (L[i, k] - s * w[i]) / c
            w[i] = c * w[i] - s * L[i, k]
    return True


@numba.njit(cache=True)
def psd_sqrt(Q):
    """Lower ``L`` with ``L L' = Q`` for a symmetric positive semi-definite ``Q``: a
    Cholesky factorization whose pivots at or below 1e-13 of their diagonal entry (a
    singular direction, e.g. states without process noise) give a zero column; (L, ok)
    with ok False when a pivot is clearly negative (Q indefinite) or not finite
    (:func:`fednav.core.kernels.cholesky_columns`)."""
    return cholesky_columns(Q, True)


@numba.njit(cache=True)
def factor_product(S):
    """``S S'`` for a lower-triangular ``S`` (exactly symmetric; triangle-aware)."""
    n = S.shape[0]
    P = np.empty((n, n))
    for i in range(n):
        for j in range(i + 1):
            s = 0.0
            for k in range(j + 1):
                s += S[i, k] * S[j, k]
            P[i, j] = s
            P[j, i] = s
    return P


@numba.njit(cache=True)
def weighted_factor(D, w, m, cm, E):
    """Lower factor ``L`` (p, p) of ``sum_i w_i D[i] D[i]' + cm m m' + E E'`` (``D``
    (K, p) rows, weights ``w`` (K,) of either sign, ``E`` (p, q) a factor of a positive
    semi-definite term): one :func:`tria` of the positive terms, then a rank-1 downdate for
    each negative one (negative weights of a sparse grid, ``cm < 0``).  Returns (L, code)
    with code :data:`DOWNDATE` when a downdate leaves the matrix not positive definite."""
    K, p = D.shape
    qe = E.shape[1]
    npos = 0
    for i in range(K):
        if w[i] > 0.0:
            npos += 1
    extra = 1 if cm > 0.0 else 0
    nze = 0  # the non-zero columns of E (a singular noise has zero columns)
    for j in range(qe):
        for r in range(p):
            if E[r, j] != 0.0:
                nze += 1
                break
    A = np.empty((p, npos + nze + extra))
    col = 0
    for i in range(K):
        if w[i] > 0.0:
            sw = math.sqrt(w[i])
            for r in range(p):
                A[r, col] = sw * D[i, r]
            col += 1
    for j in range(qe):
        nz = False
        for r in range(p):
            if E[r, j] != 0.0:
                nz = True
                break
        if nz:
            for r in range(p):
                A[r, col] = E[r, j]
            col += 1
    if extra:
        sc = math.sqrt(cm)
        for r in range(p):
            A[r, col] = sc * m[r]
    L = tria(A)
    for i in range(K):
        if w[i] < 0.0:
            if not chol_downdate(L, math.sqrt(-w[i]) * D[i]):
                return L, DOWNDATE
    if cm < 0.0:
        if not chol_downdate(L, math.sqrt(-cm) * m):
            return L, DOWNDATE
    return L, OK


@numba.njit(cache=True)
def sr_propagate(Phi, S, Lq, sq):
    """Time update of the factor: ``tria([Phi S, sq Lq])`` (``Phi P Phi' + sq^2 Q``);
    (S, ok) with ok False when it is not finite."""
    n = S.shape[0]
    q = Lq.shape[1]
    keep = np.zeros(q, dtype=np.bool_)  # the non-zero columns of Lq (singular Q)
    for j in range(q):
        for r in range(n):
            if Lq[r, j] != 0.0:
                keep[j] = True
                break
    A = np.empty((n, n + keep.sum()))
    A[:, :n] = Phi @ S
    col = n
    for j in range(q):
        if keep[j]:
            for r in range(n):
                A[r, col] = sq * Lq[r, j]
            col += 1
    L = tria(A)
    return L, np.isfinite(L.sum())


@numba.njit(cache=True)
def _finish_update(L, x, r, m):
    """From the lower post-array ``[[Se, 0], [Kb, S+]]`` and the residual ``r``: (x+, S+,
    Se Se', NIS, code)."""
    Se = np.ascontiguousarray(L[:m, :m])
    for i in range(m):
        if not Se[i, i] > 0.0:
            return x, np.ascontiguousarray(L[m:, m:]), Se @ Se.T, np.nan, INNOVATION
    e = np.empty(m)  # Se e = r
    for i in range(m):
        s = r[i]
        for k in range(i):
            s -= Se[i, k] * e[k]
        e[i] = s / Se[i, i]
    nis = 0.0
    for i in range(m):
        nis += e[i] * e[i]
    xn = x + np.ascontiguousarray(L[m:, :m]) @ e
    Sn = np.ascontiguousarray(L[m:, m:])
    Pzz = factor_product(Se)
    code = OK if math.isfinite(nis + xn.sum() + Sn.sum()) else NOT_FINITE
    for i in range(Sn.shape[0]):
        if code == OK and not Sn[i, i] > 0.0:
            code = NOT_PD
    return xn, Sn, Pzz, nis, code


@numba.njit(cache=True)
def same(A, B):
    """Whether two arrays of one shape hold the same values."""
    a = A.ravel()
    b = B.ravel()
    for i in range(a.shape[0]):
        if a[i] != b[i]:
            return False
    return True


@numba.njit(cache=True)
def sr_kf_update(x, S, H, r, Rs):
    """Kalman (Joseph-equivalent) update on the factor: the pre-array ``[[Rs, H S], [0,
    S]]`` lower-triangularized.  Returns (x+, S+, innovation covariance, NIS, code)."""
    n = x.shape[0]
    m = r.shape[0]
    A = np.zeros((m + n, m + n))
    A[:m, :m] = Rs
    A[:m, m:] = H @ S
    A[m:, m:] = S
    return _finish_update(tria(A), x, r, m)


@numba.njit(cache=True)
def _predicted(xm, L, code):
    """A time update's (mean, factor, code), the code NOT_FINITE where a factorization
    that succeeded left a non-finite mean or factor."""
    if code == OK and not math.isfinite(xm.sum() + L.sum()):
        code = NOT_FINITE
    return xm, L, code


@numba.njit(cache=True)
def sr_sigma_predict(Y, Wm, Wc, Lq, sq):
    """Sigma-point time update on the factor from the propagated points ``Y`` (K, n), point
    0 the image of the centre: with ``d_i = Y_i - Y_0`` and ``m = sum_{i>0} Wm_i d_i``,
    the mean is ``Y_0 + m`` and (``Wc_i = Wm_i`` for ``i > 0``) the covariance
    ``sum_{i>0} Wc_i d_i d_i' + (sum Wc - 2) m m' + sq^2 Q``: the zeroth weight enters
    through the rank-1 term (``beta - alpha^2`` for the scaled UKF: an update for the usual
    ``beta = 2``, a downdate when negative), never the ``-1e6`` of ``Wc_0`` at small
    ``alpha``.  Returns (mean, S, code)."""
    K, n = Y.shape
    D = Y[1:] - Y[0]
    m = Wm[1:] @ D
    cm = Wc.sum() - 2.0
    L, code = weighted_factor(D, Wc[1:], m, cm, sq * Lq)
    return _predicted(Y[0] + m, L, code)


@numba.njit(cache=True)
def sr_sigma_update(dX, Z, Wm, Wc, x, y, Rs):
    """Sigma-point measurement update on the factor: ``dX`` (K, n) the points' offsets from
    the centre ``x`` (row 0 zero), ``Z`` (K, m) their predicted measurements.  The joint
    deviations ``[Z_i - Z_0; dX_i]`` with the weights of :func:`sr_sigma_predict` and
    ``[Rs; 0]`` give the lower factor ``[[Se, 0], [Kb, S+]]`` of ``[[Pzz, Pxz'], [Pxz,
    P]]`` — ``Se Se' = Pzz``, ``Kb Se' = Pxz``, ``S+ S+' = P - Pxz Pzz^-1 Pxz'`` — with no
    downdate for positive weights.  Returns (x+, S+, Pzz, NIS, code)."""
    K, m = Z.shape
    n = x.shape[0]
    D = np.empty((K - 1, m + n))
    for i in range(1, K):
        for j in range(m):
            D[i - 1, j] = Z[i, j] - Z[0, j]
        for j in range(n):
            D[i - 1, m + j] = dX[i, j]
    mv = Wm[1:] @ D
    cm = Wc.sum() - 2.0
    E = np.zeros((m + n, m))
    E[:m, :m] = Rs
    L, code = weighted_factor(D, Wc[1:], mv, cm, E)
    z_hat = Z[0] + mv[:m]
    r = y - z_hat
    if code != OK:
        return x, np.ascontiguousarray(L[m:, m:]), np.zeros((m, m)), np.nan, code, r
    xn, Sn, Pzz, nis, code = _finish_update(L, x, r, m)
    return xn, Sn, Pzz, nis, code, r


@numba.njit(cache=True)
def sr_fuse(xs, Ss):
    """Square-root information fusion of k estimates (x_i, S_i S_i'): the information
    factors ``U_i = S_i^-1`` stacked, with their state columns reversed, and the
    information vectors ``U_i x_i`` as a last column, lower-triangularized in one
    :func:`tria`; the fused factor is ``J L^-T J`` (``J`` the reversal: lower again) and the
    fused state a back-substitution.  No covariance is inverted or formed.

    Parameters
    ----------
    xs : ndarray, shape (k, n)
        The estimates (filter units).
    Ss : ndarray, shape (k, n, n)
        Their lower Cholesky factors (``P_i = S_i S_i'``, filter units).

    Returns
    -------
    x_g : ndarray, shape (n,)
        The fused estimate ``P_g sum P_i^-1 x_i``.
    S_g : ndarray, shape (n, n)
        Lower factor of ``P_g = (sum P_i^-1)^-1``.
    traces : ndarray, shape (k,)
        ``tr(P_i^-1)`` (adaptive sharing; units^-2).
    bad : int
        -1 on success, ``i`` when ``S_i`` is singular, ``k`` when the fused information is.
    """
    k, n = xs.shape
    if k == 1:
        return xs[0].copy(), Ss[0].copy(), np.ones(1), -1
    A = np.empty((n + 1, k * n))
    tr = np.empty(k)
    for f in range(k):
        S = Ss[f]
        for i in range(n):
            if not S[i, i] > 0.0:
                return xs[0].copy(), Ss[0].copy(), tr, f
        U = lower_inverse(S)  # S^-1, lower
        t2 = 0.0
        for i in range(n):
            for j in range(i + 1):
                t2 += U[i, j] * U[i, j]
        tr[f] = t2
        u = U @ xs[f]
        for i in range(n):  # A' rows = U's rows; A's row r = U's column n-1-r
            for r in range(n):
                A[r, f * n + i] = U[i, n - 1 - r]
            A[n, f * n + i] = u[i]
    L = tria(A)
    Lt = L[:n, :n]
    ell = L[n, :n]
    for i in range(n):
        if not Lt[i, i] > 0.0:
            return xs[0].copy(), Ss[0].copy(), tr, k
    T = lower_inverse(Lt)  # Lt^-1, lower
    yv = T.T @ ell        # Lt' y = ell
    xg = yv[::-1].copy()
    Sg = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            Sg[i, j] = T[n - 1 - j, n - 1 - i]
    return xg, Sg, tr, -1


@numba.njit(cache=True)
def sr_project(x, S, D, r, Rs):
    """Estimate projection onto ``D x = d`` (``r = d - D x``) on the factor, as
    :func:`fednav.filters.constrained.project`: gain ``K = P D' (D P D')^-1``, covariance
    ``(I - K D) P (I - K D)' + K R_d K'`` — the array update with no noise (``[[0, D S],
    [0, S]]``), then ``tria([S0, K Rs])``.  Returns (x~, S~, ``D P D' + R_d``, NIS against
    it (NaN where that is singular), code)."""
    n = x.shape[0]
    m = r.shape[0]
    A = np.zeros((m + n, m + n))
    A[:m, m:] = D @ S
    A[m:, m:] = S
    L = tria(A)
    Se = np.ascontiguousarray(L[:m, :m])
    for i in range(m):
        if not Se[i, i] > 0.0:
            return x, S, Se @ Se.T, np.nan, INNOVATION
    Ti = lower_inverse(Se)
    Kb = np.ascontiguousarray(L[m:, :m])
    xn = x + Kb @ (Ti @ r)
    K = Kb @ Ti
    B = np.empty((n, n + m))
    B[:, :n] = L[m:, m:]
    B[:, n:] = K @ Rs
    Sn = tria(B)
    Pzz = Se @ Se.T + Rs @ Rs.T
    Lz, ok = psd_sqrt(Pzz)
    nis = np.nan
    if ok:
        good = True
        for i in range(m):
            if not Lz[i, i] > 0.0:
                good = False
        if good:
            e = lower_inverse(Lz) @ r
            nis = e @ e
    code = OK if math.isfinite(xn.sum() + Sn.sum()) else NOT_FINITE
    return xn, Sn, Pzz, nis, code


@numba.njit(cache=True)
def sr_ukf_update(Z, S, wi, cm, x, y, Rs):
    """:func:`sr_sigma_update` for the symmetric UKF points ``x``, ``x +- sqrt(c) S_i``
    (weights ``wi = 1 / (2 c)`` past the zeroth) from their predicted measurements ``Z``
    (2n + 1, m): each pair of joint deviations turned by 45 degrees gives a column
    ``sqrt(wi / 2) (dz_i + dz_(i+n))`` with no state part and one ``[sqrt(wi / 2) (dz_i -
    dz_(i+n)); S_i]``, so the array is ``[[tria([Rs, sums, sqrt(cm) mz]), diffs], [0,
    S]]`` — the size of the KF array update.  Returns (x+, S+, Pzz, NIS, code, r)."""
    K, m = Z.shape
    n = S.shape[0]
    h = math.sqrt(0.5 * wi)
    mz = np.zeros(m)
    for i in range(1, K):
        for j in range(m):
            mz[j] += wi * (Z[i, j] - Z[0, j])
    T = np.empty((m, m + n + (1 if cm > 0.0 else 0)))
    T[:, :m] = Rs
    A = np.zeros((m + n, m + n))
    for i in range(n):
        for j in range(m):
            a = Z[1 + i, j] - Z[0, j]
            b = Z[1 + n + i, j] - Z[0, j]
            T[j, m + i] = h * (a + b)
            A[j, m + i] = h * (a - b)
    if cm > 0.0:
        sc = math.sqrt(cm)
        for j in range(m):
            T[j, m + n] = sc * mz[j]
    A[:m, :m] = tria(T)
    A[m:, m:] = S
    L = tria(A)
    r = y - (Z[0] + mz)
    if cm < 0.0:
        v = np.zeros(m + n)
        v[:m] = math.sqrt(-cm) * mz
        if not chol_downdate(L, v):
            return x, S, np.zeros((m, m)), np.nan, DOWNDATE, r
    xn, Sn, Pzz, nis, code = _finish_update(L, x, r, m)
    return xn, Sn, Pzz, nis, code, r


@numba.njit(cache=True)
def _regression(D, G, w):
    """``J = sum_i w_i D_i G_i'`` and the residuals ``E_i = D_i - J G_i`` (rows), over
    points ``G`` (K, n) with ``sum_i w_i G_i G_i' = I``."""
    K, p = D.shape
    n = G.shape[1]
    J = np.zeros((p, n))
    for i in range(K):
        for a in range(p):
            wd = w[i] * D[i, a]
            for b in range(n):
                J[a, b] += wd * G[i, b]
    E = D - G @ J.T
    return J, E


@numba.njit(cache=True)
def sr_grid_predict(Y, G, w, Lq, sq):
    """Quadrature (sparse-grid) time update on the factor from the propagated points
    ``Y`` (K, n) of the unit points ``G`` (row 0 the origin, weights ``w`` of either sign
    summing to 1, ``sum w G G' = I``).  The deviations ``d_i = Y_i - Y_0`` are split into
    their regression on the unit points, ``J = sum w_i d_i G_i'`` (for a linear map
    ``A``, ``J = A S`` exactly), and residuals ``e_i = d_i - J G_i`` (zero for a linear
    map): the covariance is ``J J' + sum w_i e_i e_i' - m m' + sq^2 Q`` (``m = sum w_i
    d_i``; the cross terms vanish), so the negative weights are downdates by the small
    nonlinear residuals only, never by the large linear part.  Returns (mean, S, code)."""
    K, n = Y.shape
    D = Y[1:] - Y[0]
    Gi = G[1:]
    wi = w[1:]
    J, E = _regression(D, Gi, wi)
    m = wi @ D
    X = np.empty((n, n + Lq.shape[1]))
    X[:, :n] = J
    X[:, n:] = sq * Lq
    L, code = weighted_factor(E, wi, m, w.sum() - 2.0, X)
    return _predicted(Y[0] + m, L, code)


@numba.njit(cache=True)
def sr_grid_update(Z, G, w, S, x, y, Rs):
    """Quadrature measurement update on the factor (points ``x + G S'``, predicted
    measurements ``Z`` (K, m)): with ``Jz = sum w_i dz_i G_i'`` and residuals ``ez_i``
    (:func:`sr_grid_predict`), the joint factor is the triangularization of ``[[tria([Rs,
    sqrt(w+) ez+]), Jz], [0, S]]`` — the state part of every joint deviation is exactly
    ``S G_i`` — downdated by ``[sqrt(-w) ez-; 0]`` for each negative weight and by
    ``[mz; 0]``.  Returns (x+, S+, Pzz, NIS, code, r)."""
    K, m = Z.shape
    n = S.shape[0]
    D = Z[1:] - Z[0]
    Gi = G[1:]
    wi = w[1:]
    Jz, Ez = _regression(D, Gi, wi)
    mz = wi @ D
    Rz, code = weighted_factor(Ez, np.maximum(wi, 0.0), mz, 0.0, Rs)
    A = np.zeros((m + n, m + n))
    A[:m, :m] = Rz
    A[:m, m:] = Jz
    A[m:, m:] = S
    L = tria(A)
    r = y - (Z[0] + mz)
    v = np.zeros(m + n)
    for i in range(K - 1):
        if wi[i] < 0.0:
            sw = math.sqrt(-wi[i])
            for j in range(m):
                v[j] = sw * Ez[i, j]
            if not chol_downdate(L, v):
                return x, S, np.zeros((m, m)), np.nan, DOWNDATE, r
    cm = w.sum() - 2.0
    if cm < 0.0:
        sc = math.sqrt(-cm)
        for j in range(m):
            v[j] = sc * mz[j]
        if not chol_downdate(L, v):
            return x, S, np.zeros((m, m)), np.nan, DOWNDATE, r
    xn, Sn, Pzz, nis, code = _finish_update(L, x, r, m)
    return xn, Sn, Pzz, nis, code, r


@numba.njit(cache=True)
def ukf_points(x, S, sc):
    """The UKF's points ``x``, ``x +- sc S_i`` (rows) and their offsets from ``x``."""
    n = x.shape[0]
    dX = np.zeros((2 * n + 1, n))
    for i in range(n):
        for j in range(i, n):  # S lower: column i is zero above row i
            v = sc * S[j, i]
            dX[1 + i, j] = v
            dX[1 + n + i, j] = -v
    X = np.empty_like(dX)
    for k in range(2 * n + 1):
        for j in range(n):
            X[k, j] = x[j] + dX[k, j]
    return X, dX
