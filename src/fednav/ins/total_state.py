"""Total-state (direct) filtering of the navigation state (paper 003).

The filter estimates the navigation state itself — attitude, ENU velocity, position —
instead of the INS error.  Its mean *is* the INS (:class:`~fednav.ins.strapdown.Strapdown`),
propagated by the mechanization at the full IMU rate.  Uncertainty lives on the tangent
space ``d = [phi (3), dv (3), dp (3)]`` in filter units (arc-minutes, m/s, metres ENU):

* ``X [+] d``: attitude ``C = exp([phi x]) C_X`` (a rotation of the navigation frame by
  ``phi``), ``v = v_X + dv``, position moved by ``dp`` metres east/north/up;
* ``Y [-] X``: the ``d`` with ``X [+] d = Y``; the attitude part is ``log(C_Y C_X')`` —
  (with Y the truth and X the INS, ``d = S x_err`` for the error state of
  :mod:`fednav.ins.error_model`, ``S = diag(+1 x3, -1 x6)``: same attitude sign, opposite
  velocity/position sign);
  recovered platform angles, never a difference of Euler angles (paper 003, eq. 27–29;
  fednav uses the exact exponential where the paper writes the small-angle matrix).

The filter state is augmented with the gyro and accelerometer errors ``b`` (6, body
axes), carried and estimated as first-order Gauss–Markov processes (random walk when the
correlation time is infinite): paper 003's "9 + 6 gyro/accelerometer first-order Markov"
= 15 states.  Coloured (Markov) noise can only be represented by carrying it as states;
a 9-state filter that treats the random-walking bias as white noise becomes inconsistent
and, with chi-square fault detection on, rejects good measurements and diverges (seen
and documented in docs/paper003.md).

Time update (augmented UKF, paper 003 section 2.1): sigma points over
``[d (9), db (6), w (6)]`` with covariance ``blockdiag(P, Q_w)``, ``w`` = white gyro and
accelerometer noise averaged over the interval [rad/s, m/s^2].  Every sigma point is
flown through the same strapdown kernel over the interval (one coarse step with the
interval's summed increments, minus its IMU error ``b + db + w``); the central point is
flown the same way, and only the deviations ``chi_i [-] chi_0`` are kept and re-applied
around the full-rate INS.  The coarse step's own (common-mode) error therefore cancels.
Measurement updates are linear on the tangent space (the simplified UKF), by each
sensor's total-state model (its ``SensorSpec.total``: ``fednav.sensors.gnss.GnssTotal``,
``fednav.sensors.star.StarTotal``).
"""

from __future__ import annotations

import numba
import numpy as np

from ..core import attitude as att
from ..core import earth
from ..core.kernels import (
    cholesky_lower,
    quat_mul,
    quat_to_rotvec,
    rotvec_to_quat,
)
from .error_model import SCALE
from .strapdown import Strapdown, mechanize

N_NAV = 9
N_BIAS = 6
N_STATE = N_NAV + N_BIAS
N_NOISE = 6
#: Filter units of the tangent coordinates [phi (arcmin), v (m/s), p (m)].
TSCALE = SCALE[:N_NAV]
#: Filter units of the bias states [gyro (deg/h), accelerometer (mg)].
BSCALE = np.r_[SCALE[9:12], SCALE[15:18]]


@numba.njit(cache=True)
def _boxplus(states, d, scale):
    out = states.copy()
    for i in range(states.shape[0]):
        dd = d[i] * scale
        q = quat_mul(rotvec_to_quat(dd[0:3]), states[i, 0:4])
        out[i, 0:4] = q / np.sqrt(q @ q)
        for j in range(3):
            out[i, 4 + j] += dd[3 + j]
        lat, h = states[i, 7], states[i, 9]
        rm, rn = earth.radii_nb(lat)
        out[i, 7] = lat + dd[7] / (rm + h)
        out[i, 8] = earth.wrap_lon(states[i, 8] + dd[6] / ((rn + h) * np.cos(lat)))
        out[i, 9] = h + dd[8]
    return out


@numba.njit(cache=True)
def _boxminus(states, ref, scale):
    n = states.shape[0]
    out = np.empty((n, 9))
    qc = ref[0:4].copy()
    qc[1:] = -qc[1:]
    rm, rn = earth.radii_nb(ref[7])
    for i in range(n):
        phi = quat_to_rotvec(quat_mul(states[i, 0:4], qc))
        out[i, 0:3] = phi
        for j in range(3):
            out[i, 3 + j] = states[i, 4 + j] - ref[4 + j]
        out[i, 6] = earth.wrap_lon(states[i, 8] - ref[8]) * (rn + ref[9]) * np.cos(ref[7])
        out[i, 7] = (states[i, 7] - ref[7]) * (rm + ref[9])
        out[i, 8] = states[i, 9] - ref[9]
        for j in range(9):
            out[i, j] /= scale[j]
    return out


