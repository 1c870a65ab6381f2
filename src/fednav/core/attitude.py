"""Attitude representations and conversions (see ``docs/conventions.md``).

* ``C`` — direction cosine matrix C_b^n (body -> ENU navigation), ``v_n = C @ v_b``.
* ``q`` — unit quaternion q_b^n, scalar first ``[w, x, y, z]``, same rotation as ``C``.
* ``euler`` — ``[pitch, roll, heading]`` [rad]; ``C = Rz(-heading) Rx(pitch) Ry(roll)``
  with body axes x right, y forward, z up. Heading is measured from north, positive
  toward east (clockwise seen from above), in [0, 2*pi).
* ``rotvec`` — rotation vector (axis * angle) [rad].
* misalignment ``phi = [phiE, phiN, phiU]`` — platform error angles: the computed
  attitude is ``C_hat = C_n^n' C`` with ``C_n^n' = exp(-[phi x]) ~ I - [phi x]``.

All functions are vectorised over leading dimensions.  Each conversion has one source,
written once in :mod:`fednav.core.kernels` as a function of scalars: those without a branch
(``euler_to_dcm``, ``quat_to_dcm``, ``quat_mul``) run here as plain Python on whole arrays,
those with one (the small-angle forms of ``rotvec_to_quat``, ``quat_to_rotvec``) run
compiled over the rows.
"""

from __future__ import annotations

import math

import numpy as np

from . import kernels

TWO_PI = 2.0 * np.pi


