"""The solution in the field's common formats, on request (``fednav process ... --export
kml,gpx,geojson``): ``solution.kml`` for Google Earth (the track coloured by its
horizontal 1-sigma, the outages drawn apart), ``solution.gpx`` for GPS tools,
``solution.geojson`` for a GIS and ``KF_GINS_Navresult.nav`` in KF-GINS's layout
(:func:`fednav.io.kfgins.write_kfgins_nav`: its plotting script reads it).

Heights: GeoJSON's third coordinate is the height above the WGS-84 ellipsoid (RFC 7946),
which is what fednav's ``h`` is; KML and most GPX readers take heights above mean sea
level, so the KML track is clamped to the ground and the GPX elevation is the ellipsoidal
height (said in the file's description).  Times: a solution whose times are seconds since
1970-01-01 (an RTKLIB or Unix clock: larger than the GPS epoch) carries them as UTC-like
date-times in the GPX and KML (on the file's own clock: GPS time is 18 s ahead of UTC);
any other time base has them as seconds in the descriptions only.
"""

from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path

import numpy as np

from ..core import units
from ..core.atomic import replacing
from ..io.kfgins import write_kfgins_nav
from ..navigator.solution import Solution

#: The formats ``--export`` takes, each with the package that writes it.
EXPORTS = {"kml": "simplekml", "gpx": "gpxpy", "geojson": "geojson", "kfgins": "numpy"}
#: the file each kind writes, when it is not ``solution.<kind>``
FILE_NAMES = {"kfgins": "KF_GINS_Navresult.nav"}
#: Horizontal 1-sigma bins of the KML track's colours [m] and their colours (aabbggrr).
SIGMA_BINS_M = (0.1, 0.5, 2.0, 10.0)
COLOURS = ("ff00ff00", "ff00ffaa", "ff00ffff", "ff0088ff", "ff0000ff")
#: Times above this are seconds since 1970-01-01 (after the GPS epoch, 1980-01-06).
ABSOLUTE_AFTER_S = 315964800.0


def check_exports(spec: str | None) -> tuple[str, ...]:
    """The formats of ``--export`` (comma-separated; None or '': none); a ValueError names
    an unknown one or the missing package (the extra ``export`` of fednav)."""
    kinds = tuple(dict.fromkeys(k.strip().lower() for k in (spec or "").split(",")
                                if k.strip()))
    for k in kinds:
        if k not in EXPORTS:
            raise ValueError(f"--export {k}: must be one or more of "
                             f"{', '.join(EXPORTS)} (comma-separated)")
        try:
            __import__(EXPORTS[k])
        except ImportError:
            raise ValueError(f"--export {k} needs {EXPORTS[k]}: pip install "
                             f"'fednav[export]'") from None
    return kinds


def _horizontal_sigma(sol: Solution) -> np.ndarray:
    return np.hypot(sol.sigma[:, 6], sol.sigma[:, 7])


def _when(t: float):
    """A date-time for a time [s] since 1970-01-01, else None."""
    if t <= ABSOLUTE_AFTER_S:
        return None
    return _dt.datetime.fromtimestamp(float(t), _dt.UTC)


def _inside(t: np.ndarray, outages: dict) -> list[tuple[str, float, float, np.ndarray]]:
    """Each outage window with the solution rows inside it: (sensor, start, end, rows)."""
    out = []
    for name, windows in (outages or {}).items():
        for a, b in windows:
            rows = np.flatnonzero((t >= a) & (t < b))
            if len(rows):
                out.append((name, float(a), float(b), rows))
    return out


def write_kml(path: Path, sol: Solution, outages: dict | None = None) -> Path:
    """The track as KML: one line per run of rows in the same horizontal 1-sigma bin
    (:data:`SIGMA_BINS_M`: green below 0.1 m to red above 10 m), the outage windows in a
    folder of their own (white, wide), clamped to the ground."""
    import simplekml

    kml = simplekml.Kml(name=f"fednav solution ({len(sol.t)} rows)")
    lat, lon = units.to_deg(sol.lla[:, 0]), units.to_deg(sol.lla[:, 1])
    s = _horizontal_sigma(sol)
    b = np.digitize(s, SIGMA_BINS_M)
    track = kml.newfolder(name="track, coloured by horizontal 1-sigma")
    edges = np.flatnonzero(np.diff(b)) + 1
    for lo, hi in zip(np.r_[0, edges], np.r_[edges, len(b)], strict=True):
        rows = slice(lo, min(hi + 1, len(b)))  # (each run joins the next)
        ls = track.newlinestring(coords=list(zip(lon[rows], lat[rows], strict=True)))
        k = int(b[lo])
        bound = (f"< {SIGMA_BINS_M[k]:g} m" if k < len(SIGMA_BINS_M)
                 else f">= {SIGMA_BINS_M[-1]:g} m")
        ls.name = f"horizontal 1-sigma {bound}"
        ls.description = (f"t {sol.t[lo]:.3f} .. {sol.t[rows][-1]:.3f} s, horizontal "
                          f"1-sigma {s[rows].min():.3g} .. {s[rows].max():.3g} m")
        ls.altitudemode = simplekml.AltitudeMode.clamptoground
        ls.style.linestyle.color = COLOURS[k]
        ls.style.linestyle.width = 3
        when = _when(sol.t[lo])
        if when is not None:
            ls.timespan.begin = when.isoformat()
            ls.timespan.end = _when(sol.t[rows][-1]).isoformat()
    gaps = _inside(sol.t, outages)
    if gaps:
        folder = kml.newfolder(name="outages")
        for name, a, c, rows in gaps:
            ls = folder.newlinestring(name=f"{name} outage {a:g}-{c:g} s",
                                      coords=list(zip(lon[rows], lat[rows], strict=True)))
            ls.description = (f"{name} measurements withheld from {a:g} to {c:g} s; "
                              f"horizontal 1-sigma at its end {s[rows][-1]:.3g} m")
            ls.altitudemode = simplekml.AltitudeMode.clamptoground
            ls.style.linestyle.color = "ffffffff"
            ls.style.linestyle.width = 6
    with replacing(Path(path)) as tmp:
        kml.save(str(tmp))
    return Path(path)


