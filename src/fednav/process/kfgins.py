"""A KF-GINS configuration (``kf-gins.yaml``) as a fednav system description, key by key.

KF-GINS (i2Nav-WHU's C++ loosely coupled GNSS/INS) reads one YAML file: the data files,
the processing window, the initial state and its 1-sigma, the IMU's noise and the
antenna lever arm, each in its own units (deg/h, mGal, ppm, deg/sqrt(h), m/s/sqrt(h);
north-east-down and forward-right-down).  :func:`translate` walks every key and says what
became of it (:class:`KeyFate`: ``used`` as it is, ``translated`` into another unit,
frame or model, ``ignored`` with the reason, ``unknown`` — not a KF-GINS key), so a
KF-GINS user's folder runs with no edit: ``fednav process kfgins kf-gins.yaml``.

The models differ in two places, said where they apply: KF-GINS's biases and scale
factors are first-order Gauss–Markov states sharing one correlation time; fednav's gyro
has a constant-bias state beside its Gauss–Markov one (``imu.gyro_bias_deg_h`` is set so
that the two start with KF-GINS's initial sigma), its accelerometer bias is Gauss–Markov
(``filter.accel_bias: gauss_markov``), and its Gauss–Markov scale-factor states
(``imu.*_scale_tau_s``) start at their stationary sigma where KF-GINS's may start
elsewhere (``initsgstd``).  fednav's IMU figures are one per
model (isotropic): a figure that differs between axes is taken at its largest axis.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core import attitude as att
from ..core import units
from ..core.config import ConfigError, read_mapping
from ..io.navego import navego_euler_to_fednav

#: every key KF-GINS reads (imunoise's keys under ``imunoise.``)
KEYS = ("imupath", "gnsspath", "outputpath", "imudatalen", "imudatarate", "starttime",
        "endtime", "initpos", "initvel", "initatt", "initgyrbias", "initaccbias",
        "initgyrscale", "initaccscale", "initposstd", "initvelstd", "initattstd",
        "initbgstd", "initbastd", "initsgstd", "initsastd", "imunoise.arw", "imunoise.vrw",
        "imunoise.gbstd", "imunoise.abstd", "imunoise.gsstd", "imunoise.asstd",
        "imunoise.corrtime", "antlever")
#: the keys KF-GINS cannot run without
REQUIRED = ("imupath", "gnsspath", "imudatalen", "imudatarate", "starttime", "endtime",
            "initpos", "initvel", "initatt", "initposstd", "initvelstd", "initattstd",
            "imunoise.arw", "imunoise.vrw", "imunoise.gbstd", "imunoise.abstd",
            "imunoise.gsstd", "imunoise.asstd", "imunoise.corrtime", "antlever")


@dataclass(frozen=True)
class KeyFate:
    """What became of one KF-GINS key: ``fate`` is ``used``, ``translated``,
    ``ignored`` or ``unknown``; ``detail`` says into what, or why."""

    key: str
    fate: str
    detail: str

    def line(self) -> str:
        return f"{self.key}: {self.fate} — {self.detail}"


@dataclass
class Translation:
    """A KF-GINS configuration as fednav's: ``system`` (a system description mapping),
    ``keys`` (every key's :class:`KeyFate`), the data files ``imu`` and ``gnss`` (paths
    resolved), the window ``start_s``/``end_s`` (GPS seconds of the week; None: the
    file's), ``rate_hz`` and ``imu_columns``, and the ``source`` file."""

    source: Path
    system: dict
    keys: list[KeyFate]
    imu: Path
    gnss: Path
    start_s: float | None
    end_s: float | None
    rate_hz: float
    imu_columns: int
    #: ``initgyrbias`` ... in SI, FRD axes, taken out of the increments at reading
    known_errors: dict = field(default_factory=dict)

    def fate(self, key: str) -> KeyFate:
        return next(k for k in self.keys if k.key == key)


def _flat(data: dict) -> dict:
    out = {}
    for k, v in data.items():
        if k == "imunoise" and isinstance(v, dict):
            out.update({f"imunoise.{kk}": vv for kk, vv in v.items()})
        else:
            out[k] = v
    return out


def _vec(src: str, flat: dict, key: str, n: int = 3) -> np.ndarray | None:
    if key not in flat:
        return None
    try:
        a = np.asarray(flat[key], dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ConfigError(f"{src}: {key} must be {n} numbers, got {flat[key]!r}") from None
    if a.shape != (n,) or not np.isfinite(a).all():
        raise ConfigError(f"{src}: {key} must be {n} finite numbers, got {flat[key]!r}")
    return a


def _num(src: str, flat: dict, key: str) -> float:
    try:
        v = float(flat[key])
    except (TypeError, ValueError):
        raise ConfigError(f"{src}: {key} must be a number, got {flat[key]!r}") from None
    if not np.isfinite(v):
        raise ConfigError(f"{src}: {key} must be finite, got {flat[key]!r}")
    return v


def _largest(a: np.ndarray, what: str) -> tuple[float, str]:
    """A per-axis figure as fednav's one figure (its largest axis) and what was done."""
    v = float(np.max(np.abs(a)))
    same = np.allclose(a, a[0], rtol=1e-9, atol=0.0)
    return v, "" if same else f" (axes differ {a.tolist()}: the largest, {v:g}, {what})"


def _resolve(src: Path, value, key: str) -> Path:
    """A data path of the configuration: as written when it exists (KF-GINS runs in the
    folder it was started from), else beside the configuration, else the same name
    beside it (a folder moved whole)."""
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{src}: {key} is empty; give the file's path")
    p = Path(value)
    for cand in (p, src.parent / p, src.parent / p.name):
        if cand.is_file():
            return cand
    raise ConfigError(f"{src}: {key} '{value}' not found (looked as written, beside the "
                      f"configuration and for {p.name} beside it)")


def translate(path) -> Translation:
    """Read a ``kf-gins.yaml`` and translate it (module docstring); a missing required
    key or a malformed value is a one-line :class:`~fednav.core.config.ConfigError`."""
    path = Path(path)
    src = str(path)
    data = read_mapping(path, "KF-GINS configuration")
    flat = _flat(data)
    missing = [k for k in REQUIRED if k not in flat]
    if missing:
        raise ConfigError(f"{src}: not a complete KF-GINS configuration: missing "
                          f"{', '.join(missing)}")
    fates: list[KeyFate] = []

    def say(key, fate, detail):
        fates.append(KeyFate(key, fate, detail))

    system: dict = {"imu": {}, "sensors": {"gnss": {}}, "filter": {}}
    imu_path = _resolve(path, flat["imupath"], "imupath")
    gnss_path = _resolve(path, flat["gnsspath"], "gnsspath")
    say("imupath", "used", f"the IMU file {imu_path}")
    say("gnsspath", "used", f"the GNSS file {gnss_path}")
    say("outputpath", "ignored", "fednav writes to --out (KF_GINS_Navresult.nav among "
        "its files)")
    cols = int(_num(src, flat, "imudatalen"))
    if cols < 7:
        raise ConfigError(f"{src}: imudatalen is {cols}; a KF-GINS IMU file has at least 7 "
                          f"columns")
    say("imudatalen", "used", "7 columns: time, increments" if cols == 7 else
        f"{cols} columns: the 8th, an odometer speed, is the odometer sensor's series when "
        f"sensors.odometer is configured (KF-GINS does not use it)")
    rate = _num(src, flat, "imudatarate")
    say("imudatarate", "used", f"{rate:g} Hz, checked against the file's stamps (the "
        f"stamps are used; a mismatch is warned about)")
    start, end = _num(src, flat, "starttime"), _num(src, flat, "endtime")
    say("starttime", "used", f"the IMU rows that end at or after {start:g} s; the "
        f"initial state holds at the IMU stamp nearest it (initial.t_s)")
    say("endtime", "used", "to the end of the IMU file" if end < 0 else
        f"the last IMU row at or before {end:g} s")

    pos = _vec(src, flat, "initpos")
    vel = _vec(src, flat, "initvel")
    rpy = _vec(src, flat, "initatt")
    euler = np.degrees(navego_euler_to_fednav(*np.radians(rpy)))
    euler[2] %= 360.0
    initial = {"lat_deg": float(pos[0]), "lon_deg": float(pos[1]), "h_m": float(pos[2]),
               "vel_mps": [float(vel[1]), float(vel[0]), float(-vel[2])],
               "euler_deg": [float(x) for x in euler]}
    if start > 0:
        initial["t_s"] = start
    say("initpos", "used", "initial.lat_deg, lon_deg, h_m (the IMU's point)")
    say("initvel", "translated", "[north, east, down] -> initial.vel_mps [east, north, up]")
    say("initatt", "translated", "[roll, pitch, yaw] of FRD in NED -> initial.euler_deg "
        "[pitch, roll, heading] of fednav's body in ENU")
    psd, vsd, asd = (_vec(src, flat, k) for k in ("initposstd", "initvelstd", "initattstd"))
    # Euler sigmas -> the misalignment's (first order, at the initial attitude)
    J = att.euler_error_jacobian(np.radians(euler))
    Ji = np.linalg.inv(J)
    e_sd = np.radians(asd[[1, 0, 2]])  # [pitch, roll, heading]
    phi_sd = np.sqrt(np.diag(Ji @ np.diag(e_sd**2) @ Ji.T))
    initial["sigma"] = {"position_m": [float(psd[1]), float(psd[0]), float(psd[2])],
                        "velocity_mps": [float(vsd[1]), float(vsd[0]), float(vsd[2])],
                        "attitude_arcsec": [float(x) for x in units.to_arcsec(phi_sd)]}
    system["initial"] = initial
    say("initposstd", "translated", "[N, E, D] -> initial.sigma.position_m [E, N, U]")
    say("initvelstd", "translated", "[N, E, D] -> initial.sigma.velocity_mps [E, N, U]")
    say("initattstd", "translated", "[roll, pitch, yaw] -> initial.sigma.attitude_arcsec, "
        "the misalignment [east, north, up] with the same Euler-angle sigmas at the "
        "initial attitude")
    known = {}
    for key, name, si in (("initgyrbias", "gyro_bias", units.deg_per_h),
                          ("initaccbias", "accel_bias", units.milligal),
                          ("initgyrscale", "gyro_scale", units.ppm),
                          ("initaccscale", "accel_scale", units.ppm)):
        v = _vec(src, flat, key)
        if v is None or not np.any(v != 0):
            say(key, "used", "zero (or not given): nothing taken out of the increments")
            continue
        known[name] = si(v)
        say(key, "translated", f"{v.tolist()} (FRD axes) taken out of the IMU increments as "
            f"KF-GINS does; fednav's estimate is of what remains")

    imu = system["imu"]
    arw, note = _largest(_vec(src, flat, "imunoise.arw"), "imu.gyro_arw_deg_sqrt_h")
    imu["gyro_arw_deg_sqrt_h"] = arw
    say("imunoise.arw", "used", "imu.gyro_arw_deg_sqrt_h [deg/sqrt(h)]" + note)
    vrw, note = _largest(_vec(src, flat, "imunoise.vrw"), "m/s/sqrt(h)")
    imu["accel_vrw_mps_sqrt_s"] = float(units.mps_per_sqrt_h(vrw))
    say("imunoise.vrw", "translated", "m/s/sqrt(h) / 60 -> imu.accel_vrw_mps_sqrt_s" + note)
    tau_h = _num(src, flat, "imunoise.corrtime")
    if tau_h <= 0:
        raise ConfigError(f"{src}: imunoise.corrtime must be positive, got {tau_h}")
    gb, note = _largest(_vec(src, flat, "imunoise.gbstd"), "deg/h")
    ab, note_a = _largest(_vec(src, flat, "imunoise.abstd"), "mGal")
    tau_s = tau_h * units.HOUR
    imu.update({"gyro_markov_deg_h": gb, "gyro_markov_tau_s": tau_s,
                "accel_markov_mps2": float(units.milligal(ab)), "accel_markov_tau_s": tau_s})
    system["filter"]["accel_bias"] = "gauss_markov"
    say("imunoise.gbstd", "used", "imu.gyro_markov_deg_h, the Gauss–Markov drift's sigma"
        + note)
    say("imunoise.abstd", "translated", "mGal -> imu.accel_markov_mps2 (x 1e-5), "
        "filter.accel_bias: gauss_markov" + note_a)
    say("imunoise.corrtime", "translated", f"{tau_h:g} h -> imu.gyro_markov_tau_s, "
        f"accel_markov_tau_s and the scale states' *_scale_tau_s {tau_h * 3600:g} s")
    for key, of in (("initbgstd", "gbstd"), ("initbastd", "abstd"), ("initsgstd", "gsstd"),
                    ("initsastd", "asstd")):
        if key not in flat:
            say(key, "used", f"not given: the start sigma is imunoise.{of}'s, as in KF-GINS")
    bg0 = _vec(src, flat, "initbgstd")
    if bg0 is None:
        imu["gyro_bias_deg_h"] = 0.0
    else:
        b, note = _largest(bg0, "deg/h")
        imu["gyro_bias_deg_h"] = float(np.sqrt(max(b**2 - gb**2, 0.0)))
        say("initbgstd", "translated", "imu.gyro_bias_deg_h, the constant-bias state's "
            "sigma, so that it and the Gauss–Markov state start with this sigma together"
            + note + ("" if b >= gb else f" (smaller than gbstd {gb:g}: fednav's start "
                      f"sigma is gbstd's)"))
    ba0 = _vec(src, flat, "initbastd")
    imu["accel_bias_mps2"] = 0.0  # (the Gauss–Markov state starts with abstd's sigma)
    if ba0 is not None:
        b, note = _largest(ba0, "mGal")
        imu["accel_bias_mps2"] = float(units.milligal(b))
        say("initbastd", "translated", "mGal -> imu.accel_bias_mps2 (fednav's start sigma "
            "is the larger of it and abstd)" + note)
    states = []
    for which, key, key0 in (("gyro", "imunoise.gsstd", "initsgstd"),
                             ("accel", "imunoise.asstd", "initsastd")):
        # KF-GINS: a Gauss–Markov state of stationary sigma gsstd and correlation time
        # corrtime, starting at initsgstd (default gsstd); fednav's Gauss–Markov scale
        # states start at their stationary sigma
        s, note = _largest(_vec(src, flat, key), "ppm")
        s0 = _vec(src, flat, key0)
        s0v, note0 = _largest(s0, "ppm") if s0 is not None else (s, "")
        if s > 0:
            states.append(f"{which}_scale")
            imu[f"{which}_scale_ppm"] = s
            imu[f"{which}_scale_tau_s"] = tau_s
            say(key, "translated", f"filter.states {which}_scale, Gauss–Markov: "
                f"imu.{which}_scale_ppm {s:g} and imu.{which}_scale_tau_s "
                f"{tau_h * 3600:g} (corrtime)" + note)
            if s0 is not None:
                say(key0, "used" if s0v == s else "translated", "the start sigma, "
                    + ("as gsstd's" if s0v == s else f"approximated by {key}'s {s:g} "
                       f"(fednav's Gauss–Markov scale states start at their stationary "
                       f"sigma)") + note0)
        elif s0v > 0:  # (no noise: random constants that start at initsgstd)
            states.append(f"{which}_scale")
            imu[f"{which}_scale_ppm"] = s0v
            say(key, "used", f"zero: the {which} scale factors are random constants")
            say(key0, "used", f"imu.{which}_scale_ppm {s0v:g}, their start sigma" + note0)
        else:
            say(key, "used", f"zero: no {which} scale-factor state")
            if s0 is not None:
                say(key0, "used", "zero")
    if states:
        system["filter"]["states"] = states
    lever = _vec(src, flat, "antlever")
    system["sensors"]["gnss"]["lever_m"] = [float(lever[1]), float(lever[0]),
                                            float(-lever[2])]
    say("antlever", "translated", "[forward, right, down] -> sensors.gnss.lever_m "
        "[right, forward, up]")
    for k in flat:
        if k not in KEYS:
            say(k, "unknown", "not a key KF-GINS reads: ignored")
    return Translation(path, system, fates, imu_path, gnss_path,
                       start if start > 0 else None, None if end < 0 else end, rate, cols,
                       known)


def find_config(path) -> Path:
    """The KF-GINS configuration a user points at: the file itself, or the one YAML file
    of a folder that names ``imupath`` (a one-line error when there are none or
    several)."""
    path = Path(path)
    if path.is_file():
        return path
    if not path.is_dir():
        raise ConfigError(f"{path}: not found (a kf-gins.yaml or the folder holding it)")
    found = [p for p in sorted(path.glob("*.y*ml"))
             if "imupath" in p.read_text(encoding="utf-8", errors="replace")]
    if len(found) != 1:
        raise ConfigError(f"{path}: {'no' if not found else len(found)} KF-GINS "
                          f"configuration(s) (YAML with imupath) in the folder"
                          + (f": {', '.join(p.name for p in found)}; give one" if found
                             else ""))
    return found[0]


def merge(base: dict, over: dict) -> dict:
    """``over`` (a user's system description, the keys it sets) laid over ``base``:
    sections merged key by key, other values replaced."""
    out = dict(base)
    for k, v in over.items():
        out[k] = merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k),
                                                                          dict) else v
    return out


