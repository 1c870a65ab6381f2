"""Reading a day of RINEX against processing the 10-minute car drive (issue 41's target).

Writes a 24 h RINEX 2.11 observation file at 30 s (2 880 epochs, 10 GPS satellites each
with C1, L1, D1, S1: fednav's own writer, ``fednav.io.rinex.write_rinex_obs``), then
times, alternated in one process, reading it (``fednav.io.read_rinex_obs``, georinex
inside) and ``fednav.process.process`` on the car drive of ``examples/car-drive.yaml``
(simulated once, 600 s at 200 Hz).  Best of three each; the ratio is the figure.

    python benchmarks/rinex_read.py
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def day_file(folder: Path) -> Path:
    from fednav.io.rinex import WEEK_S, write_rinex_obs

    rng = np.random.default_rng(1)
    t = 2200 * WEEK_S + np.arange(0.0, 86400.0, 30.0)
    sv = np.array([f"G{i:02d}" for i in range(1, 33)])
    pr = np.full((len(t), len(sv)), np.nan)
    for i in range(len(t)):  # 10 satellites per epoch, the set turning slowly
        k = (np.arange(10) + i // 120) % len(sv)
        pr[i, k] = 2.0e7 + rng.uniform(0.0, 5.0e6, 10)
    seen = np.isfinite(pr)
    obs = {"C1": pr, "L1": np.where(seen, pr / 0.19029367, np.nan),
           "D1": np.where(seen, rng.normal(0.0, 2000.0, pr.shape), np.nan),
           "S1": np.where(seen, np.round(rng.uniform(30.0, 50.0, pr.shape)), np.nan)}
    return write_rinex_obs(folder / "day.26o", t, sv, obs, approx_xyz=[-3976219.5,
                                                                    3382372.6, 3652513.0])


def main() -> None:
    from fednav.io import read_gnss_csv, read_imu_csv
    from fednav.io.rinex import read_rinex_obs
    from fednav.navigator.system import load_system
    from fednav.process import process
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    folder = Path(tempfile.mkdtemp(prefix="fednav-rinex-"))
    path = day_file(folder)
    write_csv_dataset(simulate_dataset(load_dataset_config(ROOT / "examples" /
                                                           "car-drive.yaml")), folder)
    imu, gnss = read_imu_csv(folder / "imu.csv"), read_gnss_csv(folder / "gnss.csv")
    system = load_system(folder / "process.yaml")
    process(imu, {"gnss": gnss}, system)  # (kernels loaded)
    read_rinex_obs(path)
    times = {"read 24 h RINEX": [], "process the car drive": []}
    for _ in range(3):
        t0 = time.perf_counter()
        obs = read_rinex_obs(path)
        times["read 24 h RINEX"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        process(imu, {"gnss": gnss}, system)
        times["process the car drive"].append(time.perf_counter() - t0)
    r, p = min(times["read 24 h RINEX"]), min(times["process the car drive"])
    print(f"{path.stat().st_size / 1e6:.1f} MB, {len(obs.t)} epochs: read {r:.2f} s; "
          f"processing the 600 s car drive {p:.2f} s; ratio {r / p:.2f}")


if __name__ == "__main__":
    main()
