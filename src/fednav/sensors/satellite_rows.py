"""The raw GNSS measurement's rows, compiled: one source for the Python model and the engine.

:class:`fednav.sensors.gnss_raw.SatelliteRanges` (the Python loop's model) and the
navigator's compiled engine (:mod:`fednav.navigator.engine`) both build a raw GNSS
epoch's rows with these functions, so the two fly the same operations:

- :func:`antenna`: the antenna's ECEF position and velocity from the INS and the lever
  arm, and how its ECEF velocity turns with the local frame;
- :func:`usable`: the satellites of a measurement's slots above the elevation mask, each
  with its 1-sigma (its own, or the section's zenith figure scaled by elevation);
- :func:`rows`: the residuals (INS-derived - measured) and ``H`` of their pseudorange and
  range-rate rows (the model and its Jacobian: :mod:`fednav.sensors.gnss_raw`);
- :func:`bind`: the three, with the receiver clock's jump test (the clock totals moved in
  place by a millisecond jump or the first epoch's bias and drift);
- :func:`points_rows`: ``h(X) = X H'`` of sigma points (the model is linear).

A measurement ``z`` is :data:`SLOTS` slots of :data:`FIELDS` values (NaN: an empty slot).
Frames: ECEF for the satellites and the antenna, ENU for the error state's position and
velocity; SI throughout.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..core import earth
from ..ins.error_model import N_STATES
from .measurement import POS_E, POS_N, POS_U, VEL_E, VEL_N, VEL_U, row_jacobian

#: The values of one satellite's slot of ``z``.
FIELDS = ("prn", "x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "pr_m", "rr_mps",
          "sigma_pr_m", "sigma_rr_mps")
(PRN, SX, SY, SZ, SVX, SVY, SVZ, PR, RR, SPR, SRR) = range(len(FIELDS))
NF = len(FIELDS)
#: Satellites one measurement holds at most (GPS above a 5 deg mask: 8 to 13).
SLOTS = 14
WIDTH = SLOTS * NF
#: Rows one measurement gives at most (a pseudorange and a range rate per satellite).
MAX_ROWS = 2 * SLOTS

#: A pseudorange residual whose median over an epoch's satellites is larger than this [m]
#: (3.3 us) is the receiver clock's jump (receivers that keep their bias within a
#: millisecond jump by 1 ms, 300 km): the clock's total moves by it before the update
#: (:func:`bind`); an INS this far off in height has no solution left.
CLOCK_JUMP_M = 1000.0
#: Likewise the clock's drift [m/s] from the median range-rate residual: a free-running
#: crystal drifts by up to a few ppm (the GSI stations' receivers: +418 and -323 m/s),
#: beyond the drift's 1-sigma at the start; past this the first epoch with Dopplers sets it.
CLOCK_DRIFT_JUMP_MPS = 50.0

#: The antenna's position and velocity error rows (:func:`row_jacobian`'s kinds).
_KINDS = np.array([POS_E, POS_N, POS_U, VEL_E, VEL_N, VEL_U], dtype=np.int64)
_ONE_DEG = math.radians(1.0)


@numba.njit(cache=True)
def median(v) -> float:
    """``np.median`` of a short 1-D array, to the bit (the mean of the two middle values
    of an even count; NaN when one is NaN)."""
    s = np.sort(v)
    n = s.shape[0]
    if np.isnan(s[-1]):  # (sorted last)
        return np.nan
    return s[n // 2] if n % 2 else (s[n // 2 - 1] + s[n // 2]) / 2.0


@numba.extending.register_jitable
def elevation_sigma(sigma_zenith, el):
    """1-sigma at elevation ``el`` [rad] of a ranging error of 1-sigma ``sigma_zenith``
    at the zenith: ``sigma sqrt((1 + 1 / sin^2 el) / 2)`` (RTKLIB's weighting, equal
    parts constant and elevation-dependent; scalars or arrays)."""
    s = np.sin(np.maximum(el, _ONE_DEG))
    return sigma_zenith * np.sqrt(0.5 * (1.0 + 1.0 / (s * s)))


@numba.njit(cache=True)
def antenna(view, lever):
    """The antenna at ``lever`` (body right-forward-up [m]) from the INS ``view``
    (:data:`~fednav.sensors.measurement.View`: position [rad, rad, m], ENU velocity [m/s],
    attitude C_b^n, body rate [rad/s]): its ECEF position ``r`` [m] and velocity ``v``
    [m/s], ``C_n^e`` there, its latitude, longitude and height, and ``turn`` (3, 2) =
    d(C_n^e v_enu)/d(east, north) [1/s]: how the ECEF velocity of a fixed ENU velocity
    turns with the local frame as the position moves (a term of 1e-6 per second)."""
    lla, vel, C, omega = view.lla, view.vel, view.C, view.omega
    lat, lon, h = lla[0], lla[1], lla[2]
    ve = np.empty(3)
    for i in range(3):
        ve[i] = vel[i]
    if lever[0] != 0.0 or lever[1] != 0.0 or lever[2] != 0.0:
        d = np.zeros(3)
        w = np.array([omega[1] * lever[2] - omega[2] * lever[1],
                      omega[2] * lever[0] - omega[0] * lever[2],
                      omega[0] * lever[1] - omega[1] * lever[0]])
        for i in range(3):
            for j in range(3):
                d[i] += C[i, j] * lever[j]
                ve[i] += C[i, j] * w[j]
        lat, lon, h = earth.moved_nb(lat, lon, h, d[0], d[1], d[2])
    sl, cl, so, co = math.sin(lat), math.cos(lat), math.sin(lon), math.cos(lon)
    Cne = np.array([[-so, -sl * co, cl * co], [co, -sl * so, cl * so], [0.0, cl, sl]])
    rm, rn = earth.radii_nb(lat)
    r = np.array([(rn + h) * cl * co, (rn + h) * cl * so, (rn * (1.0 - earth.E2) + h) * sl])
    v = np.zeros(3)
    for i in range(3):
        for j in range(3):
            v[i] += Cne[i, j] * ve[j]
    d_lat = np.array([[0.0, -cl * co, -sl * co], [0.0, -cl * so, -sl * so], [0.0, -sl, cl]])
    d_lon = np.array([[-co, sl * so, -cl * so], [-so, -sl * co, cl * co], [0.0, 0.0, 0.0]])
    turn = np.zeros((3, 2))
    for i in range(3):
        for j in range(3):
            turn[i, 0] += d_lon[i, j] * ve[j]
            turn[i, 1] += d_lat[i, j] * ve[j]
        turn[i, 0] /= (rn + h) * cl
        turn[i, 1] /= rm + h
    return r, v, Cne, np.array([lat, lon, h]), turn


@numba.njit(cache=True)
def usable(z, ant, figures):
    """The satellites of measurement ``z`` (:data:`WIDTH` values) that have a number,
    position, velocity and pseudorange (and no non-positive 1-sigma of it), above the
    elevation mask seen from the antenna ``ant`` (:func:`antenna`), as rows (m,
    :data:`NF`) in slot order: a missing 1-sigma filled with the zenith figure scaled by
    elevation (:func:`elevation_sigma`), the range rate NaN where its 1-sigma is not
    positive (no range-rate row).  ``figures`` = (mask [rad], zenith 1-sigma of a
    pseudorange [m] and of a range rate [m/s])."""
    r, lla = ant[0], ant[3]
    mask, sigma_pr, sigma_rr = figures[0], figures[1], figures[2]
    out = np.empty((SLOTS, NF))
    sl, cl = math.sin(lla[0]), math.cos(lla[0])
    so, co = math.sin(lla[1]), math.cos(lla[1])
    m = 0
    for i in range(SLOTS):
        s = z[i * NF:(i + 1) * NF]
        ok = True
        for j in range(PR + 1):
            ok = ok and math.isfinite(s[j])
        if not ok or s[SPR] <= 0.0:
            continue
        dx, dy, dz = s[SX] - r[0], s[SY] - r[1], s[SZ] - r[2]
        east = -so * dx + co * dy
        north = -sl * co * dx - sl * so * dy + cl * dz
        up = cl * co * dx + cl * so * dy + sl * dz
        el = math.atan2(up, math.hypot(east, north))
        if not el >= mask:
            continue
        for j in range(NF):
            out[m, j] = s[j]
        if s[SRR] <= 0.0:
            out[m, RR] = np.nan
        if not math.isfinite(out[m, SPR]):
            out[m, SPR] = elevation_sigma(sigma_pr, el)
        if not math.isfinite(out[m, SRR]):
            out[m, SRR] = elevation_sigma(sigma_rr, el)
        m += 1
    return out[:m]


@numba.njit(cache=True)
def rows(sat, ant, J, clock, dt, n, ic):
    """The rows of satellites ``sat`` (:func:`usable`) seen by the antenna ``ant``
    (:func:`antenna`) with the receiver clock's bias and drift ``clock`` [m, m/s] at the
    filter epoch, the measurement valid ``dt`` [s] after it:
    each satellite's pseudorange row, then the range-rate rows of those with a finite
    range rate.  ``J`` (6, 18): the antenna's ENU position and velocity errors against
    the 18 core states (:func:`row_jacobian` with the lever arm).  Returns the residuals
    ``y`` (INS-derived - measured) and ``H`` (d, ``n``) with the clock's bias and drift in
    columns ``ic``, ``ic + 1`` (:mod:`fednav.sensors.gnss_raw`'s model)."""
    r, v, Cne, turn = ant[0], ant[1], ant[2], ant[4]
    cb, cd = clock[0], clock[1]
    m = sat.shape[0]
    d = m
    for i in range(m):
        if math.isfinite(sat[i, RR]):
            d += 1
    y = np.empty(d)
    H = np.zeros((d, n))
    cbt = cb + dt * cd  # (the bias at the measurement's time)
    k = m
    un = np.empty(3)
    gn = np.empty(3)
    for i in range(m):
        dx, dy, dz = sat[i, SX] - r[0], sat[i, SY] - r[1], sat[i, SZ] - r[2]
        rho = math.sqrt(dx * dx + dy * dy + dz * dz)
        u0, u1, u2 = dx / rho, dy / rho, dz / rho
        w0, w1, w2 = sat[i, SVX] - v[0], sat[i, SVY] - v[1], sat[i, SVZ] - v[2]
        rhod = u0 * w0 + u1 * w1 + u2 * w2
        y[i] = rho + cbt - sat[i, PR]
        for j in range(3):  # the line of sight in ENU
            un[j] = u0 * Cne[0, j] + u1 * Cne[1, j] + u2 * Cne[2, j]
        for c in range(N_STATES):
            H[i, c] = -(un[0] * J[0, c] + un[1] * J[1, c] + un[2] * J[2, c])
        H[i, ic] = -1.0
        H[i, ic + 1] = -dt  # (the bias at t: its error dcb + dt dcd)
        if not math.isfinite(sat[i, RR]):
            continue
        y[k] = rhod + cd - sat[i, RR]
        g0, g1, g2 = (w0 - rhod * u0) / rho, (w1 - rhod * u1) / rho, (w2 - rhod * u2) / rho
        for j in range(3):
            gn[j] = g0 * Cne[0, j] + g1 * Cne[1, j] + g2 * Cne[2, j]
        for j in range(2):  # (the antenna's ECEF velocity turns with its frame)
            gn[j] += u0 * turn[0, j] + u1 * turn[1, j] + u2 * turn[2, j]
        for c in range(N_STATES):
            H[k, c] = (-(un[0] * J[3, c] + un[1] * J[4, c] + un[2] * J[5, c])
                       - (gn[0] * J[0, c] + gn[1] * J[1, c] + gn[2] * J[2, c]))
        H[k, ic + 1] = -1.0
        k += 1
    return y, H


@numba.njit(cache=True)
def _jacobian(view, lever):
    """The antenna's ENU position and velocity error rows against the 18 core states."""
    J = np.zeros((6, N_STATES))
    row_jacobian(_KINDS, view.lla, view.vel, view.C, view.omega, lever, J)
    return J


@numba.njit(cache=True)
def antenna_rows(sat, view, lever, clock, dt, n, ic):
    """:func:`rows` of ``sat`` against the INS ``view`` (the antenna at ``lever``)."""
    return rows(sat, antenna(view, lever), _jacobian(view, lever), clock, dt, n, ic)


@numba.njit(cache=True)
def bind(z, view, lever, clock, dt, figures, n, ic):
    """The rows of measurement ``z`` (valid ``dt`` [s] after the filter epoch) against the
    INS ``view`` with the antenna at ``lever``: the satellites used (:func:`usable`, with
    ``figures``), their residuals and ``H`` (:func:`rows`), and whether the clock totals
    ``clock`` = (bias [m], drift [m/s]) moved first: by the median range-rate residual
    when beyond :data:`CLOCK_DRIFT_JUMP_MPS` (the first epoch's drift), by the median
    pseudorange residual when beyond :data:`CLOCK_JUMP_M` (a receiver's millisecond jump,
    or the first epoch's bias) — ``clock`` is changed in place and the rows are those
    after the move."""
    ant = antenna(view, lever)
    sat = usable(z, ant, figures)
    J = _jacobian(view, lever)
    y, H = rows(sat, ant, J, clock, dt, n, ic)
    m = sat.shape[0]
    moved = False
    if m:
        jump = median(y[:m])
        drift = median(y[m:]) if y.shape[0] > m else 0.0
        if abs(drift) > CLOCK_DRIFT_JUMP_MPS:
            clock[1] -= drift
            moved = True
        if abs(jump) > CLOCK_JUMP_M:
            clock[0] -= jump
            moved = True
        if moved:
            y, H = rows(sat, ant, J, clock, dt, n, ic)
    return sat, y, H, moved


@numba.njit(cache=True)
def noise(sat):
    """The rows' noise covariance (diagonal) [m^2, (m/s)^2] and each row's satellite
    number and id (``2 prn`` a pseudorange, ``2 prn + 1`` a range rate): what fault
    detection leaves out together and what the lockout guard compares."""
    m = sat.shape[0]
    d = m
    for i in range(m):
        if math.isfinite(sat[i, RR]):
            d += 1
    R = np.zeros((d, d))
    groups = np.empty(d, dtype=np.int64)
    ids = np.empty(d, dtype=np.int64)
    k = m
    for i in range(m):
        prn = np.int64(sat[i, PRN])
        R[i, i] = sat[i, SPR] * sat[i, SPR]
        groups[i], ids[i] = prn, 2 * prn
        if math.isfinite(sat[i, RR]):
            R[k, k] = sat[i, SRR] * sat[i, SRR]
            groups[k], ids[k] = prn, 2 * prn + 1
            k += 1
    return R, groups, ids


@numba.njit(cache=True)
def points_rows(X, H):
    """``X H'``: the rows of the points ``X`` (p, n) (a linear model's ``h``)."""
    p, n = X.shape
    d = H.shape[0]
    Z = np.empty((p, d))
    for i in range(p):
        for r in range(d):
            s = 0.0
            for c in range(n):
                s += H[r, c] * X[i, c]
            Z[i, r] = s
    return Z
