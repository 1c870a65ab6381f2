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
- **GNSS positions vs their velocities' integral** (:func:`gnss_scale_check`): a position
  axis in another unit.
- **GNSS-IMU time offset** (:func:`imu_gnss_offset`): the GNSS velocity's changes
  correlated with the IMU's.

Thresholds hold several sigmas of each statistic (false alarms on the clean data of the
tests and the docs: none; docs/reliability.md gives the measured rates).  Every function
returns warnings (strings naming the check, the figure, where, and the likely causes).
Units SI; ENU navigation frame; body right-forward-up.
"""

from __future__ import annotations

import numba
import numpy as np

from ..core import attitude as att
from ..core import earth, units
from ..ins.alignment import coarse_level
from ..ins.stops import stationary, still_spans

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


def _runs_constant(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end indices (inclusive) of the runs of equal consecutive values of
    ``x`` (N,)."""
    change = np.flatnonzero(np.diff(x) != 0)
    starts = np.r_[0, change + 1]
    ends = np.r_[change, len(x) - 1]
    return starts, ends


def stuck_axes(t, gyro, accel, moving) -> list[str]:
    """Warnings for IMU axes constant for more than :data:`STUCK_S` while ``moving``
    (bool per sample: the GNSS speed says the vehicle moves) and another axis of the
    same triad changes."""
    out = []
    for name, a in (("gyro", gyro), ("accel", accel)):
        for j in range(3):
            s, e = _runs_constant(a[:, j])
            long = (t[e] - t[s] > STUCK_S)
            others = np.delete(a, j, axis=1)
            for k in np.flatnonzero(long):
                seg = others[s[k]:e[k] + 1]
                # (an ideal simulated IMU on a steady path is constant on every axis)
                if moving[s[k]:e[k] + 1].mean() > 0.5 and np.any(seg != seg[0]):
                    out.append(f"IMU {name} {'xyz'[j]} reads {a[s[k], j]:.6g} unchanged from "
                               f"{t[s[k]]:.1f} s to {t[e[k]]:.1f} s while the vehicle moves: "
                               f"a stuck axis (a sensor fault, or a column filled with a "
                               f"constant)")
                    break
    return out


def rest_spans(t, accel, dt, accel_vrw, t_gnss, vel_gnss, sigma_v) -> list[tuple[float,
                                                                              float]]:
    """Spans ``(start, end)`` [s] at rest: the GNSS speed below :data:`REST_SPEED` (and 3
    sigma of its velocity) and the accelerometers still (the SHOE detector's
    accelerometer term alone: a corrupted gyro must not hide a stop) for :data:`REST_S`."""
    if vel_gnss is None or len(t_gnss) < 3:
        return []
    speed = np.linalg.norm(vel_gnss, axis=1)
    slow_g = speed < max(REST_SPEED, 3.0 * float(np.max(sigma_v)))
    slow = np.interp(t, t_gnss, slow_g.astype(float)) > 0.999
    inside = (t >= t_gnss[0]) & (t <= t_gnss[-1])
    still = stationary(np.zeros_like(accel), accel, dt, 1.0, accel_vrw)
    return still_spans(t, slow & inside & still, REST_S)


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
        m = (t >= a) & (t <= b)
        T = b - a
        f = accel[m].mean(axis=0)
        w = gyro[m].mean(axis=0)
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
        for name, x in (("gyro", gyro[m]), ("accel", accel[m])):
            sd = x.std(axis=0)
            ref = np.median(sd)
            j = int(np.argmax(np.abs(np.log(np.maximum(sd, 1e-300) / max(ref, 1e-300)))))
            if (name not in said and ref > 0 and sd[j] > 0
                    and not 1 / NOISE_RATIO < sd[j] / ref < NOISE_RATIO):
                said.add(name)
                out.append(f"at rest ({a:.1f}..{b:.1f} s) the {name} {'xyz'[j]} scatters "
                           f"{sd[j] / ref:.3g} times as much as the triad's median axis: "
                           f"that axis in another unit or scale (deg vs rad, g vs m/s^2)")
        if solution is None or "level" in said:
            continue
        ms = (solution.t >= a) & (solution.t <= b)
        if not ms.any():
            continue
        lev = coarse_level(f)[:2]
        q = att.euler_to_quat(solution.euler[ms])
        sol = att.quat_to_euler(np.mean(q * np.sign(q @ q[0])[:, None], axis=0))[:2]
        d = att.wrap_pi(sol - lev)
        s = np.hypot(solution.sigma_euler[ms, :2].mean(axis=0), ab / g)
        k = int(np.argmax(np.abs(d) / s))
        if abs(d[k]) > REST_SIGMAS * s[k] and abs(d[k]) > units.deg(0.05):
            said.add("level")
            out.append(f"at rest ({a:.1f}..{b:.1f} s) the solution's {('pitch', 'roll')[k]} "
                       f"differs from the accelerometers' levelling by "
                       f"{units.to_deg(d[k]):.3g} deg ({abs(d[k]) / s[k]:.0f} sigma): a gyro "
                       f"axis in another unit or scale, or stuck, or the IMU's axes in "
                       f"another order")
    return out


