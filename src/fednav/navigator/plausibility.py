"""Physical plausibility checks of a run's data and solution: what the health monitor
(:func:`fednav.navigator.health.run_health`) adds to the innovation statistics, for
corruptions the filter absorbs without large innovations.

- **Stuck axis**: an IMU axis whose output does not change for :data:`STUCK_S` while the
  GNSS says the vehicle moves (any real sensor's output changes then: vibration, noise).
- **At rest** (the GNSS speed below :data:`REST_SPEED` and the accelerometers quiet for
  :data:`REST_S`): the specific force's magnitude must be gravity's within the
  accelerometer bias figure; the gyros' mean rate must be the Earth rate within the gyro
  bias figure; and the solution's pitch and roll must agree with the accelerometers'
  levelling (a gyro axis in another unit or scale, or stuck, tilts the solution while the
  GNSS-only innovations stay small).
- **GNSS residuals**: the GNSS fixes minus the solution just before each update, per axis,
  normalised by their predicted sigma: a mean (bias) beyond :data:`BIAS_LIMIT` sigma on an
  axis.
- **GNSS positions vs their velocities' integral** (:func:`fix_scale_check`): a position
  axis in another unit.
- **GNSS-IMU time offset** (:func:`imu_fix_offset`): the GNSS velocity's changes
  correlated with the IMU's.

Thresholds hold several sigmas of each statistic (false alarms on the clean data of the
tests and the docs: none; docs/reliability.md gives the measured rates).  Every function
returns warnings (strings naming the check, the figure, where, and the likely causes).
Units SI; ENU navigation frame; body right-forward-up.
"""

from __future__ import annotations

from functools import lru_cache

import numba
import numpy as np

from ..core import attitude as att
from ..core import earth, kernels, units
from ..core.kernels import dcm_of_sincos
from ..core.samples import midpoints
from ..ins import stops
from ..ins.alignment import coarse_level
from ..sensors.registry import label

#: An IMU axis unchanged for this long [s] while the vehicle moves is stuck.
STUCK_S = 2.0
#: GNSS speed [m/s] below which (and its 3 sigma) the vehicle may be at rest ...
REST_SPEED = 0.1
#: ... for at least this long [s], with the accelerometers quiet.
REST_S = 3.0
#: Sigmas of the figures a statistic at rest may be off before a warning.
REST_SIGMAS = 5.0
#: An axis scattering at rest this many times more (or less) than its triad's median
#: axis is in another unit or scale (a real triad's axes differ by a factor 2 or 3).
NOISE_RATIO = 5.0
#: Floor of the gravity check [m/s^2] (local gravity models and scale factors).
GRAVITY_FLOOR = 0.05
#: Mean normalised GNSS residual of an axis beyond which it is biased (in sigmas of one
#: residual: a mean of half a sigma over the whole run is no noise).
BIAS_LIMIT = 0.5
#: Time offsets [s] the correlation reports (when beyond 5 of its sigmas) ...
OFFSET_LIMIT_S = 0.05
#: ... from the GNSS velocity's changes over this window [s] ...
OFFSET_WINDOW_S = 1.0
#: ... searched over +- this [s] (larger offsets: the GNSS course check of ``process``).
OFFSET_SEARCH_S = 1.0
#: The lag is only told where the IMU's velocity changes explain the GNSS's: the best
#: misfit at most this share of the GNSS changes' own scatter (a slow, vibrating rover's
#: IMU changes are noise beside its GNSS's, and any lag "fits").
EXPLAINED = 0.5


@numba.njit(cache=True)
def median_step(t):
    """The median of the steps of ``t`` (N >= 2,) [s] (``np.median(np.diff(t))``)."""
    return np.median(t[1:] - t[:-1])


@numba.njit(cache=True)
def imu_pass(t, gyro, accel, W, stuck_s):
    """The per-sample statistics of the IMU checks, in one pass over the samples.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Sample times [s], increasing.
    gyro, accel : ndarray, shape (N, 3)
        Angular rate [rad/s] and specific force [m/s^2], body axes.
    W : int
        Samples of the stillness detector's window (:func:`fednav.ins.stops.stationary`'s,
        shifted inside the data at the ends).
    stuck_s : float
        Duration [s] (>= 0) beyond which a run of one constant value is reported.

    Returns
    -------
    runs : ndarray of int64, shape (M, 3)
        The runs of equal consecutive values (a zero difference) lasting more than
        ``stuck_s``: axis (0..2 gyro x, y, z; 3..5 accel x, y, z), first and last sample,
        by axis, then time.
    scatter : ndarray, shape (N,)
        Each sample's window sum of ``||a_i - mean(a)||^2`` of the specific force
        [m^2/s^4] (the accelerometer term of the SHOE detector:
        :func:`fednav.ins.stops.window_scatter`, as :func:`fednav.ins.stops.stationary`
        takes it).
    """
    n = len(t)
    found = []
    repeats = 0  # values equal to the axis' previous one, all axes (rows in memory order)
    for x in (np.ravel(gyro), np.ravel(accel)):
        for i in range(len(x) - 3):
            repeats += x[i + 3] - x[i] == 0.0
    for a in range(6 if repeats else 0):  # (by axis, then time; none: every run one long)
        x = gyro[:, a] if a < 3 else accel[:, a - 3]
        start = 0
        for i in range(n):
            if i == n - 1 or x[i + 1] - x[i] != 0.0:  # (as np.diff: NaN and inf end a run)
                if t[i] - t[start] > stuck_s:
                    found.append((a, start, i))
                start = i + 1
    runs = np.empty((len(found), 3), dtype=np.int64)
    for r in range(len(found)):
        runs[r, 0], runs[r, 1], runs[r, 2] = found[r]
    return runs, stops.window_scatter(accel, W)


