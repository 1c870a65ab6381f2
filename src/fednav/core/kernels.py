"""Small numba kernels shared by the compiled hot paths.

Note: numba's on-disk cache is per source file; a kernel changed here is not seen by
cached callers in other modules until their cache files (``__pycache__/*.nbi|*.nbc``) are
removed.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, inline="always")
def rodrigues_series(a2):
    """``sin(a) / a`` and ``(1 - cos a) / a^2`` from ``a2 = a^2`` by their series to a^6:
    below 1e-3 rad (a2 < 1e-6) the error is under 1e-20, with no cancellation."""
    return (1.0 - a2 * (1.0 / 6.0 - a2 * (1.0 / 120.0 - a2 / 5040.0)),
            0.5 - a2 * (1.0 / 24.0 - a2 * (1.0 / 720.0 - a2 / 40320.0)))


@numba.njit(cache=True, inline="always")
def rodrigues_coefficients(a2):
    """``sin(a) / a`` and ``(1 - cos a) / a^2`` (the series below 1e-3 rad)."""
    if a2 < 1e-6:
        return rodrigues_series(a2)
    a = np.sqrt(a2)
    return np.sin(a) / a, (1.0 - np.cos(a)) / a2


@numba.njit(cache=True, inline="always")
def rodrigues_entries(r0, r1, r2, s, c):
    """The nine entries, row-major, of ``I + s [r x] + c [r x]^2`` (Rodrigues' formula
    with the coefficients of :func:`rodrigues_coefficients`)."""
    return (1.0 - c * (r1 * r1 + r2 * r2), -s * r2 + c * r0 * r1, s * r1 + c * r0 * r2,
            s * r2 + c * r0 * r1, 1.0 - c * (r0 * r0 + r2 * r2), -s * r0 + c * r1 * r2,
            -s * r1 + c * r0 * r2, s * r0 + c * r1 * r2, 1.0 - c * (r0 * r0 + r1 * r1))


@numba.njit(cache=True, inline="always")
def rotvec_to_dcm(r0, r1, r2, out):
    """Rodrigues' formula for the rotation vector (r0, r1, r2) [rad], written into ``out``."""
    s, c = rodrigues_coefficients(r0 * r0 + r1 * r1 + r2 * r2)
    e = rodrigues_entries(r0, r1, r2, s, c)
    for k in range(9):
        out[k // 3, k % 3] = e[k]


@numba.njit(cache=True)
def cholesky_lower(S):
    """Lower Cholesky factor of a symmetric matrix; (L, ok) with ok False when S is not
    positive definite (no exception inside compiled code, explicit loops: no LAPACK call
    overhead at navigation-filter sizes)."""
    n = S.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        d = S[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return L, False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, n):
            s = S[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    return L, True


@numba.njit(cache=True)
def matmul_sparse(A, B):
    """``A @ B`` by explicit loops that skip the zero entries of ``A`` (state-space matrices
    F, Phi, Qc are mostly zeros); equal to ``A @ B`` up to the order of rounding."""
    n, m = A.shape
    p = B.shape[1]
    out = np.zeros((n, p))
    for i in range(n):
        for k in range(m):
            a = A[i, k]
            if a != 0.0:
                for j in range(p):
                    out[i, j] += a * B[k, j]
    return out


@numba.njit(cache=True)
def spd_inverse(P):
    """Inverse of an SPD matrix via its Cholesky factor (explicit loops: no LAPACK call
    overhead at these sizes); returns (inverse, ok)."""
    n = P.shape[0]
    L, ok = cholesky_lower(P)
    if not ok:
        return P, False
    # W = L^-1 (lower triangular), then P^-1 = W' W.
    W = np.zeros((n, n))
    for i in range(n):
        W[i, i] = 1.0 / L[i, i]
        for j in range(i):
            s = 0.0
            for k in range(j, i):
                s -= L[i, k] * W[k, j]
            W[i, j] = s / L[i, i]
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            s = 0.0
            for k in range(i, n):
                s += W[k, i] * W[k, j]
            out[i, j] = s
            out[j, i] = s
    return out, True


# --- Scalar forms for per-sample loops: tuples of floats, nothing allocated.
@numba.njit(cache=True, inline="always")
def rotvec_to_quat_s(x, y, z, small_a2=1e-12):
    """Rotation vector -> quaternion as 4 scalars (scalar first); the series form is used
    while the squared angle is below ``small_a2``."""
    a2 = x * x + y * y + z * z
    if a2 < small_a2:
        c, s = 1.0 - a2 / 8.0, 0.5 - a2 / 48.0
    else:
        a = math.sqrt(a2)
        c, s = math.cos(0.5 * a), math.sin(0.5 * a) / a
    return c, s * x, s * y, s * z


@numba.njit(cache=True, inline="always")
def quat_mul_s(a0, a1, a2, a3, b0, b1, b2, b3):
    """Hamilton product of two quaternions given as scalars (scalar first)."""
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@numba.njit(cache=True, inline="always")
def quat_to_rotvec_s(w, x, y, z):
    """Unit quaternion (scalars) -> rotation vector (angle in [0, pi])."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 / w if s < 1e-9 else 2.0 * math.atan2(s, w) / s
    return k * x, k * y, k * z


@numba.njit(cache=True, inline="always")
def quat_to_dcm_s(w, x, y, z):
    """Unit quaternion (scalars) -> the 9 DCM elements, row by row."""
    return (w * w + x * x - y * y - z * z, 2.0 * (x * y - w * z), 2.0 * (x * z + w * y),
            2.0 * (x * y + w * z), w * w - x * x + y * y - z * z, 2.0 * (y * z - w * x),
            2.0 * (x * z - w * y), 2.0 * (y * z + w * x), w * w - x * x - y * y + z * z)


@numba.njit(cache=True)
def rotvec_to_quat(r):
    """Rotation vector -> unit quaternion (scalar first)."""
    a2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    a = np.sqrt(a2)
    if a < 1e-8:
        c = 1.0 - a2 / 8.0
        s = 0.5 - a2 / 48.0
    else:
        c = np.cos(0.5 * a)
        s = np.sin(0.5 * a) / a
    return np.array([c, s * r[0], s * r[1], s * r[2]])


@numba.njit(cache=True)
def quat_mul(p, q):
    """Hamilton product (scalar first)."""
    return np.array([
        p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
        p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
        p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
        p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0],
    ])


@numba.njit(cache=True)
def quat_to_dcm(q):
    """Unit quaternion -> DCM."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    c = np.empty((3, 3))
    c[0, 0] = w * w + x * x - y * y - z * z
    c[0, 1] = 2 * (x * y - w * z)
    c[0, 2] = 2 * (x * z + w * y)
    c[1, 0] = 2 * (x * y + w * z)
    c[1, 1] = w * w - x * x + y * y - z * z
    c[1, 2] = 2 * (y * z - w * x)
    c[2, 0] = 2 * (x * z - w * y)
    c[2, 1] = 2 * (y * z + w * x)
    c[2, 2] = w * w - x * x - y * y + z * z
    return c


@numba.njit(cache=True)
def quat_to_rotvec(q):
    """Unit quaternion -> rotation vector (angle in [0, pi])."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = np.sqrt(x * x + y * y + z * z)
    if s < 1e-9:
        k = 2.0 / w
    else:
        k = 2.0 * np.arctan2(s, w) / s
    return np.array([k * x, k * y, k * z])


@numba.njit(cache=True, inline="always")
def dcm_to_rotvec(C, out):
    """Rotation vector of the DCM ``C`` [rad], written into ``out``.

    Small angles (below 1e-3 rad) take ``a / sin a`` as a series in ``sin a`` (half the
    antisymmetric part): no inverse trigonometric call, and exact to rounding."""
    v0, v1, v2 = C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]
    tr = C[0, 0] + C[1, 1] + C[2, 2]
    s2 = 0.25 * (v0 * v0 + v1 * v1 + v2 * v2)  # sin(a)^2
    if tr > 1.0 and s2 < 1e-6:
        k = 0.5 * (1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * 5.0 / 112.0)))
    else:
        a = np.arccos(min(1.0, max(-1.0, 0.5 * (tr - 1.0))))
        k = 0.5 * (1.0 + a * a / 6.0) if a < 1e-6 else a / (2.0 * np.sin(a))
    out[0] = k * v0
    out[1] = k * v1
    out[2] = k * v2


@numba.njit(cache=True, inline="always")
def coning_sculling_s(ax, ay, az, bx, by, bz, pax, pay, paz, pbx, pby, pbz, has_prev):
    """Two-sample coning and sculling: the rotation vector of the current angle increment
    ``a`` corrected by ``a_prev x a / 12``, and the sculling term
    ``(a_prev x b + b_prev x a) / 12`` for the velocity increment ``b`` (body axes, rad and
    m/s).  Without a previous sample: ``a`` and zero."""
    if not has_prev:
        return ax, ay, az, 0.0, 0.0, 0.0
    return (ax + (pay * az - paz * ay) / 12.0,
            ay + (paz * ax - pax * az) / 12.0,
            az + (pax * ay - pay * ax) / 12.0,
            ((pay * bz - paz * by) + (pby * az - pbz * ay)) / 12.0,
            ((paz * bx - pax * bz) + (pbz * ax - pbx * az)) / 12.0,
            ((pax * by - pay * bx) + (pbx * ay - pby * ax)) / 12.0)


@numba.njit(cache=True)
def euler_to_dcm(pitch, roll, heading):
    """Compiled scalar twin of :func:`fednav.core.attitude.euler_to_dcm` (tested equal)."""
    st, ct = np.sin(pitch), np.cos(pitch)
    sg, cg = np.sin(roll), np.cos(roll)
    sp, cp = np.sin(heading), np.cos(heading)
    c = np.empty((3, 3))
    c[0, 0] = cg * cp + st * sg * sp
    c[1, 0] = -cg * sp + st * sg * cp
    c[2, 0] = -ct * sg
    c[0, 1] = sp * ct
    c[1, 1] = cp * ct
    c[2, 1] = st
    c[0, 2] = sg * cp - st * cg * sp
    c[1, 2] = -sg * sp - st * cg * cp
    c[2, 2] = ct * cg
    return c