def gnss_residuals(solution, gnss) -> dict | None:
    """GNSS fixes minus the forward ``solution`` just before each update (its row before
    the fix's time, moved to the antenna), per ENU axis, and their predicted sigma
    (the fix's and the solution's, independent): ``{"t", "dp", "sp", "dv", "sv"}`` (fix
    times [s], position residuals [m], velocity residuals [m/s] and their sigmas); None
    without usable fixes."""
    t = solution.t
    inside = (gnss.t > t[0]) & (gnss.t <= t[-1])
    if inside.sum() < 10:
        return None
    tg = gnss.t[inside]
    k = np.clip(np.searchsorted(t, tg, side="left") - 1, 0, len(t) - 1)
    lla, vel = solution.lla[k], solution.vel[k]
    if np.any(gnss.lever):
        lla, vel = earth.lever_arm_point(lla, vel, att.euler_to_dcm(solution.euler[k]),
                                         solution.omega[k], gnss.lever)
    out = {"t": tg}
    rows = gnss.sigma_rows[inside] if gnss.sigma_rows is not None else None
    if gnss.lla is not None:
        g = gnss.lla[inside]
        d = earth.llh_difference_enu(g[:, 0], g[:, 1], g[:, 2], lla[:, 0], lla[:, 1],
                                     lla[:, 2])
        d -= vel * (tg - t[k])[:, None]  # the row is one sample before the fix
        sr = (rows[:, [1, 0, 2]] if rows is not None
              else np.broadcast_to(np.asarray(gnss.sigma_pos)[[1, 0, 2]], d.shape))
        out["dp"] = d
        out["sp"] = np.hypot(sr, solution.sigma[k][:, 6:9])
    if gnss.vel is not None:
        sr = (rows[:, 3:6] if rows is not None
              else np.broadcast_to(np.asarray(gnss.sigma_vel), (len(tg), 3)))
        out["dv"] = gnss.vel[inside] - vel
        out["sv"] = np.hypot(sr, solution.sigma[k][:, 3:6])
    return out


@numba.njit(cache=True)
def _offset_misfit(t, V, tg, k, j, dvg, lags):
    """Per lag ``lags[l]`` [s]: the sum of squares of the GNSS velocity changes ``dvg``
    (K, 3) over fix pairs (``j``, ``k``) minus the IMU velocity ``V`` (N, 3, at times
    ``t``) linearly interpolated at the fixes' times ``tg`` minus the lag, each axis's
    mean misfit removed (a tilt's or a bias's constant part)."""
    n, G, K = len(t), len(tg), len(k)
    cost = np.empty(len(lags))
    Vx = np.empty((G, 3))
    r = np.empty((K, 3))
    for li in range(len(lags)):
        p = 0
        for g in range(G):  # (fix times increase: the bracket only moves forward)
            x = tg[g] - lags[li]
            while p < n - 2 and t[p + 1] <= x:
                p += 1
            w = (x - t[p]) / (t[p + 1] - t[p])
            for a in range(3):
                Vx[g, a] = (1.0 - w) * V[p, a] + w * V[p + 1, a]
        c = 0.0
        for a in range(3):
            mean = 0.0
            for q in range(K):
                r[q, a] = dvg[q, a] - (Vx[k[q], a] - Vx[j[q], a])
                mean += r[q, a]
            mean /= K
            for q in range(K):
                c += (r[q, a] - mean) ** 2
        cost[li] = c
    return cost


