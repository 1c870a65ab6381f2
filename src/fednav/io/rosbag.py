"""ROS 1 and ROS 2 bags -> fednav data, read with ``rosbags`` (pure Python: no ROS install).

A ROS 1 ``.bag`` file, a ROS 2 bag folder (``metadata.yaml`` with sqlite3 or MCAP storage)
or a single ROS 2 ``.db3`` / ``.mcap`` file is read in place (below) or, where that path
cannot, opened with :class:`rosbags.highlevel.AnyReader`; the message types fednav reads
and what they become are in :func:`read_rosbag`.

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
``child_frame_id``), so their raw bytes are decoded for all messages by one compiled pass
(:func:`decode`, :mod:`fednav.io.rosmsg`), checked against ``rosbags``' own
deserialisation of the first message (any difference: every message deserialised by
``rosbags``), in place in the file's mapped bytes.  A ROS 2 bag folder with uncompressed
sqlite3 storage is read from its database pages (:class:`_SqliteBag`,
:mod:`fednav.io.sqlite_pages`: the ``messages`` table's rows walked by a compiled loop),
one with MCAP storage by :mod:`fednav.io.mcap` (:class:`_McapBag`), a ROS 1 bag by
:mod:`fednav.io.ros1bag` (:class:`_Ros1Bag`), each file's records walked by a compiled
loop; every other bag, and what these cannot read, through ``AnyReader``, one pass over
its messages (``benchmarks/rosbag_read.py``).
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


#: The fields after each message's ``header``: (name, little-endian type or "string",
#: count, the values of a message ``rosbags`` deserialised; None for a field fednav does
#: not read, skipped by its size).
LAYOUTS = {
    IMU: (("orientation", "f8", 4, None),
          # (its first element says whether the driver estimates the orientation: -1
          # or 0 unknown; the other eight are not read)
          ("orientation_covariance", "f8", 1, lambda m: m.orientation_covariance[:1]),
          ("orientation_covariance_rest", "f8", 8, None),
          ("angular_velocity", "f8", 3, lambda m: _xyz(m.angular_velocity)),
          ("angular_velocity_covariance", "f8", 9, None),
          ("linear_acceleration", "f8", 3, lambda m: _xyz(m.linear_acceleration)),
          ("linear_acceleration_covariance", "f8", 9, None)),
    NAVSATFIX: (("status", "i1", 1, lambda m: (m.status.status,)),
                ("service", "u2", 1, None),
                ("latitude", "f8", 1, lambda m: (m.latitude,)),
                ("longitude", "f8", 1, lambda m: (m.longitude,)),
                ("altitude", "f8", 1, lambda m: (m.altitude,)),
                ("position_covariance", "f8", 9, lambda m: m.position_covariance),
                ("position_covariance_type", "u1", 1,
                 lambda m: (m.position_covariance_type,))),
    TWIST: (("linear", "f8", 3, lambda m: _xyz(m.twist.twist.linear)),
            ("angular", "f8", 3, None),
            ("covariance", "f8", 36, lambda m: m.twist.covariance)),
    ODOMETRY: (("child_frame_id", "string", 0, None),
               ("position", "f8", 3, None),
               ("orientation", "f8", 4, None),
               ("pose_covariance", "f8", 36, None),
               ("linear", "f8", 3, lambda m: _xyz(m.twist.twist.linear)),
               ("angular", "f8", 3, None),
               ("twist_covariance", "f8", 36, lambda m: m.twist.covariance)),
    MAGNETIC_FIELD: (("magnetic_field", "f8", 3, lambda m: _xyz(m.magnetic_field)),
                     ("magnetic_field_covariance", "f8", 9, None)),
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
    """A topic's messages as stored: bag (receive) times [ns] (N,), the bytes ``buf``
    (uint8) holding the raw messages and their lengths ``lens`` (N,); the messages start
    at ``starts`` (N,) in ``buf`` (the file's bytes, read in place), or lie back to back
    (``starts`` None)."""

    bag_ns: np.ndarray
    buf: np.ndarray
    lens: np.ndarray
    starts: np.ndarray | None = None

    def at(self) -> np.ndarray:
        """Where each message starts in ``buf``."""
        return np.cumsum(self.lens) - self.lens if self.starts is None else self.starts


def _raw(bag_ns, datas) -> _Raw:
    """A :class:`_Raw` of raw messages ``datas`` (bytes) with their bag times [ns]."""
    lens = np.fromiter(map(len, datas), np.int64, len(datas))
    return _Raw(np.asarray(bag_ns, dtype=np.int64), np.frombuffer(b"".join(datas), np.uint8),
                lens)


def decode(buf: np.ndarray, lens: np.ndarray, msgtype: str, ros2: bool,
           starts: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The fields fednav reads (those of :data:`LAYOUTS` with a getter) of raw messages
    of type ``msgtype`` (one of :data:`LAYOUTS`) in ``buf`` (uint8; their lengths
    ``lens``, their starts ``starts`` or back to back; ROS 2 CDR or ROS 1
    serialisation), every message in one compiled pass (:func:`fednav.io.rosmsg.records`):
    ``{name: (N, count) array}`` with the header's ``sec`` and ``nsec``.  Strings are
    skipped by their length prefixes, and the fields not read by their sizes; CDR's
    alignment (to each value's size, from the byte after the 4-byte encapsulation
    header) is applied per message.  Raises :class:`LayoutError` when a message does not
    match (big-endian CDR, a short or long message)."""
    from . import rosmsg

    lens = np.asarray(lens, np.int64)
    if starts is None:
        starts = np.cumsum(lens) - lens
    layout = (_HEADER2 if ros2 else _HEADER1) + LAYOUTS[msgtype]
    views, _, code, f = rosmsg.records(
        buf, starts, lens, ros2, [(None if kind == "string" else np.dtype("<" + kind),
                                   count, get is not None)
                                  for _, kind, count, get in layout])
    if code == rosmsg.NOT_CDR_LE:
        raise LayoutError(f"{msgtype}: not little-endian CDR")
    if code == rosmsg.ENDS_BEFORE:
        raise LayoutError(f"{msgtype}: messages end before {layout[f][0]}")
    if code == rosmsg.LONGER:
        raise LayoutError(f"{msgtype}: messages longer than the type's fields")
    return {name: v for (name, *_), v in zip(layout, views, strict=True) if v is not None}


def _messages(raw: _Raw, first: int | None = None) -> list[bytes]:
    """Each raw message of ``raw`` (or its ``first`` ones) as bytes."""
    return [raw.buf[a:a + n].tobytes() for a, n in zip(raw.at()[:first].tolist(),
                                                       raw.lens[:first].tolist(),
                                                       strict=True)]


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


def _fields(bag, topic: str, msgtype: str, raw: _Raw) -> dict[str, np.ndarray]:
    """The decoded fields of a topic's messages (:func:`decode`, checked against
    ``rosbags``' deserialisation of the first message; any difference: every message
    deserialised by ``rosbags``).  ``bag.decoding[topic]`` says which way."""
    if not len(raw.lens):
        return {}
    try:
        ref = _deserialised(bag.deserialize, _messages(raw, 1), msgtype)
        try:
            out = decode(raw.buf, raw.lens, msgtype, bag.ros2, raw.starts)
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

    def load(self, wanted: dict[str, str]) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type}, in one pass
        over the bag."""
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
    """A ROS 2 bag folder with uncompressed sqlite3 storage, its ``messages`` table read
    from the file's pages (:mod:`fednav.io.sqlite_pages`: one compiled loop over the
    rows, the messages decoded in place; no Python object per message).  Topics and
    counts from ``metadata.yaml``, topic ids from the ``topics`` table.
    (``AnyReader`` counts each topic's messages with a join when it opens a sqlite3 bag:
    more time than the whole read here.)  Messages deserialised with ``rosbags``'
    standard types."""

    ros2 = True
    reader_name = "sqlite3"
    #: the ``messages`` table's columns as rosbag2 writes them
    COLUMNS = ["id", "topic_id", "timestamp", "data"]

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

    def load(self, wanted: dict[str, str]) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type}, in place in
        each storage file's bytes."""
        import sqlite3

        from . import sqlite_pages as sp

        parts: dict[str, list[_Raw]] = {t: [] for t in wanted}
        for f in self.files:
            try:
                table = sp.read_table(f, "messages")
                con = sqlite3.connect(f"{f.resolve().as_uri()}?mode=ro&immutable=1",
                                      uri=True)
                try:
                    ids: dict = {}
                    for name, mt, tid in con.execute("SELECT name, type, id FROM topics"):
                        ids.setdefault((name, mt), []).append(tid)
                finally:
                    con.close()
            except (sp.SqliteFormatError, sqlite3.Error) as e:
                raise _NoFastPath(_one_line(e)) from None
            if table.columns != self.COLUMNS:
                raise _NoFastPath(f"{f}: messages columns {table.columns}")
            k, v = table.kind, table.value
            for t, msgtype in wanted.items():
                if (t, msgtype) not in ids:
                    continue
                rows = np.flatnonzero(np.isin(v[:, 1], ids[(t, msgtype)])
                                      & (k[:, 1] == sp.INTEGER))
                if not len(rows):
                    continue
                if (np.any(k[rows, 2] != sp.INTEGER) or np.any(k[rows, 3] != sp.BLOB)
                        or np.any(v[rows, 3] == sp.ON_OVERFLOW)):
                    raise _NoFastPath(f"{f}: {t}: messages not as rosbag2 writes them")
                parts[t].append(_Raw(v[rows, 2], table.buf, table.size[rows, 3],
                                     v[rows, 3]))
        return _joined(parts)


