"""ROS 1 and ROS 2 bags -> fednav data, read with ``rosbags`` (pure Python: no ROS install).

A ROS 1 ``.bag`` file, a ROS 2 bag folder (``metadata.yaml`` with sqlite3 or MCAP storage)
or a single ROS 2 ``.db3`` / ``.mcap`` file is opened with
:class:`rosbags.highlevel.AnyReader`; the message types fednav reads and what they become
are in :func:`read_rosbag`.

ROS conventions (REP-103): body frames forward-left-up (FLU), world frames east-north-up
(ENU), SI units, times as ``header.stamp`` (the time the data describe) beside the bag's
own receive time.  fednav's body is right-forward-up: body vectors turn with
:data:`FLU_TO_RFU` here, at the reader (the IMU's ``mounting``: its axes when they are not
ROS's FLU); world (ENU) vectors are fednav's already.

Times are ROS times, seconds since 1970-01-01 (or since the simulator's start for a bag
recorded with ``use_sim_time``), as floats: about 0.24 us of resolution at today's
dates, well inside the IMU's checks (the export writes them back as the same ROS times).

Speed: ``rosbags`` deserialises one message at a time in Python (about 10 us each).  The
messages read here have a fixed layout after their header (and Odometry's
``child_frame_id``), so their raw bytes are decoded with numpy for all messages at once
(:func:`decode`), checked against ``rosbags``' own deserialisation of the first message
(any difference: every message deserialised by ``rosbags``).  A ROS 2 bag folder with
uncompressed sqlite3 storage is read with ``sqlite3`` itself (:class:`_SqliteBag`: the
IMU's fields concatenated by SQLite, no Python object per message), one with MCAP storage
with :mod:`fednav.io.mcap` (:class:`_McapBag`: the file's records walked by a compiled
loop); every other bag through ``AnyReader``, one pass over its messages
(``benchmarks/rosbag_read.py``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import NamedTuple

import numpy as np

from ..core import mounting as mt
from ..core import units
from ..sensors.mag import usable
from .data import (
    DataError,
    GnssData,
    ImuData,
    SensorData,
    Series,
    VelocityData,
    height_offset_to_gnss,
    import_for,
)

IMU = "sensor_msgs/msg/Imu"
NAVSATFIX = "sensor_msgs/msg/NavSatFix"
TWIST = "geometry_msgs/msg/TwistWithCovarianceStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
MAGNETIC_FIELD = "sensor_msgs/msg/MagneticField"
FLUID_PRESSURE = "sensor_msgs/msg/FluidPressure"
#: What fednav reads, by its name (``imu`` and registered sensors), with the message type.
TYPES = {"imu": IMU, "gnss": NAVSATFIX, "velocity": TWIST, "odometer": ODOMETRY,
         "mag": MAGNETIC_FIELD, "baro": FLUID_PRESSURE}

#: ``C_flu^rfu``: a vector in ROS's body axes (x forward, y left, z up) in fednav's
#: (x right, y forward, z up) is ``FLU_TO_RFU @ v`` (``core.mounting``'s ``FLU``).
FLU_TO_RFU = mt.from_letters("FLU")
#: 1-sigma of a NavSatFix position whose covariance is unknown (type 0) [m], each axis
#: (``read_gnss_csv``'s default; the CLI takes ``sensors.gnss.sigma_pos_enu_m``).
DEFAULT_GNSS_SIGMA_M = 5.0
#: 1-sigma of a twist velocity whose covariance is unknown [m/s], each ENU axis
#: (``sensors.velocity.sigma_mps`` replaces it).
DEFAULT_VELOCITY_SIGMA_MPS = 0.1
#: ISA standard atmosphere at sea level: pressure [Pa], temperature [K], lapse rate
#: [K/m], and the exponent ``R L / (g M)`` of the barometric formula.
P0_PA, T0_K, LAPSE_K_PER_M, BARO_EXPONENT = 101325.0, 288.15, 0.0065, 0.190263
#: NavSatFix status and covariance types (sensor_msgs/msg/NavSatStatus, NavSatFix).
STATUS_NO_FIX = -1
COVARIANCE_TYPE_UNKNOWN, COVARIANCE_TYPE_DIAGONAL_KNOWN = 0, 2


def flu_to_rfu(v) -> np.ndarray:
    """Body vectors (N, 3) in ROS's FLU axes in fednav's RFU ones: ``v @ FLU_TO_RFU.T``,
    written as the permutation it is, ``[-y, x, z]`` (exact, and free of a BLAS call on a
    tall matrix, which costs more than the whole permutation)."""
    v = np.asarray(v, dtype=float)
    return np.column_stack([-v[:, 1], v[:, 0], v[:, 2]])


def pressure_altitude(p_pa):
    """Pressure altitude [m] (height in the ISA standard atmosphere, from sea level) of
    static pressures ``p_pa`` [Pa]: ``(T0 / L) (1 - (p / p0)^(R L / g M))``, valid in
    the troposphere (below 11 km)."""
    p = np.asarray(p_pa, dtype=float)
    return T0_K / LAPSE_K_PER_M * (1.0 - (p / P0_PA) ** BARO_EXPONENT)


def pressure_altitude_slope(p_pa):
    """``d(pressure_altitude)/dp`` [m/Pa] at ``p_pa`` [Pa] (negative: about -0.083 m/Pa
    at sea level), to turn a pressure's 1-sigma into a height's."""
    p = np.asarray(p_pa, dtype=float)
    return -T0_K / LAPSE_K_PER_M * BARO_EXPONENT * (p / P0_PA) ** (BARO_EXPONENT - 1) / P0_PA


@dataclass
class BagRecording:
    """What a ROS bag holds, in fednav's frames and units (times [s]: ROS times).

    ``imu`` the IMU (rates, body RFU); ``series`` the aiding sensors by registered name
    (``gnss`` :class:`~fednav.io.GnssData`, ``velocity`` :class:`~fednav.io.VelocityData`,
    ``odometer``, ``mag``, ``baro`` :class:`~fednav.io.SensorData`), what
    :func:`fednav.process.process` takes; ``topics`` every topic in the bag with its
    message type; ``quality`` what the reader did (keys in :func:`read_rosbag`);
    ``notes`` what it left out or assumed, one line each."""

    source: str
    imu: ImuData
    series: dict[str, Series]
    topics: dict[str, str]
    quality: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def gnss(self) -> GnssData | None:
        """The GNSS fixes (``series["gnss"]``) or None."""
        return self.series.get("gnss")


# ------------------------------------------------------------------ raw message decoding
def _xyz(v):
    return (v.x, v.y, v.z)


def _xyzw(q):
    return (q.x, q.y, q.z, q.w)


#: The fields after each message's ``header``: (name, little-endian type or "string",
#: count, the values of a message ``rosbags`` deserialised).
LAYOUTS = {
    IMU: (("orientation", "f8", 4, lambda m: _xyzw(m.orientation)),
          ("orientation_covariance", "f8", 9, lambda m: m.orientation_covariance),
          ("angular_velocity", "f8", 3, lambda m: _xyz(m.angular_velocity)),
          ("angular_velocity_covariance", "f8", 9,
           lambda m: m.angular_velocity_covariance),
          ("linear_acceleration", "f8", 3, lambda m: _xyz(m.linear_acceleration)),
          ("linear_acceleration_covariance", "f8", 9,
           lambda m: m.linear_acceleration_covariance)),
    NAVSATFIX: (("status", "i1", 1, lambda m: (m.status.status,)),
                ("service", "u2", 1, lambda m: (m.status.service,)),
                ("latitude", "f8", 1, lambda m: (m.latitude,)),
                ("longitude", "f8", 1, lambda m: (m.longitude,)),
                ("altitude", "f8", 1, lambda m: (m.altitude,)),
                ("position_covariance", "f8", 9, lambda m: m.position_covariance),
                ("position_covariance_type", "u1", 1,
                 lambda m: (m.position_covariance_type,))),
    TWIST: (("linear", "f8", 3, lambda m: _xyz(m.twist.twist.linear)),
            ("angular", "f8", 3, lambda m: _xyz(m.twist.twist.angular)),
            ("covariance", "f8", 36, lambda m: m.twist.covariance)),
    ODOMETRY: (("child_frame_id", "string", 0, None),
               ("position", "f8", 3, lambda m: _xyz(m.pose.pose.position)),
               ("orientation", "f8", 4, lambda m: _xyzw(m.pose.pose.orientation)),
               ("pose_covariance", "f8", 36, lambda m: m.pose.covariance),
               ("linear", "f8", 3, lambda m: _xyz(m.twist.twist.linear)),
               ("angular", "f8", 3, lambda m: _xyz(m.twist.twist.angular)),
               ("twist_covariance", "f8", 36, lambda m: m.twist.covariance)),
    MAGNETIC_FIELD: (("magnetic_field", "f8", 3, lambda m: _xyz(m.magnetic_field)),
                     ("magnetic_field_covariance", "f8", 9,
                      lambda m: m.magnetic_field_covariance)),
    FLUID_PRESSURE: (("fluid_pressure", "f8", 1, lambda m: (m.fluid_pressure,)),
                     ("variance", "f8", 1, lambda m: (m.variance,))),
}
#: std_msgs/Header: ROS 2 ``stamp`` (int32 sec, uint32 nanosec), ``frame_id``; ROS 1
#: ``seq`` first and an unsigned ``sec``.
_HEADER2 = (("sec", "i4", 1, lambda m: (m.header.stamp.sec,)),
            ("nsec", "u4", 1, lambda m: (m.header.stamp.nanosec,)),
            ("frame_id", "string", 0, None))
_HEADER1 = (("seq", "u4", 1, None), ("sec", "u4", 1, lambda m: (m.header.stamp.sec,)),
            ("nsec", "u4", 1, lambda m: (m.header.stamp.nanosec,)),
            ("frame_id", "string", 0, None))


class LayoutError(ValueError):
    """Raw messages that are not in the layout :data:`LAYOUTS` gives (decoded the slow
    way instead)."""


class _Raw(NamedTuple):
    """A topic's messages as stored: bag (receive) times [ns] (N,) or None, the raw
    messages back to back ``buf`` (uint8) and their lengths ``lens`` (N,); or, for the
    IMU of the sqlite3 path, ``buf`` the (N, 56) records of :data:`_IMU_SQL` and ``first``
    one whole message, ``lens`` None."""

    bag_ns: np.ndarray | None
    buf: np.ndarray
    lens: np.ndarray | None
    first: bytes = b""


def _raw(bag_ns, datas) -> _Raw:
    """A :class:`_Raw` of raw messages ``datas`` (bytes) with their bag times [ns]."""
    lens = np.fromiter(map(len, datas), np.int64, len(datas))
    return _Raw(np.asarray(bag_ns, dtype=np.int64), np.frombuffer(b"".join(datas), np.uint8),
                lens)


def _take(buf: np.ndarray, off: np.ndarray, rows: np.ndarray | None, dtype: np.dtype,
          count: int) -> np.ndarray:
    """``count`` values of ``dtype`` at byte offsets ``off`` (N,) of ``buf``: (N, count).
    ``rows``: ``buf`` as (N, L) messages of one length, used (a view of ``buf``, no
    copy) when every offset is the same distance into its message."""
    k = dtype.itemsize * count
    if rows is not None:
        rel = off - np.arange(len(off)) * rows.shape[1]
        if len(rel) and np.all(rel == rel[0]):
            return rows[:, rel[0]:rel[0] + k].view(dtype)
    return buf[off[:, None] + np.arange(k)].view(dtype)


def decode(buf: np.ndarray, lens: np.ndarray, msgtype: str,
           ros2: bool) -> dict[str, np.ndarray]:
    """The fields of raw messages of type ``msgtype`` (one of :data:`LAYOUTS`) stored
    back to back in ``buf`` (uint8; their lengths ``lens``; ROS 2 CDR or ROS 1
    serialisation), every message at once: ``{name: (N, count) array}`` with the
    header's ``sec`` and ``nsec``.  Strings are skipped by their length prefixes; CDR's
    alignment (to each value's size, from the byte after the 4-byte encapsulation header)
    is applied per message.  Raises :class:`LayoutError` when a message does not match
    (big-endian CDR, a short or long message)."""
    n = len(lens)
    ends = np.cumsum(lens)
    starts = ends - lens
    rows = buf.reshape(n, -1) if n and np.all(lens == lens[0]) else None
    if ros2:
        if np.any(lens < 4) or np.any(buf[starts] != 0) or np.any(buf[starts + 1] != 1):
            raise LayoutError(f"{msgtype}: not little-endian CDR")
        origin = starts + 4
    else:
        origin = starts
    off = origin.copy()
    out = {}
    for name, kind, count, _ in (_HEADER2 if ros2 else _HEADER1) + LAYOUTS[msgtype]:
        if kind == "string":
            if ros2:
                off = origin + (off - origin + 3) // 4 * 4
            if np.any(off + 4 > ends):
                raise LayoutError(f"{msgtype}: messages end before {name}")
            size = _take(buf, off, rows, np.dtype("<u4"), 1)[:, 0].astype(np.int64)
            off = off + 4 + size
            continue
        dt = np.dtype("<" + kind)
        if ros2:
            off = origin + (off - origin + dt.itemsize - 1) // dt.itemsize * dt.itemsize
        if np.any(off + dt.itemsize * count > ends):
            raise LayoutError(f"{msgtype}: messages end before {name}")
        out[name] = _take(buf, off, rows, dt, count)
        off = off + dt.itemsize * count
    rest = ends - off  # (CDR pads the end to 4 bytes)
    if np.any(rest < 0) or np.any(rest > (3 if ros2 else 0)):
        raise LayoutError(f"{msgtype}: messages longer than the type's fields")
    return out


def _messages(raw: _Raw) -> list[bytes]:
    """Each raw message of ``raw`` as bytes."""
    ends = np.cumsum(raw.lens)
    data = raw.buf.tobytes()
    return [data[e - n:e] for e, n in zip(ends.tolist(), raw.lens.tolist(), strict=True)]


def _deserialised(deserialize, datas, msgtype: str) -> dict[str, np.ndarray]:
    """:func:`decode`'s result the slow way: ``deserialize(data, msgtype)`` (``rosbags``)
    of each raw message ``datas``."""
    fields = [(name, kind, get) for name, kind, _, get
              in (_HEADER2 + LAYOUTS[msgtype]) if get is not None]
    rows = {name: [] for name, _, _ in fields}
    for d in datas:
        m = deserialize(d, msgtype)
        for name, _, get in fields:
            rows[name].append(np.asarray(get(m), dtype=float).ravel())
    return {name: np.asarray(rows[name], dtype=kind).reshape(len(datas), -1)
            for name, kind, _ in fields}


def _same(a: dict, b: dict) -> bool:
    """Whether decoding ``a`` agrees with ``b`` (of its first rows) in every field both
    have."""
    return all(np.array_equal(np.asarray(a[k][:len(b[k])], dtype=float),
                              np.asarray(b[k], dtype=float), equal_nan=True)
               for k in a if k in b)


#: The bytes of an Imu message the sqlite3 path takes, by SQL ``substr``: the stamp
#: (8 after the 4-byte CDR encapsulation), angular_velocity and linear_acceleration (24
#: each, at fixed distances from the end: only doubles follow the frame_id, and the CDR
#: body ends 8-aligned, so without padding).  (SQLite's time grows with the bytes
#: concatenated: the encapsulation is checked on one whole message.)
_IMU_SQL = "substr(data, 5, 8) || substr(data, -192, 24) || substr(data, -96, 24)"
_IMU_RECORD = 56


def _records(bag, raw: _Raw) -> dict[str, np.ndarray] | None:
    """The IMU fields of the sqlite3 path's records (``sec``, ``nsec``,
    ``angular_velocity``, ``linear_acceleration``, and the first message's
    ``orientation_covariance``); None when a whole message is not little-endian CDR or
    the records disagree with ``rosbags``' deserialisation of it."""
    r = raw.buf
    if raw.first[:2] != b"\x00\x01":
        return None
    d = {"sec": r[:, 0:4].copy().view("<i4"), "nsec": r[:, 4:8].copy().view("<u4"),
         "angular_velocity": r[:, 8:32].copy().view("<f8"),
         "linear_acceleration": r[:, 32:56].copy().view("<f8")}
    try:
        m = _deserialised(bag.deserialize, [raw.first], IMU)
    except Exception:  # (rosbags' errors: read the whole messages instead)
        return None
    same = np.flatnonzero((d["sec"][:, 0] == m["sec"][0, 0])
                          & (d["nsec"][:, 0] == m["nsec"][0, 0]))
    if not len(same) or not all(np.array_equal(d[k][same[0]], m[k][0], equal_nan=True)
                                for k in ("angular_velocity", "linear_acceleration")):
        return None
    d["orientation_covariance"] = m["orientation_covariance"]
    return d