def imu_gnss_offset(solution, imu, gnss, window_s: float = OFFSET_WINDOW_S,
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
    if gnss.vel is None or len(solution.t) < 10:
        return None
    t = solution.t
    f = np.column_stack([np.interp(t, imu.t, imu.accel[:, j]) for j in range(3)])
    g = earth.gravity(solution.lla[:, 0], solution.lla[:, 2])
    C = att.euler_to_dcm(solution.euler)
    a = np.einsum("kij,kj->ki", C, f)
    a[:, 2] -= g
    dt = np.diff(t)
    V = np.vstack([np.zeros(3), np.cumsum(0.5 * (a[1:] + a[:-1]) * dt[:, None], axis=0)])
    if np.any(gnss.lever):  # the antenna's velocity: + C (w x lever)
        V += np.einsum("kij,kj->ki", C, np.cross(solution.omega, gnss.lever))
    tg = gnss.t
    period = float(np.median(np.diff(tg))) if len(tg) > 1 else np.inf
    m = max(1, int(round(window_s / period)))
    k = np.arange(m, len(tg))
    j = k - m
    ok = ((tg[k] - tg[j] <= 1.5 * m * period) & (tg[j] - search_s >= t[0])
          & (tg[k] + search_s <= t[-1]))
    k, j = k[ok], j[ok]
    if len(k) < 20:
        return None
    dvg = gnss.vel[k] - gnss.vel[j]

    def misfit(lags):
        return _offset_misfit(t, V, tg, k, j, dvg, np.asarray(lags, dtype=float)), dvg

    # coarse (0.05 s) then fine (0.01 s): the misfit is smooth over the 1 s windows
    lags = np.arange(-search_s, search_s + 1e-9, 0.05)
    cost, _ = misfit(lags)
    i = int(np.argmin(cost))
    if i in (0, len(lags) - 1):
        return None  # at the edge: an offset beyond the search (the course check's)
    lags = lags[i] + np.arange(-0.04, 0.04 + 1e-9, 0.01)
    cost, _ = misfit(lags)
    i = int(np.argmin(cost))
    tau = float(lags[i])
    signal = float(((dvg - dvg.mean(axis=0)) ** 2).sum())
    if cost[i] > EXPLAINED * signal:
        return None  # the IMU's changes do not explain the GNSS's (vibration, a crawl)
    # 1-sigma from the misfit's curvature (Gauss-Newton), widened for the overlapping
    # windows (each fix in m of them)
    h = 0.01
    c0, r0 = misfit(np.array([tau]))
    cm, cp = misfit(np.array([tau - h]))[0], misfit(np.array([tau + h]))[0]
    curv = float((cp + cm - 2 * c0)[0]) / h**2
    if curv <= 0:
        return None
    s2 = float(c0[0]) / max(r0.size - 3, 1)
    return tau, float(np.sqrt(2.0 * s2 / curv * m))


def offset_check(solution, imu, gnss) -> list[str]:
    """A warning when :func:`imu_gnss_offset` finds an offset beyond
    :data:`OFFSET_LIMIT_S` and 5 of its sigmas."""
    est = imu_gnss_offset(solution, imu, gnss)
    if est is None:
        return []
    tau, s = est
    if abs(tau) > OFFSET_LIMIT_S and abs(tau) > 5.0 * s:
        when = "after" if tau > 0 else "before"
        return [f"{gnss.source}: the GNSS velocity's changes match the IMU's best with the "
                f"fixes stamped {abs(tau):.2f} s {when} their time of validity (+-{s:.2f} s, "
                f"by correlation): a GNSS-IMU time offset (sensors.gnss.time_offset_s: "
                f"{-tau:.2f} corrects it), or a velocity latency"]
    return []


#: Stretches [s] over which the GNSS positions are compared with their velocities'
#: integral (each its own offset: a velocity bias drifts the integral slowly) ...
SCALE_CHUNK_S = 60.0
#: ... and the slope's distance from 1 that is a warning (beyond 5 of its sigmas too).
SCALE_LIMIT = 0.2


def gnss_scale_check(gnss) -> list[str]:
    """Warnings for GNSS position axes (east, north, up) that do not follow the integral
    of the GNSS velocity: the least-squares slope of the positions on the integral (an
    offset per :data:`SCALE_CHUNK_S` stretch) off 1 by more than :data:`SCALE_LIMIT` and
    5 of its sigmas (from the fit's own scatter, widened for serial correlation): a
    height in km or feet, positions in another unit, or a velocity axis in another unit or
    sign.  Along an axis the run hardly travels (the integral's travel within 10 times its
    own noise's) nothing is said."""
    if gnss.lla is None or gnss.vel is None or len(gnss.t) < 10:
        return []
    t = gnss.t
    V = np.vstack([np.zeros(3), np.cumsum(0.5 * (gnss.vel[1:] + gnss.vel[:-1])
                                          * np.diff(t)[:, None], axis=0)])
    lla = gnss.lla
    # the positions as their fix-to-fix displacements summed (each in its local ENU
    # axes, as the velocity is: one origin far away bends east and north near a pole)
    step = earth.llh_difference_enu(lla[1:, 0], lla[1:, 1], lla[1:, 2], lla[:-1, 0],
                                    lla[:-1, 1], lla[:-1, 2])
    p = np.vstack([np.zeros(3), np.cumsum(step, axis=0)])
    chunk = np.floor((t - t[0]) / SCALE_CHUNK_S).astype(int)
    n_chunks = int(chunk.max()) + 1
    count = np.bincount(chunk, minlength=n_chunks)[:, None]

    def centred(x):
        sums = np.stack([np.bincount(chunk, x[:, a], n_chunks) for a in range(3)], axis=1)
        return x - (sums / np.maximum(count, 1))[chunk]

    x, y = centred(V), centred(p)
    # The integral's own noise (a random walk of the velocity noise: over n fixes its
    # scatter about the mean is q n^2 / 6, q = (sigma_v period)^2) must be small beside its
    # travel, else the slope is attenuated towards 0 (errors in the regressor): a level
    # drive tells nothing about the height's unit.
    period = float(np.median(np.diff(t)))
    q = (np.asarray(gnss.sigma_vel, dtype=float) * period) ** 2
    noise_xx = q * float(np.sum(count.astype(float) ** 2)) / 6.0
    out = []
    names = ("east", "north", "height")
    dof = max(len(t) - n_chunks - 1, 1)
    for a in range(3):
        sxx = float(x[:, a] @ x[:, a])
        if sxx <= 100.0 * noise_xx[a]:
            continue
        slope = float(x[:, a] @ y[:, a]) / sxx
        r = y[:, a] - slope * x[:, a]
        rho = float(np.clip(r[1:] @ r[:-1] / max(r @ r, 1e-300), 0.0, 0.99))
        sig = np.sqrt(float(r @ r) / dof / sxx * (1 + rho) / (1 - rho))
        if abs(slope - 1.0) > SCALE_LIMIT and abs(slope - 1.0) > 5.0 * sig:
            out.append(f"{gnss.source}: the GNSS {names[a]} changes {slope:.3g} times as "
                       f"much as its velocity's integral says (+-{sig:.2g}): a {names[a]} "
                       f"in another unit (km, feet, radians), or that velocity axis in "
                       f"another unit or sign")
    return out


def residual_checks(res: dict | None, source: str) -> list[str]:
    """Per-axis bias and time-offset warnings from :func:`gnss_residuals`."""
    out = []
    if res is None:
        return out
    names = ("east", "north", "up")
    for key, what, unit in (("dp", "position", "m"), ("dv", "velocity", "m/s")):
        if key not in res:
            continue
        z = res[key] / res["s" + key[1]]
        n = len(z)
        # the serial correlation of the residuals (a filter lags the fixes): the mean's
        # sigma from the lag-1 autocorrelation
        zc = z - z.mean(axis=0)
        rho = np.clip(np.sum(zc[1:] * zc[:-1], axis=0) / np.maximum(np.sum(zc**2, axis=0),
                                                                     1e-300), 0.0, 0.99)
        se = z.std(axis=0) * np.sqrt((1 + rho) / (1 - rho) / n)
        mean = z.mean(axis=0)
        for j in range(3):
            if abs(mean[j]) > BIAS_LIMIT and abs(mean[j]) > 4.0 * se[j]:
                b = float(np.mean(res[key][:, j]))
                out.append(f"{source}: the GNSS {names[j]} {what} differs from the solution "
                           f"by {b:+.3g} {unit} on average ({mean[j]:+.2f} of its sigma over "
                           f"{n} fixes): a biased or mis-signed axis (NED written as ENU), a "
                           f"lever arm, or a wrong sigma")
                break
    return out


__all__ = ["at_rest", "gnss_residuals", "gnss_scale_check", "imu_gnss_offset", "offset_check",
           "residual_checks", "rest_spans", "stuck_axes"]