def boxplus(states: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``X [+] d`` for INS state rows (S, STATE_SIZE) and tangent rows d (S, 9) (filter units)."""
    states = np.ascontiguousarray(np.atleast_2d(states), dtype=float)
    d = np.ascontiguousarray(np.atleast_2d(d), dtype=float)
    return _boxplus(states, d, TSCALE)


def boxminus(states: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """``Y [-] X`` for state rows Y (S, STATE_SIZE) and one reference state X (filter units).

    Position differences use the reference's radii of curvature (first order in the
    difference, as the error statistics do)."""
    states = np.ascontiguousarray(np.atleast_2d(states), dtype=float)
    return _boxminus(states, np.ascontiguousarray(ref, dtype=float), TSCALE)


def attitude_innovation(C_meas, C_est) -> np.ndarray:
    """Rotation [rad] from the estimated to the measured attitude, ``log(C_meas C_est')``.

    Valid at any heading (no 0/360 wrap) and any pitch (no Euler singularity)."""
    return att.dcm_to_rotvec(np.asarray(C_meas) @ np.swapaxes(np.asarray(C_est), -1, -2))


@numba.njit(cache=True)
def _fly_coarse(states, dth, dv, noise, T, gains):
    """One strapdown step of length T for each state row with its own IMU error."""
    nan = np.full(1, np.nan)
    o4 = np.empty((0, 4))
    o3 = np.empty((0, 3))
    a = np.empty((1, 3))
    b = np.empty((1, 3))
    for i in range(states.shape[0]):
        for j in range(3):
            a[0, j] = dth[j] - noise[i, j] * T
            b[0, j] = dv[j] - noise[i, 3 + j] * T
        mechanize(states[i], a, b, T, nan, gains, o4, o3, o3)


@numba.njit(cache=True)
def _predict(state, dth, dv, h_ref, dt, gains, P, c, Lw, Wm, Wc, decay, Qb, tscale, bscale):
    """The augmented-UKF time update (see the module docstring) in one compiled call.

    Flies the sigma points (coarse step) and the full-rate navigation mean (``state`` in
    place); returns (P, mean tangent correction (15,), ok)."""
    n_s, n_w = P.shape[0], Lw.shape[0]
    n = n_s + n_w
    Lp, ok = cholesky_lower(c * P)
    if not ok:
        return P, np.zeros(n_s), False
    L = np.zeros((n, n))  # blockdiag(P, Qw): factor the blocks separately
    L[:n_s, :n_s] = Lp
    L[n_s:, n_s:] = Lw
    D = np.zeros((2 * n + 1, n))
    D[1:n + 1] = L.T
    D[n + 1:] = -L.T
    chi = np.empty((2 * n + 1, state.shape[0]))
    for i in range(2 * n + 1):
        chi[i] = state
    chi = _boxplus(chi, np.ascontiguousarray(D[:, :N_NAV]), tscale)
    chi[:, 10:20] = 0.0  # coarse steps: no previous-sample coning/sculling terms
    T = dt * dth.shape[0]
    err = np.empty((2 * n + 1, N_BIAS))
    for i in range(2 * n + 1):
        for j in range(N_BIAS):  # bias deviation + white noise [SI]
            err[i, j] = D[i, N_NAV + j] * bscale[j] + D[i, n_s + j]
    dth_sum = np.zeros(3)
    dv_sum = np.zeros(3)
    for k in range(dth.shape[0]):
        dth_sum += dth[k]
        dv_sum += dv[k]
    _fly_coarse(chi, dth_sum, dv_sum, err, T, gains)
    dev = np.empty((2 * n + 1, n_s))
    dev[:, :N_NAV] = _boxminus(chi, chi[0].copy(), tscale)
    for i in range(2 * n + 1):
        for j in range(N_BIAS):
            dev[i, N_NAV + j] = D[i, N_NAV + j] * decay[j]
    mean = Wm @ dev
    r = dev - mean
    Pn = (r * Wc.reshape(-1, 1)).T @ r
    Pn[N_NAV:, N_NAV:] += Qb
    Pn = 0.5 * (Pn + Pn.T)
    o4 = np.empty((0, 4))
    o3 = np.empty((0, 3))
    mechanize(state, dth, dv, dt, h_ref, gains, o4, o3, o3)  # the navigation mean at full rate
    return Pn, mean, True


class TotalStateUKF:
    """Augmented UKF on the navigation state and IMU errors (see module docstring).

    ``ins``: the strapdown navigator that carries the navigation mean; ``P0`` (15, 15)
    covariance of ``[d (9), b (6)]`` in filter units; ``Qw`` (6, 6) covariance of the white
    gyro [rad/s] and accelerometer [m/s^2] noise averaged over one filter interval;
    ``bias_decay`` (6,) ``exp(-T / tau)`` of the bias processes (1 = random walk) and
    ``Qb`` (6, 6) their driving noise over one interval (filter units).
    """

    def __init__(self, ins: Strapdown, P0, Qw, Qb=None, bias_decay=None, alpha: float = 1e-3,
                 beta: float = 2.0, kappa: float = 0.0, name: str = "total-state ukf"):
        self.ins, self.name = ins, name
        self.P = np.array(P0, dtype=float)
        self.Qw = np.array(Qw, dtype=float)
        self.Qb = np.zeros((N_BIAS, N_BIAS)) if Qb is None else np.array(Qb, dtype=float)
        self.decay = np.ones(N_BIAS) if bias_decay is None else np.asarray(bias_decay, float)
        if self.P.shape != (N_STATE, N_STATE) or self.Qw.shape != (N_NOISE, N_NOISE):
            raise ValueError(f"{name}: P0 must be (15, 15) and Qw (6, 6)")
        if not np.allclose(self.Qw, self.Qw.T) or np.linalg.eigvalsh(self.Qw).min() < 0:
            raise ValueError(f"{name}: Qw must be symmetric positive semi-definite")
        self.b = np.zeros(N_BIAS)  # estimated IMU errors, SI [rad/s x3, m/s^2 x3]
        n = N_STATE + N_NOISE
        lam = alpha**2 * (n + kappa) - n
        self.c = n + lam
        self.Wm = np.full(2 * n + 1, 0.5 / self.c)
        self.Wc = self.Wm.copy()
        self.Wm[0] = lam / self.c
        self.Wc[0] = lam / self.c + 1.0 - alpha**2 + beta
        # PSD square root of c Qw (zero noise components allowed).
        ev, V = np.linalg.eigh(self.c * self.Qw)
        self._Lw = V * np.sqrt(np.clip(ev, 0.0, None))
        self.step = 0

    def compensate(self, dtheta, dv):
        """IMU increments with the estimated errors removed."""
        dt = self.ins.dt
        return (np.asarray(dtheta) - self.b[:3] * dt, np.asarray(dv) - self.b[3:] * dt)

    def predict(self, dtheta, dv, h_ref=None) -> None:
        """Time update over one interval of raw IMU increments (N, 3)."""
        self.step += 1
        dth, dvc = self.compensate(dtheta, dv)
        n = len(dth)
        h_ref = (np.full(n, np.nan) if h_ref is None or self.ins.baro is None
                 else np.ascontiguousarray(h_ref, dtype=float))
        P, mean, ok = _predict(self.ins.state, np.ascontiguousarray(dth),
                               np.ascontiguousarray(dvc), h_ref, self.ins.dt,
                               self.ins.baro_loop, self.P, self.c, self._Lw, self.Wm,
                               self.Wc, self.decay, self.Qb, TSCALE, BSCALE)
        if not ok:
            raise FloatingPointError(f"{self.name} predict at step {self.step}: covariance is "
                                     f"not positive definite")
        if not np.isfinite(self.ins.state.sum() + P.sum()):
            raise FloatingPointError(f"{self.name} predict at step {self.step}: state or "
                                     f"covariance became NaN/inf")
        self.P = P
        self.b *= self.decay
        self.apply(mean)

    def apply(self, d) -> None:
        """Move the estimate by ``d`` (15, filter units): ``X <- X [+] d``, ``b += db``."""
        d = np.asarray(d, dtype=float)
        self.ins.state[:] = _boxplus(self.ins.state[None], d[None, :N_NAV], TSCALE)[0]
        # keep the velocity history used by the strapdown's midpoint extrapolation
        self.ins.state[16:19] += d[3:6] * TSCALE[3:6]
        self.b += d[N_NAV:N_STATE] * BSCALE
