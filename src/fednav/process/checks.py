"""Checks of recorded data before they are flown: their units (:func:`check_units`), the
GNSS-IMU time offset (:func:`time_offset`) and the GNSS velocity's latency
(:func:`velocity_latency`), the keys of the system description they leave unused
(:func:`ignored_keys`), and the IMU's axes against what is declared.

:func:`check_mounting`: do the IMU's axes, as declared (``imu.mounting``, or the file
format's own axes), agree with the data?  An IMU logged forward-right-down and read as
right-forward-up runs with the roll 180 deg and the heading 90 deg off and only small
warnings; the data say so plainly — gravity is on the wrong axis, the vehicle speeds up
along the wrong one — and the check names the mounting that fits them.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel

from ..core import attitude as att
from ..core import earth
from ..core import mounting as mt
from ..core.samples import held_integral, midpoints
from ..filters.particle import PROGRESSIVE_ESS
from ..io.data import DataError, FixData, ImuData
from ..sensors import registry
from ..sensors.imu import FIGURES

#: The least angle [deg] between the mean specific force and the body's up axis that a
#: declared mounting is refused at (another square mounting then fits better: a vehicle
#: is not tilted by 45 deg on average over a recording).
GRAVITY_REFUSE_DEG = 45.0
#: How strongly the along-track acceleration must follow one horizontal body axis, and
#: at most the declared forward axis, for a warning that the forward axis is another.
FORWARD_FIT, FORWARD_DECLARED = 0.7, 0.3


def _track_correlation(imu: ImuData, fixes: FixData | None, R) -> np.ndarray | None:
    """How the vehicle's speeding up and slowing down follows each horizontal body axis
    of the data turned by ``R`` (a candidate mounting, relative to the data as read):
    the correlations [right, forward] of the GNSS along-track acceleration (the speed's
    rate over fixes at least 1 s apart, above 2 m/s) with the body specific force
    averaged over the same intervals; None without GNSS velocities that vary."""
    if fixes is None or fixes.vel is None or len(fixes.t) < 10:
        return None
    # the first fix at or after each whole second from the first (a fix-to-fix rate of
    # 5 Hz fixes is mostly noise)
    grid = fixes.t[0] + np.arange(int((fixes.t[-1] - fixes.t[0]) // 1.0) + 1)
    keep = np.unique(np.searchsorted(fixes.t, grid - 1e-9))
    tg, vg = fixes.t[keep], fixes.vel[keep]
    inside = (tg >= imu.t[0]) & (tg <= imu.t[-1])
    tg, vg = tg[inside], vg[inside]
    if len(tg) < 10:
        return None
    speed = np.hypot(vg[:, 0], vg[:, 1])
    moving = (speed[1:] > 2.0) & (speed[:-1] > 2.0)
    a_track = np.diff(speed) / np.diff(tg)
    if moving.sum() < 10 or np.std(a_track[moving]) < 0.05:
        return None  # (a vehicle at constant speed says nothing)
    f = mt.rotate_rows(imu.accel, R)
    cum = held_integral(imu.t, f[:, :2])
    fi = np.column_stack([np.interp(tg, imu.t, cum[:, j]) for j in range(2)])
    f_mean = np.diff(fi, axis=0) / np.diff(tg)[:, None]
    out = np.zeros(2)
    for j in range(2):
        x = f_mean[moving, j]
        if np.std(x) > 0.0:
            out[j] = float(np.corrcoef(a_track[moving], x)[0, 1])
    return out


def _set_fields(model: BaseModel, prefix: str):
    """(dotted key, field info) of every field ``model`` was given a value for, sections
    walked into."""
    for name in model.model_fields_set:
        info = type(model).model_fields[name]
        value = getattr(model, name)
        if isinstance(value, BaseModel):
            yield from _set_fields(value, f"{prefix}{name}.")
        else:
            yield f"{prefix}{name}", info


def ignored_keys(cfg) -> list[str]:
    """The keys a system description sets that processing recorded data does not use,
    each with why: fields declared simulation-only
    (:func:`fednav.core.config.simulation_only`), a sensor's ``period_s`` where its file
    gives the times (not a pseudo-measurement or a detector's rate), and a sensor's
    Gauss–Markov figures when ``filter.states`` does not select its state."""
    out = []
    for key, info in _set_fields(cfg, ""):
        why = (info.json_schema_extra or {}).get("simulation_only") if isinstance(
            info.json_schema_extra, dict) else None
        if why:
            out.append(f"{key} ({why})")
    for name in cfg.sensors:
        sec, spec = cfg.sensors[name], registry.spec(name)
        for key, info in _set_fields(sec, f"sensors.{name}."):
            extra = info.json_schema_extra if isinstance(info.json_schema_extra, dict) else {}
            if extra.get("simulation_only"):
                out.append(f"{key} ({extra['simulation_only']})")
        if "period_s" in sec.model_fields_set and not (spec.pseudo or spec.detector):
            out.append(f"sensors.{name}.period_s (the {name} file's time stamps give "
                       f"the times)")
        tm = sec.timing
        if tm.delay_compensation != "curve_fit":
            out += [f"sensors.{name}.timing.{k} (acts with delay_compensation: curve_fit)"
                    for k in ("curve_fit_degree", "curve_fit_points")
                    if k in tm.model_fields_set]
        block = getattr(spec.model, "markov_block", None)
        key = getattr(type(sec), "MARKOV_KEY", None)
        if block and key and block not in cfg.filter.states:
            out += [f"sensors.{name}.{k} (acts with filter.states: [{block}])"
                    for k in (key, "markov_tau_s") if k in sec.model_fields_set]
    out += _conditional(cfg)
    return out


#: Filter settings that act only for some filter types: key -> (the types, what to say).
_BY_TYPE = {"alpha": ({"ukf", "sukf", "cukf", "raukf"}, "a sigma-point filter (ukf, sukf, "
                      "cukf, raukf)"),
            "beta": ({"ukf", "sukf", "cukf", "raukf"}, "a sigma-point filter"),
            "kappa": ({"ukf", "sukf", "cukf", "raukf"}, "a sigma-point filter"),
            "grid_level": ({"sghqf", "aasghqf"}, "a sparse-grid filter (sghqf, aasghqf)")}


def _conditional(cfg) -> list[str]:
    """Keys that act only with another setting, given without it."""
    f, out = cfg.filter, []
    types = f.types()
    for key, (need, what) in _BY_TYPE.items():
        if key in f.model_fields_set and not types & need:
            out.append(f"filter.{key} (acts with {what})")
    if "pf" not in types:
        out += [f"filter.pf.{k} (acts with a particle filter: filter.type or a local "
                f"filter's type pf)" for k in sorted(f.pf.model_fields_set)]
    elif f.pf.roughening > 0.0 and (f.pf.resample_threshold == 0.0 or (
            f.pf.progressive_correction and f.pf.resample_threshold <= PROGRESSIVE_ESS)):
        # (the progressive correction keeps at least PROGRESSIVE_ESS of them effective)
        out.append(f"filter.pf.roughening (acts after a resampling, which a "
                   f"resample_threshold of {f.pf.resample_threshold:g} never starts"
                   + (" with progressive_correction" if f.pf.resample_threshold else "")
                   + ")")
    if "fixed_factors" in f.model_fields_set and f.sharing != "fixed":
        out.append("filter.fixed_factors (acts with filter.sharing: fixed)")
    if f.fdi_alpha is None:
        out += [f"filter.{k} (acts with filter.fdi_alpha)"
                for k in ("fdi_recovery", "fdi_readmit_s") if k in f.model_fields_set]
    if "noise" in cfg.model_fields_set and cfg.noise != "as-given" and f.state == "total":
        out.append("noise (acts with filter.state: error: the total-state navigator has "
                   "no smoother to identify with)")
    given = cfg.imu.model_fields_set
    if "grade" in given and all({eng, si} & given for eng, _, si in FIGURES.values()):
        out.append("imu.grade (the config gives every figure: the preset fills none)")
    for key, block in (("gyro_scale_ppm", "gyro_scale"), ("accel_scale_ppm", "accel_scale"),
                       ("gyro_scale_tau_s", "gyro_scale"),
                       ("accel_scale_tau_s", "accel_scale")):
        if key in cfg.imu.model_fields_set and block not in f.states:
            out.append(f"imu.{key} (acts with filter.states: [{block}])")
    return out


def mounted_imu(imu: ImuData, mounting) -> ImuData:
    """``imu`` in the mounting a system description declares (``imu.mounting``; None:
    as read): turned when its reader applied another (:meth:`ImuData.remount`), itself
    when the reader applied this one already."""
    if mounting is None:
        return imu
    M = mt.parse(mounting)
    if imu.mounting is not None and np.allclose(imu.mounting, M, rtol=0.0, atol=1e-12):
        return imu
    return imu.remount(mounting)


def check_mounting(imu: ImuData, fixes: FixData | None = None) -> list[str]:
    """Refuse IMU data whose declared axes gravity contradicts, naming the mounting that
    fits; warn when the vehicle speeds up along another axis than the declared forward
    one.

    * Gravity: over a recording a vehicle's mean specific force points up (its mean
      acceleration is small beside g); at more than :data:`GRAVITY_REFUSE_DEG` from the
      body's up axis the declared mounting is refused.  The fitting mounting is the axis
      permutation of the data as read whose up axis the mean specific force is nearest,
      and among those four the one whose forward axis the along-track acceleration
      follows (from the GNSS velocity), else the nearest to the declared one.
    * Forward axis (a warning): where the GNSS along-track acceleration follows another
      horizontal axis (correlation above :data:`FORWARD_FIT`) and not the declared
      forward one (below :data:`FORWARD_DECLARED`); an aircraft or a boat may crab, so
      this is not a refusal.

    Returns the warnings; raises DataError for a refusal."""
    declared = imu.mounting if imu.mounting is not None else np.eye(3)
    name = imu.mounting_name
    f = np.mean(imu.accel, axis=0)
    g = float(np.linalg.norm(f))
    if g < 1.0:
        return []  # (free fall or a unit problem: check_units speaks of the latter)
    up = f / g
    angle = float(np.degrees(np.arccos(np.clip(up[2], -1.0, 1.0))))
    warnings: list[str] = []
    if angle > GRAVITY_REFUSE_DEG:
        # candidates R applied to the data as read: the new mounting is R @ declared
        cands = [R for R in mt.proper_permutations() if (R @ up)[2] > np.cos(np.radians(
            GRAVITY_REFUSE_DEG))]
        scored = []
        for R in cands:
            r = _track_correlation(imu, fixes, R)
            fits_forward = r is not None and r[1] > FORWARD_FIT
            turn = float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))
            scored.append((not fits_forward, turn, R))
        scored.sort(key=lambda x: (x[0], x[1]))
        forward_known, R = not scored[0][0], scored[0][2]
        new = R @ declared
        fit = mt.letters_of(new) or "a rotation of the declared axes"
        axis = {0: "right", 1: "forward", 2: "up"}[int(np.argmax(np.abs(up)))]
        sign = "+" if up[int(np.argmax(np.abs(up)))] > 0 else "-"
        raise DataError(
            f"{imu.source}: the accelerometers read gravity along the body's {sign}{axis} "
            f"axis ({angle:.0f} deg from up), so the IMU's axes are not mounted as declared "
            f"(imu.mounting: {name}); imu.mounting: {fit} fits the data"
            + ("" if forward_known else f" (its forward axis is a guess: the "
                                        f"{registry.label(getattr(fixes, 'name', None))} "
                                        f"speed did not vary "
                                        f"enough to tell)"))
    r = _track_correlation(imu, fixes, np.eye(3))
    if r is not None and abs(r[0]) > FORWARD_FIT and abs(r[1]) < FORWARD_DECLARED:
        s = 1.0 if r[0] > 0 else -1.0  # the data's +-right axis is the forward one:
        R = np.array([[0.0, -s, 0.0], [s, 0.0, 0.0], [0.0, 0.0, 1.0]])  # a quarter turn
        fit = mt.letters_of(R @ declared) or "a rotation about up"
        warnings.append(
            f"{imu.source}: the vehicle speeds up and slows down along the body's "
            f"{'+' if s > 0 else '-'}right axis (correlation {abs(r[0]):.2f} with the "
            f"{registry.label(fixes.name)} along-track acceleration, {abs(r[1]):.2f} "
            f"along forward): the IMU's axes "
            f"turned about up from the declared mounting ({name})? imu.mounting: {fit} "
            f"fits (an aircraft or a boat that crabs may do this)")
    return warnings


#: Largest GNSS-IMU time offset :func:`time_offset` looks for [s] (GPS - UTC is 18 s).
OFFSET_SEARCH_S = 30.0


#: An offset :func:`time_offset` finds is a warning beyond this [s] (or half a GNSS
#: period): the course departs from the heading systematically (body roll, the angle of
#: attack in banked turns; the antenna's lever arm is taken out), which moved the
#: estimate by up to 0.25 s on data with no offset (docs/real-data.md, "Independent
#: data").
OFFSET_WARN_S = 0.3


def time_offset(imu: ImuData, fixes: FixData, step: float = 0.01) -> float | None:
    """The GNSS-IMU time offset [s] the data show, to add to the GNSS time stamps (as
    ``sensors.<name>.time_offset_s``): the shift of the GNSS course that best matches the
    heading the gyro integrates (about the mean specific force's axis, at rest "up"; the
    course of the IMU's point: the antenna's lever arm taken out),
    searched over +-:data:`OFFSET_SEARCH_S` in ``step`` s — None when the vehicle turns
    too little while moving (less than 30 deg of course change above 2 m/s) for the
    offset to be observable."""
    if fixes.vel is None or len(fixes.t) < 10:
        return None
    speed = np.hypot(fixes.vel[:, 0], fixes.vel[:, 1])
    moving = speed > 2.0
    if moving.sum() < 10:
        return None
    tg = fixes.t[moving]
    up = np.mean(imu.accel, axis=0)
    up /= max(np.linalg.norm(up), 1e-12)
    mid = midpoints(imu.t)
    heading = -held_integral(imu.t, imu.gyro @ up)  # (gyro bias
    # and Earth rate drift slowly: a straight-line trend is removed from the misfit below)
    lever = np.asarray(getattr(fixes, "lever", np.zeros(3)), dtype=float)
    cuts = np.flatnonzero(np.diff(tg) > 2.0) + 1
    h0 = np.interp(tg, imu.t, heading)
    turn = (earth.north_turn(fixes.t, fixes.lla, fixes.vel)[moving]
            if fixes.lla is not None else 0.0)

    def course_at(shift: float) -> np.ndarray:
        """The course of the IMU's point, the fixes taken ``shift`` s after their stamps."""
        course = np.arctan2(fixes.vel[moving, 0], fixes.vel[moving, 1])
        if np.any(lever):
            # the antenna's velocity holds the arm's, C (w x lever): in a turn an antenna
            # behind the IMU runs a course lagging the heading by about lever / speed
            # (0.14 s at 7 m/s, 1 m behind); taken out with the course as the heading
            # (level, no sideslip), the rate where the fix is taken to be (a sample's
            # rates hold from its stamp: at mid-interval)
            w = np.column_stack([np.interp(tg + shift, mid, imu.gyro[:, a])
                                 for a in range(3)])
            level = att.euler_to_dcm(np.column_stack([np.zeros((len(tg), 2)), course]))
            v = fixes.vel[moving] - earth.lever_arm_velocity(0.0, level, w, lever)
            course = np.arctan2(v[:, 0], v[:, 1])
        # unwrapped within each stretch of moving fixes; across a gap (an outage, a stop)
        # its turns are unseen, so each stretch takes the 2 pi branch nearest the gyro's
        # heading (unwrapped across a 300 deg turn in an outage it read 25 s offset)
        offset = None  # (the gyro heading's unknown start against the course: the first
        # stretch's, whatever its size)
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(tg)], strict=True):
            c = np.unwrap(course[a:b])
            d = float(np.median(h0[a:b] - c))
            offset = d if offset is None else offset
            course[a:b] = c + 2 * np.pi * np.round((d - offset) / (2 * np.pi))
        # the course is measured from north, which turns while the gyro sees none of it
        # (near the pole a false offset of 30 s)
        return course - turn

    course = course_at(0.0)
    if np.ptp(course) < np.radians(30.0):
        return None
    x = tg - tg.mean()

    def best(lags):
        """The lag of the least misfit (after a straight line over time is removed)."""
        t = tg[None, :] + lags[:, None]
        w = ((t >= imu.t[0]) & (t <= imu.t[-1])).astype(float)
        r = (course[None, :] - np.interp(t, imu.t, heading)) * w
        n, sx, sxx = w.sum(1), w @ x, w @ x**2
        sr, sxr, srr = r.sum(1), r @ x, (r * r).sum(1)
        with np.errstate(invalid="ignore", divide="ignore"):
            b = (n * sxr - sx * sr) / (n * sxx - sx**2)
            a = (sr - b * sx) / n
            cost = (srr - a * sr - b * sxr) / n
        cost[~(n >= max(10, 0.5 * len(tg)))] = np.inf
        cost[~np.isfinite(cost)] = np.inf
        return None if not np.isfinite(cost).any() else float(lags[int(np.argmin(cost))])

    coarse = best(np.arange(-OFFSET_SEARCH_S, OFFSET_SEARCH_S + 0.05, 0.1))
    if coarse is None:
        return None
    if np.any(lever):  # (the arm's rate where the coarse search puts the fixes)
        course = course_at(coarse)
    return best(np.arange(coarse - 0.2, coarse + 0.2 + step / 2, step))