def stuck_axes(t, gyro, accel, runs, t_fix, vel_fix) -> list[str]:
    """Warnings for IMU axes constant for more than :data:`STUCK_S` while the GNSS speed
    (``vel_fix`` [m/s] at ``t_fix`` [s]) says the vehicle moves (above 1 m/s over most
    of the run) and another axis of the same triad changes; ``runs`` the long constant
    runs of :func:`imu_pass`."""
    out = []
    fast = (np.linalg.norm(vel_fix, axis=1) > 1.0).astype(float) if len(runs) else None
    for j in range(6):
        name, a = ("gyro", gyro) if j < 3 else ("accel", accel)
        for s, e in runs[runs[:, 0] == j, 1:]:
            seg = np.delete(a[s:e + 1], j % 3, axis=1)
            tt = t[s:e + 1]
            moving = np.interp(tt, t_fix, fast) > 0.5
            moving &= (tt >= t_fix[0]) & (tt <= t_fix[-1])
            # (an ideal simulated IMU on a steady path is constant on every axis)
            if moving.mean() > 0.5 and np.any(seg != seg[0]):
                out.append(f"IMU {name} {'xyz'[j % 3]} reads {a[s, j % 3]:.6g} unchanged from "
                           f"{t[s]:.1f} s to {t[e]:.1f} s while the vehicle moves: a stuck "
                           f"axis (a sensor fault, or a column filled with a constant)")
                break
    return out


def _percentile(x, d, p, floor=np.inf):
    """The ``p``-th percentile of ``x / d`` (``d`` > 0) as ``np.percentile`` (linear)
    gives it; inf where it is at least ``floor`` (to within 1e-15: no more samples below
    it than the percentile's rank, counted without the selection).  numpy's own
    selection (called once per recording: compiling it cost ~10 s of a first run)."""
    n = len(x)
    v = (n - 1) * (p / 100.0)
    k = int(np.floor(v))
    if 0 <= v < n - 1 and floor < np.inf:
        if np.count_nonzero(x < floor * d) <= k:
            return np.inf
    y = x / d
    if np.isnan(y).any():
        return np.nan
    if v >= n - 1:
        return y.max()
    if v < 0:
        return y.min()
    part = np.partition(y, k)
    lo, hi = float(part[k]), float(part[k + 1:].min())
    g = v - k
    return hi - (hi - lo) * (1.0 - g) if g >= 0.5 else lo + (hi - lo) * g


@lru_cache(maxsize=64)
def _chi2_ppf(p: float, dof: int) -> float:
    from ..core.stats import chi2_ppf

    return float(chi2_ppf(p, dof))


@numba.njit(cache=True)
def _rest_runs(t, scatter, sa2, thr, t_fix, slow_g, min_s):
    """Spans (K, 2) [s] of consecutive samples still (``scatter / sa2 <= thr``), slow
    (``slow_g`` 1.0 or 0.0 at ``t_fix``, interpolated, above 0.999) and within the GNSS
    times, lasting at least ``min_s``."""
    n, m = len(t), len(t_fix)
    out = []
    a = -1
    j = 0
    for i in range(n + 1):
        ok = (i < n and t[i] >= t_fix[0] and t[i] <= t_fix[-1]
              and scatter[i] / sa2 <= thr)
        if ok:  # slow: np.interp's value there (bracket t_fix[j] <= t < t_fix[j + 1])
            while j < m - 1 and t_fix[j + 1] <= t[i]:
                j += 1
            if j == m - 1 or t_fix[j] == t[i]:
                ok = slow_g[j] > 0.999
            else:
                slope = (slow_g[j + 1] - slow_g[j]) / (t_fix[j + 1] - t_fix[j])
                ok = slope * (t[i] - t_fix[j]) + slow_g[j] > 0.999
        if ok and a < 0:
            a = i
        elif not ok and a >= 0:
            if t[i - 1] - t[a] >= min_s:
                out.append((t[a], t[i - 1]))
            a = -1
    spans = np.empty((len(out), 2))
    for k in range(len(out)):
        spans[k, 0], spans[k, 1] = out[k]
    return spans


def rest_spans(t, scatter, dt, accel_vrw, t_fix, vel_fix, sigma_v) -> list[tuple[float,
                                                                                float]]:
    """Spans ``(start, end)`` [s] at rest: the GNSS speed below :data:`REST_SPEED` (and 3
    sigma of its velocity) and the accelerometers still for :data:`REST_S`: the SHOE
    detector's accelerometer term alone (:func:`fednav.ins.stops.stationary` with the
    gyros left out: a corrupted gyro must not hide a stop) on ``scatter``
    (:func:`imu_pass`, period ``dt`` [s], white noise ``accel_vrw`` [m/s/sqrt(s)])."""
    n = len(t)
    if vel_fix is None or len(t_fix) < 3 or n == 0:
        return []
    speed = np.linalg.norm(vel_fix, axis=1)
    slow_g = speed < max(REST_SPEED, 3.0 * float(np.max(sigma_v)))
    # stationary's noise floor at rest: the figure's, unless the recording's quietest
    # windows are less than half as noisy
    W = max(2, int(round(stops.WINDOW_S / dt)))
    cnt = min(W, n)
    p = stops.QUIET_PERCENTILE
    ratio = _chi2_ppf(p / 100.0, 3 * (W - 1)) / (3 * (W - 1))
    sa2 = accel_vrw**2 / dt
    quiet = _percentile(scatter, 3.0 * max(cnt - 1, 1), p,
                        0.5 * sa2 * ratio * (1.0 + 1e-9)) / ratio
    sa2 = stops.rest_variance(quiet, sa2, 1e-24)
    thr = _chi2_ppf(1.0 - stops.ALPHA, 3 * (cnt - 1) + 3 * cnt)
    spans = _rest_runs(t, scatter, sa2, thr, t_fix, slow_g.astype(float), REST_S)
    return [(float(a), float(b)) for a, b in spans]