def write_gpx(path: Path, sol: Solution) -> Path:
    """The track as GPX 1.1: each row a track point with its ellipsoidal height as the
    elevation, its time when the solution's is absolute, and its time [s] and horizontal
    1-sigma [m] in the point's comment."""
    import gpxpy.gpx

    gpx = gpxpy.gpx.GPX()
    gpx.creator = "fednav"
    gpx.description = ("fednav solution; elevation: height above the WGS-84 ellipsoid [m]; "
                       + ("times on the solution's clock" if _when(sol.t[0]) else
                          f"times not absolute (t {sol.t[0]:.3f} .. {sol.t[-1]:.3f} s)"))
    trk = gpxpy.gpx.GPXTrack(name="fednav solution")
    seg = gpxpy.gpx.GPXTrackSegment()
    lat, lon = units.to_deg(sol.lla[:, 0]), units.to_deg(sol.lla[:, 1])
    s = _horizontal_sigma(sol)
    for i in range(len(sol.t)):
        p = gpxpy.gpx.GPXTrackPoint(float(lat[i]), float(lon[i]),
                                    elevation=float(sol.lla[i, 2]), time=_when(sol.t[i]))
        p.comment = f"t {sol.t[i]:.3f} s, horizontal 1-sigma {s[i]:.3g} m"
        seg.points.append(p)
    trk.segments.append(seg)
    gpx.tracks.append(trk)
    with replacing(Path(path)) as tmp:
        Path(tmp).write_text(gpx.to_xml(version="1.1"))
    return Path(path)


def write_geojson(path: Path, sol: Solution, outages: dict | None = None) -> Path:
    """The track as a GeoJSON FeatureCollection (RFC 7946): a LineString of ``[lon, lat,
    h]`` (h above the ellipsoid) with the times [s] and horizontal 1-sigma [m] of its
    vertices as properties, and one LineString per outage window."""
    import geojson

    lat, lon = units.to_deg(sol.lla[:, 0]), units.to_deg(sol.lla[:, 1])
    coords = np.column_stack([lon, lat, sol.lla[:, 2]]).round(9).tolist()
    s = _horizontal_sigma(sol)
    feats = [geojson.Feature(geometry=geojson.LineString(coords), properties={
        "name": "fednav solution", "t_s": np.round(sol.t, 6).tolist(),
        "sigma_horizontal_m": np.round(s, 4).tolist()})]
    for name, a, b, rows in _inside(sol.t, outages):
        feats.append(geojson.Feature(geometry=geojson.LineString(
            [coords[i] for i in rows]), properties={"name": f"{name} outage",
                                                    "outage_s": [a, b]}))
    fc = geojson.FeatureCollection(feats)
    if not fc.is_valid:
        raise ValueError(f"solution.geojson: {fc.errors()}")
    with replacing(Path(path)) as tmp:
        Path(tmp).write_text(json.dumps(fc))
    return Path(path)


def write_exports(out: Path, sol: Solution, kinds, outages: dict | None = None) -> list[Path]:
    """``solution.<kind>`` in ``out`` (made if missing) for each of ``kinds``
    (:data:`EXPORTS`)."""
    Path(out).mkdir(parents=True, exist_ok=True)
    writers = {"kml": lambda p: write_kml(p, sol, outages), "gpx": lambda p: write_gpx(p, sol),
               "geojson": lambda p: write_geojson(p, sol, outages),
               "kfgins": lambda p: write_kfgins_nav(p, sol.t, sol.lla, sol.vel, sol.euler)}
    return [writers[k](Path(out) / FILE_NAMES.get(k, f"solution.{k}")) for k in kinds]