def _joined(parts: dict[str, list[_Raw]]) -> dict[str, _Raw]:
    """Each topic's messages of several files as one :class:`_Raw`: one file's in place;
    those of several files copied back to back (only the topic's messages: not the files,
    which may hold gigabytes of images); none: empty."""
    from .rosmsg import gather

    out = {}
    for t, ps in parts.items():
        if len(ps) == 1:
            out[t] = ps[0]
            continue
        if not ps:
            out[t] = _Raw(np.zeros(0, np.int64), np.zeros(0, np.uint8),
                          np.zeros(0, np.int64))
            continue
        out[t] = _Raw(np.concatenate([p.bag_ns for p in ps]),
                      np.concatenate([gather(p.buf, p.at(), p.lens) for p in ps]),
                      np.concatenate([p.lens for p in ps]))
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

    def load(self, wanted: dict[str, str]) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type}, in place in
        each file's records."""
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
                    parts[t].append(_Raw(m.log_ns[rows], m.buf, m.lens[rows],
                                         m.offs[rows]))
        return _joined(parts)


class _Ros1Bag(_SqliteBag):
    """A ROS 1 bag file read with :mod:`fednav.io.ros1bag`: the file read whole, its
    records walked by a compiled loop, the messages decoded in place.  Topics and counts
    from the walk; a connection whose type's MD5 sum is not the standard ROS 1 (Noetic)
    definition's is left to ``rosbags`` (which reads the bag's own definitions)."""

    ros2 = False
    reader_name = "ros1"

    def __init__(self, path: Path):
        from rosbags.rosbag1.reader import normalize

        from . import ros1bag

        self.path, self.src, self.decoding = path, str(path), {}
        try:
            self.m, self.connections = ros1bag.read(path)
        except (ros1bag.Ros1BagError, UnicodeError, ValueError) as e:
            raise _NoFastPath(_one_line(e)) from None
        self.topic_of = {c: normalize(topic) for c, (topic, _, _) in self.m.channels.items()}
        counts = np.bincount(self.m.channel, minlength=max(self.m.channels, default=-1) + 1)
        self.topics, self.counts = {}, {}
        for c, (_, msgtype, _) in sorted(self.m.channels.items()):
            t = self.topic_of[c]
            self.topics.setdefault(t, msgtype)
            self.counts[t] = self.counts.get(t, 0) + int(counts[c])
        self.topics = dict(sorted(self.topics.items()))

    @classmethod
    def of(cls, path: Path) -> _Ros1Bag | None:
        """The bag at ``path`` when it is a ROS 1 bag file, else None."""
        from . import ros1bag

        try:
            with open(path, "rb") as f:
                magic = f.read(len(ros1bag.MAGIC))
        except OSError:  # (rosbags' reader says why, in one line)
            return None
        return cls(path) if magic == ros1bag.MAGIC else None

    def deserialize(self, data: bytes, msgtype: str):
        return _standard_types(1).deserialize_ros1(data, msgtype)

    def load(self, wanted: dict[str, str]) -> dict[str, _Raw]:
        """The raw messages of the topics ``wanted`` {topic: message type}, in place in
        the file's bytes."""
        m, out = self.m, {}
        for t, msgtype in wanted.items():
            ids = [c for c, (_, mt, _) in m.channels.items()
                   if self.topic_of[c] == t and mt == msgtype]
            md5 = _standard_types(1).generate_msgdef(msgtype, ros_version=1)[1]
            if any(self.connections[c].get("md5sum", b"").decode("ascii", "replace") != md5
                   for c in ids):
                raise _NoFastPath(f"{t}: not the standard {msgtype} (its MD5 sum)")
            rows = np.flatnonzero(np.isin(m.channel, ids))
            out[t] = _Raw(m.log_ns[rows], m.buf, m.lens[rows], m.offs[rows])
        return out