def _fields(bag, topic: str, msgtype: str, raw: _Raw) -> dict[str, np.ndarray]:
    """The decoded fields of a topic's messages (:func:`decode`, checked against
    ``rosbags``' deserialisation of the first message; any difference: every message
    deserialised by ``rosbags``).  ``bag.decoding[topic]`` says which way."""
    if raw.lens is None:
        if not len(raw.buf):
            return {}
        d = _records(bag, raw)
        if d is not None:
            bag.decoding[topic] = "sqlite3"
            return d
        raw = bag.load({topic: msgtype})[topic]  # (the whole messages)
    if not len(raw.lens):
        return {}
    try:
        ref = _deserialised(bag.deserialize, [raw.buf[:raw.lens[0]].tobytes()], msgtype)
        try:
            out = decode(raw.buf, raw.lens, msgtype, bag.ros2)
            if not _same(out, ref):
                raise LayoutError(f"{msgtype}: numpy and rosbags decodings differ")
            bag.decoding[topic] = "numpy"
        except LayoutError:
            out = _deserialised(bag.deserialize, _messages(raw), msgtype)
            bag.decoding[topic] = "rosbags"
    except Exception as e:  # (rosbags' errors for a message it cannot read)
        if isinstance(e, DataError):
            raise
        raise DataError(f"ROS bag {bag.src}: {topic}: messages that are not "
                        f"{msgtype} ({_one_line(e)})") from None
    return out


