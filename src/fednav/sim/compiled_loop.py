"""The closed loop of :func:`fednav.sim.runs.run_mode` in one compiled call.

For the configuration that Monte Carlo campaigns spend their time in — error-state
federated UKF local filters (with or without a master) in fusion-reset mode, equal, fixed
or adaptive sharing, star-sensor and SAR fixes used at the first filter epoch after they
arrive (no delay compensation, no fault detection, no constraint) — the whole run,
strapdown INS at IMU rate, error-model discretisation, sigma-point time and measurement
updates, fusion and feedback, runs in one numba function built from the same kernels the
Python classes call (:mod:`fednav.ins.strapdown`, :mod:`fednav.ins.error_model`,
:mod:`fednav.filters.ukf`, :mod:`fednav.filters.federated`).  Nothing in a cycle goes
back to the interpreter; the per-cycle Python orchestration (about 250 us a cycle) is
gone.

Every other configuration runs the general Python loop.  :func:`supported` says which
path a mode takes; the test suite flies both paths on the same data and finds them equal
within 1e-9 relative.  Keep them making the same floating-point operations in the same
order: the UKF's small ``alpha`` (paper 002: 1e-3, centre weight ``-1e6``) magnifies any
last-bit difference to about 1e-6 relative in the error statistics of a 1200 s flight.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core import earth
from ..core.kernels import cholesky_lower
from ..core.kernels import quat_to_dcm as _q2dcm
from ..core.units import ARCMIN
from ..filters.federated import _fuse
from ..filters.ukf import _predict_moments, _sigma_points, _update
from ..ins.error_model import _interval, _transition
from ..ins.strapdown import _correct
from ..ins.strapdown import _run as _strapdown_run
from ..sensors.measurement import euler_error_nb

#: Sensor kinds the compiled loop measures with (see :func:`_residual`).
KINDS = {"star": 0, "sar": 1}
SHARING = {"equal": 0, "fixed": 1, "adaptive": 2}
_TWO_PI = 2.0 * np.pi
#: Failure codes returned by :func:`closed_loop` -> what the Python loop would raise.
FAILURES = {1: "navigation state became non-finite",
            2: "covariance is not positive definite (sigma points)",
            3: "state or covariance became NaN/inf",
            4: "innovation covariance not positive definite",
            5: "covariance is not positive definite (after update)",
            6: "federated fusion: covariance is not positive definite"}


def supported(ftype: str, aiding, timing: dict, central: bool, constraint, fdi_alpha,
              reset: bool, incs) -> bool:
    """Whether :func:`closed_loop` covers this mode (else the Python loop runs it)."""
    fdi_off = (all(v is None for v in fdi_alpha.values()) if isinstance(fdi_alpha, dict)
               else fdi_alpha is None)
    return (ftype == "ukf" and bool(aiding) and all(a in KINDS for a in aiding)
            and all(tm.delay_compensation in ("none", "interpolate") for tm in timing.values())
            and not central and constraint is None and fdi_off and reset and incs is None)


@numba.njit(cache=True)
def _wrap_pi(a):
    return (a + np.pi) % _TWO_PI - np.pi


@numba.njit(cache=True)
def _residual(kind, state, C, z, out):
    """INS-derived minus sensor: star [pitch, roll, heading] arcmin (StarAttitude), SAR
    [east m, north m, heading arcmin] (SarFix)."""
    pitch = math.asin(min(1.0, max(-1.0, C[2, 1])))
    roll = math.atan2(-C[2, 0], C[2, 2])
    heading = math.atan2(C[0, 1], C[1, 1]) % _TWO_PI
    if kind == 0:
        out[0] = (pitch - z[0]) / ARCMIN
        out[1] = _wrap_pi(roll - z[1]) / ARCMIN
    else:
        lat, lon, h = state[7], state[8], state[9]
        rm, rn = earth.radii_nb(lat)
        out[0] = (lon - z[1]) * (rn + h) * np.cos(lat)
        out[1] = (lat - z[0]) * (rm + h)
    out[2] = _wrap_pi(heading - z[2]) / ARCMIN


@numba.njit(cache=True)
def _predicted(kind, C, X):
    """The measurement model ``h`` of each sigma point: StarAttitude.h, SarFix.h."""
    e = euler_error_nb(C, X)
    if kind == 1:
        for i in range(X.shape[0]):
            e[i, 0] = X[i, 6]
            e[i, 1] = X[i, 7]
    return e


@numba.njit(cache=True)
def closed_loop(state, dtheta, dv, h_ref, dt, gains, n_per, T, k1, k2, itg, ita, noise,
                nsub, scale, X, P, beta, c, Wm, Wc, sharing, kinds, m_cycle, m_filter, m_z,
                R, states, var, betas, nis):
    """Fly ``states.shape[0]`` filter cycles; fills ``states`` (INS state after each
    cycle), ``var`` (fused covariance diagonal), ``betas`` and ``nis`` (one per
    measurement).  ``X``, ``P``, ``beta``: the filters (locals then master) after the
    federated filter's reset; ``m_*``: the measurements in the order the Python loop
    applies them.  Returns (failure code, cycle, filter); code 0 when the run completed."""
    nf = X.shape[0]
    n_cycles = states.shape[0]
    comp_g = np.zeros(3)
    comp_a = np.zeros(3)
    dth = np.empty((n_per, 3))
    dvc = np.empty((n_per, 3))
    no_q = np.empty((0, 4))
    no_3 = np.empty((0, 3))
    y = np.empty(3)
    m = 0
    n_meas = m_cycle.shape[0]
    for k in range(n_cycles):
        b = k * n_per
        for i in range(n_per):
            for j in range(3):
                dth[i, j] = dtheta[b + i, j] - comp_g[j] * dt
                dvc[i, j] = dv[b + i, j] - comp_a[j] * dt
        s0 = state.copy()
        _strapdown_run(state, dth, dvc, dt, h_ref[b:b + n_per], gains, no_q, no_3, no_3)
        if not math.isfinite(state.sum()):
            return 1, k, -1
        params, Cm, _, Qd = _interval(s0, state, dvc.sum(axis=0), T, k1, k2, itg, ita,
                                      noise, scale)
        for f in range(nf):
            S = _sigma_points(X[f], P[f], c)
            if S.shape[0] == 0:
                return 2, k, f
            x, Pn, ok = _predict_moments(_transition(S, T, nsub, params, Cm, scale), Wm, Wc,
                                         (1.0 / beta[f]) * Qd)
            if not ok:
                return 3, k, f
            X[f] = x
            P[f] = Pn
        C = _q2dcm(state[0:4])
        while m < n_meas and m_cycle[m] == k:
            f = m_filter[m]
            _residual(kinds[f], state, C, m_z[m], y)
            S = _sigma_points(X[f], P[f], c)
            if S.shape[0] == 0:
                return 2, k, f
            x, Pn, _, _, ni, ok = _update(S, _predicted(kinds[f], C, S), Wm, Wc, X[f],
                                          P[f], y, R[f])
            if not ok or not math.isfinite(ni):
                return 4, k, f
            if not math.isfinite(x.sum() + Pn.sum()):
                return 3, k, f
            if not cholesky_lower(Pn)[1]:
                return 5, k, f
            X[f] = x
            P[f] = Pn
            nis[m] = ni
            m += 1
        xg, Pg, traces, bad = _fuse(X, P)
        if bad >= 0:
            return 6, k, bad
        if sharing == 2:
            s = traces.sum()
            for f in range(nf):
                beta[f] = 1.0 * traces[f] / s
        for f in range(nf):
            X[f] = xg - xg  # reset to the fused estimate, then its feedback (zero)
            P[f] = Pg / beta[f]
            betas[k, f] = beta[f]
        for i in range(18):
            var[k, i] = Pg[i, i]
        d = xg * scale
        _correct(state, d[0:3], d[3:6], d[6:9])
        for j in range(3):
            comp_g[j] += d[9 + j] + d[12 + j]
            comp_a[j] += d[15 + j]
        states[k] = state
    return 0, -1, -1
