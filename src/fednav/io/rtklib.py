"""RTKLIB position solutions (``.pos``, the output of ``rnx2rtkp``/RTKPOST/RTKNAVI) as the
GNSS's series.

The file's ``%`` header ends with the column line; the time is ``yyyy/mm/dd hh:mm:ss.sss``
or ``week tow`` in the time system the header names (``GPST``, ``UTC`` ...); positions are
latitude/longitude in degrees (or degrees-minutes-seconds) and ellipsoidal height, or ECEF
``x/y/z-ecef(m)``; then ``Q`` (1 fixed, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP), the
satellite count, the 1-sigma ``sdn sde sdu`` [m] (and their signed square-root
covariances, not used: fednav's GNSS noise is diagonal) and, when the solution has them,
the velocity ``vn ve vu`` [m/s] with its ``sdvn sdve sdvu``.  A baseline solution
(``e/n/u-baseline``) is relative to its base and refused.

Times: by default seconds since 1970-01-01 on the file's own clock — RTKLIB's own time
tags, what its ``.tag`` files for an IMU log hold — or ``time="week"``: seconds of the GPS
week (a GPST file only; KF-GINS's time base; a file across a week's end is refused, its
times not increasing).
"""

from __future__ import annotations

import calendar
import re
from pathlib import Path

import numpy as np

from ..core import earth, units
from .data import DataError, GnssData, require_file

#: The solution's quality flag Q and its meaning.
QUALITY = {1: "fixed", 2: "float", 3: "sbas", 4: "dgps", 5: "single", 6: "ppp"}
#: Seconds of one GPS week.
WEEK_S = 604800.0
#: 1980-01-06 00:00:00 (the GPS epoch) in seconds since 1970-01-01 (same clock).
GPS_EPOCH_S = 315964800.0


def _columns(header: str) -> list[str]:
    """The column names of the header line (the first one, the time, may be two tokens:
    date and time, or week and tow)."""
    return re.findall(r"[a-z][a-z0-9\-]*(?:\([^)]*\))?", header.lower())


def _dms(deg, minutes, sec) -> np.ndarray:
    sign = np.where(np.char.startswith(deg.astype(str), "-"), -1.0, 1.0)
    return sign * (np.abs(deg.astype(float)) + minutes.astype(float) / 60.0
                   + sec.astype(float) / 3600.0)