#: A GNSS velocity latency :func:`velocity_latency` finds is a warning beyond this [s]
#: (and three of its sigmas).
LATENCY_WARN_S = 0.05


def velocity_latency(fixes: FixData) -> tuple[float, float] | None:
    """How much older than its stamp the GNSS velocity is [s], and the estimate's 1-sigma,
    from the positions: the velocity of position differences over about 1 s
    (``v_p(t) = (p(t + h) - p(t - h)) / 2h``, valid at ``t``) minus the reported velocity
    is ``L a(t)`` for a velocity that lags by ``L`` (``a``: the reported velocity's rate),
    so ``L`` is the least-squares slope of that difference on ``a`` over the horizontal
    components.  None without positions and velocities, or with too little acceleration
    (the slope's sigma above 0.1 s)."""
    if fixes.lla is None or fixes.vel is None or len(fixes.t) < 20:
        return None
    t = fixes.t
    period = float(np.median(np.diff(t)))
    k = max(1, int(round(0.5 / period)))
    d = earth.llh_difference_enu(fixes.lla[:, 0], fixes.lla[:, 1], fixes.lla[:, 2],
                                 fixes.lla[0, 0], fixes.lla[0, 1], fixes.lla[0, 2])
    i = np.arange(k, len(t) - k)
    span = t[i + k] - t[i - k]
    ok = np.abs(span - 2 * k * period) < 0.25 * period  # no gap inside
    i, span = i[ok], span[ok]
    if len(i) < 10:
        return None
    vp = (d[i + k, :2] - d[i - k, :2]) / span[:, None]
    a = (fixes.vel[i + k, :2] - fixes.vel[i - k, :2]) / span[:, None]
    r = vp - fixes.vel[i, :2]
    aa = float(np.sum(a * a))
    if aa <= 0.0:
        return None
    L = float(np.sum(r * a)) / aa
    res = r - L * a
    sigma = float(np.sqrt(np.sum(res * res) / max(res.size - 1, 1) / aa))
    # neighbouring differences share fixes: about 2k of them carry one error
    sigma *= np.sqrt(2 * k)
    if sigma > 0.1:
        return None
    return L, sigma