@numba.njit(cache=True)
def _moments(gyro, accel):
    """Means and standard deviations per axis of ``gyro`` and ``accel`` (n, 3): rows mean,
    sd, mean, sd; summed in order, as numpy's ``mean(axis=0)`` and ``std(axis=0)`` do."""
    n = len(gyro)
    out = np.zeros((4, 3))
    for r in range(2):
        x = gyro if r == 0 else accel
        for i in range(n):
            for a in range(3):
                out[2 * r, a] += x[i, a]
        for a in range(3):
            out[2 * r, a] /= n
        for i in range(n):
            for a in range(3):
                d = x[i, a] - out[2 * r, a]
                out[2 * r + 1, a] += d * d
        for a in range(3):
            out[2 * r + 1, a] = np.sqrt(out[2 * r + 1, a] / n)
    return out


def at_rest(t, gyro, accel, spans, lla, figures, solution=None) -> list[str]:
    """Gravity, Earth-rate and levelling checks over the rest ``spans``; ``lla`` a
    position of the run [rad, rad, m]; ``figures`` the IMU's SI figures
    (:func:`fednav.process.run.imu_figures` keys); ``solution`` the forward
    :class:`~fednav.navigator.solution.Solution` (for the levelling check)."""
    out = []
    if not spans:
        return out
    fig = lambda k: float(figures.get(k) or 0.0)  # noqa: E731
    ab = np.hypot(fig("accel_bias_mps2"), fig("accel_markov_mps2"))
    gb = np.hypot(fig("gyro_bias_radps"), fig("gyro_markov_radps"))
    arw, vrw = fig("gyro_arw_rad_sqrt_s"), fig("accel_vrw_mps_sqrt_s")
    g = float(earth.gravity(lla[0], lla[2]))
    said = set()
    for a, b in spans:
        m = slice(np.searchsorted(t, a), np.searchsorted(t, b, side="right"))  # (t increases)
        T = b - a
        moments = _moments(gyro[m], accel[m])
        w, f = moments[0], moments[2]
        mag = float(np.linalg.norm(f))
        tol = max(REST_SIGMAS * (np.sqrt(3.0) * ab + vrw / np.sqrt(T)), GRAVITY_FLOOR)
        if "gravity" not in said and abs(mag - g) > tol:
            said.add("gravity")
            out.append(f"at rest ({a:.1f}..{b:.1f} s) the accelerometers read {mag:.4g} m/s^2 "
                       f"where gravity is {g:.4g} m/s^2 (bias figure {ab:.2g} m/s^2): an "
                       f"accelerometer unit or scale factor, or an axis stuck or exchanged")
        rate = float(np.linalg.norm(w))
        sw = np.sqrt(gb**2 + arw**2 / T)  # one axis' mean rate: its bias and noise
        j = int(np.argmax(np.abs(w)))
        if "earth rate" not in said and abs(w[j]) > earth.OMEGA_IE + REST_SIGMAS * sw:
            said.add("earth rate")
            out.append(f"at rest ({a:.1f}..{b:.1f} s) the gyro {'xyz'[j]} reads "
                       f"{units.to_deg_per_h(w[j]):.4g} deg/h where the Earth turns at "
                       f"15.04 deg/h (bias figure {units.to_deg_per_h(gb):.3g} deg/h): a gyro "
                       f"axis in another unit or scale, stuck or offset, or a platform "
                       f"turning while the vehicle stands")
        elif ("earth rate" not in said and REST_SIGMAS * sw < 0.5 * earth.OMEGA_IE
              and rate < earth.OMEGA_IE - REST_SIGMAS * sw):
            said.add("earth rate")
            out.append(f"at rest ({a:.1f}..{b:.1f} s) the gyros read "
                       f"{units.to_deg_per_h(rate):.3g} deg/h, less than the Earth's 15.04 "
                       f"deg/h that gyros of this grade see: a gyro unit, or an axis stuck "
                       f"at zero")
        for name, sd in (("gyro", moments[1]), ("accel", moments[3])):
            ref = sorted(sd)[1]  # (the median of three)
            j = int(np.argmax(np.abs(np.log(np.maximum(sd, 1e-300) / max(ref, 1e-300)))))
            if (name not in said and ref > 0 and sd[j] > 0
                    and not 1 / NOISE_RATIO < sd[j] / ref < NOISE_RATIO):
                said.add(name)
                out.append(f"at rest ({a:.1f}..{b:.1f} s) the {name} {'xyz'[j]} scatters "
                           f"{sd[j] / ref:.3g} times as much as the triad's median axis: "
                           f"that axis in another unit or scale (deg vs rad, g vs m/s^2)")
        if solution is None or "level" in said:
            continue
        ms = slice(np.searchsorted(solution.t, a), np.searchsorted(solution.t, b, side="right"))
        if ms.stop <= ms.start:
            continue
        lev = coarse_level(f)[:2]
        q, sigma = _mean_quaternion(solution.euler[ms], solution.sigma_euler[ms])
        sol = att.dcm_to_euler(kernels.quat_to_dcm(q))[:2]  # (att.quat_to_euler's steps)
        d = att.wrap_pi(sol - lev)
        s = np.hypot(sigma, ab / g)
        k = int(np.argmax(np.abs(d) / s))
        if abs(d[k]) > REST_SIGMAS * s[k] and abs(d[k]) > units.deg(0.05):
            said.add("level")
            out.append(f"at rest ({a:.1f}..{b:.1f} s) the solution's {('pitch', 'roll')[k]} "
                       f"differs from the accelerometers' levelling by "
                       f"{units.to_deg(d[k]):.3g} deg ({abs(d[k]) / s[k]:.0f} sigma): a gyro "
                       f"axis in another unit or scale, or stuck, or the IMU's axes in "
                       f"another order")
    return out


