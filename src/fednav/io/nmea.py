"""NMEA 0183 receiver logs (read with ``pynmea2``) as the GNSS's series.

Sentences of one epoch share its UTC time of day: ``GGA`` gives the position (latitude,
longitude, the altitude above mean sea level plus the geoid separation: the ellipsoidal
height) and the fix quality (0, no fix: dropped); ``RMC`` the date, speed and course over
ground (status ``V``: void, not used); ``VTG`` speed and course (the epoch of the sentence
before it); ``GST`` the position's 1-sigma (latitude, longitude, altitude errors [m]);
``ZDA`` the date.  Any talker (GP, GN, GL, GA, BD ...).  A line that is not a valid
sentence (checksum, truncation) is skipped and counted.

Velocity: NMEA's is horizontal only (speed and course over ground), and fednav's GNSS
model measures the whole velocity, so by default the fixes are positions only (the
alignment takes the course from their differences); ``velocity=True`` adds east and north
from speed and course with the vertical 0 at a 1-sigma of :data:`NO_VERTICAL_SIGMA` — no
information, but a row that counts in the GNSS's NIS/dof (about 5/6 of it then).

Times: seconds since 1970-01-01 UTC from the sentences' dates (the time of day rolling
over to the next day when it runs backwards); a log without RMC or ZDA has no date: times
are then seconds since 00:00 UTC of its first day, with a warning (``date=`` gives the
day).
"""

from __future__ import annotations

import calendar
import datetime as _dt
import warnings
from pathlib import Path

import numpy as np

from ..core import units
from .data import DataError, GnssData, import_for, require_file

#: Knots and km/h in m/s.
KNOT_MPS = 1852.0 / 3600.0
KMH_MPS = 1.0 / 3.6
#: The vertical velocity's 1-sigma [m/s]: NMEA has none (no information).
NO_VERTICAL_SIGMA = 100.0
#: GGA fix quality and its meaning.
FIX = {1: "gps", 2: "dgps", 3: "pps", 4: "rtk_fixed", 5: "rtk_float", 6: "dead_reckoning",
       7: "manual", 8: "simulation"}


class NmeaDateWarning(UserWarning):
    """An NMEA log without a date: its times are seconds of its first day."""


def _seconds(ts) -> float:
    return ts.hour * 3600.0 + ts.minute * 60.0 + ts.second + ts.microsecond * 1e-6


