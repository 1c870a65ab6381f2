"""Forward-filter attitude RMSE on simulated MEMS car drives: the alignment of
``fednav process`` (``alignment.initial_attitude: align``) against starting from a file attitude
with 1/1/2 deg (roll, pitch, yaw) 1-sigma errors, over several seeds and two IMU classes.

    python benchmarks/attitude_convergence.py [--seeds 5]

Drive: ``examples/car-drive.yaml`` (10 min, static start, turns, slopes), GNSS 5 Hz,
GNSS only (no velocity sensor).  IMU classes: ADIS16405 (the example's figures) and an
ADIS16488 class (below).  Issue 13's targets, whole-run forward RMSE: ADIS16405 roll and
pitch <= 0.10 deg, yaw <= 0.5 deg; ADIS16488 roll/pitch <= 0.03 deg, yaw <= 0.25 deg.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from fednav import load_system
from fednav.core import units
from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv
from fednav.process.run import errors_against, process, rmse
from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

ROOT = Path(__file__).resolve().parents[1]
ADIS16488 = {"random_bias": True, "gyro_bias_deg_h": 25.0, "gyro_markov_deg_h": 6.0,
             "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 0.3, "accel_bias_ug": 300.0,
             "accel_markov_ug": 70.0, "accel_markov_tau_s": 100.0,
             "accel_vrw_ug_sqrt_hz": 50.0}
KEYS = ("roll_deg", "pitch_deg", "yaw_deg", "north_m", "east_m", "vn_mps", "ve_mps")


def one(imu_class: str, seed: int, folder: Path) -> dict[str, dict[str, float]]:
    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    upd = {"seed": seed, "velocity": None}
    if imu_class == "ADIS16488":
        upd["imu"] = cfg.imu.model_copy(update=ADIS16488)
    cfg = cfg.model_copy(update=upd)
    d = folder / f"{imu_class}-{seed}"
    write_csv_dataset(simulate_dataset(cfg), d)
    pc = load_system(d / "process.yaml")
    gc = pc.sensors.gnss
    g = read_gnss_csv(d / "gnss.csv", gc.sigma_pos_enu_m, gc.sigma_vel_mps, gc.lever_m)
    imu = read_imu_csv(d / "imu.csv")
    ref = read_reference_csv(d / "reference.csv")
    rng = np.random.default_rng(seed + 1000)
    sig = units.deg(np.array([1.0, 1.0, 2.0]))  # pitch, roll, heading
    file_imu = dataclasses.replace(imu, initial_euler=ref.euler[0] + sig * rng.standard_normal(3),
                                   initial_euler_sigma=sig)
    out = {}
    for how, data in (("file 1/1/2 deg", file_imu), ("align", imu)):
        c = pc.model_copy(update={"alignment": pc.alignment.model_copy(
            update={"initial_attitude": "file" if how != "align" else "align"})})
        t0 = time.perf_counter()
        r = rmse(errors_against(process(data, {"gnss": g}, c).forward, ref))
        out[how] = {**{k: r[k] for k in KEYS}, "s": time.perf_counter() - t0}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    n = ap.parse_args().seeds
    with tempfile.TemporaryDirectory() as tmp:
        for imu_class in ("ADIS16405", "ADIS16488"):
            rows = {}
            for seed in range(1, n + 1):
                for how, r in one(imu_class, seed, Path(tmp)).items():
                    rows.setdefault(how, []).append(r)
                    print(f"{imu_class} seed {seed} {how:15s} " + "  ".join(
                        f"{k} {r[k]:.3f}" for k in KEYS), flush=True)
            for how, rs in rows.items():
                med = {k: np.median([r[k] for r in rs]) for k in KEYS}
                worst = {k: np.max([r[k] for r in rs]) for k in KEYS}
                print(f"{imu_class} {how:15s} median " + "  ".join(
                    f"{k} {med[k]:.3f}" for k in KEYS))
                print(f"{imu_class} {how:15s} worst  " + "  ".join(
                    f"{k} {worst[k]:.3f}" for k in KEYS))


if __name__ == "__main__":
    sys.exit(main())