@numba.njit(cache=True)
def _antenna_rows(k, lla, vel, euler, omega, lever):
    """Position [rad, rad, m] and ENU velocity [m/s] (K, 3) of the antenna at ``lever``
    (body, m) at the solution's rows ``k``: :func:`fednav.core.earth.lever_arm_point`
    (``moved(lla, C l)`` and ``vel + C (omega x l)``, C from
    :func:`fednav.core.kernels.dcm_of_sincos`); the IMU's
    rows without a lever arm."""
    out_p = np.empty((len(k), 3))
    out_v = np.empty((len(k), 3))
    arm = lever[0] != 0.0 or lever[1] != 0.0 or lever[2] != 0.0
    ang = np.empty((3, len(k)))
    for q in range(len(k)):
        for a in range(3):
            ang[a, q] = euler[k[q], a]
    sn, cs = _sincos(ang)
    for q in range(len(k)):
        i = k[q]
        for a in range(3):
            out_p[q, a], out_v[q, a] = lla[i, a], vel[i, a]
        if not arm:
            continue
        c = dcm_of_sincos(sn[0, q], cs[0, q], sn[1, q], cs[1, q], sn[2, q], cs[2, q])
        u0 = omega[i, 1] * lever[2] - omega[i, 2] * lever[1]
        u1 = omega[i, 2] * lever[0] - omega[i, 0] * lever[2]
        u2 = omega[i, 0] * lever[1] - omega[i, 1] * lever[0]
        d = np.empty(3)
        for a in range(3):
            d[a] = c[3 * a] * lever[0] + c[3 * a + 1] * lever[1] + c[3 * a + 2] * lever[2]
            out_v[q, a] += c[3 * a] * u0 + c[3 * a + 1] * u1 + c[3 * a + 2] * u2
        out_p[q, 0], out_p[q, 1], out_p[q, 2] = earth.moved_nb(
            lla[i, 0], lla[i, 1], lla[i, 2], d[0], d[1], d[2])
    return out_p, out_v


@numba.njit(cache=True)
def _mean_and_sigma(z):
    """Per column of ``z`` (n, 3): the mean and its sigma, the scatter widened for the
    serial correlation (the lag-1 autocorrelation, clipped to 0..0.99: a filter lags the
    fixes); sums in order, as numpy's ``axis=0`` reductions form them."""
    n = len(z)
    mean = np.zeros(3)
    se = np.zeros(3)
    for a in range(3):
        for i in range(n):
            mean[a] += z[i, a]
        mean[a] /= n
        lag1, ss = 0.0, 0.0
        for i in range(n):
            d = z[i, a] - mean[a]
            ss += d * d
            if i > 0:
                lag1 += d * (z[i - 1, a] - mean[a])
        rho = min(max(lag1 / max(ss, 1e-300), 0.0), 0.99)
        se[a] = np.sqrt(ss / n) * np.sqrt((1 + rho) / (1 - rho) / n)
    return mean, se


def fix_residuals(solution, fixes) -> dict | None:
    """GNSS fixes minus the forward ``solution`` just before each update (its row before
    the fix's time, moved to the antenna), per ENU axis, and their predicted sigma
    (the fix's and the solution's, independent): ``{"t", "dp", "sp", "dv", "sv"}`` (fix
    times [s], position residuals [m], velocity residuals [m/s] and their sigmas); None
    without usable fixes."""
    t = solution.t
    inside = (fixes.t > t[0]) & (fixes.t <= t[-1])
    if inside.sum() < 10:
        return None
    tg = fixes.t[inside]
    k = np.clip(np.searchsorted(t, tg, side="left") - 1, 0, len(t) - 1)
    lla, vel = _antenna_rows(k, solution.lla, solution.vel, solution.euler, solution.omega,
                             np.asarray(fixes.lever, dtype=float))
    out = {"t": tg}
    rows = fixes.sigma_rows[inside] if fixes.sigma_rows is not None else None
    if fixes.lla is not None:
        g = fixes.lla[inside]
        d = earth.llh_difference_enu(g[:, 0], g[:, 1], g[:, 2], lla[:, 0], lla[:, 1],
                                     lla[:, 2])
        sr = (rows[:, [1, 0, 2]] if rows is not None
              else np.asarray(fixes.sigma_pos_enu, dtype=float)[None, :])
        # (the row is one sample before the fix: its velocity carries it to the fix)
        out["dp"], out["sp"] = _with_sigma(d, -vel, tg - t[k], sr, solution.sigma, k, 6)
    if fixes.vel is not None:
        sr = (rows[:, 3:6] if rows is not None
              else np.asarray(fixes.sigma_vel, dtype=float)[None, :])
        out["dv"], out["sv"] = _with_sigma(fixes.vel[inside], -vel, np.ones(len(tg)), sr,
                                           solution.sigma, k, 3)
    return out


