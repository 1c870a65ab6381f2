"""u-blox UBX logs (read with ``pyubx2``): the receiver's ``NAV-PVT`` solutions as the
GNSS's series.

Each ``NAV-PVT`` gives a fix: latitude, longitude, the height above the ellipsoid, the
NED velocity (turned into ENU here), their accuracy estimates ``hAcc`` (the horizontal
position's 1-sigma, used for north and for east, as PX4's EKF2 uses it), ``vAcc`` (up) and
``sAcc`` (each velocity axis), the fix type and the carrier solution.  A fix is kept when
``gnssFixOK`` is set and the fix is 3-D (type 3, or 4: GNSS + dead reckoning); the others,
and the messages of other classes (NMEA mixed in, other UBX messages), are counted.

Times: by default seconds since 1970-01-01 UTC from the message's date and time (its
``nano`` correction included; a fix without a valid date and time is dropped), or
``time="week"``: the GPS time of week ``iTOW`` [s] (KF-GINS's time base).
"""

from __future__ import annotations

import calendar
from pathlib import Path

import numpy as np

from ..core import units
from .data import DataError, GnssData, import_for, require_file

#: NAV-PVT fix types and carrier solutions.
FIX_TYPE = {0: "no_fix", 1: "dead_reckoning", 2: "2d", 3: "3d", 4: "gnss_dr", 5: "time_only"}
CARRIER = {0: "none", 1: "float", 2: "fixed"}


def read_ubx(path, *, time: str = "utc", lever=(0.0, 0.0, 0.0)) -> GnssData:
    """Read the ``NAV-PVT`` fixes of a u-blox UBX log (module docstring).

    Parameters
    ----------
    path : str or Path
        The binary log (``.ubx``).
    time : {"utc", "week"}
        The time base of ``t``: seconds since 1970-01-01 UTC, or the GPS time of week.
    lever : sequence of float
        The antenna lever arm, body right-forward-up [m].

    Returns
    -------
    GnssData
        ``t`` [s], lat/lon [rad], h above the ellipsoid [m], ENU velocity [m/s], each fix's
        1-sigma from its accuracy estimates; ``quality`` counts the fixes by fix type and
        carrier solution and what was left out.

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    pyubx2 = import_for(path, "pyubx2", "UBX")
    path = Path(path)
    require_file(path, "UBX log")
    src = str(path)
    if time not in ("utc", "week"):
        raise DataError(f"{src}: time must be 'utc' or 'week', got '{time}'")
    rows, kinds, left = [], {}, {"not_3d_or_no_fix_ok": 0, "no_valid_utc": 0,
                                 "other_messages": 0, "errors": 0}
    with path.open("rb") as f:
        reader = pyubx2.UBXReader(f, protfilter=pyubx2.UBX_PROTOCOL, quitonerror=1,
                           errorhandler=lambda e: left.__setitem__("errors",
                                                                   left["errors"] + 1))
        for _, m in reader:
            if m is None or getattr(m, "identity", "") != "NAV-PVT":
                left["other_messages"] += 1
                continue
            if not m.gnssFixOk or m.fixType not in (3, 4):
                left["not_3d_or_no_fix_ok"] += 1
                continue
            if time == "utc":
                if not (m.validDate and m.validTime):
                    left["no_valid_utc"] += 1
                    continue
                t = calendar.timegm((m.year, m.month, m.day, m.hour, m.min, m.second)) \
                    + m.nano * 1e-9
            else:
                t = m.iTOW * 1e-3
            rows.append((t, m.lat, m.lon, m.height * 1e-3, m.velE * 1e-3, m.velN * 1e-3,
                         -m.velD * 1e-3, m.hAcc * 1e-3, m.vAcc * 1e-3, m.sAcc * 1e-3))
            key = f"{FIX_TYPE.get(m.fixType, m.fixType)}/{CARRIER.get(m.carrSoln, m.carrSoln)}"
            kinds[key] = kinds.get(key, 0) + 1
    if not rows:
        raise DataError(f"{src}: no NAV-PVT message with a 3-D fix (what was left out: "
                        f"{left})")
    a = np.array(rows, dtype=float)
    order = np.argsort(a[:, 0], kind="stable")
    a = a[order]
    dup = np.r_[False, np.diff(a[:, 0]) <= 0]  # (a repeated epoch: the first kept)
    left["repeated_epochs"] = int(dup.sum())
    a = a[~dup]
    h, v, s = a[:, 7], a[:, 8], a[:, 9]
    sig = np.column_stack([h, h, v, s, s, s])  # north, east, up [m], vE, vN, vU [m/s]
    sig = np.maximum(sig, 1e-3)  # (an accuracy estimate of 0: a millimetre, mm/s)
    lla = np.column_stack([units.deg(a[:, 1]), units.deg(a[:, 2]), a[:, 3]])
    out = GnssData(src, a[:, 0], lla, a[:, 4:7], np.full(3, 5.0), np.full(3, 0.1),
                   np.asarray(lever, dtype=float), sigma_rows=sig)
    out.quality.update({"gnss_ubx_fixes": kinds, "gnss_ubx_left_out": left})
    return out