#: moving: horizontally faster than this [m/s] (the wheeled-vehicle hint)
WHEELED_SPEED_MPS = 3.0
#: the hint needs at least this long moving [s]
WHEELED_MIN_S = 60.0
#: a velocity that stays along the IMU's forward axis within this RMS [m/s], sideways and
#: vertically, while moving: a wheeled vehicle (the hint's threshold)
WHEELED_RMS_MPS = 0.25


def wheeled_hint(sol, system) -> list[str]:
    """A hint (``ProcessResult.hints``) suggesting the non-holonomic constraint
    (``sensors.nhc``) when the forward solution ``sol`` moves like a wheeled vehicle —
    its velocity in body axes (right, forward, up at the IMU) stays along the forward
    axis within
    :data:`WHEELED_RMS_MPS` RMS sideways and vertically over at least
    :data:`WHEELED_MIN_S` of motion faster than :data:`WHEELED_SPEED_MPS` — and the
    system has no such constraint or body-velocity sensor.  On straight runs GNSS does
    not see the heading; the constraint does (measured: docs/real-data.md, "A moving
    start").  A drone's, a boat's or a pedestrian's velocity leaves the forward axis."""
    from ..core import attitude as att

    flown = set(system.sensors if system.aiding is None else system.aiding)
    if {"nhc", "odometer", "dvl"} & flown or len(sol.t) < 2:
        return []
    vb = np.einsum("nji,nj->ni", att.euler_to_dcm(sol.euler), sol.vel)
    moving = np.hypot(sol.vel[:, 0], sol.vel[:, 1]) > WHEELED_SPEED_MPS
    dt = float(np.median(np.diff(sol.t)))
    if moving.sum() * dt < WHEELED_MIN_S:
        return []
    side, up = (float(np.sqrt(np.mean(vb[moving, j] ** 2))) for j in (0, 2))
    if max(side, up) > WHEELED_RMS_MPS:
        return []
    return [f"the vehicle's velocity stays along its forward axis (sideways {side:.2f}, "
            f"vertical {up:.2f} m/s RMS over {moving.sum() * dt:.0f} s of motion): a "
            f"wheeled vehicle? sensors.nhc (the non-holonomic constraint) makes its "
            f"heading observable on straight runs, where GNSS does not (docs/real-data.md, "
            f"\"A moving start\")"]