@numba.njit(cache=True)
def _with_sigma(x, y, w, sr, sigma, k, col):
    """Residuals ``x + y w`` (K, 3) (``w`` (K,) per row) and their sigmas, the fix's
    ``sr`` (K, 3, or one row for all) and the solution's ``sigma[k, col:col + 3]``
    combined as independent (``np.hypot``)."""
    n = len(x)
    r = np.empty((n, 3))
    s = np.empty((n, 3))
    for q in range(n):
        i = q if len(sr) > 1 else 0
        for a in range(3):
            r[q, a] = x[q, a] + y[q, a] * w[q]
            s[q, a] = np.hypot(sr[i, a], sigma[k[q], col + a])
    return r, s


#: Rows between exact sines and cosines in :func:`_sincos` (in between: the
#: angle-addition formulas over the change since) ...
RESEED_ROWS = 128
#: ... and the change [rad] beyond which they are exact too.
RESEED_ANGLE = 0.3


@numba.njit(cache=True)
def _sincos(x):
    """Sines and cosines (k, n) of angles ``x`` (k, n) [rad] that change little from one
    of the n to the next (an attitude, a latitude at the IMU rate): exact at a row every
    :data:`RESEED_ROWS` rows and after a change beyond :data:`RESEED_ANGLE` from it; in
    between, that row's turned by the change ``d`` since, with the series of ``sin d``
    and ``cos d`` to ``d^11`` and ``d^12`` (the next terms below 3e-17 for
    ``|d| <= 0.3``; no error carried from row to row).  Two libm calls per angle and row
    were most of the cost of the kernels that use it; the series runs as one branch-free
    (vectorised) loop."""
    k, n = x.shape
    s = np.empty((k, n))
    c = np.empty((k, n))
    for a in range(k):
        xa, sa, ca = x[a], s[a], c[a]
        r = 0
        while r < n:  # a block from an exact row to the next
            xr = xa[r]
            sr, cr = np.sin(xr), np.cos(xr)
            e = min(r + RESEED_ROWS, n)
            far = False
            for i in range(r + 1, e):  # (a branch-free look first: rarely any)
                far |= not abs(xa[i] - xr) <= RESEED_ANGLE
            if far:
                e = r + 1
                while e < min(r + RESEED_ROWS, n) and abs(xa[e] - xr) <= RESEED_ANGLE:
                    e += 1
            for i in range(r, e):
                d = xa[i] - xr
                d2 = d * d  # (Horner on multiplications: a division costs as much as libm)
                sd = d * (1.0 + d2 * (-1.0 / 6 + d2 * (1.0 / 120 + d2 * (-1.0 / 5040 + d2 * (
                    1.0 / 362880 + d2 * (-1.0 / 39916800))))))
                cd = 1.0 + d2 * (-0.5 + d2 * (1.0 / 24 + d2 * (-1.0 / 720 + d2 * (
                    1.0 / 40320 + d2 * (-1.0 / 3628800 + d2 * (1.0 / 479001600))))))
                sa[i] = sr * cd + cr * sd
                ca[i] = cr * cd - sr * sd
            r = e
    return s, c


