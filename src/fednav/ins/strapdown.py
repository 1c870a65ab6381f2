"""Strapdown inertial navigation in the ENU frame at IMU rate (numba).

Inputs are body angle increments ``dtheta`` [rad] and velocity increments ``dv`` [m/s]
over each IMU interval ``dt`` [s] (body right-forward-up).  Per sample:

* attitude: rotation vector with the two-sample (current + previous) coning correction
  ``phi = dtheta_k + dtheta_{k-1} x dtheta_k / 12``; the navigation frame rotates by
  ``omega_in^n dt`` evaluated at the interval midpoint;
* velocity: rotation compensation ``dtheta x dv / 2``, two-sample sculling
  ``(dtheta_{k-1} x dv_k + dv_{k-1} x dtheta_k) / 12``, frame-rotation term, Coriolis
  and normal gravity at the extrapolated midpoint;
* position: trapezoidal integration of latitude, longitude and height; the longitude is
  kept in (-pi, pi] (:func:`fednav.core.earth.wrap_lon`: a track across the antimeridian
  goes on from -pi, and a start given in 0..2 pi is brought there by the constructor).
  Near the poles the latitude/longitude integration stays accurate (measured against an
  ECEF great-circle truth: 3 mm in 600 s at 250 m/s passing 11 km from the pole, 0.25 m
  passing 1.1 km from it, ``benchmarks/polar.py``); at the pole itself an eastward
  velocity makes the transport rate infinite (``docs/conventions.md``).

The vertical channel can be damped by a barometric height reference through a second-
or third-order loop (:class:`BaroLoop`).  The loop is driven by the height difference
INS - baro formed at each baro sample and held until the next one (holding the baro
height itself would inject the climb rate times the baro period as an error).  The INS
height is taken at the barometer's point, ``h + (C_b^n l)_up`` with the attitude at the
sample and the barometer's lever arm ``l`` (body RFU, m; :attr:`BaroLoop.lever_m`), so a
barometer 2 m above the IMU does not pull the INS 2 m up (the error model's loop terms
leave out the attitude error's share of that height, at most ``|l| |phi|``: 2 mm at 2 m
and 1 mrad).  The state
lives in a flat float array so the same compiled kernel serves open-loop runs and filter
loops with feedback.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from ..core import attitude, earth
from ..core.kernels import (
    coning_sculling_s,
    quat_mul_s,
    quat_to_dcm_s,
    rotation_compensated_s,
    rotvec_to_quat_s,
)
from ..core.kernels import quat_mul as _qmul
from ..core.kernels import quat_to_dcm as _q2dcm
from ..core.kernels import rotvec_to_quat as _rv2q

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
    (the 2g/R instability of the free vertical channel is cancelled in the gain);
    ``lever_m``: the barometer's position from the IMU, body RFU axes [m].
    """

    time_constant: float = 10.0
    order: int = 3
    lever_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

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
def mechanize(state, dtheta, dv, dt, h_ref, loop, out_q, out_v, out_p):
    """``loop``: the baro loop's gains [k1, k2, k3] and the barometer's lever arm [lx,
    ly, lz] (body, m): :attr:`Strapdown.baro_loop`."""
    # Scalar arithmetic throughout: no array is allocated per sample.
    n = dtheta.shape[0]
    record = out_q.shape[0] == n
    q0, q1, q2, q3 = state[0], state[1], state[2], state[3]
    ve, vn, vu = state[4], state[5], state[6]
    lat, lon, h = state[7], state[8], state[9]
    px, py, pz = state[10], state[11], state[12]  # previous angle increment
    ux, uy, uz = state[13], state[14], state[15]  # previous velocity increment
    wpe, wpn, wpu = state[16], state[17], state[18]  # previous velocity
    has_prev = state[19] > 0.5
    b_int = state[20]
    dh = state[21]
    lx, ly, lz = loop[3], loop[4], loop[5]
    om = earth.OMEGA_IE
    for k in range(n):
        ax, ay, az = dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]
        bx, by, bz = dv[k, 0], dv[k, 1], dv[k, 2]
        # Midpoint extrapolation of velocity and position.
        if has_prev:
            me, mn, mu = ve + 0.5 * (ve - wpe), vn + 0.5 * (vn - wpn), vu + 0.5 * (vu - wpu)
        else:
            me, mn, mu = ve, vn, vu
        rm, rn = earth.radii_nb(lat)
        lat_m = lat + 0.5 * dt * mn / (rm + h)
        h_m = h + 0.5 * dt * mu
        sl, cl = math.sin(lat_m), math.cos(lat_m)
        sl2 = sl * sl  # one sine of the midpoint latitude for radii, rates and gravity
        rm, rn = earth.radii_of_sin2_nb(sl2)
        iee, ien, ieu = 0.0, om * cl, om * sl
        ene = -mn / (rm + h_m)
        enn = me / (rn + h_m)
        enu = me * sl / cl / (rn + h_m)
        ine, inn, inu = iee + ene, ien + enn, ieu + enu
        gmag = earth.gravity_of_sin2_nb(sl2, h_m)
        # Coning and sculling (current + previous sample).
        fx, fy, fz, sx, sy, sz = coning_sculling_s(ax, ay, az, bx, by, bz, px, py, pz,
                                                   ux, uy, uz, has_prev)
        cx, cy, cz = rotation_compensated_s(ax, ay, az, bx, by, bz, sx, sy, sz)
        # C_b^n from the quaternion.
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = quat_to_dcm_s(q0, q1, q2, q3)
        ne = c00 * cx + c01 * cy + c02 * cz
        nn = c10 * cx + c11 * cy + c12 * cz
        nu = c20 * cx + c21 * cy + c22 * cz
        ze, zn, zu = ine * dt, inn * dt, inu * dt
        de = ne - 0.5 * (zn * nu - zu * nn)
        dn = nn - 0.5 * (zu * ne - ze * nu)
        du = nu - 0.5 * (ze * nn - zn * ne)
        we, wn, wu = 2.0 * iee + ene, 2.0 * ien + enn, 2.0 * ieu + enu
        acc_e = -(wn * mu - wu * mn)
        acc_n = -(wu * me - we * mu)
        acc_u = -(we * mn - wn * me)
        acc_u -= gmag
        if not math.isnan(h_ref[k]):
            dh = h + c20 * lx + c21 * ly + c22 * lz - h_ref[k]  # at the baro's point
        acc_u -= loop[1] * dh + b_int
        b_int += loop[2] * dh * dt
        ve_n = ve + de + acc_e * dt
        vn_n = vn + dn + acc_n * dt
        vu_n = vu + du + acc_u * dt
        # Position: trapezoid on velocity.
        h_new = h + 0.5 * dt * (vu + vu_n) - loop[0] * dh * dt
        h_a = 0.5 * (h + h_new)
        lat_new = lat + 0.5 * dt * (vn + vn_n) / (rm + h_a)
        lat_a = 0.5 * (lat + lat_new)
        rm2, rn2 = earth.radii_nb(lat_a)
        lon_new = earth.wrap_lon(lon + 0.5 * dt * (ve + ve_n) / ((rn2 + h_a) * math.cos(lat_a)))
        # Attitude: q <- r(-zeta) * q * r(phi) (body rotation, then navigation frame).
        r0, r1, r2, r3 = rotvec_to_quat_s(fx, fy, fz)
        t0, t1, t2, t3 = quat_mul_s(q0, q1, q2, q3, r0, r1, r2, r3)
        r0, r1, r2, r3 = rotvec_to_quat_s(-ze, -zn, -zu)
        q0, q1, q2, q3 = quat_mul_s(r0, r1, r2, r3, t0, t1, t2, t3)
        qn = math.sqrt(q0 ** 2 + q1 ** 2 + q2 ** 2 + q3 ** 2)
        q0, q1, q2, q3 = q0 / qn, q1 / qn, q2 / qn, q3 / qn
        wpe, wpn, wpu = ve, vn, vu
        ve, vn, vu = ve_n, vn_n, vu_n
        lat, lon, h = lat_new, lon_new, h_new
        px, py, pz = ax, ay, az
        ux, uy, uz = bx, by, bz
        has_prev = True
        if record:
            out_q[k, 0], out_q[k, 1], out_q[k, 2], out_q[k, 3] = q0, q1, q2, q3
            out_v[k, 0], out_v[k, 1], out_v[k, 2] = ve, vn, vu
            out_p[k, 0], out_p[k, 1], out_p[k, 2] = lat, lon, h
    state[0], state[1], state[2], state[3] = q0, q1, q2, q3
    state[4], state[5], state[6] = ve, vn, vu
    state[7], state[8], state[9] = lat, lon, h
    state[10], state[11], state[12] = px, py, pz
    state[13], state[14], state[15] = ux, uy, uz
    state[16], state[17], state[18] = wpe, wpn, wpu
    state[19] = 1.0
    state[20] = b_int
    state[21] = dh