def _matrix(e):
    """9 elements, row by row (scalars or arrays) -> (..., 3, 3)."""
    out = np.empty(np.broadcast_shapes(*(np.shape(v) for v in e)) + (3, 3))
    for k, v in enumerate(e):
        out[..., k // 3, k % 3] = v
    return out


def _rows(kernel, a, n_in: int, n_out: int) -> np.ndarray:
    """A compiled row kernel over the leading dimensions of ``a`` (..., n_in)."""
    a = np.asarray(a, dtype=float)
    flat = np.ascontiguousarray(a.reshape(-1, n_in))
    out = np.empty((len(flat), n_out))
    kernel(flat, out)
    return out.reshape(a.shape[:-1] + (n_out,))


def wrap_pi(a):
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % TWO_PI - np.pi


def wrap_2pi(a):
    """Wrap angles to [0, 2*pi)."""
    return np.asarray(a) % TWO_PI


def skew(v):
    """Skew-symmetric (cross-product) matrix ``[v x]``, shape (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    if v.ndim == 1:  # one vector: plain floats
        x, y, w = float(v[0]), float(v[1]), float(v[2])
        return np.array([[0.0, -w, y], [w, 0.0, -x], [-y, x, 0.0]])
    z = np.zeros_like(v[..., 0])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2
    )


def euler_to_dcm(euler):
    """Euler ``[pitch, roll, heading]`` -> C_b^n, shape (..., 3, 3)
    (:func:`fednav.core.kernels.dcm_of_sincos`)."""
    e = np.asarray(euler, dtype=float)
    s, c = np.sin(e), np.cos(e)
    return _matrix(kernels.dcm_of_sincos.py_func(s[..., 0], c[..., 0], s[..., 1], c[..., 1],
                                                 s[..., 2], c[..., 2]))


def dcm_to_euler(C):
    """C_b^n -> Euler ``[pitch, roll, heading]``; heading in [0, 2*pi)."""
    C = np.asarray(C, dtype=float)
    if C.ndim == 2:  # one attitude: plain floats (called once per filter epoch)
        h = math.atan2(C[0, 1], C[1, 1])
        return np.array([math.asin(min(1.0, max(-1.0, C[2, 1]))),
                         math.atan2(-C[2, 0], C[2, 2]), h % TWO_PI])
    pitch = np.arcsin(np.clip(C[..., 2, 1], -1.0, 1.0))
    roll = np.arctan2(-C[..., 2, 0], C[..., 2, 2])
    heading = wrap_2pi(np.arctan2(C[..., 0, 1], C[..., 1, 1]))
    return np.stack([pitch, roll, heading], axis=-1)


def quat_mul(p, q):
    """Hamilton product ``p * q`` (scalar first; :func:`fednav.core.kernels.quat_mul_s`)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    return np.stack(kernels.quat_mul_s.py_func(p[..., 0], p[..., 1], p[..., 2], p[..., 3],
                                               q[..., 0], q[..., 1], q[..., 2], q[..., 3]),
                    axis=-1)


def quat_conj(q):
    """Conjugate (inverse of a unit quaternion)."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_to_dcm(q):
    """Unit quaternion -> DCM (:func:`fednav.core.kernels.quat_to_dcm_s`)."""
    q = np.asarray(q, dtype=float)
    return _matrix(kernels.quat_to_dcm_s.py_func(q[..., 0], q[..., 1], q[..., 2], q[..., 3]))


def dcm_to_quat(C):
    """DCM -> unit quaternion with non-negative scalar part (Shepperd's method)."""
    C = np.asarray(C, dtype=float)
    tr = C[..., 0, 0] + C[..., 1, 1] + C[..., 2, 2]
    cand = np.stack(
        [
            np.stack([1 + tr, C[..., 2, 1] - C[..., 1, 2], C[..., 0, 2] - C[..., 2, 0],
                      C[..., 1, 0] - C[..., 0, 1]], -1),
            np.stack([C[..., 2, 1] - C[..., 1, 2], 1 + 2 * C[..., 0, 0] - tr,
                      C[..., 0, 1] + C[..., 1, 0], C[..., 0, 2] + C[..., 2, 0]], -1),
            np.stack([C[..., 0, 2] - C[..., 2, 0], C[..., 0, 1] + C[..., 1, 0],
                      1 + 2 * C[..., 1, 1] - tr, C[..., 1, 2] + C[..., 2, 1]], -1),
            np.stack([C[..., 1, 0] - C[..., 0, 1], C[..., 0, 2] + C[..., 2, 0],
                      C[..., 1, 2] + C[..., 2, 1], 1 + 2 * C[..., 2, 2] - tr], -1),
        ],
        axis=-2,
    )
    diag = np.stack([tr, C[..., 0, 0], C[..., 1, 1], C[..., 2, 2]], -1)
    k = np.argmax(diag, axis=-1)
    q = np.take_along_axis(cand, k[..., None, None], axis=-2)[..., 0, :]
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return q * np.where(q[..., :1] < 0, -1.0, 1.0)


def rotvec_to_quat(r):
    """Rotation vector -> unit quaternion (:func:`fednav.core.kernels.rotvec_to_quat_s`,
    the series form for tiny angles)."""
    return _rows(kernels.rotvec_to_quat_rows, r, 3, 4)


def quat_to_rotvec(q):
    """Unit quaternion -> rotation vector with angle in [0, pi]
    (:func:`fednav.core.kernels.quat_to_rotvec_s`)."""
    return _rows(kernels.quat_to_rotvec_rows, q, 4, 3)


def rotvec_to_dcm(r):
    """Rotation vector -> DCM (Rodrigues' formula)."""
    return quat_to_dcm(rotvec_to_quat(r))


def dcm_to_rotvec(C):
    """DCM -> rotation vector [rad] (:func:`fednav.core.kernels.dcm_to_rotvec`)."""
    C = np.asarray(C, dtype=float)
    flat = np.ascontiguousarray(C.reshape(-1, 3, 3))
    out = np.empty((len(flat), 3))
    kernels.dcm_to_rotvec_rows(flat, out)
    return out.reshape(C.shape[:-2] + (3,))


def euler_to_quat(euler):
    """Euler ``[pitch, roll, heading]`` -> q_b^n."""
    return dcm_to_quat(euler_to_dcm(euler))


def quat_to_euler(q):
    """q_b^n -> Euler ``[pitch, roll, heading]``."""
    return dcm_to_euler(quat_to_dcm(q))


def misalignment_dcm(phi):
    """Exact C_n^n' for platform error angles ``phi`` (rotation by ``-phi``)."""
    return rotvec_to_dcm(-np.asarray(phi, dtype=float))


def apply_misalignment(C, phi):
    """Computed attitude ``C_hat = C_n^n'(phi) @ C`` for a true attitude ``C``."""
    return misalignment_dcm(phi) @ np.asarray(C, dtype=float)


def misalignment(C_true, C_computed):
    """Platform error angles ``phi`` such that ``C_computed = exp(-[phi x]) C_true``."""
    Ct = np.asarray(C_true, dtype=float)
    return -dcm_to_rotvec(np.asarray(C_computed) @ np.swapaxes(Ct, -1, -2))


def euler_difference(e1, e2):
    """``e1 - e2`` for Euler ``[pitch, roll, heading]``, roll and heading wrapped to +-pi."""
    d = np.asarray(e1, dtype=float) - np.asarray(e2, dtype=float)
    return np.concatenate([d[..., :1], wrap_pi(d[..., 1:])], axis=-1)


def euler_error_jacobian(euler):
    """d(Euler error)/d(phi): Euler ``[pitch, roll, heading]`` of ``C_hat`` minus that of ``C``.

    For ``C_hat = (I - [phi x]) C`` (first order)::

        d_pitch   = -cos(psi) phiE + sin(psi) phiN
        d_roll    = -(sin(psi) phiE + cos(psi) phiN) / cos(theta)
        d_heading =  phiU - tan(theta) (sin(psi) phiE + cos(psi) phiN)

    These are paper 002's eq. 3 (rows reordered); shape (..., 3, 3).
    """
    e = np.asarray(euler, dtype=float)
    if e.ndim == 1:  # one attitude: plain floats, no stacking
        s, c = math.sin(e[2]), math.cos(e[2])
        ct, tt = math.cos(e[0]), math.tan(e[0])
        return np.array([[-c, s, 0.0], [-s / ct, -c / ct, 0.0], [-tt * s, -tt * c, 1.0]])
    th, psi = e[..., 0], e[..., 2]
    s, c, ct, tt = np.sin(psi), np.cos(psi), np.cos(th), np.tan(th)
    z = np.zeros_like(s)
    one = np.ones_like(s)
    return np.stack(
        [
            np.stack([-c, s, z], -1),
            np.stack([-s / ct, -c / ct, z], -1),
            np.stack([-tt * s, -tt * c, one], -1),
        ],
        -2,
    )