def check_units(imu: ImuData, fixes: FixData | None) -> list[str]:
    """Refuse IMU data in the wrong unit; warn about GNSS positions that look like radians.

    * accelerometer: the median specific-force magnitude of a vehicle on or near the
      Earth is about 9.8 m/s^2; a median near 1 means the file is in g;
    * gyro: the yaw rate measured about the mean "up" axis (the mean specific force) is
      regressed on the GNSS course rate over the intervals where the vehicle moves and
      turns; a slope near 57 means deg/s (needs some turning: a straight run is not
      tested);
    * GNSS latitude/longitude all within 3.2 deg of (0, 0): radians read as degrees?
      (a warning: real data there exist).
    Returns the warnings; raises DataError for the refusals.
    """
    warnings = []
    fmag = float(np.median(np.linalg.norm(imu.accel, axis=1)))
    if 0.5 < fmag < 1.5:
        raise DataError(f"{imu.source}: median specific force {fmag:.3f}: looks like g; "
                        f"fednav expects m/s^2")
    if fixes is None:
        return warnings
    if fixes.vel is not None and len(fixes.t) > 5:
        up = np.mean(imu.accel, axis=0)
        up /= max(np.linalg.norm(up), 1e-12)
        # GNSS epochs at least 1 s apart: the course rate of 5 Hz fixes is mostly noise
        keep = [0]
        for i in range(1, len(fixes.t)):
            if fixes.t[i] - fixes.t[keep[-1]] >= 1.0 - 1e-9:
                keep.append(i)
        tg, vg = fixes.t[keep], fixes.vel[keep]
        speed = np.hypot(vg[:, 0], vg[:, 1])
        course = np.unwrap(np.arctan2(vg[:, 0], vg[:, 1]))
        dt = np.diff(tg)
        c_rate = -np.diff(course) / dt  # heading from north toward east: yaw rate = -dpsi/dt
        moving = (speed[1:] > 2.0) & (speed[:-1] > 2.0) & (dt < 5.0)
        yaw = held_integral(imu.t, imu.gyro @ up)
        g_rate = (np.interp(tg[1:], imu.t, yaw) - np.interp(tg[:-1], imu.t, yaw)) / dt
        inside = (tg[:-1] >= imu.t[0]) & (tg[1:] <= imu.t[-1])
        turning = moving & inside & (np.abs(c_rate) > np.radians(3.0))
        if turning.sum() >= 5:
            c, g = c_rate[turning], g_rate[turning]
            slope = float(c @ g / (c @ c))
            if 20.0 < abs(slope) < 200.0:
                raise DataError(f"{imu.source}: gyro rates are {slope:.1f} x the "
                                f"{registry.label(fixes.name)} course rate while turning: "
                                f"looks like deg/s; fednav expects rad/s")
    if fixes.lla is None:
        return warnings
    lat, lon = np.degrees(fixes.lla[:, 0]), np.degrees(fixes.lla[:, 1])
    if np.all(np.abs(lat) < 1.6) and np.all(np.abs(lon) < 3.2):
        warnings.append(f"{fixes.source}: every position lies within 1.6 deg of latitude 0 and "
                        f"3.2 deg of longitude 0: latitude/longitude in radians where "
                        f"degrees are expected?")
    return warnings


