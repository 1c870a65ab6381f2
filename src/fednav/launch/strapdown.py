"""Strapdown inertial navigation in the launch inertial frame (numba, IMU rate).

LI is inertial, so the mechanization has no Earth-rate, transport-rate or Coriolis terms
(compare the ENU core, :mod:`fednav.ins.strapdown`).  Per IMU sample ``k`` with body
increments ``dtheta_k`` [rad], ``dv_k`` [m/s] over ``dt`` [s]:

* attitude ``q_b^li <- q_b^li * q(phi)``, ``phi = dtheta_k + dtheta_{k-1} x dtheta_k / 12``
  (two-sample coning);
* specific-force increment in LI ``dv_li = C_b^li(t_{k-1}) (dv_k + dtheta_k x dv_k / 2 +
  dtheta_k x (dtheta_k x dv_k) / 6 + (dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12)``
  (rotation compensation to second order — the second-order term is 2e-9 m/s per
  sample at a 0.4 deg/s pitch rate under 4 g of thrust, 1e-5 m/s over a burn — and
  two-sample sculling);
* velocity ``v <- v + dv_li + g_li(r_mid) dt`` with zonal gravitation at the extrapolated
  midpoint ``r + v dt / 2``;
* position ``r <- r + (v_old + v_new) dt / 2``.

The state is a flat array so the same kernel serves open-loop runs and filter loops with
feedback; a call over one filter interval also returns what the error model needs: the
summed LI specific-force increment and its integral over the interval, and the attitude,
position and velocity at the interval's middle sample.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core.kernels import coning_sculling_s, quat_mul_s, quat_to_dcm_s, rotvec_to_quat_s
from .frame import LaunchFrame, gravitation_li_xyz

STATE_SIZE = 17  # q (4), v (3), r (3), dtheta_prev (3), dv_prev (3), has_prev
#: Interval summary: dv_li sum (3), q at the middle sample (4), r there (3), v there (3),
#: and the double integral of the LI specific force over the interval (3) [m].
AUX_SIZE = 16


@numba.njit(cache=True)
def _run(state, dtheta, dv, dt, r0, Ce, degree, out_q, out_v, out_r, aux):
    n = dtheta.shape[0]
    record = out_q.shape[0] == n
    q0, q1, q2, q3 = state[0], state[1], state[2], state[3]
    vx, vy, vz = state[4], state[5], state[6]
    rx, ry, rz = state[7], state[8], state[9]
    ax0, ay0, az0 = state[10], state[11], state[12]
    bx0, by0, bz0 = state[13], state[14], state[15]
    has_prev = state[16] > 0.5
    sx = sy = sz = 0.0
    dx = dy = dz = 0.0
    mid = n // 2
    for k in range(n):
        if k == mid and aux.shape[0] > 0:
            aux[3], aux[4], aux[5], aux[6] = q0, q1, q2, q3
            aux[7], aux[8], aux[9] = rx, ry, rz
            aux[10], aux[11], aux[12] = vx, vy, vz
        ax, ay, az = dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]
        bx, by, bz = dv[k, 0], dv[k, 1], dv[k, 2]
        # Coning and sculling with the previous sample.
        px, py, pz, cx, cy, cz = coning_sculling_s(ax, ay, az, bx, by, bz, ax0, ay0, az0,
                                                   bx0, by0, bz0, has_prev)
        # Rotation compensation to second order: dv + a x dv / 2 + a x (a x dv) / 6.
        tx = ay * bz - az * by
        ty = az * bx - ax * bz
        tz = ax * by - ay * bx
        ux = bx + 0.5 * tx + (ay * tz - az * ty) / 6.0 + cx
        uy = by + 0.5 * ty + (az * tx - ax * tz) / 6.0 + cy
        uz = bz + 0.5 * tz + (ax * ty - ay * tx) / 6.0 + cz
        # Rotate into LI with the attitude at the start of the interval.
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = quat_to_dcm_s(q0, q1, q2, q3)
        wx = c00 * ux + c01 * uy + c02 * uz
        wy = c10 * ux + c11 * uy + c12 * uz
        wz = c20 * ux + c21 * uy + c22 * uz
        dx += (sx + 0.5 * wx) * dt
        dy += (sy + 0.5 * wy) * dt
        dz += (sz + 0.5 * wz) * dt
        sx += wx
        sy += wy
        sz += wz
        gx, gy, gz = gravitation_li_xyz(rx + 0.5 * dt * vx, ry + 0.5 * dt * vy,
                                        rz + 0.5 * dt * vz, r0, Ce, degree)
        nvx = vx + wx + gx * dt
        nvy = vy + wy + gy * dt
        nvz = vz + wz + gz * dt
        rx += 0.5 * dt * (vx + nvx)
        ry += 0.5 * dt * (vy + nvy)
        rz += 0.5 * dt * (vz + nvz)
        vx, vy, vz = nvx, nvy, nvz
        # Attitude: q * q(phi).
        e0, e1, e2, e3 = rotvec_to_quat_s(px, py, pz)
        n0, n1, n2, n3 = quat_mul_s(q0, q1, q2, q3, e0, e1, e2, e3)
        nn = 1.0 / math.sqrt(n0 * n0 + n1 * n1 + n2 * n2 + n3 * n3)
        q0, q1, q2, q3 = n0 * nn, n1 * nn, n2 * nn, n3 * nn
        ax0, ay0, az0 = ax, ay, az
        bx0, by0, bz0 = bx, by, bz
        has_prev = True
        if record:
            out_q[k, 0], out_q[k, 1], out_q[k, 2], out_q[k, 3] = q0, q1, q2, q3
            out_v[k, 0], out_v[k, 1], out_v[k, 2] = vx, vy, vz
            out_r[k, 0], out_r[k, 1], out_r[k, 2] = rx, ry, rz
    if aux.shape[0] > 0:
        aux[0], aux[1], aux[2] = sx, sy, sz
        aux[13], aux[14], aux[15] = dx, dy, dz
    state[0], state[1], state[2], state[3] = q0, q1, q2, q3
    state[4], state[5], state[6] = vx, vy, vz
    state[7], state[8], state[9] = rx, ry, rz
    state[10], state[11], state[12] = ax0, ay0, az0
    state[13], state[14], state[15] = bx0, by0, bz0
    state[16] = 1.0 if has_prev else 0.0


_NO_Q = np.empty((0, 4))
_NO_3 = np.empty((0, 3))
_NO_AUX = np.empty(0)


class LaunchStrapdown:
    """SINS in LI: attitude quaternion q_b^li (scalar first), velocity and position in LI.

    ``q0``, ``v0`` [m/s], ``r0`` [m] initial state; ``dt`` IMU period [s] (default 0.02 s,
    the paper's SINS period); ``frame`` gives the gravitation model.
    """

    def __init__(self, frame: LaunchFrame, q0, v0, r0, dt: float = 0.02):
        self.frame = frame
        self.dt = float(dt)
        self.state = np.zeros(STATE_SIZE)
        q = np.asarray(q0, dtype=float)
        self.state[0:4] = q / np.linalg.norm(q)
        self.state[4:7] = v0
        self.state[7:10] = r0
        self._consts = (np.ascontiguousarray(frame.r0_eci), np.ascontiguousarray(
            frame.C_eci_li), int(frame.degree))

    @property
    def q(self) -> np.ndarray:
        return self.state[0:4].copy()

    @property
    def v(self) -> np.ndarray:
        return self.state[4:7].copy()

    @property
    def r(self) -> np.ndarray:
        return self.state[7:10].copy()

    @staticmethod
    def _check(dtheta, dv):
        dtheta = np.ascontiguousarray(dtheta, dtype=float)
        dv = np.ascontiguousarray(dv, dtype=float)
        n = dtheta.shape[0]
        if dtheta.shape != (n, 3) or dv.shape != (n, 3):
            raise ValueError(f"LaunchStrapdown: dtheta and dv must both be (N, 3), got "
                             f"{dtheta.shape} and {dv.shape}")
        return dtheta, dv

    def run(self, dtheta, dv) -> dict[str, np.ndarray]:
        """Integrate IMU increments (N, 3); returns q, v, r after every sample."""
        dtheta, dv = self._check(dtheta, dv)
        n = dtheta.shape[0]
        out = {"q": np.empty((n, 4)), "v": np.empty((n, 3)), "r": np.empty((n, 3))}
        _run(self.state, dtheta, dv, self.dt, *self._consts, out["q"], out["v"], out["r"],
             _NO_AUX)
        self._finite()
        return out

    def interval(self, dtheta, dv) -> np.ndarray:
        """Integrate one filter interval without recording; returns the ``AUX_SIZE`` summary
        (summed LI specific-force increment, q, r and v at the middle sample, and the
        double integral of the LI specific force)."""
        aux = np.empty(AUX_SIZE)
        _run(self.state, dtheta, dv, self.dt, *self._consts, _NO_Q, _NO_3, _NO_3, aux)
        self._finite()
        return aux

    def _finite(self):
        if not math.isfinite(self.state.sum()):
            raise FloatingPointError("LaunchStrapdown: navigation state became non-finite")