@numba.njit(cache=True)
def _antenna_velocity(t, t_imu, accel, lla, euler, omega, lever):
    """The IMU's velocity change since ``t[0]`` [m/s] (N, 3), ENU, at the solution's
    rows (times ``t``, position ``lla``, attitude ``euler``, body rate ``omega``): the
    specific force ``accel`` (at ``t_imu``, linearly interpolated) rotated to ENU by
    C_b^n (:func:`fednav.core.kernels.dcm_of_sincos`, from the sines and
    cosines of :func:`_sincos`) plus gravity (:func:`fednav.core.earth.gravity_of_sin2`),
    integrated by trapezoids, moved to the antenna at ``lever`` (body, m) by
    ``C (omega x lever)``.  Row by row only where a row needs the one before (the
    interpolation's bracket, the integral); the rest in branch-free loops."""
    n, m = len(t), len(t_imu)
    ang = np.empty((4, n))  # pitch, roll, heading, latitude
    for i in range(n):
        for a in range(3):
            ang[a, i] = euler[i, a]
        ang[3, i] = lla[i, 0]
    sn, cs = _sincos(ang)
    f = np.empty((3, n))
    p = 0
    for i in range(n):
        ti = t[i]  # np.interp's bracket (times increase: it only moves on)
        while p < m - 1 and t_imu[p + 1] <= ti:
            p += 1
        w = 0.0
        if ti >= t_imu[0] and p < m - 1:
            w = (ti - t_imu[p]) / (t_imu[p + 1] - t_imu[p])
        q = min(p + 1, m - 1)
        for a in range(3):
            f[a, i] = accel[p, a] + w * (accel[q, a] - accel[p, a])
    st, sg, sp, sl = sn[0], sn[1], sn[2], sn[3]
    ct, cg, cp = cs[0], cs[1], cs[2]
    h = lla[:, 2].copy()
    g = np.empty(n)
    for i in range(n):
        g[i] = earth.gravity_of_sin2_nb(sl[i] * sl[i], h[i])
    e = np.empty((3, n))
    la = np.empty((3, n))
    arm = lever[0] != 0.0 or lever[1] != 0.0 or lever[2] != 0.0
    u = np.zeros((3, n))
    if arm:
        for i in range(n):
            u[0, i] = omega[i, 1] * lever[2] - omega[i, 2] * lever[1]
            u[1, i] = omega[i, 2] * lever[0] - omega[i, 0] * lever[2]
            u[2, i] = omega[i, 0] * lever[1] - omega[i, 1] * lever[0]
    for i in range(n):
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = dcm_of_sincos(
            st[i], ct[i], sg[i], cg[i], sp[i], cp[i])
        e[0, i] = c00 * f[0, i] + c01 * f[1, i] + c02 * f[2, i]
        e[1, i] = c10 * f[0, i] + c11 * f[1, i] + c12 * f[2, i]
        e[2, i] = c20 * f[0, i] + c21 * f[1, i] + c22 * f[2, i] - g[i]
        # the antenna's velocity relative to the IMU: C (omega x lever) (zero without)
        la[0, i] = c00 * u[0, i] + c01 * u[1, i] + c02 * u[2, i]
        la[1, i] = c10 * u[0, i] + c11 * u[1, i] + c12 * u[2, i]
        la[2, i] = c20 * u[0, i] + c21 * u[1, i] + c22 * u[2, i]
    V = np.empty((n, 3))
    v0 = v1 = v2 = 0.0
    for i in range(n):
        if i > 0:
            dt2 = 0.5 * (t[i] - t[i - 1])
            v0 += (e[0, i] + e[0, i - 1]) * dt2
            v1 += (e[1, i] + e[1, i - 1]) * dt2
            v2 += (e[2, i] + e[2, i - 1]) * dt2
        V[i, 0], V[i, 1], V[i, 2] = v0 + la[0, i], v1 + la[1, i], v2 + la[2, i]
    return V


@numba.njit(cache=True)
def _mean_quaternion(euler, sigma_euler):
    """The mean of the unit quaternions q_b^n of the attitudes ``euler`` (n, 3) [pitch,
    roll, heading] [rad], each signed as the first (the mean of
    ``att.euler_to_quat(euler)`` so aligned; ``C = Rz(-heading) Rx(pitch) Ry(roll)`` as
    the product of the three rotations' quaternions, :func:`_sincos` of the half
    angles); and the mean of the first two columns of their 1-sigma ``sigma_euler``
    [rad] (summed in order, as numpy's ``mean(axis=0)``)."""
    sigma = np.zeros(2)
    for i in range(len(sigma_euler)):
        sigma[0] += sigma_euler[i, 0]
        sigma[1] += sigma_euler[i, 1]
    sigma /= len(sigma_euler)
    sn, cs = _sincos(0.5 * np.ascontiguousarray(euler.T))
    out = np.zeros(4)
    q0 = np.zeros(4)
    for i in range(len(euler)):
        a = kernels.quat_mul_s(cs[0, i], sn[0, i], 0.0, 0.0, cs[1, i], 0.0, sn[1, i], 0.0)
        q = kernels.quat_mul_s(cs[2, i], 0.0, 0.0, -sn[2, i], a[0], a[1], a[2], a[3])
        if i == 0:
            for r in range(4):
                q0[r] = q[r]
        dot = q[0] * q0[0] + q[1] * q0[1] + q[2] * q0[2] + q[3] * q0[3]
        sign = 1.0 if dot > 0 else (-1.0 if dot < 0 else 0.0)
        for r in range(4):
            out[r] += sign * q[r]
    return out / len(euler), sigma


@numba.njit(cache=True)
def _offset_misfit(t, V, tg, k, j, dvg, lags):
    """Per lag ``lags[l]`` [s]: the sum of squares of the GNSS velocity changes ``dvg``
    (K, 3) over fix pairs (``j``, ``k``) minus the IMU velocity ``V`` (N, 3, at times
    ``t``) linearly interpolated at the fixes' times ``tg`` minus the lag (from the
    bracket ``t[p] <= x < t[p + 1]``, p in 0..N-2), each axis's mean misfit removed (a
    tilt's or a bias's constant part)."""
    n, G, K = len(t), len(tg), len(k)
    cost = np.empty(len(lags))
    Vx = np.empty((G, 3))
    r = np.empty((K, 3))
    at = np.zeros(G, dtype=np.int64)  # each fix's bracket at the previous lag
    for li in range(len(lags)):
        for g in range(G):
            x = tg[g] - lags[li]
            p = at[g] if li > 0 else (at[g - 1] if g > 0 else 0)
            while p > 0 and t[p] > x:
                p -= 1
            while p < n - 2 and t[p + 1] <= x:
                p += 1
            at[g] = p
            w = (x - t[p]) / (t[p + 1] - t[p])
            for a in range(3):
                Vx[g, a] = (1.0 - w) * V[p, a] + w * V[p + 1, a]
        s0 = s1 = s2 = 0.0  # (the three axes' sums side by side: in order along each)
        for q in range(K):
            r[q, 0] = dvg[q, 0] - (Vx[k[q], 0] - Vx[j[q], 0])
            r[q, 1] = dvg[q, 1] - (Vx[k[q], 1] - Vx[j[q], 1])
            r[q, 2] = dvg[q, 2] - (Vx[k[q], 2] - Vx[j[q], 2])
            s0 += r[q, 0]
            s1 += r[q, 1]
            s2 += r[q, 2]
        m0, m1, m2 = s0 / K, s1 / K, s2 / K
        c0 = c1 = c2 = 0.0
        for q in range(K):
            c0 += (r[q, 0] - m0) ** 2
            c1 += (r[q, 1] - m1) ** 2
            c2 += (r[q, 2] - m2) ** 2
        cost[li] = c0 + c1 + c2
    return cost