#: the reference file of KF-GINS's dataset, looked for beside the configuration and the
#: IMU file
TRUTH = "truth.nav"


def read_kfgins(path, cfg=None) -> dict:
    """A KF-GINS user's folder or ``kf-gins.yaml`` read for :func:`fednav.process.run.process`:
    ``{"imu", "sensors", "ref", "system", "warnings", "paths", "translation"}``.

    ``cfg`` (a :class:`~fednav.navigator.system.System`, e.g. ``--config``): the keys it
    sets are laid over the translation (:func:`merge`).  The reference is the dataset's
    ``truth.nav`` when there is one beside the configuration or the IMU file (said in
    the warnings).  The warnings list every key ``ignored`` or ``unknown``."""
    from ..core.config import validate
    from ..io.kfgins import (
        read_kfgins_gnss,
        read_kfgins_imu,
        read_kfgins_nav,
        read_kfgins_odometer,
    )
    from ..navigator.system import System

    tr = translate(find_config(path))
    user = {} if cfg is None else cfg.model_dump(exclude_unset=True, mode="json")
    if cfg is not None and "sensors" in user:  # (a section's dump holds every default)
        user["sensors"] = {n: c.model_dump(exclude_unset=True, mode="json")
                           for n, c in cfg.sensors.items()}
    system = validate(merge(tr.system, user), System, f"{tr.source} (as fednav's system "
                                                      f"description, with --config)")
    imu = read_kfgins_imu(tr.imu, start_s=tr.start_s, end_s=tr.end_s, rate_hz=tr.rate_hz,
                          max_bridge_s=system.imu.max_bridge_s,
                          mounting=system.imu.mounting, known_errors=tr.known_errors)
    g = system.sensors.gnss
    sensors = {"gnss": read_kfgins_gnss(tr.gnss, lever=g.lever_m, start_s=tr.start_s,
                                        end_s=tr.end_s)}
    warnings = [f"{tr.source}: {k.line()}" for k in tr.keys if k.fate in ("ignored",
                                                                           "unknown")]
    if system.filter.period_s is None and len(sensors["gnss"].t) > 1:
        # KF-GINS updates at each fix's own time; fednav's epochs are whole IMU samples
        # on a grid: about a fifth of the fix interval bounds a fix's wait for its update
        # whatever the IMU clock's offset from its nominal rate (epoch_drift)
        from .run import samples_within

        dt = imu.period()
        p = float(np.median(np.diff(sensors["gnss"].t)))
        n = samples_within(p / 5, dt)
        system = system.model_copy(update={"filter": system.filter.model_copy(
            update={"period_s": n * dt})})
        tr.keys.append(KeyFate("(update timing)", "translated", f"KF-GINS updates at each "
                               f"fix's time: filter.period_s {n * dt:.6g} s ({n} IMU "
                               f"samples, a fifth of the {p:g} s between fixes)"))
    paths = {"kfgins_config": tr.source, "imu": tr.imu, "gnss": tr.gnss}
    if tr.imu_columns > 7:
        if "odometer" in system.sensors:
            sensors["odometer"] = read_kfgins_odometer(tr.imu, start_s=tr.start_s,
                                                       end_s=tr.end_s)
        else:
            warnings.append(f"{tr.imu}: the odometer column is not used (no "
                            f"sensors.odometer section in --config; KF-GINS does not use "
                            f"it either)")
    ref = None
    for folder in dict.fromkeys((tr.source.parent, tr.imu.parent)):
        if (folder / TRUTH).is_file():
            ref = read_kfgins_nav(folder / TRUTH)
            paths["reference"] = folder / TRUTH
            warnings.append(f"{folder / TRUTH}: taken as the reference (KF-GINS's dataset "
                            f"truth)")
            break
    return {"imu": imu, "sensors": sensors, "ref": ref, "system": system,
            "warnings": warnings, "paths": paths, "translation": tr}
