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
def cholesky_columns(S, semi):
    """Lower ``L`` with ``L L' = S`` (symmetric ``S``) column by column; (L, ok).

    ``semi`` False: ``S`` must be positive definite (ok False at the first pivot that is
    not positive, NaN included).  ``semi`` True: ``S`` positive semi-definite — a pivot at
    or below 1e-13 of its diagonal entry (a singular direction, e.g. states without
    process noise) leaves a zero column; ok False when a pivot is clearly negative
    (below -1e-8 of its diagonal entry), a diagonal entry is negative or a pivot is not
    finite."""
    n = S.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        d = S[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if semi:
            if not math.isfinite(d) or d < -1e-8 * abs(S[j, j]) or S[j, j] < 0.0:
                return L, False
            if d <= 1e-13 * abs(S[j, j]):
                continue
        elif not d > 0.0:
            return L, False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            s = S[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    return L, True


@numba.njit(cache=True)
def cholesky_lower(S):
    """Lower Cholesky factor of a symmetric matrix; (L, ok) with ok False when S is not
    positive definite (no exception inside compiled code, explicit loops: no LAPACK call
    overhead at navigation-filter sizes; :func:`cholesky_columns`)."""
    return cholesky_columns(S, False)


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
def lower_inverse(L):
    """Inverse of a lower-triangular matrix with a positive diagonal (lower triangular;
    forward substitution, explicit loops)."""
    n = L.shape[0]
    W = np.zeros((n, n))
    for i in range(n):
        W[i, i] = 1.0 / L[i, i]
        for j in range(i):
            s = 0.0
            for k in range(j, i):
                s -= L[i, k] * W[k, j]
            W[i, j] = s / L[i, i]
    return W


@numba.njit(cache=True)
def spd_inverse(P):
    """Inverse of an SPD matrix via its Cholesky factor (explicit loops: no LAPACK call
    overhead at these sizes); returns (inverse, ok)."""
    n = P.shape[0]
    L, ok = cholesky_lower(P)
    if not ok:
        return P, False
    W = lower_inverse(L)  # then P^-1 = W' W
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
#: Squared rotation angle [rad^2] below which :func:`rotvec_to_quat_s` takes the series
#: ``cos(a/2) = 1 - a^2/8``, ``sin(a/2)/a = 1/2 - a^2/48`` (exact to rounding there: the
#: next terms are below 1e-33); the one threshold of every rotation-vector conversion.
SMALL_ANGLE2 = 1e-16


@numba.njit(cache=True, inline="always")
def rotvec_to_quat_s(x, y, z):
    """Rotation vector [rad] -> unit quaternion as 4 scalars (scalar first): the one source
    of every rotation-vector-to-quaternion conversion in fednav (the compiled
    :func:`rotvec_to_quat`, :func:`fednav.core.attitude.rotvec_to_quat` and the strapdowns
    call it)."""
    a2 = x * x + y * y + z * z
    if a2 < SMALL_ANGLE2:
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


@numba.njit(cache=True, inline="always")
def dcm_of_sincos(st, ct, sg, cg, sp, cp):
    """The 9 elements of C_b^n (ENU), row by row, from the sines and cosines of pitch
    (``st``, ``ct``), roll (``sg``, ``cg``) and heading (``sp``, ``cp``):
    ``C = Rz(-heading) Rx(pitch) Ry(roll)``, columns the body right, forward, up axes in
    ENU.  One source: compiled here (:func:`euler_to_dcm_s`, the health monitor's
    integrals with sines at hand), and run by :func:`fednav.core.attitude.euler_to_dcm`
    on whole arrays as plain Python (it has no branch)."""
    return (cg * cp + st * sg * sp, sp * ct, sg * cp - st * cg * sp,
            -cg * sp + st * sg * cp, cp * ct, -sg * sp - st * cg * cp,
            -ct * sg, st, ct * cg)


@numba.njit(cache=True, inline="always")
def euler_to_dcm_s(pitch, roll, heading):
    """Euler ``[pitch, roll, heading]`` [rad] -> the 9 elements of C_b^n (ENU), row by row
    (:func:`dcm_of_sincos`)."""
    return dcm_of_sincos(np.sin(pitch), np.cos(pitch), np.sin(roll), np.cos(roll),
                         np.sin(heading), np.cos(heading))


@numba.njit(cache=True)
def _matrix_nb(e):
    c = np.empty((3, 3))
    c[0, 0], c[0, 1], c[0, 2] = e[0], e[1], e[2]
    c[1, 0], c[1, 1], c[1, 2] = e[3], e[4], e[5]
    c[2, 0], c[2, 1], c[2, 2] = e[6], e[7], e[8]
    return c


@numba.njit(cache=True)
def rotvec_to_quat(r):
    """Rotation vector -> unit quaternion (scalar first), compiled (:func:`rotvec_to_quat_s`)."""
    c, x, y, z = rotvec_to_quat_s(r[0], r[1], r[2])
    return np.array([c, x, y, z])


@numba.njit(cache=True)
def rotvec_to_quat_rows(r, out):
    """:func:`rotvec_to_quat_s` of every row of ``r`` (N, 3) into ``out`` (N, 4)."""
    for i in range(r.shape[0]):
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = rotvec_to_quat_s(r[i, 0], r[i, 1],
                                                                      r[i, 2])


@numba.njit(cache=True)
def quat_mul(p, q):
    """Hamilton product (scalar first), compiled (:func:`quat_mul_s`)."""
    a, b, c, d = quat_mul_s(p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3])
    return np.array([a, b, c, d])


@numba.njit(cache=True)
def quat_to_dcm(q):
    """Unit quaternion -> DCM, compiled (:func:`quat_to_dcm_s`)."""
    return _matrix_nb(quat_to_dcm_s(q[0], q[1], q[2], q[3]))


@numba.njit(cache=True)
def quat_to_rotvec(q):
    """Unit quaternion -> rotation vector (angle in [0, pi]), compiled
    (:func:`quat_to_rotvec_s`)."""
    x, y, z = quat_to_rotvec_s(q[0], q[1], q[2], q[3])
    return np.array([x, y, z])


@numba.njit(cache=True)
def quat_to_rotvec_rows(q, out):
    """:func:`quat_to_rotvec_s` of every row of ``q`` (N, 4) into ``out`` (N, 3)."""
    for i in range(q.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = quat_to_rotvec_s(q[i, 0], q[i, 1], q[i, 2], q[i, 3])


@numba.njit(cache=True)
def euler_to_dcm(pitch, roll, heading):
    """Euler ``[pitch, roll, heading]`` -> C_b^n, compiled (:func:`euler_to_dcm_s`)."""
    return _matrix_nb(euler_to_dcm_s(pitch, roll, heading))


@numba.njit(cache=True, inline="always")
def dcm_to_rotvec(C, out):
    """Rotation vector of the DCM ``C`` [rad] (angle in [0, pi]), written into ``out``.

    Small angles (below 1e-3 rad) take ``a / sin a`` as a series in ``sin a`` (half the
    antisymmetric part): no inverse trigonometric call, and exact to rounding; angles up
    to 2.8 rad ``a / (2 sin a)`` times that part.  Beyond (where ``sin a`` vanishes) the
    rotation goes through the quaternion (Shepperd's choice of the largest component,
    then :func:`quat_to_rotvec_s`), accurate up to and at pi."""
    v0, v1, v2 = C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]
    tr = C[0, 0] + C[1, 1] + C[2, 2]
    if tr > -0.9:
        s2 = 0.25 * (v0 * v0 + v1 * v1 + v2 * v2)  # sin(a)^2
        if tr > 1.0 and s2 < 1e-6:
            k = 0.5 * (1.0 + s2 * (1.0 / 6.0 + s2 * (3.0 / 40.0 + s2 * 5.0 / 112.0)))
        else:
            a = np.arccos(min(1.0, max(-1.0, 0.5 * (tr - 1.0))))
            k = 0.5 * (1.0 + a * a / 6.0) if a < 1e-6 else a / (2.0 * np.sin(a))
        out[0] = k * v0
        out[1] = k * v1
        out[2] = k * v2
        return
    d0, d1, d2 = C[0, 0], C[1, 1], C[2, 2]
    if tr >= d0 and tr >= d1 and tr >= d2:
        w, x, y, z = 1.0 + tr, v0, v1, v2
    elif d0 >= d1 and d0 >= d2:
        w, x, y, z = v0, 1.0 + 2.0 * d0 - tr, C[0, 1] + C[1, 0], C[0, 2] + C[2, 0]
    elif d1 >= d2:
        w, x, y, z = v1, C[0, 1] + C[1, 0], 1.0 + 2.0 * d1 - tr, C[1, 2] + C[2, 1]
    else:
        w, x, y, z = v2, C[0, 2] + C[2, 0], C[1, 2] + C[2, 1], 1.0 + 2.0 * d2 - tr
    n = math.sqrt(w * w + x * x + y * y + z * z)
    out[0], out[1], out[2] = quat_to_rotvec_s(w / n, x / n, y / n, z / n)


@numba.njit(cache=True)
def dcm_to_rotvec_rows(C, out):
    """:func:`dcm_to_rotvec` of every DCM of ``C`` (N, 3, 3) into ``out`` (N, 3)."""
    for i in range(C.shape[0]):
        dcm_to_rotvec(C[i], out[i])


@numba.njit(cache=True, inline="always")
def rotation_compensated_s(ax, ay, az, bx, by, bz, sx, sy, sz):
    """The velocity increment ``b`` of an interval (body axes at its start, m/s) with the
    rotation compensation ``a x b / 2`` of the interval's angle increment ``a`` [rad] and
    the sculling term ``s`` (:func:`coning_sculling_s`)."""
    return (bx + 0.5 * (ay * bz - az * by) + sx,
            by + 0.5 * (az * bx - ax * bz) + sy,
            bz + 0.5 * (ax * by - ay * bx) + sz)


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