@numba.njit(cache=True)
def body_frame_velocity(dtheta, dv, out, out_q):
    """The specific force integrated in the body frame of the first sample's start, held
    fixed in inertial space: ``out[k] = sum_{i<=k} C_{b_i}^{b_0} dv_i`` [m/s] (``C``: the
    attitude at the start of interval ``i`` relative to it, from the angle increments
    alone — gyros measure the inertial rate; the velocity increments rotation-compensated
    and sculling-corrected as :func:`mechanize` does), and ``out_q[k]`` the attitude at
    the end of interval ``k`` (quaternion ``q_b^{b0}``).  ``dtheta``, ``dv`` (N, 3) [rad,
    m/s], body right-forward-up; ``out`` (N, 3), ``out_q`` (N, 4).  In-motion levelling
    matches it with the GNSS velocity's change (:func:`fednav.ins.alignment.align`)."""
    q0, q1, q2, q3 = 1.0, 0.0, 0.0, 0.0
    px = py = pz = ux = uy = uz = 0.0
    ex = ey = ez = 0.0
    for k in range(dtheta.shape[0]):
        ax, ay, az = dtheta[k, 0], dtheta[k, 1], dtheta[k, 2]
        bx, by, bz = dv[k, 0], dv[k, 1], dv[k, 2]
        fx, fy, fz, sx, sy, sz = coning_sculling_s(ax, ay, az, bx, by, bz, px, py, pz,
                                                   ux, uy, uz, k > 0)
        cx, cy, cz = rotation_compensated_s(ax, ay, az, bx, by, bz, sx, sy, sz)
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = quat_to_dcm_s(q0, q1, q2, q3)
        ex += c00 * cx + c01 * cy + c02 * cz
        ey += c10 * cx + c11 * cy + c12 * cz
        ez += c20 * cx + c21 * cy + c22 * cz
        out[k, 0], out[k, 1], out[k, 2] = ex, ey, ez
        r0, r1, r2, r3 = rotvec_to_quat_s(fx, fy, fz)
        q0, q1, q2, q3 = quat_mul_s(q0, q1, q2, q3, r0, r1, r2, r3)
        qn = math.sqrt(q0 ** 2 + q1 ** 2 + q2 ** 2 + q3 ** 2)
        q0, q1, q2, q3 = q0 / qn, q1 / qn, q2 / qn, q3 / qn
        out_q[k, 0], out_q[k, 1], out_q[k, 2], out_q[k, 3] = q0, q1, q2, q3
        px, py, pz, ux, uy, uz = ax, ay, az, bx, by, bz


