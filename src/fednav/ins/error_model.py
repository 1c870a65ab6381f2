"""SINS error-state model (18 states, ENU) for the error-state (indirect) filters.

State, in SI inside this module::

    0:3   phi      platform error angles phiE, phiN, phiU [rad] (C_hat = exp(-[phi x]) C)
    3:6   dv       velocity error vE, vN, vU, computed minus true [m/s]
    6:9   dp       position error east, north, up, computed minus true [m]
    9:12  eps_c    gyro constant drift, body axes [rad/s]
    12:15 eps_r    gyro first-order Gauss-Markov drift, body axes [rad/s]
    15:18 nabla    accelerometer bias, body axes [m/s^2] (Gauss-Markov; constant if tau = inf)

This is paper 002's state (phi, dVE, dVN, dL, dlambda, eps_c, eps_r, nabla_c) extended by
the vertical channel (dvU, dh) and with position in metres, the paper-004 18-state layout.
Optional blocks (IMU scale factors, Gauss–Markov GNSS and velocity-sensor errors) follow state 17
when a system selects them: :mod:`fednav.ins.states` (:class:`~fednav.ins.states.
StateLayout`).
With a barometric damping loop in the mechanization the loop terms appear in F, so the
filter knows the vertical channel is held.

Filters see the state in *filter units* ``x_f = x_SI / SCALE`` (arc-minutes, m/s, m,
deg/h, mg): covariance entries are then O(1e-4 .. 1e2) instead of spanning 1e-15 .. 1e2,
which keeps Cholesky factors and the information-form fusion well conditioned.

Two propagation models share the same physics:

* :meth:`ErrorProcess.F` — the classic linear model (Qin Yongyuan / Titterton);
* :meth:`ErrorProcess.transition` — the exact nonlinear model for large errors:
  ``dE/dt = [(C_hat eps - w_in_hat) x] E + E [w_in x]`` for the error rotation
  ``E = C_n^n'``, velocity error ``(I - E^T) f_hat + E^T C_hat nabla`` + Coriolis and gravity
  differences, position from the latitude/longitude-rate differences and the rates of the
  metres-per-radian scales at the INS's position.  This is paper
  000's eq. 40 written with a rotation matrix instead of Euler platform angles (no
  singularity).  The test suite checks that F is its Jacobian at zero error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from ..core import earth, units
from ..core.kernels import (
    dcm_to_rotvec,
    matmul_sparse,
    rodrigues_coefficients,
    rodrigues_entries,
    rodrigues_series,
)
from ..core.kernels import quat_to_dcm as _quat_to_dcm
from .states import CORE, StateLayout

N_STATES = 18
PHI, DV, DP, EPS_C, EPS_R, NABLA = (slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12),
                                     slice(12, 15), slice(15, 18))
STATE_NAMES = ("phiE", "phiN", "phiU", "dvE", "dvN", "dvU", "dE", "dN", "dU",
               "eps_cx", "eps_cy", "eps_cz", "eps_rx", "eps_ry", "eps_rz",
               "nabla_x", "nabla_y", "nabla_z")
#: SI value of one filter unit per state (see module docstring).
SCALE = np.r_[np.full(3, units.ARCMIN), np.ones(6), np.full(6, units.deg_per_h(1.0)),
              np.full(3, units.milli_g(1.0))]


@dataclass(frozen=True)
class ImuNoiseModel:
    """What the filter assumes about the IMU (SI units, per axis, isotropic).

    gyro_arw [rad/sqrt(s)], accel_vrw [m/s/sqrt(s)]; bias random walks gyro_bias_rw
    [rad/s/sqrt(s)] and accel_bias_rw [m/s^2/sqrt(s)] (on the constant-bias states);
    Markov sigma and tau for the gyro
    drift [rad/s, s] and accelerometer bias [m/s^2, s] (tau = inf: constant bias).
    """

    gyro_arw: float = 0.0
    accel_vrw: float = 0.0
    gyro_bias_rw: float = 0.0
    accel_bias_rw: float = 0.0
    gyro_markov_sigma: float = 0.0
    gyro_markov_tau: float = np.inf
    accel_markov_sigma: float = 0.0
    accel_markov_tau: float = np.inf


# ----------------------------------------------------------------- nonlinear transition
# The sigma points (or quadrature points) are propagated together: every array below
# holds one point per column, and every stage is a loop over the points with the same
# scalar arithmetic the model would make point by point.  Independent iterations keep
# the floating-point units busy (one point alone is a long chain of dependent operations)
# and let the compiler use SIMD; each point's result is bit-for-bit that of the
# point-by-point evaluation, because no operation is reordered or contracted.
_VEC = {"cache": True, "error_model": "numpy"}  # no zero-division branch: loops vectorise


@numba.njit(inline="always")
def _dcm_entries(r0, r1, r2, s, c, out, i):
    """Rodrigues' formula (:func:`fednav.core.kernels.rodrigues_entries`) into column ``i`` of
    ``out`` (9, P), row-major."""
    e = rodrigues_entries(r0, r1, r2, s, c)
    for k in range(9):
        out[k, i] = e[k]


@numba.njit(**_VEC)
def _rotvec_to_dcm_cols(W, row, h, out):
    """``rotvec_to_dcm(h * W[row:row + 3, i])`` for every column ``i`` into ``out`` (9, P);
    the same series below 1e-3 rad, taken without a branch when every point is there."""
    P = W.shape[1]
    small = True
    for i in range(P):
        r0, r1, r2 = h * W[row, i], h * W[row + 1, i], h * W[row + 2, i]
        if not r0 * r0 + r1 * r1 + r2 * r2 < 1e-6:
            small = False
    if small:
        for i in range(P):
            r0, r1, r2 = h * W[row, i], h * W[row + 1, i], h * W[row + 2, i]
            s, c = rodrigues_series(r0 * r0 + r1 * r1 + r2 * r2)
            _dcm_entries(r0, r1, r2, s, c, out, i)
        return
    for i in range(P):
        r0, r1, r2 = h * W[row, i], h * W[row + 1, i], h * W[row + 2, i]
        s, c = rodrigues_coefficients(r0 * r0 + r1 * r1 + r2 * r2)
        _dcm_entries(r0, r1, r2, s, c, out, i)


@numba.njit(inline="always")
def _mul_cols(A, B, out):
    """out = A @ B per column (row-major 3x3 matrices, one per column of (9, P))."""
    for a in range(3):
        for b in range(3):
            for i in range(out.shape[1]):
                out[3 * a + b, i] = (A[3 * a, i] * B[b, i] + A[3 * a + 1, i] * B[3 + b, i]
                                     + A[3 * a + 2, i] * B[6 + b, i])


@numba.njit(**_VEC)
def _rotate_cols(E, D, row, h, R, tmp):
    """E <- exp(h [wl x]) E exp(h [wr x]) per column: E (9, P) row-major 3x3, wl and wr
    in rows row:row + 3 and row + 3:row + 6 of D; R, tmp (9, P) scratch."""
    _rotvec_to_dcm_cols(D, row, h, R)
    _mul_cols(R, E, tmp)
    _rotvec_to_dcm_cols(D, row + 3, h, R)
    _mul_cols(tmp, R, E)


@numba.njit(cache=True)
def _nominal_terms(p):
    """Terms of ``_rates`` that depend on the nominal only: w_ie0 + w_en0 (3),
    (2 w_ie0 + w_en0) x v0 (3), cos(lat0), sin(lat0),
    1 / (rm + h0)."""
    lat0, h0, rm, rn = p[0], p[1], p[8], p[9]
    v0e, v0n, v0u = p[2], p[3], p[4]
    om = earth.OMEGA_IE
    c0, s0 = np.cos(lat0), np.sin(lat0)
    wie = np.array([0.0, om * c0, om * s0])
    wen = np.array([-v0n / (rm + h0), v0e / (rn + h0), v0e * s0 / c0 / (rn + h0)])
    a = 2.0 * wie + wen
    out = np.empty(9)
    out[0:3] = wie + wen
    out[3] = a[1] * v0u - a[2] * v0n
    out[4] = a[2] * v0e - a[0] * v0u
    out[5] = a[0] * v0n - a[1] * v0e
    out[6] = c0
    out[7] = s0
    out[8] = 1.0 / (rm + h0)
    return out


_gravity_of_sin2 = numba.njit(inline="always", error_model="numpy")(earth.gravity_of_sin2)


@numba.njit(inline="always")
def _cos_sin_series(d):
    """cos and sin of ``d`` by their series: error under 1e-20 below 1e-3 rad."""
    d2 = d * d
    return (1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 / 720.0)),
            d * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 / 5040.0))))


@numba.njit(**_VEC)
def _true_lat_cos_sin(x, k0, cs):
    """cos and sin of the true latitude lat0 - dN / (rm + h0) of every column of ``x``
    into ``cs`` (2, P), from those of lat0: the offset's cosine and sine by their series
    below 1e-3 rad (a few kilometres, what sigma points need), else by the library; the
    loop has no branch when every point is below."""
    P = x.shape[1]
    c0, s0, k8 = k0[6], k0[7], k0[8]
    small = True
    for i in range(P):
        if not abs(x[7, i] * k8) < 1e-3:
            small = False
    if small:
        for i in range(P):
            cd, sd = _cos_sin_series(x[7, i] * k8)
            cs[0, i] = c0 * cd + s0 * sd
            cs[1, i] = s0 * cd - c0 * sd
        return
    for i in range(P):
        d = x[7, i] * k8
        cd, sd = _cos_sin_series(d) if abs(d) < 1e-3 else (np.cos(d), np.sin(d))
        cs[0, i] = c0 * cd + s0 * sd
        cs[1, i] = s0 * cd - c0 * sd


@numba.njit(**_VEC)
def _rates(x, E, p, C0, k0, cs, out):
    """Derivatives of every column of ``x`` (n, P; SI) with error rotations ``E`` (9, P):
    the non-attitude states into rows 3:n of ``out`` (n + 6, P), the attitude rotation
    rates into rows n:n + 3 (``wl``, left of E) and n + 3:n + 6 (``wr``, right of E).
    ``p`` = [lat0, h0, vE0, vN0, vU0, fE, fN, fU, rm, rn, k1, k2, 1/tau_g, 1/tau_a, g0,
    w_b (3), f_b (3), then :meth:`~fednav.ins.states.StateLayout.model_vector` without its
    Qc part]; ``k0`` from :func:`_nominal_terms`; ``cs`` (2, P) scratch."""
    P, n = x.shape[1], x.shape[0]
    isg, isa = int(p[21]), int(p[22])
    h0 = p[1]
    fe, fn_, fu = p[5], p[6], p[7]
    rm, rn, k1, k2, itg, ita, g0 = p[8], p[9], p[10], p[11], p[12], p[13], p[14]
    om = earth.OMEGA_IE
    v0e, v0n, v0u = p[2], p[3], p[4]
    c0 = k0[6]
    q00, q01, q02 = C0[0, 0], C0[0, 1], C0[0, 2]
    q10, q11, q12 = C0[1, 0], C0[1, 1], C0[1, 2]
    q20, q21, q22 = C0[2, 0], C0[2, 1], C0[2, 2]
    w0, w1, w2, k3, k4, k5 = k0[0], k0[1], k0[2], k0[3], k0[4], k0[5]
    # True rates (the computed ones are in k0); true latitude lat0 - dN / (rm + h0).
    _true_lat_cos_sin(x, k0, cs)
    se = v0u / (rn + h0) - v0n * math.tan(p[0]) / (rm + h0)
    sn = v0u / (rm + h0)
    for i in range(P):
        h = h0 - x[8, i]
        ve, vn, vu = v0e - x[3, i], v0n - x[4, i], v0u - x[5, i]
        c1, s1 = cs[0, i], cs[1, i]
        irm, irn, ic1 = 1.0 / (rm + h), 1.0 / (rn + h), 1.0 / c1
        wie1, wie2 = om * c1, om * s1  # w_ie east is zero
        wen0, wen1, wen2 = -vn * irm, ve * irn, ve * s1 * ic1 * irn
        e0 = x[9, i] + x[12, i]
        e1 = x[10, i] + x[13, i]
        e2 = x[11, i] + x[14, i]
        if isg >= 0:  # the scale-factor error on the interval's body rate
            e0 += p[15] * x[isg, i]
            e1 += p[16] * x[isg + 1, i]
            e2 += p[17] * x[isg + 2, i]
        out[n, i] = q00 * e0 + q01 * e1 + q02 * e2 - w0
        out[n + 1, i] = q10 * e0 + q11 * e1 + q12 * e2 - w1
        out[n + 2, i] = q20 * e0 + q21 * e1 + q22 * e2 - w2
        out[n + 3, i] = 0.0 + wen0
        out[n + 4, i] = wie1 + wen1
        out[n + 5, i] = wie2 + wen2
        # Velocity error: (I - E^T) f + E^T C0 nabla - Coriolis difference + gravity
        # difference.
        b0, b1, b2 = x[15, i], x[16, i], x[17, i]
        if isa >= 0:  # the scale-factor error on the interval's specific force
            b0 += p[18] * x[isa, i]
            b1 += p[19] * x[isa + 1, i]
            b2 += p[20] * x[isa + 2, i]
        cn0 = q00 * b0 + q01 * b1 + q02 * b2
        cn1 = q10 * b0 + q11 * b1 + q12 * b2
        cn2 = q20 * b0 + q21 * b1 + q22 * b2
        a0, a1, a2 = fe - cn0, fn_ - cn1, fu - cn2
        a1x = 2 * 0.0 + wen0
        a1y = 2 * wie1 + wen1
        a1z = 2 * wie2 + wen2
        cor0 = k3 - (a1y * vu - a1z * vn)
        cor1 = k4 - (a1z * ve - a1x * vu)
        cor2 = k5 - (a1x * vn - a1y * ve)
        out[3, i] = fe - (E[0, i] * a0 + E[3, i] * a1 + E[6, i] * a2) - cor0
        out[4, i] = fn_ - (E[1, i] * a0 + E[4, i] * a1 + E[7, i] * a2) - cor1
        out[5, i] = (fu - (E[2, i] * a0 + E[5, i] * a1 + E[8, i] * a2) - cor2
                     - g0 + _gravity_of_sin2(s1 * s1, h) - k2 * x[8, i])
        # Position error in metres at the INS's (computed) position: dE = (RN + h0) cos(lat0)
        # dlon and dN = (RM + h0) dlat, so their rates also carry the rates of those
        # metres-per-radian scales (vU0 / (RN + h0) - vN0 tan(lat0) / (RM + h0)) dE and
        # vU0 / (RM + h0) dN.
        out[6, i] = v0e - ve * ((rn + h0) * c0) * irn * ic1 + se * x[6, i]
        out[7, i] = v0n - vn * (rm + h0) * irm + sn * x[7, i]
        out[8, i] = x[5, i] - k1 * x[8, i]
        for j in range(3):
            out[9 + j, i] = 0.0
            out[12 + j, i] = -itg * x[12 + j, i]
            out[15 + j, i] = -ita * x[15 + j, i]
        for j in range(18, n):  # the optional states: Gauss-Markov, constant or driven
            out[j, i] = -p[23 + j - 18] * x[j, i]
            drv = int(p[23 + n - 18 + j - 18])
            if drv >= 0:
                out[j, i] += x[drv, i]


@numba.njit(cache=True)
def propagate_points(X, T, nsub, p, C0, scale):
    """Propagate each row of X (filter units) over T seconds with the nonlinear model
    (midpoint rule: geometric for the attitude error rotation, RK2 for the rest)."""
    P, n = X.shape
    hs = T / nsub
    x = np.empty((n, P))
    xm = np.empty((n, P))
    d = np.empty((n + 6, P))
    E = np.empty((9, P))
    Em = np.empty((9, P))
    tmp = np.empty((9, P))
    R = np.empty((9, P))
    cs = np.empty((2, P))
    for j in range(n):
        for i in range(P):
            x[j, i] = X[i, j] * scale[j]
    k0 = _nominal_terms(p)
    _rotvec_to_dcm_cols(x, 0, -1.0, E)
    for _ in range(nsub):
        _rates(x, E, p, C0, k0, cs, d)
        for j in range(3, n):
            for i in range(P):
                xm[j, i] = x[j, i] + 0.5 * hs * d[j, i]
        Em[:, :] = E
        _rotate_cols(Em, d, n, 0.5 * hs, R, tmp)
        _rates(xm, Em, p, C0, k0, cs, d)
        for j in range(3, n):
            for i in range(P):
                x[j, i] += hs * d[j, i]
        _rotate_cols(E, d, n, hs, R, tmp)
    out = np.empty_like(X)
    C = np.empty((3, 3))
    rv = np.empty(3)
    for i in range(P):
        for a in range(3):
            for b in range(3):
                C[a, b] = E[3 * a + b, i]
        dcm_to_rotvec(C, rv)
        x[0, i], x[1, i], x[2, i] = -rv[0], -rv[1], -rv[2]
        for j in range(n):
            out[i, j] = x[j, i] / scale[j]
    return out


@numba.njit(cache=True)
def _F(p, C):
    """Continuous linear error dynamics F (SI) at the nominal ``p`` (see ``_rates``)."""
    m = (p.shape[0] - 23) // 2  # optional states (1/tau, driver column each)
    lat, h = p[0], p[1]
    ve, vn, vu = p[2], p[3], p[4]
    fe, fn, fu = p[5], p[6], p[7]
    rm, rn, k1, k2, itg, ita = p[8], p[9], p[10], p[11], p[12], p[13]
    Rm, Rn = rm + h, rn + h
    sl, cl = np.sin(lat), np.cos(lat)
    tl = sl / cl
    om = earth.OMEGA_IE
    w = np.array([0.0, om * cl, om * sl])  # w_ie
    wen = np.array([-vn / Rm, ve / Rn, ve * tl / Rn])
    win = w + wen
    a = 2.0 * w + wen
    # d(w_ie)/d(dp), d(w_en)/d(dv), d(w_en)/d(dp) with dp = [dE, dN, dU] in metres.
    dwie = np.zeros((3, 3))
    dwie[1, 1] = -om * sl / Rm
    dwie[2, 1] = om * cl / Rm
    dwv = np.zeros((3, 3))
    dwv[0, 1] = -1.0 / Rm
    dwv[1, 0] = 1.0 / Rn
    dwv[2, 0] = tl / Rn
    dwp = np.zeros((3, 3))
    dwp[0, 2] = vn / Rm**2
    dwp[1, 2] = -ve / Rn**2
    dwp[2, 1] = ve / (cl**2 * Rn * Rm)
    dwp[2, 2] = -ve * tl / Rn**2
    V = np.array([[0.0, -vu, vn], [vu, 0.0, -ve], [-vn, ve, 0.0]])
    F = np.zeros((18 + m, 18 + m))
    # Attitude: phi' = -w_in x phi + dw_in - C eps.
    F[0, 1], F[0, 2], F[1, 0], F[1, 2], F[2, 0], F[2, 1] = (
        win[2], -win[1], -win[2], win[0], win[1], -win[0])
    F[0:3, 3:6] = dwv
    F[0:3, 6:9] = dwie + dwp
    F[0:3, 9:12] = -C
    F[0:3, 12:15] = -C
    # Velocity: dv' = f x phi + C nabla - (2 w_ie + w_en) x dv + v x (2 dw_ie + dw_en) + dg.
    F[3, 1], F[3, 2], F[4, 0], F[4, 2], F[5, 0], F[5, 1] = -fu, fn, fu, -fe, -fn, fe
    F[3:6, 3:6] = V @ dwv
    F[3, 4] += a[2]
    F[3, 5] -= a[1]
    F[4, 3] -= a[2]
    F[4, 5] += a[0]
    F[5, 3] += a[1]
    F[5, 4] -= a[0]
    F[3:6, 6:9] = V @ (2.0 * dwie + dwp)
    F[5, 8] += earth.gravity_gradient_nb(lat, h) - k2
    F[5, 7] -= earth.gravity_dlat_nb(lat) / Rm
    F[3:6, 15:18] = C
    # Position (metres).
    F[6, 3] = 1.0
    F[6, 6] = vu / Rn - vn * tl / Rm  # the rate of dE's metres per radian of longitude
    F[6, 7] = ve * tl / Rm
    F[6, 8] = -ve / Rn
    F[7, 4] = 1.0
    F[7, 7] = vu / Rm  # the rate of dN's metres per radian of latitude
    F[7, 8] = -vn / Rm
    F[8, 5] = 1.0
    F[8, 8] = -k1
    for i in range(3):
        F[12 + i, 12 + i] = -itg
        F[15 + i, 15 + i] = -ita
    # Optional states: scale factors scale the body rate and specific force (ins.states).
    isg, isa = int(p[21]), int(p[22])
    for j in range(3):
        if isg >= 0:
            F[0:3, isg + j] = -C[:, j] * p[15 + j]
        if isa >= 0:
            F[3:6, isa + j] = C[:, j] * p[18 + j]
    for k in range(m):
        F[18 + k, 18 + k] = -p[23 + k]
        drv = int(p[23 + m + k])
        if drv >= 0:
            F[18 + k, drv] = 1.0
    return F


@numba.njit(cache=True)
def _Qc(p, C, q):
    """Continuous process-noise density (SI); q = [arw, vrw, gyro GM sigma, accel GM sigma,
    baro noise density, gyro bias random walk, accel bias random walk, then the layout's
    :meth:`~fednav.ins.states.StateLayout.model_vector`]."""
    k1, k2, itg, ita = p[10], p[11], p[12], p[13]
    m = (q.shape[0] - 9) // 3
    Q = np.zeros((18 + m, 18 + m))
    Q[0:3, 0:3] = q[0] ** 2 * (C @ C.T)
    Q[3:6, 3:6] = q[1] ** 2 * (C @ C.T)
    Q[5, 5] += k2**2 * q[4]
    Q[8, 8] += k1**2 * q[4]
    Q[5, 8] = k1 * k2 * q[4]
    Q[8, 5] = Q[5, 8]
    for i in range(3):
        Q[9 + i, 9 + i] = q[5] ** 2
        Q[12 + i, 12 + i] = 2.0 * q[2] ** 2 * itg
        Q[15 + i, 15 + i] = 2.0 * q[3] ** 2 * ita + q[6] ** 2
    for k in range(m):
        Q[18 + k, 18 + k] = q[9 + m + k]
    return Q


@numba.njit(cache=True)
def _discretize(p, C, q, T, scale):
    """Phi (4th-order Taylor over T/2, squared) and Qd (trapezoid), in filter units.
    (The products skip zeros in a fixed order, so the 18 states come out bit for bit the
    same whatever optional states follow them; BLAS's blocking would not: it saved 3 us of
    13 an interval.)"""
    F = _F(p, C)
    Qc = _Qc(p, C, q)
    n = F.shape[0]
    A = F * (0.5 * T)
    A2 = matmul_sparse(A, A)
    half = np.eye(n) + A + matmul_sparse(A2, np.eye(n) / 2.0 + A / 6.0 + A2 / 24.0)
    Phi = matmul_sparse(half, half)
    Qd = 0.5 * (matmul_sparse(Phi, matmul_sparse(Qc, Phi.T)) + Qc) * T
    for i in range(n):
        for j in range(n):
            Phi[i, j] *= scale[j] / scale[i]
            Qd[i, j] /= scale[i] * scale[j]
    return Phi, 0.5 * (Qd + Qd.T)


@numba.njit(cache=True)
def white_qd(Phi, noise, T, scale):
    """The part of Qd (filter units) that the IMU's white noise makes — ARW and VRW,
    ``noise[0]``, ``noise[1]`` (the vector of :func:`model_constants`) — by the same
    trapezoid as :func:`_discretize`: ``0.5 (Phi Qc_w Phi' + Qc_w) T``, ``Qc_w`` the white
    blocks of ``_Qc`` (``C C' = I``).  What an online adaptation of the white noise scales
    (:class:`fednav.navigator.system.QAdaptationConfig`)."""
    n = Phi.shape[0]
    q = np.zeros(n)
    for i in range(3):
        q[i] = noise[0] ** 2 / scale[i] ** 2
        q[3 + i] = noise[1] ** 2 / scale[3 + i] ** 2
    A = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            A[i, j] = Phi[i, j] * q[j]
    Qw = A @ Phi.T
    for i in range(n):
        Qw[i, i] += q[i]
    Qw *= 0.5 * T
    return 0.5 * (Qw + Qw.T)


@dataclass
class Nominal:
    """INS (computed) navigation over one filter interval, at its midpoint.

    lat [rad], h [m], vel ENU [m/s], C = C_b^n (computed), fn = mean specific force in
    the navigation frame [m/s^2], wb = mean body rate [rad/s] (what a gyro scale-factor
    error scales; zero when not given).
    """

    lat: float
    h: float
    vel: np.ndarray
    C: np.ndarray
    fn: np.ndarray
    wb: np.ndarray | None = None


def model_constants(noise: ImuNoiseModel, baro_gains=(0.0, 0.0), baro_q: float = 0.0,
                    layout: StateLayout = CORE):
    """What the compiled model functions read besides the nominal point: baro loop gains
    k1, k2, inverse Markov times 1/tau_g, 1/tau_a [1/s] (0 for a constant bias) and the
    noise vector of ``_Qc`` (ending with the ``layout``'s
    :meth:`~fednav.ins.states.StateLayout.model_vector`)."""
    itg = 0.0 if np.isinf(noise.gyro_markov_tau) else 1.0 / noise.gyro_markov_tau
    ita = 0.0 if np.isinf(noise.accel_markov_tau) else 1.0 / noise.accel_markov_tau
    vec = np.r_[noise.gyro_arw, noise.accel_vrw, noise.gyro_markov_sigma,
                noise.accel_markov_sigma, float(baro_q), noise.gyro_bias_rw,
                noise.accel_bias_rw, layout.model_vector()]
    return float(baro_gains[0]), float(baro_gains[1]), itg, ita, vec


class ErrorProcess:
    """The error model over one interval ``T``: Phi, Qd and the nonlinear transition.

    Everything returned is in filter units (see :data:`SCALE`; ``layout``: the optional
    states, :class:`~fednav.ins.states.StateLayout`, whose units :attr:`scale` holds).
    """

    def __init__(self, nom: Nominal, T: float, noise: ImuNoiseModel,
                 baro_gains=(0.0, 0.0), baro_q: float = 0.0, nsub: int = 2,
                 layout: StateLayout = CORE):
        self._set_model(T, noise, baro_gains, baro_q, nsub, layout)
        v, f = np.asarray(nom.vel, float), np.asarray(nom.fn, float)
        C0 = np.ascontiguousarray(nom.C, dtype=float)
        wb = np.zeros(3) if nom.wb is None else np.asarray(nom.wb, dtype=float)
        params = _nominal_params(float(nom.lat), float(nom.h), v[0], v[1], v[2], f[0], f[1],
                                 f[2], self.k1, self.k2, self.itg, self.ita, wb, C0.T @ f,
                                 self._aug)
        self._set_nominal(params, C0, *_discretize(params, C0, self._noise, self.T,
                                                   self.scale), nom)

    @classmethod
    def of_interval(cls, s0, s1, dv_sum, T: float, noise: ImuNoiseModel,
                    baro_gains=(0.0, 0.0), baro_q: float = 0.0, nsub: int = 2,
                    dtheta_sum=None, layout: StateLayout = CORE):
        """The model linearised at the middle of an INS interval (see
        :func:`interval_process`): nominal point, Phi and Qd in one compiled call."""
        self = cls.__new__(cls)
        self._set_model(T, noise, baro_gains, baro_q, nsub, layout)
        dth = np.zeros(3) if dtheta_sum is None else np.asarray(dtheta_sum, dtype=float)
        self._set_nominal(*interval_model(np.asarray(s0, dtype=float), np.asarray(s1, dtype=float),
                                     np.asarray(dv_sum, dtype=float), dth, self.T, self.k1,
                                     self.k2, self.itg, self.ita, self._noise, self.scale))
        return self

    def _set_model(self, T, noise, baro_gains, baro_q, nsub, layout) -> None:
        self.T, self.noise, self.nsub = float(T), noise, int(nsub)
        self.baro_q = float(baro_q)
        self.layout = layout
        self.scale = layout.scale(SCALE)
        self.k1, self.k2, self.itg, self.ita, self._noise = model_constants(
            noise, baro_gains, baro_q, layout)
        self._aug = _layout_part(self._noise)

    def _set_nominal(self, params, C0, Phi, Qd, nom: Nominal | None = None) -> None:
        self._params, self._C0, self.Phi, self.Qd = params, C0, Phi, Qd
        self.rm, self.rn = params[8], params[9]
        self.nom = nom if nom is not None else Nominal(
            lat=params[0], h=params[1], vel=params[2:5].copy(), C=C0, fn=params[5:8].copy())

    @property
    def Qd_white(self) -> np.ndarray:
        """The part of ``Qd`` the IMU's white noise makes (:func:`white_qd`)."""
        return white_qd(self.Phi, self._noise, self.T, self.scale)

    # ------------------------------------------------------------------ SI models
    def F_si(self) -> np.ndarray:
        """Continuous-time linear error dynamics (SI units)."""
        return _F(self._params, self._C0)

    def Qc_si(self) -> np.ndarray:
        """Continuous process-noise spectral density (SI units)."""
        return _Qc(self._params, self._C0, self._noise)

    # ------------------------------------------------------------ filter interface
    def transition(self, X: np.ndarray) -> np.ndarray:
        """Nonlinear propagation of state rows ``X`` (S, n) in filter units over T."""
        X = np.ascontiguousarray(np.atleast_2d(X), dtype=float)
        return propagate_points(X, self.T, self.nsub, self._params, self._C0, self.scale)

    def linear_transition(self, X: np.ndarray) -> np.ndarray:
        """``Phi @ x`` for each row of X (filter units)."""
        return np.atleast_2d(X) @ self.Phi.T


def to_si(x):
    """Filter units -> SI for a state vector (or rows of vectors)."""
    return np.asarray(x) * SCALE


def cov_to_si(P):
    """Filter units -> SI for a covariance."""
    return np.asarray(P) * np.outer(SCALE, SCALE)


def from_si(x):
    """SI -> filter units for a state vector."""
    return np.asarray(x) / SCALE


def interval_process(s0, s1, dv_sum, T: float, noise: ImuNoiseModel, baro_gains=(0.0, 0.0),
                     baro_q: float = 0.0, nsub: int = 2, dtheta_sum=None,
                     layout: StateLayout = CORE) -> ErrorProcess:
    """The error model over one filter interval of the strapdown INS, linearised at the
    interval's midpoint: ``s0``, ``s1`` the INS state (:mod:`fednav.ins.strapdown` layout)
    at its start and end, ``dv_sum`` and ``dtheta_sum`` the compensated velocity and angle
    increments summed over it (body, m/s and rad; the angles matter to a gyro
    scale-factor state only).  One compiled call builds the nominal point, Phi and Qd."""
    return ErrorProcess.of_interval(s0, s1, dv_sum, T, noise, baro_gains, baro_q, nsub,
                                    dtheta_sum, layout)


@numba.njit(cache=True)
def _layout_part(noise):
    """The part of the noise vector (:func:`model_constants`) the nominal point carries:
    the optional scale-factor blocks' starts, every optional state's 1/tau and driver
    column."""
    m = (noise.shape[0] - 9) // 3
    return np.concatenate((noise[7:9 + m], noise[9 + 2 * m:]))


@numba.njit(cache=True)
def _nominal_params(lat, h, ve, vn, vu, fe, fn, fu, k1, k2, itg, ita, wb, fb, aug):
    """The nominal-point vector the compiled model functions read (see ``_rates``)."""
    rm, rn = earth.radii_nb(lat)
    out = np.empty(23 + aug.shape[0] - 2)
    out[0:15] = np.array([lat, h, ve, vn, vu, fe, fn, fu, rm, rn, k1, k2, itg, ita,
                          earth.gravity_nb(lat, h)])
    out[15:18] = wb
    out[18:21] = fb
    out[21:] = aug
    return out


@numba.njit(cache=True)
def interval_model(s0, s1, dv_sum, dth_sum, T, k1, k2, itg, ita, noise, scale):
    """Nominal parameters, C_b^n, Phi and Qd of one INS interval (see interval_process)."""
    qm = s0[0:4] + s1[0:4]
    Cm = _quat_to_dcm(qm / np.sqrt(qm @ qm))
    lat = 0.5 * (s0[7] + s1[7])
    h = 0.5 * (s0[9] + s1[9])
    fb = dv_sum / T
    f = Cm @ dv_sum / T
    params = _nominal_params(lat, h, 0.5 * (s0[4] + s1[4]), 0.5 * (s0[5] + s1[5]),
                             0.5 * (s0[6] + s1[6]), f[0], f[1], f[2], k1, k2, itg, ita,
                             dth_sum / T, fb, _layout_part(noise))
    Phi, Qd = _discretize(params, Cm, noise, T, scale)
    return params, Cm, Phi, Qd


def apply_feedback(ins, dx, scale=SCALE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Remove the estimated errors ``dx`` (filter units of ``scale``) from the INS ``ins``;
    returns the gyro [rad/s] and accelerometer [m/s^2] corrections to add to the IMU
    compensation and the optional states' (SI, zero for the 18; to add to their totals,
    :mod:`fednav.ins.states`)."""
    d = np.asarray(dx) * scale
    ins.correct(d[PHI], d[DV], d[DP])
    opt = d.copy()
    opt[:18] = 0.0
    return d[EPS_C] + d[EPS_R], d[NABLA], opt