def read_nmea(path, *, date: str | _dt.date | None = None, sigma_pos_enu=5.0,
              sigma_vel=0.1, lever=(0.0, 0.0, 0.0), velocity: bool = False) -> GnssData:
    """Read an NMEA 0183 log (module docstring).

    Parameters
    ----------
    path : str or Path
        The log (text, one sentence per line).
    date : str or date, optional
        The UTC day of the first epoch (``YYYY-MM-DD``) for a log without RMC or ZDA.
    sigma_pos_enu, sigma_vel, lever
        As :func:`fednav.io.read_gnss_csv`: the figures where the log gives none (GST) [m,
        m/s], the antenna lever arm body right-forward-up [m].
    velocity : bool
        Also the speed and course over ground (RMC/VTG) as the horizontal velocity (the
        vertical 0 at :data:`NO_VERTICAL_SIGMA`; module docstring).

    Returns
    -------
    GnssData
        ``t`` [s], lat/lon [rad], ellipsoidal h [m], ENU velocity [m/s] (when the log has
        speed and course), each fix's 1-sigma when it has GST; ``quality`` counts the
        fixes by GGA quality, the sentences skipped and those without a fix.

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    pynmea2 = import_for(path, "pynmea2", "NMEA")
    path = Path(path)
    require_file(path, "NMEA log")
    src = str(path)
    epochs: dict[float, dict] = {}  # time of day -> what the sentences said
    order: list[float] = []
    bad = 0
    day0 = None
    last = None
    for line in path.read_text(errors="replace").splitlines():
        s = line.strip()
        if not s.startswith("$"):
            continue
        try:
            m = pynmea2.parse(s, check=True)
        except (pynmea2.ParseError, ValueError, AttributeError, TypeError):
            bad += 1
            continue
        kind = m.sentence_type
        ts = getattr(m, "timestamp", None) if kind != "VTG" else None
        if kind == "VTG":
            key = last
        elif isinstance(ts, _dt.time):
            key = _seconds(ts)
        else:
            continue
        if key is None:
            continue
        if key not in epochs:
            epochs[key] = {}
            order.append(key)
        e = epochs[key]
        last = key
        try:
            if kind == "GGA":
                if m.gps_qual and int(m.gps_qual) > 0 and m.latitude is not None:
                    e["lla"] = (m.latitude, m.longitude,
                                float(m.altitude) + float(m.geo_sep or 0.0))
                    e["fix"] = int(m.gps_qual)
                else:
                    e["nofix"] = True
            elif kind == "RMC":
                if m.datestamp is not None:
                    e["date"] = m.datestamp
                    day0 = day0 or m.datestamp
                if m.status == "A" and m.spd_over_grnd is not None and m.true_course is not None:
                    e["vel"] = (float(m.spd_over_grnd) * KNOT_MPS, float(m.true_course))
            elif kind == "VTG":
                if m.spd_over_grnd_kmph is not None and m.true_track is not None:
                    e.setdefault("vel", (float(m.spd_over_grnd_kmph) * KMH_MPS,
                                         float(m.true_track)))
            elif kind == "GST":
                sd = (m.std_dev_latitude, m.std_dev_longitude, m.std_dev_altitude)
                if all(v is not None for v in sd):
                    e["sigma"] = tuple(float(v) for v in sd)
            elif kind == "ZDA":
                if m.year and m.month and m.day:
                    e["date"] = _dt.date(int(m.year), int(m.month), int(m.day))
                    day0 = day0 or e["date"]
        except (ValueError, TypeError):
            bad += 1
    fixes = [k for k in order if "lla" in epochs[k]]
    if not fixes:
        raise DataError(f"{src}: no GGA sentence with a fix (quality > 0)"
                        + (f"; {bad} line(s) not valid NMEA" if bad else ""))
    # the day of each epoch: its own date, else the last one seen, rolling over at 00:00
    if date is not None:
        day0 = date if isinstance(date, _dt.date) else _dt.date.fromisoformat(str(date))
    if day0 is None:
        warnings.warn(f"{src}: no date in the log (no RMC or ZDA): times are seconds since "
                      f"00:00 UTC of its first day; read_nmea(date=...) gives the day",
                      NmeaDateWarning, stacklevel=2)
    base = 0.0 if day0 is None else float(calendar.timegm(day0.timetuple()))
    t = np.empty(len(order))
    days, prev, day = 0, None, base
    for i, k in enumerate(order):
        d = epochs[k].get("date")
        if d is not None:
            day = float(calendar.timegm(d.timetuple()))
            days = 0
        elif prev is not None and k < prev - 43200.0:  # (the time of day ran backwards)
            days += 1
        t[i] = day + days * 86400.0 + k
        prev = k
    keep = np.array(["lla" in epochs[k] for k in order])
    rows = [epochs[k] for k in order if "lla" in epochs[k]]
    lla = np.array([(units.deg(r["lla"][0]), units.deg(r["lla"][1]), r["lla"][2])
                    for r in rows])
    vel = None
    if velocity and all("vel" in r for r in rows):
        sp = np.array([r["vel"] for r in rows])
        c = units.deg(sp[:, 1])
        vel = np.column_stack([sp[:, 0] * np.sin(c), sp[:, 0] * np.cos(c), np.zeros(len(sp))])
    # each fix's 1-sigma [north, east, up m, vE, vN, vU m/s]: GST's, else the figures; with
    # a velocity always per fix, so the vertical's no-information sigma holds
    pos = np.broadcast_to(np.asarray(sigma_pos_enu, dtype=float), (3,))[[1, 0, 2]]
    sv = np.broadcast_to(np.asarray(sigma_vel, dtype=float), (3,))
    gst = all("sigma" in r for r in rows)
    sig = None
    if gst or vel is not None:
        s = np.array([r["sigma"] for r in rows]) if gst else np.tile(pos, (len(rows), 1))
        sig = np.column_stack([s, np.tile([sv[0], sv[1], NO_VERTICAL_SIGMA], (len(s), 1))])
    sv3 = sv.copy()
    fix = np.array([r["fix"] for r in rows])
    out = GnssData(src, t[keep], lla, vel,
                   np.broadcast_to(np.asarray(sigma_pos_enu, dtype=float), (3,)).copy(), sv3,
                   np.asarray(lever, dtype=float), sigma_rows=sig)
    out.quality.update({"gnss_nmea_fix": {FIX.get(int(q), str(int(q))): int((fix == q).sum())
                                          for q in np.unique(fix)},
                        "gnss_nmea_lines_skipped": bad,
                        "gnss_nmea_epochs_without_fix": int((~keep).sum())})
    return out