#: IMU samples further apart than this [s] are refused (time stamps in milliseconds read as
#: seconds put them 1000x too far apart; no strapdown IMU samples below 1 Hz).
MAX_IMU_PERIOD_S = 1.0


def check_fix_timing(imu: ImuData, fixes: FixData | None) -> tuple[list[str], dict]:
    """The fixes' clock (the GNSS's) against the IMU's: a time offset between the two
    (:func:`time_offset`) and a lag of the receiver's velocity behind its positions
    (:func:`velocity_latency`), each in the data quality (``<name>_time_offset_seen_s``,
    ``<name>_velocity_latency_seen_s`` [s], ``<name>`` the fix sensor's) and a warning
    naming the key that corrects it when it exceeds what the data can tell apart.
    Returns (warnings, quality)."""
    warnings, quality = [], {}
    if fixes is None:
        return warnings, quality
    off = time_offset(imu, fixes)
    if off is not None:
        quality[f"{fixes.name}_time_offset_seen_s"] = round(off, 2)
        if abs(off) > max(OFFSET_WARN_S, 0.5 * float(np.median(np.diff(fixes.t)))):
            who = registry.label(fixes.name)
            warnings.append(f"{fixes.source}: the {who} course matches the gyro's heading "
                            f"best with the {who} time stamps moved by {off:+.2f} s: a "
                            f"time offset between the receiver's and the IMU's clock "
                            f"(UTC vs GPS time: 18 s)? sensors.{fixes.name}.time_offset_s "
                            f"corrects it")
    lat = velocity_latency(fixes)
    if lat is not None:
        quality[f"{fixes.name}_velocity_latency_seen_s"] = round(lat[0], 3)
        if abs(lat[0]) > max(LATENCY_WARN_S, 3.0 * lat[1]):
            warnings.append(f"{fixes.source}: the {registry.label(fixes.name)} velocity lags "
                            f"its positions by "
                            f"{lat[0]:+.3f} s (+-{lat[1]:.3f} s, from the positions' "
                            f"differences): sensors.{fixes.name}.velocity_latency_s corrects it")
    return warnings, quality