# ------------------------------------------------------------------------- the bag
def _one_line(e: Exception) -> str:
    return str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__


class _AnyBag:
    """A bag opened with :class:`rosbags.highlevel.AnyReader` (every kind of bag):
    ``topics`` {topic: message type}, ``counts`` {topic: messages}, :meth:`load`,
    :meth:`deserialize`."""

    reader_name = "rosbags"

    def __init__(self, path: Path):
        from rosbags.highlevel import AnyReader

        self.path, self.src, self.decoding = path, str(path), {}
        try:
            self.reader = AnyReader([path])
            self.ros2 = self.reader.is2
            try:
                self.reader.open()
            except Exception as e:
                if "no type definitions" not in str(e):
                    raise
                # (an older ROS 2 bag without its message definitions: the standard ones)
                from rosbags.typesys import Stores, get_typestore

                self.reader = AnyReader([path], default_typestore=get_typestore(
                    Stores.LATEST if self.ros2 else Stores.ROS1_NOETIC))
                self.reader.open()
        except Exception as e:  # rosbags raises several types for what is not a bag
            kind = "folder" if path.is_dir() else "file"
            raise DataError(f"ROS bag {path}: not a readable ROS 1 or ROS 2 bag {kind} "
                            f"({_one_line(e)})") from None
        self.info = self.reader.topics
        self.topics = {t: (i.msgtype or "?") for t, i in sorted(self.info.items())}
        self.counts = {t: int(i.msgcount) for t, i in self.info.items()}

    def deserialize(self, data: bytes, msgtype: str):
        return self.reader.deserialize(data, msgtype)

    def load(self, wanted: dict[str, str], imu: str | None = None,
             imu_bag_time: bool = True) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type}, in one pass
        over the bag (``imu``, ``imu_bag_time``: the sqlite3 path's)."""
        conns = [c for t, m in wanted.items() for c in self.info[t].connections
                 if c.msgtype == m]
        got: dict[str, tuple[list, list]] = {t: ([], []) for t in wanted}
        for c, ns, data in self.reader.messages(connections=conns):
            ts, ds = got[c.topic]
            ts.append(ns)
            ds.append(data)
        return {t: _raw(*v) for t, v in got.items()}

    def close(self) -> None:
        self.reader.close()


class _SqliteBag:
    """A ROS 2 bag folder with uncompressed sqlite3 storage, read with ``sqlite3``
    itself: topics and counts from ``metadata.yaml``, the messages of the topics wanted
    in one SQL scan per storage file (the IMU's 56 bytes a message, :data:`_IMU_SQL`,
    and the other topics' messages concatenated by SQLite: no Python object per
    message).
    (``AnyReader`` counts each topic's messages with a join when it opens a sqlite3 bag:
    more time than the whole read here.)  Messages deserialised with ``rosbags``'
    standard types."""

    ros2 = True
    reader_name = "sqlite3"

    def __init__(self, path: Path, files: list[Path], info: dict):
        self.path, self.src, self.files, self.decoding = path, str(path), files, {}
        self.topics, self.counts = {}, {}
        for x in info["topics_with_message_count"]:
            meta = x["topic_metadata"]
            if meta.get("serialization_format", "cdr") != "cdr":
                raise ValueError(f"topic {meta['name']}: serialization "
                                 f"{meta['serialization_format']}")
            self.topics[meta["name"]] = meta["type"]
            self.counts[meta["name"]] = int(x["message_count"])
        self.topics = dict(sorted(self.topics.items()))

    @classmethod
    def of(cls, path: Path) -> _SqliteBag | None:
        """The bag at ``path`` when it is a ROS 2 folder with uncompressed sqlite3
        storage whose metadata this reader knows, else None."""
        found = _ros2_folder(path, "sqlite3")
        return None if found is None else cls(path, *found)

    def deserialize(self, data: bytes, msgtype: str):
        return _standard_types().deserialize_cdr(data, msgtype)

    def load(self, wanted: dict[str, str], imu: str | None = None,
             imu_bag_time: bool = True) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type}: ``imu``'s as
        :data:`_IMU_SQL` records (with their bag times when ``imu_bag_time``)."""
        import sqlite3

        parts: dict[str, list] = {t: [] for t in wanted}
        try:
            for f in self.files:
                con = sqlite3.connect(f"{f.resolve().as_uri()}?mode=ro&immutable=1",
                                      uri=True)
                con.text_factory = bytes
                try:
                    self._scan(con, wanted, imu, imu_bag_time, parts)
                finally:
                    con.close()
        except sqlite3.Error as e:
            raise _NoFastPath(_one_line(e)) from None
        out = {}
        for t, ps in parts.items():
            if t == imu:
                first = next((p[2] for p in ps if p[2]), b"")
                out[t] = _Raw(np.concatenate([p[0] for p in ps]) if imu_bag_time and ps
                              else None,
                              np.concatenate([p[1] for p in ps]) if ps
                              else np.zeros((0, _IMU_RECORD), np.uint8), None, first)
            else:
                out[t] = ps[0] if len(ps) == 1 else _raw(
                    np.concatenate([p.bag_ns for p in ps] or [np.zeros(0, np.int64)]),
                    [d for p in ps for d in _messages(p)])
        return out

    @staticmethod
    def _scan(con, wanted: dict, imu, imu_bag_time: bool, parts: dict) -> None:
        """One storage file's messages of the topics ``wanted`` into ``parts``: per
        topic, a :class:`_Raw` (the IMU: its :data:`_IMU_SQL` records, with bag times or
        None, and one whole message).  One scan of the messages table (it has no index
        on the topic), each topic's rows concatenated by SQLite in aggregate FILTERs:
        the IMU's records, the other topics' whole messages with their lengths."""
        ids = {}
        for t, m in wanted.items():
            for (tid,) in con.execute("SELECT id FROM topics WHERE name = ? AND type = ?",
                                      (t, m)).fetchall():
                ids[int(tid)] = t
        if not ids:
            return
        cols = []
        for tid, t in ids.items():
            only = f"FILTER (WHERE topic_id = {tid})"
            cols += [f"count(*) {only}", f"group_concat(timestamp) {only}"
                     if t != imu or imu_bag_time else "NULL"]
            cols += ([f"group_concat({_IMU_SQL}, '') {only}"] if t == imu else
                     [f"group_concat(data, '') {only}", f"group_concat(length(data)) {only}"])
        row = con.execute(f"SELECT {', '.join(cols)} FROM messages WHERE topic_id IN "
                          f"({', '.join(map(str, ids))})").fetchone()
        i = 0
        for tid, t in ids.items():
            n, stamps, blob = row[i:i + 3]
            lens = None if t == imu else row[i + 3]
            i += 3 if t == imu else 4
            if not n:
                continue
            ns = None if stamps is None else _integers(stamps, n, f"{t}: time stamps")
            if t != imu:
                lens = _integers(lens, n, f"{t}: message lengths")
                if int(lens.sum()) != len(blob or b""):
                    raise _NoFastPath(f"{t}: the messages do not add up to their lengths")
                parts[t].append(_Raw(ns, np.frombuffer(blob, np.uint8), lens))
                continue
            if blob is None or len(blob) != _IMU_RECORD * n:
                raise _NoFastPath(f"{t}: messages too short for {IMU}")
            first = con.execute("SELECT data FROM messages WHERE topic_id = ? LIMIT 1",
                                (tid,)).fetchone()[0]
            parts[t].append((ns, np.frombuffer(blob, np.uint8).reshape(n, _IMU_RECORD),
                             first))


def _integers(text: bytes, n: int, what: str) -> np.ndarray:
    """``n`` comma-separated integers (an SQLite ``group_concat``) as int64."""
    out = np.fromstring(text, dtype=np.int64, sep=",")
    if len(out) != n:
        raise _NoFastPath(f"{what}: {len(out)} for {n} messages")
    return out


def _ros2_folder(path: Path, storage: str) -> tuple[list[Path], dict] | None:
    """(storage files, ``rosbag2_bagfile_information``) of the ROS 2 bag folder ``path``
    when its ``metadata.yaml`` names ``storage``, a version this reader knows and no
    whole-file compression, and its files are all there; else None."""
    import yaml

    if not (path / "metadata.yaml").is_file():
        return None
    try:
        loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
        info = yaml.load((path / "metadata.yaml").read_text(), Loader=loader)[
            "rosbag2_bagfile_information"]
        if (info.get("storage_identifier") != storage or int(info["version"]) > 9
                or str(info.get("compression_mode") or "").lower() not in ("", "none")):
            return None
        files = [path / PurePath(f).name for f in info["relative_file_paths"]]
        if not files or not all(f.is_file() for f in files):
            return None
        return files, info
    except (OSError, KeyError, TypeError, ValueError, AttributeError, yaml.YAMLError):
        return None


class _McapBag(_SqliteBag):
    """A ROS 2 bag folder with MCAP storage (ROS 2's default since Iron), read with
    :mod:`fednav.io.mcap`: every file read whole, its chunks walked by a compiled loop,
    the messages of the topics wanted copied back to back (no Python object per
    message).  Topics and counts from ``metadata.yaml``; messages deserialised with
    ``rosbags``' standard types."""

    reader_name = "mcap"

    @classmethod
    def of(cls, path: Path) -> _McapBag | None:
        """The bag at ``path`` when it is a ROS 2 folder with MCAP storage whose
        metadata this reader knows, else None."""
        found = _ros2_folder(path, "mcap")
        return None if found is None else cls(path, *found)

    def load(self, wanted: dict[str, str], imu: str | None = None,
             imu_bag_time: bool = True) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type} (``imu``,
        ``imu_bag_time``: the sqlite3 path's, not needed here)."""
        from . import mcap

        parts: dict[str, list[_Raw]] = {t: [] for t in wanted}
        for f in self.files:
            try:
                m = mcap.read(f)
            except mcap.McapError as e:
                raise _NoFastPath(str(e)) from None
            for t, msgtype in wanted.items():
                ids = [c for c, (topic, schema, enc) in m.channels.items()
                       if topic == t and schema == msgtype and enc == "cdr"]
                rows = np.flatnonzero(np.isin(m.channel, ids))
                if len(rows):
                    lens = m.lens[rows]
                    parts[t].append(_Raw(m.log_ns[rows], mcap.gather(m.buf, m.offs[rows],
                                                                     lens), lens))
        empty = _Raw(np.zeros(0, np.int64), np.zeros(0, np.uint8), np.zeros(0, np.int64))
        return {t: (ps[0] if len(ps) == 1 else empty if not ps else
                    _Raw(np.concatenate([p.bag_ns for p in ps]),
                         np.concatenate([p.buf for p in ps]),
                         np.concatenate([p.lens for p in ps])))
                for t, ps in parts.items()}


@functools.cache
def _standard_types():
    """``rosbags``' typestore of the latest ROS 2 release's standard messages, made once
    (a typestore generates each message type's deserialiser on first use)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.LATEST)


class _NoFastPath(Exception):
    """A bag the sqlite3 or MCAP path cannot read (an SQLite without aggregate filters,
    another schema, concatenations that do not add up; an MCAP file :mod:`fednav.io.mcap`
    does not know): read with ``AnyReader`` instead."""


def _ns(sec, nsec) -> np.ndarray:
    """A ROS time's ``sec`` and ``nanosec`` as nanoseconds (int64)."""
    return np.asarray(sec, dtype=np.int64) * 1_000_000_000 + np.asarray(nsec, dtype=np.int64)


def _seconds(ns) -> np.ndarray:
    """Nanoseconds as seconds (float, rounded once)."""
    ns = np.asarray(ns, dtype=np.int64)
    return (ns // 1_000_000_000).astype(float) + (ns % 1_000_000_000) * 1e-9


# ---------------------------------------------------------------------------- times
class _Times:
    """Each topic's times as chosen (``header`` or ``bag``): the rows kept, their times
    and arrival times; the counts of what was dropped."""

    def __init__(self, src: str, time: str, quality: dict):
        self.src, self.time, self.quality = src, time, quality

    def __call__(self, topic: str, h_ns: np.ndarray, b_ns: np.ndarray | None):
        """(rows kept, in time order; t [s]; t_arrival [s] or None)."""
        if self.time == "header":
            if np.all(h_ns == 0):
                raise DataError(f"ROS bag {self.src}: {topic}: every header.stamp is 0 "
                                f"(unset): read it with time='bag' (--time bag)")
            key = h_ns
        else:
            key = b_ns
        order = np.argsort(key, kind="stable")
        k = key[order]
        keep = np.r_[True, np.diff(k) > 0][:len(k)] & (k != 0)
        rows = order[keep]
        if len(rows) < len(key):
            self.quality["rows_dropped"][topic] = int(len(key) - len(rows))
        t = _seconds(key[rows])
        ta = None
        if self.time == "header" and b_ns is not None:
            late = b_ns[rows] - h_ns[rows]
            self.quality["latency_s"][topic] = float(np.median(late) * 1e-9)
            if np.any(late < 0):
                self.quality["stamp_after_bag_time"][topic] = int(np.sum(late < 0))
            if np.any(late > 0):
                ta = _seconds(np.maximum(b_ns[rows], h_ns[rows]))
        return rows, t, ta


def _unknown(cov: np.ndarray) -> np.ndarray:
    """Rows of ROS covariances (N, k) marked unknown: first element -1 (ROS's "no
    estimate"), or all zero."""
    return (cov[:, 0] == -1.0) | np.all(cov == 0.0, axis=1)


# -------------------------------------------------------------------------- streams
class _Topic(NamedTuple):
    """One topic's decoded messages: ``src`` (bag:topic), bag times [ns] (or None),
    fields (:func:`decode`)."""

    topic: str
    src: str
    bag_ns: np.ndarray | None
    d: dict

    def stamps(self) -> np.ndarray:
        """The header stamps [ns]."""
        return _ns(self.d["sec"][:, 0], self.d["nsec"][:, 0])


def _imu(m: _Topic, times: _Times, max_bridge_s: float, quality: dict,
         notes: list) -> ImuData:
    rows, t, _ = times(m.topic, m.stamps(), m.bag_ns)
    if len(rows) < 2:
        raise DataError(f"ROS bag {times.src}: {m.topic} has {len(rows)} usable {IMU} "
                        f"message(s): an IMU needs 2 or more")
    imu = ImuData(m.src, t, flu_to_rfu(m.d["angular_velocity"][rows]),
                  flu_to_rfu(m.d["linear_acceleration"][rows]), max_bridge_s=max_bridge_s)
    if not np.all(_unknown(m.d["orientation_covariance"])):
        notes.append(f"imu: {m.topic}: orientation (the driver's own estimate) not used")
    notes.append(f"imu: {m.topic}: the messages' covariances are not used: the IMU noise "
                 f"figures are the system description's (imu:)")
    quality.update(imu.quality)
    quality["imu_rate_hz"] = round(1.0 / imu.period(), 6)
    return imu


def _gnss(m: _Topic, times: _Times, quality: dict, notes: list) -> GnssData:
    d = m.d
    rows, t, ta = times(m.topic, m.stamps(), m.bag_ns)
    fix = d["status"][rows, 0] > STATUS_NO_FIX
    quality["gnss_epochs_no_fix"] = int((~fix).sum())
    rows, t = rows[fix], t[fix]
    ta = None if ta is None else ta[fix]
    if not len(rows):
        raise DataError(f"ROS bag {times.src}: {m.topic}: no NavSatFix with a fix (every "
                        f"status.status is -1)")
    lla = np.column_stack([units.deg(d["latitude"][rows, 0]),
                           units.deg(d["longitude"][rows, 0]), d["altitude"][rows, 0]])
    cov = d["position_covariance"][rows]
    var = cov[:, [4, 0, 8]]  # north, east, up [m^2] (the message's rows are ENU)
    with np.errstate(invalid="ignore"):
        unknown = ((d["position_covariance_type"][rows, 0] == COVARIANCE_TYPE_UNKNOWN)
                   | _unknown(cov) | ~np.all(var > 0, axis=1)
                   | ~np.isfinite(var).all(axis=1))
    sig = None
    if not unknown.all():
        sig = np.ones((len(rows), 6))  # (velocity columns unused: NavSatFix has none)
        sig[:, :3] = np.sqrt(np.where(unknown[:, None], DEFAULT_GNSS_SIGMA_M**2, var))
    if unknown.any():
        notes.append(f"gnss: {m.topic}: {int(unknown.sum())} of {len(rows)} fixes give no "
                     f"position covariance (position_covariance_type 0 or -1): 1-sigma "
                     f"{DEFAULT_GNSS_SIGMA_M:g} m each axis assumed (or "
                     f"sensors.gnss.sigma_pos_enu_m)")
    g = GnssData(m.src, t, lla, None, np.full(3, DEFAULT_GNSS_SIGMA_M), np.full(3, 0.1),
                 np.zeros(3), sigma_rows=sig, t_arrival=ta)
    g.quality["gnss_epochs_no_fix"] = quality["gnss_epochs_no_fix"]
    quality.update(g.quality)
    return g


def _velocity(m: _Topic, times: _Times, quality: dict, notes: list) -> VelocityData:
    rows, t, ta = times(m.topic, m.stamps(), m.bag_ns)
    full = m.d["covariance"][rows]
    cov = full.reshape(-1, 6, 6)[:, :3, :3].copy()
    unknown = _unknown(full)
    if unknown.any():
        cov[unknown] = np.eye(3) * DEFAULT_VELOCITY_SIGMA_MPS**2
        notes.append(f"velocity: {m.topic}: {int(unknown.sum())} of {len(rows)} twists give "
                     f"no covariance (-1 or zeros): 1-sigma {DEFAULT_VELOCITY_SIGMA_MPS:g} "
                     f"m/s each axis assumed (or sensors.velocity.sigma_mps)")
    notes.append(f"velocity: {m.topic}: twist.linear taken as an ENU velocity [m/s] "
                 f"(its header.frame_id a world ENU frame)")
    v = VelocityData(m.src, t, m.d["linear"][rows], cov, np.zeros(3), t_arrival=ta)
    quality.update(v.quality)
    return v


def _odometer(m: _Topic, times: _Times, quality: dict, notes: list) -> SensorData:
    rows, t, ta = times(m.topic, m.stamps(), m.bag_ns)
    speed = m.d["linear"][rows, :1]  # twist.twist.linear.x: forward, child frame (FLU)
    cov = m.d["twist_covariance"][rows]
    with np.errstate(invalid="ignore"):
        unknown = _unknown(cov) | ~(cov[:, 0] > 0)
    sig, dropped = None, 0
    if unknown.all():
        notes.append(f"odometer: {m.topic}: no twist covariance (-1 or zeros): the 1-sigma "
                     f"is sensors.odometer.sigma_mps")
    else:
        if unknown.any():
            dropped = int(unknown.sum())
            notes.append(f"odometer: {m.topic}: {dropped} of {len(rows)} twists give no "
                         f"covariance: those rows left out")
            t, speed, cov = t[~unknown], speed[~unknown], cov[~unknown]
            ta = None if ta is None else ta[~unknown]
        sig = np.sqrt(cov[:, :1])
    notes.append(f"odometer: {m.topic}: the forward speed is twist.twist.linear.x in the "
                 f"child frame (taken as the body's forward axis); the pose is not used")
    return SensorData("odometer", m.src, t, speed, ta, {"odometer_rows_dropped": dropped},
                      sig)


def _mag(m: _Topic, times: _Times, quality: dict, notes: list) -> SensorData:
    rows, t, ta = times(m.topic, m.stamps(), m.bag_ns)
    b = flu_to_rfu(m.d["magnetic_field"][rows])  # [T]
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(b).all(axis=1) & usable(b)
    notes.append(f"mag: {m.topic}: the field's covariance is not used: the heading 1-sigma "
                 f"is sensors.mag.sigma_heading_deg")
    return SensorData("mag", m.src, t[ok], b[ok], None if ta is None else ta[ok],
                      {"mag_rows_dropped": int((~ok).sum())})


def _baro(m: _Topic, times: _Times, gnss: GnssData | None, quality: dict,
          notes: list) -> SensorData:
    rows, t, ta = times(m.topic, m.stamps(), m.bag_ns)
    p, var = m.d["fluid_pressure"][rows, 0], m.d["variance"][rows, 0]
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(p) & (p > 0)
    t, p, var = t[ok], p[ok], var[ok]
    ta = None if ta is None else ta[ok]
    h = pressure_altitude(p)
    off = height_offset_to_gnss(t, h, gnss)
    if np.isfinite(off):
        quality["baro_offset_m"] = off
        h = h + off
    else:
        notes.append(f"baro: {m.topic}: no GNSS height over its span: the pressure altitude "
                     f"(standard atmosphere) kept as it is, not an ellipsoidal height")
    known = var > 0
    sig = None
    if known.all():
        sig = np.sqrt(var)[:, None] * np.abs(pressure_altitude_slope(p))[:, None]
    else:
        notes.append(f"baro: {m.topic}: {int((~known).sum())} of {len(p)} pressures give no "
                     f"variance (0: unknown): the 1-sigma is sensors.baro.sigma_m")
    return SensorData("baro", m.src, t, h[:, None], ta,
                      {"baro_rows_dropped": int((~ok).sum())}, sig)


# ---------------------------------------------------------------------------- reader
def _choose(bag, name: str, given: dict) -> str | None:
    """The topic of ``name`` (``imu`` or a sensor): the one given, else the one topic of
    its message type with messages (none: None; several: a DataError naming them)."""
    msgtype = TYPES[name]
    if name in given:
        topic = given[name]
        if not topic:
            return None
        if topic not in bag.topics:
            raise DataError(f"ROS bag {bag.src}: no topic {topic} (given for {name}; "
                            f"topics: {', '.join(bag.topics) or 'none'})")
        if bag.topics[topic] != msgtype:
            raise DataError(f"ROS bag {bag.src}: topic {topic} (given for {name}) is "
                            f"{bag.topics[topic]}, not {msgtype}")
        return topic
    found = [t for t, m in bag.topics.items() if m == msgtype and bag.counts.get(t)]
    if len(found) > 1:
        option = {"imu": "--imu-topic", "gnss": "--gnss-topic"}.get(name,
                                                                   f"--topic {name}=TOPIC")
        raise DataError(f"ROS bag {bag.src}: several {msgtype} topics ({', '.join(found)}): "
                        f"choose one with topics={{'{name}': ...}} ({option})")
    return found[0] if found else None


def _read(bag, given: dict, time: str, max_bridge_s: float, mounting) -> BagRecording:
    quality: dict = {"time": time, "rows_dropped": {}, "latency_s": {},
                     "stamp_after_bag_time": {}}
    notes: list[str] = []
    times = _Times(bag.src, time, quality)
    chosen = {name: _choose(bag, name, given) for name in TYPES}
    imu_topic = chosen["imu"]
    if imu_topic is None:
        have = [t for t, m in bag.topics.items() if m == IMU]
        raise DataError(f"ROS bag {bag.src}: no {IMU} message" + (
            f" (topic {have[0]} is empty)" if have else
            f" (no topic of that type; topics: {', '.join(bag.topics) or 'none'})"))
    quality.update({f"{n}_topic": t for n, t in chosen.items() if t is not None})
    wanted = {t: TYPES[n] for n, t in chosen.items() if t is not None}
    raws = bag.load(wanted, imu_topic, time == "bag")
    got = {}
    for name, topic in chosen.items():
        if topic is not None:
            raw = raws[topic]
            got[name] = _Topic(topic, f"{bag.src}:{topic}", raw.bag_ns,
                               _fields(bag, topic, wanted[topic], raw))
    if not got["imu"].d:
        raise DataError(f"ROS bag {bag.src}: no {IMU} message (topic {imu_topic} is empty)")
    imu = _imu(got["imu"], times, max_bridge_s, quality, notes)
    imu.mounting, imu.mounting_name = FLU_TO_RFU, "FLU"
    if mounting is not None:
        imu = imu.remount(mounting)
    series: dict[str, Series] = {}
    for name, read in (("gnss", _gnss), ("velocity", _velocity), ("odometer", _odometer),
                       ("mag", _mag)):
        if name in got and got[name].d:
            series[name] = read(got[name], times, quality, notes)
    if "baro" in got and got["baro"].d:
        series["baro"] = _baro(got["baro"], times, series.get("gnss"), quality, notes)
    quality["decoding"] = dict(bag.decoding)
    quality["storage_reader"] = bag.reader_name
    return BagRecording(bag.src, imu, series, dict(bag.topics), quality, notes)


def read_rosbag(path, *, topics: dict[str, str] | None = None, time: str = "header",
                max_bridge_s: float = 0.1, mounting=None) -> BagRecording:
    """Read a ROS 1 bag (``.bag``) or a ROS 2 bag (a folder, ``.db3`` or ``.mcap``) as
    fednav data.

    Each of fednav's streams comes from the one topic of its message type with messages
    (or the topic ``topics`` names):

    * ``imu`` — ``sensor_msgs/msg/Imu``: ``angular_velocity`` [rad/s] and
      ``linear_acceleration`` [m/s^2], body FLU -> RFU.  The orientation and the
      covariances are not used (the system description's ``imu:`` figures are; a note
      says so).  Jittered or missing stamps are integrated onto a uniform grid
      (:func:`~fednav.io.data.regular_imu`).
    * ``gnss`` — ``sensor_msgs/msg/NavSatFix``: latitude, longitude [deg -> rad],
      altitude [m above the WGS-84 ellipsoid]; fixes with ``status.status`` -1 (no fix)
      dropped and counted; each fix's 1-sigma [north, east, up] from the diagonal of
      ``position_covariance`` (ENU, m^2), or :data:`DEFAULT_GNSS_SIGMA_M` where its type
      is 0 (unknown) or its first element -1 (a note says so); no velocity; lever arm
      zero.
    * ``velocity`` — ``geometry_msgs/msg/TwistWithCovarianceStamped``: ``twist.linear``
      as an ENU velocity [m/s] (its frame a world ENU one; a note says so), covariance
      its 3 x 3 linear block (unknown: :data:`DEFAULT_VELOCITY_SIGMA_MPS`, with a note).
    * ``odometer`` — ``nav_msgs/msg/Odometry`` (wheel odometry): the forward speed
      ``twist.twist.linear.x`` in the child frame (FLU: x forward) [m/s], its 1-sigma
      from the twist covariance (unknown: the ``sensors.odometer`` section's).
    * ``mag`` — ``sensor_msgs/msg/MagneticField``: the field [T], FLU -> RFU; rows too
      weak to give a heading dropped.  Its covariance is not used (the heading 1-sigma
      is ``sensors.mag``'s).
    * ``baro`` — ``sensor_msgs/msg/FluidPressure``: the pressure [Pa] as the ISA pressure
      altitude (:func:`pressure_altitude`) **shifted by the median of the GNSS height
      minus it** over their overlap, so that it is a height like fednav's
      (``quality["baro_offset_m"]``; unshifted without GNSS, with a note); 1-sigma from
      ``variance`` [Pa^2] (0: unknown, the section's).

    A covariance whose first element is -1 (ROS's "unknown") or that is all zero is
    unknown: the sensor section's figure is used and a note says so.

    Parameters
    ----------
    path : str or Path
        The bag: a ROS 1 ``.bag`` file, a ROS 2 bag folder, or a ROS 2 ``.db3`` /
        ``.mcap`` file.
    topics : dict of str to str, optional
        The topic of a stream by its name (``imu``, ``gnss``, ``velocity``,
        ``odometer``, ``mag``, ``baro``): ``{"imu": "/imu/data", "gnss": "/fix"}``; a
        name given None (or "") is not read.  Default: found by message type.
    time : {"header", "bag"}
        ``header``: each message's ``header.stamp`` is its time of validity, and the
        bag's receive time its ``t_arrival`` where later (the navigator's delay
        handling); ``bag``: the receive time (drivers that leave the stamp unset).
    max_bridge_s : float
        Longest gap or run of faulty IMU samples bridged [s]; a longer one is refused.
    mounting : str or dict, optional
        The IMU's axes when they are not ROS's FLU (``imu.mounting``: axis letters such
        as ``FRD`` or ``{euler_deg: [pitch, roll, heading]}``,
        :meth:`fednav.io.ImuData.remount`); default: FLU.

    Returns
    -------
    BagRecording
        ``imu`` (``t`` [s], rates [rad/s], specific force [m/s^2], body RFU), ``series``
        by sensor name, ``topics`` {topic: message type}, ``quality`` and ``notes``.
        Times [s] are ROS times (seconds since 1970, or the simulator's), in time order,
        repeated or zero stamps dropped and counted.  ``quality``: ``time``;
        ``imu_topic``, ``gnss_topic`` ... (the topic of each stream); ``imu_rate_hz`` and
        ImuData's ``imu_samples_bridged`` (``imu_resampled`` ...); ``gnss_epochs_no_fix``,
        ``gnss_epochs_skipped``; ``velocity_epochs_skipped``; ``baro_offset_m`` [m];
        ``rows_dropped`` {topic: repeated or zero stamps}; ``latency_s`` {topic: median
        receive time minus stamp [s]}; ``stamp_after_bag_time`` {topic: messages stamped
        after they were received}; ``decoding`` {topic: "sqlite3", "numpy" or
        "rosbags"}; ``storage_reader`` what read the bag's storage: "sqlite3" (a ROS 2
        sqlite3 folder), "mcap" (a ROS 2 MCAP folder, :mod:`fednav.io.mcap`) or
        "rosbags" (``AnyReader``: ROS 1 bags, compressed or other ROS 2 bags, and what
        the first two could not read).

    Raises
    ------
    DataError
        One line naming the bag and the problem: not found, not a bag, no Imu topic or
        no Imu message, a topic given that is missing or of another type, several topics
        of one type and none chosen, every header stamp 0 with ``time="header"``, a
        NavSatFix topic without a fix; ``rosbags`` not installed (the extra to install).
    """
    path = Path(path)
    if time not in ("header", "bag"):
        raise DataError(f"ROS bag {path}: time must be 'header' or 'bag', got '{time}'")
    given = dict(topics or {})
    for name in given:
        if name not in TYPES:
            raise DataError(f"ROS bag {path}: topics: unknown name '{name}' (one of "
                            f"{', '.join(TYPES)})")
    import_for(path, "rosbags", "ROS bag")
    if not path.exists():
        raise DataError(f"ROS bag {path}: not found")
    fast = (_SqliteBag.of(path) or _McapBag.of(path)) if path.is_dir() else None
    if fast is not None:
        try:
            return _read(fast, given, time, max_bridge_s, mounting)
        except _NoFastPath:
            pass  # (read with AnyReader)
    bag = _AnyBag(path)
    try:
        return _read(bag, given, time, max_bridge_s, mounting)
    finally:
        bag.close()