def imu_fix_offset(solution, imu, fixes, window_s: float = OFFSET_WINDOW_S,
                    search_s: float = OFFSET_SEARCH_S) -> tuple[float, float] | None:
    """The GNSS-IMU time offset [s] (how much later than their time of validity the GNSS
    fixes are stamped) and its 1-sigma, by correlation of the GNSS velocity's changes with
    the IMU's: the specific force rotated to ENU by the ``solution``'s attitude plus
    gravity, integrated, and moved to the antenna (``C (w x lever)``), over the same
    ``window_s`` pairs of fixes; the lag of least
    misfit over +-``search_s`` (an intercept per axis absorbs a tilt's or a bias's
    constant part).  None without GNSS velocities, with too little acceleration change
    to see a lag (a constant-velocity run), or where the best lag's misfit is more than
    :data:`EXPLAINED` of the GNSS changes' scatter."""
    if fixes.vel is None or len(solution.t) < 10:
        return None
    t = solution.t
    # a sample's specific force holds over [t, t + dt]: as a point of the interpolated
    # signal it is its interval's mean, at the midpoint (at its stamp it read every fix
    # half a period late: 0.01 s on a 100 Hz drive)
    V = _antenna_velocity(t, midpoints(imu.t), imu.accel, solution.lla, solution.euler,
                          solution.omega, np.asarray(fixes.lever, dtype=float))
    tg = fixes.t
    period = median_step(tg) if len(tg) > 1 else np.inf
    m = max(1, int(round(window_s / period)))
    k = np.arange(m, len(tg))
    j = k - m
    ok = ((tg[k] - tg[j] <= 1.5 * m * period) & (tg[j] - search_s >= t[0])
          & (tg[k] + search_s <= t[-1]))
    k, j = k[ok], j[ok]
    if len(k) < 20:
        return None
    dvg = fixes.vel[k] - fixes.vel[j]

    def misfit(lags):
        return _offset_misfit(t, V, tg, k, j, dvg, np.asarray(lags, dtype=float))

    # coarse (0.05 s) then fine (0.01 s): the misfit is smooth over the 1 s windows
    lags = np.arange(-search_s, search_s + 1e-9, 0.05)
    cost = misfit(lags)
    i = int(np.argmin(cost))
    if i in (0, len(lags) - 1):
        return None  # at the edge: an offset beyond the search (the course check's)
    lags = lags[i] + np.arange(-0.04, 0.04 + 1e-9, 0.01)
    cost = misfit(lags)
    i = int(np.argmin(cost))
    tau = float(lags[i])
    signal = float(((dvg - dvg.mean(axis=0)) ** 2).sum())
    if cost[i] > EXPLAINED * signal:
        return None  # the IMU's changes do not explain the GNSS's (vibration, a crawl)
    # 1-sigma from the misfit's curvature (Gauss-Newton), widened for the overlapping
    # windows (each fix in m of them)
    h = 0.01
    c0, cm, cp = misfit(np.array([tau, tau - h, tau + h]))
    curv = float(cp + cm - 2 * c0) / h**2
    if curv <= 0:
        return None
    s2 = float(c0) / max(dvg.size - 3, 1)
    return tau, float(np.sqrt(2.0 * s2 / curv * m))


def offset_check(solution, imu, fixes) -> list[str]:
    """A warning when :func:`imu_fix_offset` finds an offset beyond
    :data:`OFFSET_LIMIT_S` and 5 of its sigmas."""
    est = imu_fix_offset(solution, imu, fixes)
    if est is None:
        return []
    tau, s = est
    if abs(tau) > OFFSET_LIMIT_S and abs(tau) > 5.0 * s:
        when = "after" if tau > 0 else "before"
        who = label(fixes.name)
        return [f"{fixes.source}: the {who} velocity's changes match the IMU's best with "
                f"the fixes stamped {abs(tau):.2f} s {when} their time of validity "
                f"(+-{s:.2f} s, by correlation): a {who}-IMU time offset "
                f"(sensors.{fixes.name}.time_offset_s: {-tau:.2f} corrects it), or a "
                f"velocity latency"]
    return []


#: Stretches [s] over which the GNSS positions are compared with their velocities'
#: integral (each its own offset: a velocity bias drifts the integral slowly) ...
SCALE_CHUNK_S = 60.0
#: ... and the slope's distance from 1 that is a warning (beyond 5 of its sigmas too).
SCALE_LIMIT = 0.2


