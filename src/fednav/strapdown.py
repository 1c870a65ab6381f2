"""Strapdown inertial navigation in the ENU frame at IMU rate (numba).

Inputs are body angle increments ``dtheta`` [rad] and velocity increments ``dv`` [m/s]
over each IMU interval ``dt`` [s] (body right-forward-up).  Per sample:

* attitude: rotation vector with the two-sample (current + previous) coning correction
  ``phi = dtheta_k + dtheta_{k-1} x dtheta_k / 12``; the navigation frame rotates by
  ``omega_in^n dt`` evaluated at the interval midpoint;
* velocity: rotation compensation ``dtheta x dv / 2``, two-sample sculling
  ``(dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12``, frame-rotation term, Coriolis
  and normal gravity at the extrapolated midpoint;
* position: trapezoidal integration of latitude, longitude and height.

The vertical channel can be damped by a barometric height reference through a second-
or third-order loop (:class:`BaroLoop`).  The loop is driven by the height difference
INS - baro formed at each baro sample and held until the next one (holding the baro
height itself would inject the climb rate times the baro period as an error).  The state
lives in a flat float array so the same compiled kernel serves open-loop runs and filter
loops with feedback.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from . import attitude, earth
from .kernels import quat_mul as _qmul
from .kernels import quat_to_dcm as _q2dcm
from .kernels import rotvec_to_quat as _rv2q

# Layout of the flat state array.
_Q, _V, _P, _DTH, _DV, _VPREV, _HAS_PREV, _BARO_INT, _BARO_DH = (
    slice(0, 4), slice(4, 7), slice(7, 10), slice(10, 13), slice(13, 16), slice(16, 19), 19, 20,
    21,
)
STATE_SIZE = 22
#: Public views into :attr:`Strapdown.state`: quaternion q_b^n, ENU velocity, lat/lon/h.
STATE_Q, STATE_VEL, STATE_LLA = _Q, _V, _P


@dataclass(frozen=True)
class BaroLoop:
    """Barometric damping of the vertical channel.

    ``order`` 2 or 3; ``time_constant`` [s]: all loop poles are placed at -1/time_constant
    (the 2g/R instability of the free vertical channel is cancelled in the gain).
    """

    time_constant: float = 10.0
    order: int = 3

    def gains(self, lat: float = 0.0) -> np.ndarray:
        if self.order not in (2, 3):
            raise ValueError(f"BaroLoop: order must be 2 or 3, got {self.order}")
        if self.time_constant <= 0:
            raise ValueError("BaroLoop: time_constant must be positive")
        a = 1.0 / self.time_constant
        rm, rn = earth.radii(lat)
        wss = 2.0 * earth.gravity(lat, 0.0) / np.sqrt(rm * rn)
        if self.order == 2:
            return np.array([2 * a, a * a + wss, 0.0])
        return np.array([3 * a, 3 * a * a + wss, a**3])


@numba.njit(cache=True)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


@numba.njit(cache=True)
def _run(state, dtheta, dv, dt, h_ref, gains, out_q, out_v, out_p):
    n = dtheta.shape[0]
    record = out_q.shape[0] == n
    q = state[0:4].copy()
    v = state[4:7].copy()
    p = state[7:10].copy()
    dth_prev = state[10:13].copy()
    dv_prev = state[13:16].copy()
    v_prev = state[16:19].copy()
    has_prev = state[19] > 0.5
    b_int = state[20]
    dh = state[21]
    om = earth.OMEGA_IE
    for k in range(n):
        dth = dtheta[k]
        dvk = dv[k]
        lat, lon, h = p[0], p[1], p[2]
        # Midpoint extrapolation of velocity and position.
        if has_prev:
            vm = v + 0.5 * (v - v_prev)
        else:
            vm = v.copy()
        rm, rn = earth.radii_nb(lat)
        lat_m = lat + 0.5 * dt * vm[1] / (rm + h)
        h_m = h + 0.5 * dt * vm[2]
        rm, rn = earth.radii_nb(lat_m)
        sl, cl = np.sin(lat_m), np.cos(lat_m)
        w_ie = np.array([0.0, om * cl, om * sl])
        w_en = np.array([-vm[1] / (rm + h_m), vm[0] / (rn + h_m), vm[0] * sl / cl / (rn + h_m)])
        w_in = w_ie + w_en
        gmag = earth.gravity_nb(lat_m, h_m)
        # Coning and sculling (current + previous sample).
        if has_prev:
            phi = dth + _cross(dth_prev, dth) / 12.0
            scul = (_cross(dth_prev, dvk) + _cross(dv_prev, dth)) / 12.0
        else:
            phi = dth.copy()
            scul = np.zeros(3)
        dvb = dvk + 0.5 * _cross(dth, dvk) + scul
        C = _q2dcm(q)
        dvn = C @ dvb
        zeta = w_in * dt
        dvn = dvn - 0.5 * _cross(zeta, dvn)
        acc = -_cross(2.0 * w_ie + w_en, vm)
        acc[2] -= gmag
        if not np.isnan(h_ref[k]):
            dh = h - h_ref[k]
        acc[2] -= gains[1] * dh + b_int
        b_int += gains[2] * dh * dt
        v_new = v + dvn + acc * dt
        # Position: trapezoid on velocity.
        h_new = h + 0.5 * dt * (v[2] + v_new[2]) - gains[0] * dh * dt
        h_a = 0.5 * (h + h_new)
        lat_new = lat + 0.5 * dt * (v[1] + v_new[1]) / (rm + h_a)
        lat_a = 0.5 * (lat + lat_new)
        rm2, rn2 = earth.radii_nb(lat_a)
        lon_new = lon + 0.5 * dt * (v[0] + v_new[0]) / ((rn2 + h_a) * np.cos(lat_a))
        # Attitude: body rotation then navigation-frame rotation.
        q = _qmul(_rv2q(-zeta), _qmul(q, _rv2q(phi)))
        q = q / np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
        v_prev = v
        v = v_new
        p = np.array([lat_new, lon_new, h_new])
        dth_prev = dth.copy()
        dv_prev = dvk.copy()
        has_prev = True
        if record:
            out_q[k] = q
            out_v[k] = v
            out_p[k] = p
    state[0:4] = q
    state[4:7] = v
    state[7:10] = p
    state[10:13] = dth_prev
    state[13:16] = dv_prev
    state[16:19] = v_prev
    state[19] = 1.0
    state[20] = b_int
    state[21] = dh


@numba.njit(cache=True)
def _correct(state, phi, dvel, dpos):
    q = _qmul(_rv2q(phi), state[0:4])
    state[0:4] = q / np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    for i in range(3):
        state[4 + i] -= dvel[i]
        state[16 + i] -= dvel[i]
    lat, h = state[7], state[9]
    rm, rn = earth.radii_nb(lat)
    state[7] -= dpos[1] / (rm + h)
    state[8] -= dpos[0] / ((rn + h) * np.cos(lat))
    state[9] -= dpos[2]
    state[21] -= dpos[2]


_NO_Q = np.empty((0, 4))
_NO_3 = np.empty((0, 3))

#: Quaternion -> DCM compiled for per-cycle use (same convention as ``attitude.quat_to_dcm``).
quat_to_dcm_nb = _q2dcm


class Strapdown:
    """Strapdown INS state (attitude quaternion, ENU velocity, lat/lon/h) and its update.

    ``lla`` [rad, rad, m], ``vel`` ENU [m/s], ``euler`` [pitch, roll, heading] [rad],
    ``dt`` IMU period [s], ``baro`` optional :class:`BaroLoop`.
    """

    def __init__(self, lla, vel, euler, dt: float, baro: BaroLoop | None = None):
        self.dt = float(dt)
        self.state = np.zeros(STATE_SIZE)
        self.state[_Q] = attitude.euler_to_quat(euler)
        self.state[_V] = vel
        self.state[_P] = lla
        self.state[_VPREV] = vel
        self.baro = baro
        self._gains = baro.gains(float(lla[0])) if baro is not None else np.zeros(3)

    # --- read access -------------------------------------------------------------
    @property
    def baro_gains(self) -> np.ndarray:
        """Vertical-loop gains [k1, k2, k3] (zeros without a baro loop)."""
        return self._gains.copy()

    @property
    def q(self) -> np.ndarray:
        return self.state[_Q].copy()

    @property
    def vel(self) -> np.ndarray:
        return self.state[_V].copy()

    @property
    def lla(self) -> np.ndarray:
        return self.state[_P].copy()

    @property
    def dcm(self) -> np.ndarray:
        return _q2dcm(self.state[_Q])

    @property
    def euler(self) -> np.ndarray:
        return attitude.quat_to_euler(self.state[_Q])

    # --- update ------------------------------------------------------------------
    def run(self, dtheta, dv, h_ref=None, record: bool = True) -> dict[str, np.ndarray] | None:
        """Integrate IMU increments (N, 3).

        ``h_ref`` (N,): baro height measured at the *start* of sample k, NaN where there is
        no new baro value (the last INS - baro difference is then held).

        Returns the navigation state after each sample when ``record`` is true.
        """
        dtheta = np.ascontiguousarray(dtheta, dtype=float)
        dv = np.ascontiguousarray(dv, dtype=float)
        n = dtheta.shape[0]
        if dtheta.shape != (n, 3) or dv.shape != (n, 3):
            raise ValueError(
                f"Strapdown.run: dtheta and dv must both be (N, 3), got {dtheta.shape} and "
                f"{dv.shape}"
            )
        if h_ref is None or self.baro is None:
            h_ref = np.full(n, np.nan)
        else:
            h_ref = np.ascontiguousarray(h_ref, dtype=float)
            if h_ref.shape != (n,):
                raise ValueError(f"Strapdown.run: h_ref must be ({n},), got {h_ref.shape}")
        if record:
            out_q, out_v, out_p = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3))
        else:
            out_q, out_v, out_p = _NO_Q, _NO_3, _NO_3
        _run(self.state, dtheta, dv, self.dt, h_ref, self._gains, out_q, out_v, out_p)
        if not math.isfinite(self.state.sum()):
            raise FloatingPointError("Strapdown.run: navigation state became non-finite")
        if record:
            return {"q": out_q, "vel": out_v, "lla": out_p}
        return None

    def correct(self, phi, dvel, dpos) -> None:
        """Feedback: remove estimated errors (computed minus true) from the INS.

        ``phi`` platform error angles [rad] (C_hat = exp(-[phi x]) C), ``dvel`` ENU velocity
        error [m/s], ``dpos`` ENU position error [m].
        """
        _correct(self.state, np.asarray(phi, dtype=float), np.asarray(dvel, dtype=float),
                 np.asarray(dpos, dtype=float))
