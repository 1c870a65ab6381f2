"""An autopilot's flight log through the navigator (``fednav process ulog``).

A PX4 log (:func:`fednav.io.read_ulog`) holds the IMU, GNSS, barometer and magnetometer
but no IMU noise figures; :func:`ulog_system` completes the user's system description
from the log:

* the ``imu:`` figures, when the description gives none, are the ``consumer`` grade
  preset (:data:`fednav.sensors.imu.GRADES`: autopilot MEMS; said in a warning);
* ``sensors.gnss``: the receiver's own accuracy figures from the log (the reader's
  medians of ``eph``/``epv``/``s_variance_m_s``);
* ``sensors.mag``: the declination from the log's ``EKF2_MAG_DECL``, the inclination from
  the log itself — the angle between the mean field and the mean specific force over the
  first second (the field dips ``I`` below the horizon; at rest the specific force points
  up) — and :data:`MAG_SIGMA_DEG`; the initial heading (``alignment.coarse_heading_deg``)
  is the magnetometer's over that second, levelled by the specific force;
* ``sensors.baro``: :data:`BARO_SIGMA_M`, a filter measurement (the reader moved the
  barometric altitude onto the GNSS height).

The user's description wins wherever it gives a value.
"""

from __future__ import annotations

import numpy as np

from ..navigator.system import System

#: Heading 1-sigma of a magnetometer on an autopilot (motor currents, calibration) [deg].
MAG_SIGMA_DEG = 2.0
#: Barometric height 1-sigma [m].
BARO_SIGMA_M = 0.5


def _first_second(rec, seconds: float = 1.0):
    """The mean specific force [m/s^2] and field (body RFU) over the first ``seconds`` of
    both, or None."""
    mag = rec.sensors.get("mag")
    if mag is None or not len(mag.t):
        return None
    t0 = max(rec.imu.t[0], mag.t[0])
    f = rec.imu.accel[(rec.imu.t >= t0) & (rec.imu.t <= t0 + seconds)].mean(axis=0)
    m = mag.z[(mag.t >= t0) & (mag.t <= t0 + seconds)].mean(axis=0)
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(m))) or not np.any(m):
        return None
    return f, m


def inclination_of(rec, seconds: float = 1.0) -> float | None:
    """The field's inclination [rad] from the log: the angle between the mean specific
    force (up, at rest) and the mean field over the first ``seconds`` of both."""
    fm = _first_second(rec, seconds)
    if fm is None:
        return None
    f, m = fm
    return float(np.arcsin(np.clip(-(f @ m) / (np.linalg.norm(f) * np.linalg.norm(m)),
                                   -1.0, 1.0)))


def initial_heading(rec, declination: float, seconds: float = 1.0) -> float | None:
    """The heading [rad] at the start from the magnetometer: the field over the first
    ``seconds`` levelled with the specific force's pitch and roll, plus the declination
    [rad] (for a vehicle that does not move at first: no GNSS course)."""
    from ..ins.alignment import coarse_level
    from ..sensors.mag import magnetic_heading

    fm = _first_second(rec, seconds)
    if fm is None:
        return None
    f, m = fm
    return float((magnetic_heading(coarse_level(f), m) + declination) % (2 * np.pi))


def ulog_system(rec, cfg: System) -> tuple[System, list[str]]:
    """``cfg`` completed from the log (see the module docstring); returns it and the
    warnings saying what was assumed."""
    warnings = []
    data = cfg.model_dump(exclude_unset=True, mode="json")
    sensors = data.setdefault("sensors", {})
    g = rec.gnss
    if g is not None:
        sec = sensors.setdefault("gnss", {})
        sec.setdefault("sigma_pos_enu_m", [float(v) for v in g.sigma_pos_enu])
        sec.setdefault("sigma_vel_mps", [float(v) for v in g.sigma_vel])
    if "mag" in rec.sensors:
        sec = sensors.setdefault("mag", {})
        sec.setdefault("sigma_heading_deg", MAG_SIGMA_DEG)
        decl = rec.quality.get("mag_declination_deg")
        if "declination_deg" not in sec:
            if decl is None:
                warnings.append("the log gives no magnetic declination (EKF2_MAG_DECL): 0 "
                                "assumed; give sensors.mag.declination_deg")
            sec["declination_deg"] = float(decl or 0.0)
        if "inclination_deg" not in sec:
            inc = inclination_of(rec)
            if inc is not None:
                sec["inclination_deg"] = float(np.degrees(inc))
        # the initial heading from the magnetometer rather than the GNSS course: an
        # autopilot's vehicle may hover or fly crabbed (its course is not its heading)
        al = data.setdefault("alignment", {})
        if "coarse_heading_deg" not in al:
            h = initial_heading(rec, np.radians(sec["declination_deg"]))
            if h is not None:
                al["coarse_heading_deg"] = float(np.degrees(h))
    if "baro" in rec.sensors:
        sec = sensors.setdefault("baro", {})
        sec.setdefault("sigma_m", BARO_SIGMA_M)
        sec.setdefault("damping_loop", False)
    return System.model_validate(data), warnings