def read_rtklib_pos(path, *, time: str = "rtklib", quality: tuple[int, ...] | None = None,
                     sigma_pos_enu=5.0, sigma_vel=0.1, lever=(0.0, 0.0, 0.0)) -> GnssData:
    """Read an RTKLIB ``.pos`` solution (module docstring).

    Parameters
    ----------
    path : str or Path
        The ``.pos`` file.
    time : {"rtklib", "week"}
        The time base of ``t``: seconds since 1970-01-01 on the file's clock (RTKLIB's
        time tags), or seconds of the GPS week (a GPST file only).
    quality : tuple of int, optional
        The solution qualities Q kept (e.g. ``(1,)``: fixed only); default all.  The rows
        of each Q are counted in ``data.quality`` (``gnss_rtklib_q``).
    sigma_pos_enu, sigma_vel, lever
        As :func:`fednav.io.read_gnss_csv`: the figures where the file gives none, or 0
        (counted in ``gnss_sigma_zero_replaced``) [m, m/s], the antenna lever arm body
        right-forward-up [m].

    Returns
    -------
    GnssData
        The fixes: ``t`` [s], lat/lon [rad], h [m], ENU velocity [m/s] when the file has
        it, each fix's 1-sigma (``sigma_rows``: north, east, up m, vE, vN, vU m/s).

    Raises
    ------
    DataError
        One line naming the file and what is wrong.
    """
    path = Path(path)
    require_file(path, "RTKLIB solution")
    src = str(path)
    if time not in ("rtklib", "week"):
        raise DataError(f"{src}: time must be 'rtklib' or 'week', got '{time}'")
    lines = path.read_text(errors="replace").splitlines()
    head = [ln for ln in lines if ln.startswith("%")]
    rows = [ln.split() for ln in lines if ln.strip() and not ln.startswith("%")]
    if not head or not rows:
        raise DataError(f"{src}: not an RTKLIB solution (no '%' header, or no solution row)")
    names = _columns(head[-1].lstrip("%"))
    if not names:
        raise DataError(f"{src}: no column line at the end of the '%' header")
    system = names[0].upper()  # GPST, UTC, JST ...
    if any("baseline" in n for n in names):
        raise DataError(f"{src}: a baseline solution (e/n/u-baseline) is relative to its base "
                        f"station; output positions (lat/lon/height or x/y/z-ecef) instead")
    width = {len(r) for r in rows}
    if len(width) != 1:
        n = max(width, key=lambda w: sum(len(r) == w for r in rows))
        bad = next(i for i, r in enumerate(rows) if len(r) != n)
        raise DataError(f"{src}: solution row {bad + 1} has {len(rows[bad])} values, the "
                        f"others {n}")
    a = np.array(rows, dtype=object)
    # the time: two tokens (date time, or week tow)
    if "/" in str(a[0, 0]):
        try:
            stamp = [calendar.timegm((int(d[0:4]), int(d[5:7]), int(d[8:10]), 0, 0, 0))
                     for d in a[:, 0]]
            hms = np.array([s.split(":") for s in a[:, 1]], dtype=float)
        except (ValueError, IndexError):
            raise DataError(f"{src}: a time is not 'yyyy/mm/dd hh:mm:ss'") from None
        whole = np.asarray(stamp, dtype=float)  # (whole days: exact)
        part = hms @ np.array([3600.0, 60.0, 1.0])
    else:
        try:
            week, part = a[:, 0].astype(float), a[:, 1].astype(float)
        except ValueError:
            raise DataError(f"{src}: a time is neither 'yyyy/mm/dd hh:mm:ss' nor "
                            f"'week tow'") from None
        whole = GPS_EPOCH_S + week * WEEK_S
    if time == "week":
        if system != "GPST":
            raise DataError(f"{src}: time='week' needs a GPST solution; this one is in "
                            f"{system}")
        t = np.mod(whole - GPS_EPOCH_S, WEEK_S) + part  # (across a week's end: refused)
    else:
        t = whole + part
    rest = a[:, 2:]
    fields = names[1:]
    dms = "latitude(d'\")" in fields or any("(d'" in f for f in fields)
    if dms:  # (each angle three tokens: degrees, minutes, seconds)
        lat = units.deg(_dms(rest[:, 0], rest[:, 1], rest[:, 2]))
        lon = units.deg(_dms(rest[:, 3], rest[:, 4], rest[:, 5]))
        rest = np.column_stack([lat, lon, rest[:, 6:]])
    try:
        v = rest.astype(float)
    except ValueError:
        raise DataError(f"{src}: a value that is not a number in the solution rows") from None
    col = {f.split("(")[0]: j for j, f in enumerate(fields)}
    if "latitude" in col and "longitude" in col and "height" in col:
        lla = np.column_stack([v[:, col["latitude"]] if dms else units.deg(
            v[:, col["latitude"]]), v[:, col["longitude"]] if dms else units.deg(
                v[:, col["longitude"]]), v[:, col["height"]]])
    elif "x-ecef" in col:
        lla = np.array([earth.ecef_to_llh(r) for r in v[:, [col["x-ecef"], col["y-ecef"],
                                                            col["z-ecef"]]]])
    else:
        raise DataError(f"{src}: no position columns (latitude/longitude/height or "
                        f"x/y/z-ecef) in the header: {' '.join(fields)}")
    q = v[:, col["q"]].astype(int) if "q" in col else np.zeros(len(v), dtype=int)
    counts = {QUALITY.get(int(k), str(int(k))): int((q == k).sum()) for k in np.unique(q)}
    keep = np.ones(len(v), dtype=bool) if quality is None else np.isin(q, quality)
    if not keep.any():
        raise DataError(f"{src}: no solution of quality {list(quality)} (the file has "
                        f"{counts})")
    has_vel = all(k in col for k in ("vn", "ve", "vu"))
    vel = v[:, [col["ve"], col["vn"], col["vu"]]] if has_vel else None
    v, t, lla, q = v[keep], t[keep], lla[keep], q[keep]
    vel = None if vel is None else vel[keep]
    # each fix's 1-sigma [north, east, up m, vE, vN, vU m/s]: the file's where it gives a
    # positive one, the figures given where it has none or 0 (counted)
    figures = np.r_[np.broadcast_to(np.asarray(sigma_pos_enu, dtype=float), (3,))[[1, 0, 2]],
                    np.broadcast_to(np.asarray(sigma_vel, dtype=float), (3,))]
    s = np.tile(figures, (len(v), 1))
    given = np.zeros((len(v), 6), dtype=bool)
    for j, k in enumerate(("sdn", "sde", "sdu", "sdve", "sdvn", "sdvu")):
        if k in col and (j < 3 or has_vel):
            s[:, j] = v[:, col[k]]
            given[:, j] = True
    zero = given & ~(s > 0)
    s[zero] = np.broadcast_to(figures, s.shape)[zero]
    sig = s if (given & ~zero).any() else None  # (none given: the figures, per file)
    out = GnssData(src, t, lla, vel,
                   np.broadcast_to(np.asarray(sigma_pos_enu, dtype=float), (3,)).copy(),
                   np.broadcast_to(np.asarray(sigma_vel, dtype=float), (3,)).copy(),
                   np.asarray(lever, dtype=float), sigma_rows=sig)
    out.quality["gnss_sigma_zero_replaced"] = int(zero.any(axis=1).sum())
    out.quality.update({"gnss_rtklib_q": counts, "gnss_time_system": system,
                        "gnss_rows_of_other_quality": int((~keep).sum())})
    return out