@functools.cache
def _standard_types(ros: int = 2):
    """``rosbags``' typestore of the standard messages of the latest ROS 2 release (or
    of ROS 1 Noetic: ``ros`` 1), made once (a typestore generates each message type's
    deserialiser on first use)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.LATEST if ros == 2 else Stores.ROS1_NOETIC)


class _NoFastPath(Exception):
    """A bag the sqlite3, MCAP or ROS 1 path cannot read (a database file or schema
    :mod:`fednav.io.sqlite_pages` does not read, messages on overflow pages; an MCAP file
    :mod:`fednav.io.mcap` does not know; a ROS 1 bag :mod:`fednav.io.ros1bag` does not
    know, a message type not the standard one): read with ``AnyReader`` instead."""


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
    if np.any(~np.isin(m.d["orientation_covariance"][:, 0], (-1.0, 0.0))):
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
    raws = bag.load(wanted)
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
        after they were received}; ``decoding`` {topic: "numpy" or "rosbags"};
        ``storage_reader`` what read the bag's storage: "sqlite3" (a ROS 2 sqlite3
        folder, :mod:`fednav.io.sqlite_pages`), "mcap" (a ROS 2 MCAP folder,
        :mod:`fednav.io.mcap`), "ros1" (a ROS 1 bag, :mod:`fednav.io.ros1bag`) or
        "rosbags" (``AnyReader``: compressed or single-file ROS 2 bags, and what the
        first three could not read).

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
    try:
        fast = ((_SqliteBag.of(path) or _McapBag.of(path)) if path.is_dir() else
                _Ros1Bag.of(path))
        if fast is not None:
            return _read(fast, given, time, max_bridge_s, mounting)
    except _NoFastPath:
        pass  # (read with AnyReader)
    bag = _AnyBag(path)
    try:
        return _read(bag, given, time, max_bridge_s, mounting)
    finally:
        bag.close()