@numba.njit(cache=True)
def _run_intervals(state, dtheta, dv, dt, h_ref, loop, n_per, out, no_q, no_3):
    """:func:`mechanize` over consecutive intervals of ``n_per`` samples (recording nothing:
    ``no_q``, ``no_3`` are empty), the state after each into the rows of ``out``."""
    for k in range(out.shape[0]):
        a = k * n_per
        mechanize(state, dtheta[a:a + n_per], dv[a:a + n_per], dt, h_ref[a:a + n_per], loop,
             no_q, no_3, no_3)
        out[k] = state


@numba.njit(cache=True)
def compensate(dtheta, dv, dt, comp, xa, isg, isa, out_th, out_v):
    """The IMU increments ``dtheta``, ``dv`` (N, 3; rad, m/s) with the estimated errors
    taken out, into ``out_th``, ``out_v``: ``(dtheta - b_g dt) / (1 + s_g)`` and ``(dv -
    b_a dt) / (1 + s_a)``, ``comp`` = [b_g (3) rad/s, b_a (3) m/s^2], the scale factors
    ``s`` (fractions) at ``xa[isg:isg + 3]`` and ``xa[isa:isa + 3]`` (the totals of the
    optional error states, :mod:`fednav.ins.states`; ``isg``/``isa`` -1: no scale-factor
    state)."""
    for i in range(dtheta.shape[0]):
        for j in range(3):
            out_th[i, j] = dtheta[i, j] - comp[j] * dt
            out_v[i, j] = dv[i, j] - comp[3 + j] * dt
            if isg >= 0:
                out_th[i, j] /= 1.0 + xa[isg + j]
            if isa >= 0:
                out_v[i, j] /= 1.0 + xa[isa + j]


