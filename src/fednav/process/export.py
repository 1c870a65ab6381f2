"""The solution in the field's common formats, on request (``fednav process ... --export
kml,gpx,geojson``): ``solution.kml`` for Google Earth (the track coloured by its
horizontal 1-sigma, the outages drawn apart), ``solution.gpx`` for GPS tools,
``solution.geojson`` for a GIS, ``KF_GINS_Navresult.nav`` in KF-GINS's layout
(:func:`fednav.io.kfgins.write_kfgins_nav`: its plotting script reads it) and
``solution_bag/``, a ROS 2 bag for ROS tools (:func:`write_rosbag`:
``nav_msgs/msg/Odometry`` and ``sensor_msgs/msg/NavSatFix``).

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
EXPORTS = {"kml": "simplekml", "gpx": "gpxpy", "geojson": "geojson", "kfgins": "numpy",
           "rosbag": "rosbags"}
#: the file each kind writes, when it is not ``solution.<kind>`` (``rosbag``: a folder)
FILE_NAMES = {"kfgins": "KF_GINS_Navresult.nav", "rosbag": "solution_bag"}
#: The extra of fednav that installs a kind's package, when it is not ``export``.
EXTRAS = {"rosbag": "formats"}
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
                             f"'fednav[{EXTRAS.get(k, 'export')}]'") from None
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


#: ``--export rosbag``: the bag's topics and frames.
ODOMETRY_TOPIC, FIX_TOPIC = "/fednav/odometry", "/fednav/fix"
MAP_FRAME, BODY_FRAME = "map", "base_link"
#: The key of the bag's ``custom_data`` (metadata.yaml) that marks it as fednav's: a
#: folder without it is never replaced.
ROSBAG_MARK = "fednav"


def rosbag_frames(sol: Solution):
    """What :func:`write_rosbag` writes of each row, in ROS's frames: positions [m]
    (N, 3) in the map frame (the ENU tangent frame at the first row, exact through
    ECEF), ``C_flu^map`` (N, 3, 3) (the body's FLU axes in it), ``R`` = ``C_enu^map``
    (N, 3, 3) (each row's local ENU frame in it: the identity at the first row), and
    ``C_flu^enu`` (N, 3, 3)."""
    from ..core import attitude as att
    from ..core import earth
    from ..core import mounting as mt

    lat, lon, h = sol.lla[:, 0], sol.lla[:, 1], sol.lla[:, 2]
    C0 = earth.enu_to_ecef(lat[0], lon[0])
    r = earth.llh_to_ecef(lat, lon, h)
    pos = (r - r[0]) @ C0  # C0^T (r - r0), row by row
    R = np.einsum("ji,njk->nik", C0, earth.enu_to_ecef(lat, lon))
    C_enu = att.euler_to_dcm(sol.euler) @ mt.from_letters("FLU")  # C_rfu^enu C_flu^rfu
    return pos, R @ C_enu, R, C_enu


def write_rosbag(path: Path, sol: Solution) -> Path:
    """The solution as a ROS 2 bag folder (sqlite3 storage, metadata version 8), one
    message of each topic per row, stamped with the row's time as a ROS time (seconds
    since 1970: the input's own ROS times when it was a bag, :func:`fednav.io.read_rosbag`;
    bag time = header stamp):

    * ``/fednav/odometry`` — ``nav_msgs/msg/Odometry``; ``header.frame_id`` ``map``: the
      ENU tangent frame at the first row (x east, y north, z up, origin at the first
      row's position: its latitude, longitude and height in the bag's ``custom_data``,
      ``fednav.map_origin_lat_deg`` ...); ``child_frame_id`` ``base_link``: fednav's body
      (the IMU) in ROS's FLU axes (x forward, y left, z up).  ``pose.position`` [m];
      ``pose.orientation`` the quaternion of ``C_flu^map`` (it turns FLU body vectors into
      the map frame); ``pose.covariance`` (x, y, z, then rotations about the map's x, y,
      z) from the position and attitude-error 1-sigmas (ENU, turned into the map frame;
      no cross terms).  ``twist`` in the child frame (FLU): the velocity [m/s] and the
      body rate [rad/s]; its covariance's velocity block from the ENU velocity 1-sigmas,
      its body-rate block zero (fednav gives no 1-sigma of the rate).
    * ``/fednav/fix`` — ``sensor_msgs/msg/NavSatFix``, ``frame_id`` ``base_link``: the
      IMU's latitude, longitude [deg] and height above the WGS-84 ellipsoid [m],
      ``status`` 0 (a fix), ``position_covariance`` ENU [m^2] from the position
      1-sigmas, ``position_covariance_type`` 2 (DIAGONAL_KNOWN).

    A ``path`` that exists is replaced only when fednav wrote it (:data:`ROSBAG_MARK` in
    its metadata); anything else there is a ValueError naming it.  The bag is written in
    a hidden folder beside ``path`` and moved into place when complete."""
    import os
    import shutil

    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    from ..core import attitude as att
    from ..core import mounting as mt
    from ..core.atomic import output_error

    path = Path(path)
    if (path.exists() or path.is_symlink()) and not _fednav_bag(path):
        raise ValueError(f"{path}: exists and is not a bag fednav wrote (no "
                         f"'{ROSBAG_MARK}' in its metadata.yaml custom_data): not "
                         f"replaced; move it away or choose another output folder")
    t = np.asarray(sol.t, dtype=float)
    if len(t) and t[0] < 0:
        raise ValueError(f"{path}: solution times from {t[0]:.6f} s: ROS times are not "
                         f"negative")
    ns = np.rint(t * 1e9).astype(np.int64)
    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    Odometry, Fix = T["nav_msgs/msg/Odometry"], T["sensor_msgs/msg/NavSatFix"]
    Pose, PoseCov = T["geometry_msgs/msg/Pose"], T["geometry_msgs/msg/PoseWithCovariance"]
    Twist, TwistCov = (T["geometry_msgs/msg/Twist"],
                       T["geometry_msgs/msg/TwistWithCovariance"])
    Point, Quat, Vec = (T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Quaternion"],
                        T["geometry_msgs/msg/Vector3"])
    Status = T["sensor_msgs/msg/NavSatStatus"]
    pos, C, R, C_enu = rosbag_frames(sol)
    q = att.dcm_to_quat(C)  # [w, x, y, z]
    s = np.asarray(sol.sigma, dtype=float)
    Rt = np.swapaxes(R, 1, 2)
    pose_cov = np.zeros((len(t), 6, 6))
    pose_cov[:, :3, :3] = R @ (s[:, 6:9, None] ** 2 * np.eye(3)) @ Rt
    pose_cov[:, 3:, 3:] = R @ (s[:, 0:3, None] ** 2 * np.eye(3)) @ Rt
    v_flu = np.einsum("nji,nj->ni", C_enu, sol.vel)  # C_flu^enu^T v_enu
    w_flu = np.asarray(sol.omega, dtype=float) @ mt.from_letters("FLU")  # M^T omega_rfu
    twist_cov = np.zeros((len(t), 6, 6))
    twist_cov[:, :3, :3] = (np.swapaxes(C_enu, 1, 2) @ (s[:, 3:6, None] ** 2 * np.eye(3))
                            @ C_enu)
    fix_cov = s[:, 6:9, None] ** 2 * np.eye(3)
    lat, lon = units.to_deg(sol.lla[:, 0]), units.to_deg(sol.lla[:, 1])
    work = path.with_name(f".{path.name}.{os.getpid()}.tmp")  # (the bag: work/<name>)
    old = path.with_name(f".{path.name}.{os.getpid()}.old")
    for p in (work, old):
        shutil.rmtree(p, ignore_errors=True)
    try:
        work.mkdir()
        w = Writer(work / path.name, version=8)
        w.set_custom_data(ROSBAG_MARK, "fednav process --export rosbag")
        if len(t):
            for k, v in (("lat_deg", lat[0]), ("lon_deg", lon[0]), ("h_m", sol.lla[0, 2])):
                w.set_custom_data(f"fednav.map_origin_{k}", f"{float(v):.10f}")
        with w:
            co = w.add_connection(ODOMETRY_TOPIC, Odometry.__msgtype__, typestore=ts)
            cf = w.add_connection(FIX_TOPIC, Fix.__msgtype__, typestore=ts)
            for i in range(len(t)):
                n = int(ns[i])
                stamp = Time(n // 1_000_000_000, n % 1_000_000_000)
                odo = Odometry(
                    Header(stamp, MAP_FRAME), BODY_FRAME,
                    PoseCov(Pose(Point(*pos[i]), Quat(q[i, 1], q[i, 2], q[i, 3], q[i, 0])),
                            pose_cov[i].ravel()),
                    TwistCov(Twist(Vec(*v_flu[i]), Vec(*w_flu[i])), twist_cov[i].ravel()))
                w.write(co, n, ts.serialize_cdr(odo, Odometry.__msgtype__))
                fix = Fix(Header(stamp, BODY_FRAME), Status(0, 0), float(lat[i]),
                          float(lon[i]), float(sol.lla[i, 2]), fix_cov[i].ravel(), 2)
                w.write(cf, n, ts.serialize_cdr(fix, Fix.__msgtype__))
        if path.exists():
            os.replace(path, old)
        os.replace(work / path.name, path)
    except OSError as e:
        raise output_error(path, e) from e
    finally:
        shutil.rmtree(work, ignore_errors=True)
        shutil.rmtree(old, ignore_errors=True)
    return path


def _fednav_bag(path: Path) -> bool:
    """Whether ``path`` is a bag folder fednav wrote (:data:`ROSBAG_MARK` in its
    metadata's ``custom_data``)."""
    import yaml

    meta = path / "metadata.yaml"
    if path.is_symlink() or not path.is_dir() or not meta.is_file():
        return False
    try:
        info = yaml.safe_load(meta.read_text())["rosbag2_bagfile_information"]
        return ROSBAG_MARK in (info.get("custom_data") or {})
    except (OSError, KeyError, TypeError, AttributeError, yaml.YAMLError):
        return False


def write_exports(out: Path, sol: Solution, kinds, outages: dict | None = None) -> list[Path]:
    """``solution.<kind>`` in ``out`` (made if missing) for each of ``kinds``
    (:data:`EXPORTS`)."""
    Path(out).mkdir(parents=True, exist_ok=True)
    writers = {"kml": lambda p: write_kml(p, sol, outages), "gpx": lambda p: write_gpx(p, sol),
               "geojson": lambda p: write_geojson(p, sol, outages),
               "kfgins": lambda p: write_kfgins_nav(p, sol.t, sol.lla, sol.vel, sol.euler),
               "rosbag": lambda p: write_rosbag(p, sol)}
    return [writers[k](Path(out) / FILE_NAMES.get(k, f"solution.{k}")) for k in kinds]
