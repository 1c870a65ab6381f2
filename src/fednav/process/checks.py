"""Checks of recorded data against what the system description declares about them.

:func:`check_mounting`: do the IMU's axes, as declared (``imu.mounting``, or the file
format's own axes), agree with the data?  An IMU logged forward-right-down and read as
right-forward-up runs with the roll 180 deg and the heading 90 deg off and only small
warnings; the data say so plainly — gravity is on the wrong axis, the vehicle speeds up
along the wrong one — and the check names the mounting that fits them.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel

from ..core import mounting as mt
from ..io.data import DataError, GnssData, ImuData
from ..sensors import registry
from ..sensors.imu import FIGURES

#: The least angle [deg] between the mean specific force and the body's up axis that a
#: declared mounting is refused at (another square mounting then fits better: a vehicle
#: is not tilted by 45 deg on average over a recording).
GRAVITY_REFUSE_DEG = 45.0
#: How strongly the along-track acceleration must follow one horizontal body axis, and
#: at most the declared forward axis, for a warning that the forward axis is another.
FORWARD_FIT, FORWARD_DECLARED = 0.7, 0.3


def _track_correlation(imu: ImuData, gnss: GnssData | None, R) -> np.ndarray | None:
    """How the vehicle's speeding up and slowing down follows each horizontal body axis
    of the data turned by ``R`` (a candidate mounting, relative to the data as read):
    the correlations [right, forward] of the GNSS along-track acceleration (the speed's
    rate over fixes at least 1 s apart, above 2 m/s) with the body specific force
    averaged over the same intervals; None without GNSS velocities that vary."""
    if gnss is None or gnss.vel is None or len(gnss.t) < 10:
        return None
    # the first fix at or after each whole second from the first (a fix-to-fix rate of
    # 5 Hz fixes is mostly noise)
    grid = gnss.t[0] + np.arange(int((gnss.t[-1] - gnss.t[0]) // 1.0) + 1)
    keep = np.unique(np.searchsorted(gnss.t, grid - 1e-9))
    tg, vg = gnss.t[keep], gnss.vel[keep]
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
    cum = np.vstack([np.zeros(2), np.cumsum(f[1:, :2] * np.diff(imu.t)[:, None], axis=0)])
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
    types = {f.type} | {lc.type for lc in f.locals.values() if lc.type is not None}
    for key, (need, what) in _BY_TYPE.items():
        if key in f.model_fields_set and not types & need:
            out.append(f"filter.{key} (acts with {what})")
    if "fixed_factors" in f.model_fields_set and f.sharing != "fixed":
        out.append("filter.fixed_factors (acts with filter.sharing: fixed)")
    if f.fdi_alpha is None:
        out += [f"filter.{k} (acts with filter.fdi_alpha)"
                for k in ("fdi_recovery", "fdi_readmit_s") if k in f.model_fields_set]
    given = cfg.imu.model_fields_set
    if "grade" in given and all({eng, si} & given for eng, _, si in FIGURES.values()):
        out.append("imu.grade (the config gives every figure: the preset fills none)")
    for key, block in (("gyro_scale_ppm", "gyro_scale"), ("accel_scale_ppm", "accel_scale")):
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


def check_mounting(imu: ImuData, gnss: GnssData | None = None) -> list[str]:
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
            r = _track_correlation(imu, gnss, R)
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
            + ("" if forward_known else " (its forward axis is a guess: the GNSS speed "
                                        "did not vary enough to tell)"))
    r = _track_correlation(imu, gnss, np.eye(3))
    if r is not None and abs(r[0]) > FORWARD_FIT and abs(r[1]) < FORWARD_DECLARED:
        s = 1.0 if r[0] > 0 else -1.0  # the data's +-right axis is the forward one:
        R = np.array([[0.0, -s, 0.0], [s, 0.0, 0.0], [0.0, 0.0, 1.0]])  # a quarter turn
        fit = mt.letters_of(R @ declared) or "a rotation about up"
        warnings.append(
            f"{imu.source}: the vehicle speeds up and slows down along the body's "
            f"{'+' if s > 0 else '-'}right axis (correlation {abs(r[0]):.2f} with the GNSS "
            f"along-track acceleration, {abs(r[1]):.2f} along forward): the IMU's axes "
            f"turned about up from the declared mounting ({name})? imu.mounting: {fit} "
            f"fits (an aircraft or a boat that crabs may do this)")
    return warnings
