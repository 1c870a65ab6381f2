"""Speed of reading a ROS bag (:func:`fednav.io.read_rosbag`) against the same data as
fednav CSV files (:func:`fednav.io.read_imu_csv` + :func:`fednav.io.read_gnss_csv`).

    python benchmarks/rosbag_read.py [--repeat 3] [--seconds 600] [--all-storages] [--naive]

The data: the 10-minute car drive of ``examples/car-drive.yaml`` (200 Hz IMU, 5 Hz GNSS)
simulated once, written into a temporary folder as ``imu.csv`` + ``gnss.csv`` (fednav's
CSV writer) and as a ROS 2 bag (sqlite3 storage, ``rosbags``' default) holding
``sensor_msgs/msg/Imu`` (body FLU) on ``/imu/data`` and ``sensor_msgs/msg/NavSatFix`` on
``/fix`` (header stamps at the data's times from 2025-07-08, received 1 ms / 40 ms
later).  ``--all-storages`` also times the same bag in MCAP storage and as a ROS 1 bag;
``--naive`` times, once, what ``rosbags`` alone does: ``AnyReader`` and one
``deserialize`` per message (the baseline the reader's numpy and SQL paths replace).
Each reader is timed ``--repeat`` times, alternated, best of each.

Target (the reader's issue): the ROS 2 bag in at most 2 x the CSV files' time.  Each
storage is read in place from the file's bytes, mapped (:mod:`fednav.io.sqlite_pages`,
:mod:`fednav.io.mcap`, :mod:`fednav.io.ros1bag`), the messages decoded by one compiled
pass (:mod:`fednav.io.rosmsg`).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
T0_NS = 1_751_998_400_000_000_000  # 2025-07-08 18:13:20 UTC


def write_bag(path: Path, ds, kind: str = "sqlite3") -> Path:
    """The dataset's IMU and GNSS as a bag: ``kind`` ``sqlite3`` or ``mcap`` (ROS 2
    folder) or ``ros1`` (``path`` + ``.bag``)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from fednav.io.rosbag import FLU_TO_RFU

    ros1 = kind == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    T = ts.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    Imu, Fix = T["sensor_msgs/msg/Imu"], T["sensor_msgs/msg/NavSatFix"]
    V, Q, St = (T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"],
                T["sensor_msgs/msg/NavSatStatus"])
    ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr

    def header(ns: int, frame: str):
        stamp = Time(ns // 1_000_000_000, ns % 1_000_000_000)
        return Header(0, stamp, frame) if ros1 else Header(stamp, frame)

    none, zero = np.r_[-1.0, np.zeros(8)], np.zeros(9)
    w, a = ds.gyro @ FLU_TO_RFU, ds.accel @ FLU_TO_RFU  # (RFU -> FLU: M^T v)
    imu_ns = T0_NS + np.rint(ds.t * 1e9).astype(np.int64)
    g_ns = T0_NS + np.rint(ds.gnss_t * 1e9).astype(np.int64)
    s = np.asarray(ds.cfg.gnss.reported_sigma_pos_enu_m())
    cov = np.diag(s**2).ravel()
    lat, lon = np.degrees(ds.gnss_lla[:, 0]), np.degrees(ds.gnss_lla[:, 1])
    if ros1:
        path = path.with_suffix(".bag")
        writer = Writer1(path)
    else:
        writer = Writer(path, version=9, storage_plugin={"sqlite3": StoragePlugin.SQLITE3,
                                                         "mcap": StoragePlugin.MCAP}[kind])
    with writer as bw:
        ci = bw.add_connection("/imu/data", Imu.__msgtype__, typestore=ts)
        cg = bw.add_connection("/fix", Fix.__msgtype__, typestore=ts)
        out = [(int(n) + 1_000_000, ci, Imu(header(int(n), "imu_link"),
                                            Q(0.0, 0.0, 0.0, 1.0), none, V(*w[i]), zero,
                                            V(*a[i]), zero))
               for i, n in enumerate(imu_ns)]
        out += [(int(n) + 40_000_000, cg, Fix(header(int(n), "gps"), St(0, 1), lat[j],
                                              lon[j], ds.gnss_lla[j, 2], cov, 2))
                for j, n in enumerate(g_ns)]
        for ns, c, m in sorted(out, key=lambda x: x[0]):  # (in the order received)
            bw.write(c, ns, ser(m, c.msgtype))
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--all-storages", action="store_true")
    ap.add_argument("--naive", action="store_true")
    a = ap.parse_args()

    from fednav.io import read_gnss_csv, read_imu_csv, read_rosbag
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml").truncated(a.seconds)
    ds = simulate_dataset(cfg)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_csv_dataset(ds, d / "csv")
        bags = {"ros2 sqlite3": write_bag(d / "bag_sqlite3", ds)}
        if a.all_storages:
            bags["ros2 mcap"] = write_bag(d / "bag_mcap", ds, "mcap")
            bags["ros1"] = write_bag(d / "bag_ros1", ds, "ros1")

        def csv():
            return read_imu_csv(d / "csv" / "imu.csv"), read_gnss_csv(d / "csv" / "gnss.csv")

        readers = {"csv": csv, **{k: (lambda p=p: read_rosbag(p)) for k, p in bags.items()}}
        best = dict.fromkeys(readers, np.inf)
        for _ in range(a.repeat):
            for k, read in readers.items():
                t0 = time.perf_counter()
                read()
                best[k] = min(best[k], time.perf_counter() - t0)
        rec = read_rosbag(bags["ros2 sqlite3"])
        imu, gnss = csv()
        print(f"{len(ds.t)} IMU samples ({1 / cfg.imu_period_s:g} Hz), {len(ds.gnss_t)} GNSS "
              f"fixes, {a.seconds:g} s; best of {a.repeat}")
        print(f"  decoding: {rec.quality['decoding']}")
        print(f"  same IMU samples as the CSV: "
              f"{np.allclose(rec.imu.gyro, imu.gyro, rtol=1e-9, atol=1e-12)}, "
              f"{np.allclose(rec.imu.accel, imu.accel, rtol=1e-9, atol=1e-12)}")
        print(f"  read_imu_csv + read_gnss_csv  {best['csv']:.3f} s")
        for k, p in bags.items():
            print(f"  read_rosbag ({k:12s})    {best[k]:.3f} s   "
                  f"ratio {best[k] / best['csv']:.2f} x   (storage read by "
                  f"{read_rosbag(p).quality['storage_reader']})")
        if a.naive:
            from rosbags.highlevel import AnyReader

            t0 = time.perf_counter()
            with AnyReader([bags["ros2 sqlite3"]]) as r:
                msgs = [r.deserialize(raw, c.msgtype) for c, _, raw in r.messages()]
            naive = time.perf_counter() - t0
            print(f"  AnyReader + deserialize each ({len(msgs)} messages, once)  {naive:.3f} s"
                  f"   ratio {naive / best['csv']:.2f} x")


if __name__ == "__main__":
    main()