@numba.njit(cache=True)
def correct_state(state, phi, dvel, dpos):
    q = _qmul(_rv2q(phi), state[0:4])
    state[0:4] = q / np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    for i in range(3):
        state[4 + i] -= dvel[i]
        state[16 + i] -= dvel[i]
    lat, h = state[7], state[9]
    rm, rn = earth.radii_nb(lat)
    state[7] -= dpos[1] / (rm + h)
    state[8] = earth.wrap_lon(state[8] - dpos[0] / ((rn + h) * np.cos(lat)))
    state[9] -= dpos[2]
    state[21] -= dpos[2]


@numba.njit(cache=True)
def correct_rows(q, vel, lla, err):
    """:meth:`Strapdown.correct` applied to many navigation states in place: rows of
    ``q`` (N, 4), ``vel`` (N, 3) ENU, ``lla`` (N, 3), with ``err`` (N, 9) = platform
    angles [rad], ENU velocity [m/s], ENU position [m] (computed minus true)."""
    s = np.zeros(STATE_SIZE)
    for k in range(q.shape[0]):
        s[0:4] = q[k]
        s[4:7] = vel[k]
        s[7:10] = lla[k]
        correct_state(s, err[k, 0:3], err[k, 3:6], err[k, 6:9])
        q[k] = s[0:4]
        vel[k] = s[4:7]
        lla[k] = s[7:10]


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
        self.state[8] = earth.wrap_lon(float(self.state[8]))  # (-pi, pi], as it is kept
        self.state[_VPREV] = vel
        self.baro = baro
        self._loop = (np.r_[baro.gains(float(lla[0])), np.asarray(baro.lever_m, float)]
                       if baro is not None else np.zeros(6))

    # --- read access -------------------------------------------------------------
    @property
    def baro_gains(self) -> np.ndarray:
        """Vertical-loop gains [k1, k2, k3] (zeros without a baro loop)."""
        return self._loop[:3].copy()

    @property
    def baro_loop(self) -> np.ndarray:
        """The compiled kernel's loop constants: gains [k1, k2, k3] and the barometer's
        lever arm [lx, ly, lz] (body RFU, m)."""
        return self._loop.copy()

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
        mechanize(self.state, dtheta, dv, self.dt, h_ref, self._loop, out_q, out_v, out_p)
        if not math.isfinite(self.state.sum()):
            raise FloatingPointError("Strapdown.run: navigation state became non-finite")
        if record:
            return {"q": out_q, "vel": out_v, "lla": out_p}
        return None

    def run_intervals(self, dtheta, dv, h_ref, n_per: int) -> np.ndarray:
        """Integrate whole intervals of ``n_per`` samples (N = K n_per) in one compiled
        call, as K calls of :meth:`run` would; returns the state after each (K, 22)."""
        dtheta = np.ascontiguousarray(dtheta, dtype=float)
        dv = np.ascontiguousarray(dv, dtype=float)
        n = dtheta.shape[0]
        if h_ref is None or self.baro is None:
            h_ref = np.full(n, np.nan)
        else:
            h_ref = np.ascontiguousarray(h_ref, dtype=float)
        out = np.empty((n // n_per, STATE_SIZE))
        _run_intervals(self.state, dtheta, dv, self.dt, h_ref, self._loop, int(n_per), out,
                       _NO_Q, _NO_3)
        if not math.isfinite(out[-1].sum() if len(out) else 0.0):
            raise FloatingPointError("Strapdown.run: navigation state became non-finite")
        return out

    def correct(self, phi, dvel, dpos) -> None:
        """Feedback: remove estimated errors (computed minus true) from the INS.

        ``phi`` platform error angles [rad] (C_hat = exp(-[phi x]) C), ``dvel`` ENU velocity
        error [m/s], ``dpos`` ENU position error [m].
        """
        correct_state(self.state, np.asarray(phi, dtype=float), np.asarray(dvel, dtype=float),
                 np.asarray(dpos, dtype=float))