def fix_scale_check(fixes) -> list[str]:
    """Warnings for GNSS position axes (east, north, up) that do not follow the integral
    of the GNSS velocity: the least-squares slope of the positions on the integral (an
    offset per :data:`SCALE_CHUNK_S` stretch) off 1 by more than :data:`SCALE_LIMIT` and
    5 of its sigmas (from the fit's own scatter, widened for serial correlation): a
    height in km or feet, positions in another unit, or a velocity axis in another unit or
    sign.  Along an axis the run hardly travels (the integral's travel within 10 times its
    own noise's) nothing is said."""
    if fixes.lla is None or fixes.vel is None or len(fixes.t) < 10:
        return []
    lla = fixes.lla
    # the positions as their fix-to-fix displacements summed (each in its local ENU
    # axes, as the velocity is: one origin far away bends east and north near a pole)
    step = earth.llh_difference_enu(lla[1:, 0], lla[1:, 1], lla[1:, 2], lla[:-1, 0],
                                    lla[:-1, 1], lla[:-1, 2])
    told, slopes, sigmas = _scale_fit(fixes.t, fixes.vel, step, SCALE_CHUNK_S,
                                      np.asarray(fixes.sigma_vel, dtype=float))
    out = []
    names = ("east", "north", "height")
    for a in range(3):
        slope, sig = float(slopes[a]), float(sigmas[a])
        if told[a] and abs(slope - 1.0) > SCALE_LIMIT and abs(slope - 1.0) > 5.0 * sig:
            out.append(f"{fixes.source}: the {label(fixes.name)} {names[a]} changes "
                       f"{slope:.3g} times as "
                       f"much as its velocity's integral says (+-{sig:.2g}): a {names[a]} "
                       f"in another unit (km, feet, radians), or that velocity axis in "
                       f"another unit or sign")
    return out


@numba.njit(cache=True)
def _scale_fit(t, vel, step, chunk_s, sigma_vel):
    """:func:`fix_scale_check`'s fit per ENU axis: the GNSS velocity's integral (by
    trapezoids, ``vel`` at ``t``) and the summed position ``step`` s (K-1, 3) [m], each
    centred on its mean per ``chunk_s`` stretch; returns whether the integral's travel
    tells (its scatter beyond 100 times its own noise's), the slope of the positions on
    the integral and its sigma (from the fit's scatter, widened for the lag-1
    autocorrelation)."""
    n = len(t)
    x = np.zeros((n, 3))
    y = np.zeros((n, 3))
    for i in range(1, n):
        for a in range(3):
            x[i, a] = x[i - 1, a] + 0.5 * (vel[i, a] + vel[i - 1, a]) * (t[i] - t[i - 1])
            y[i, a] = y[i - 1, a] + step[i - 1, a]
    chunk = np.floor((t - t[0]) / chunk_s).astype(np.int64)
    n_chunks = chunk.max() + 1
    count = np.zeros(n_chunks)
    sums = np.zeros((n_chunks, 6))
    for i in range(n):
        count[chunk[i]] += 1.0
        for a in range(3):
            sums[chunk[i], a] += x[i, a]
            sums[chunk[i], 3 + a] += y[i, a]
    for i in range(n):
        c = max(count[chunk[i]], 1.0)
        for a in range(3):
            x[i, a] -= sums[chunk[i], a] / c
            y[i, a] -= sums[chunk[i], 3 + a] / c
    # The integral's own noise (a random walk of the velocity noise: over n fixes its
    # scatter about the mean is q n^2 / 6, q = (sigma_v period)^2) must be small beside its
    # travel, else the slope is attenuated towards 0 (errors in the regressor): a level
    # drive tells nothing about the height's unit.
    period = np.median(t[1:] - t[:-1])
    n2 = 0.0
    for c in range(n_chunks):
        n2 += count[c] ** 2
    dof = max(n - n_chunks - 1, 1)
    told = np.zeros(3, dtype=np.bool_)
    slopes = np.zeros(3)
    sigmas = np.zeros(3)
    for a in range(3):
        sxx, sxy = 0.0, 0.0
        for i in range(n):
            sxx += x[i, a] * x[i, a]
            sxy += x[i, a] * y[i, a]
        if sxx <= 100.0 * ((sigma_vel[a] * period) ** 2 * n2 / 6.0):
            continue
        slope = sxy / sxx
        rr, r1 = 0.0, 0.0
        for i in range(n):
            r = y[i, a] - slope * x[i, a]
            rr += r * r
            if i > 0:
                r1 += r * (y[i - 1, a] - slope * x[i - 1, a])
        rho = min(max(r1 / max(rr, 1e-300), 0.0), 0.99)
        told[a] = True
        slopes[a] = slope
        sigmas[a] = np.sqrt(rr / dof / sxx * (1 + rho) / (1 - rho))
    return told, slopes, sigmas


def residual_checks(res: dict | None, source: str) -> list[str]:
    """Per-axis bias and time-offset warnings from :func:`fix_residuals`."""
    out = []
    if res is None:
        return out
    names = ("east", "north", "up")
    for key, what, unit in (("dp", "position", "m"), ("dv", "velocity", "m/s")):
        if key not in res:
            continue
        z = res[key] / res["s" + key[1]]
        n = len(z)
        mean, se = _mean_and_sigma(z)
        for j in range(3):
            if abs(mean[j]) > BIAS_LIMIT and abs(mean[j]) > 4.0 * se[j]:
                b = float(np.mean(res[key][:, j]))
                out.append(f"{source}: the GNSS {names[j]} {what} differs from the solution "
                           f"by {b:+.3g} {unit} on average ({mean[j]:+.2f} of its sigma over "
                           f"{n} fixes): a biased or mis-signed axis (NED written as ENU), a "
                           f"lever arm, or a wrong sigma")
                break
    return out


__all__ = ["at_rest", "fix_residuals", "fix_scale_check", "imu_fix_offset", "imu_pass",
           "median_step", "offset_check", "residual_checks", "rest_spans", "stuck_axes"]
