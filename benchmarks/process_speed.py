"""Speed of real-data processing (issue 13): a 437 s drive, 200 Hz IMU + 5 Hz GNSS.

    python benchmarks/process_speed.py [--repeat 3]

The drive is the first 437 s of ``examples/car-drive.yaml`` (GNSS only), written as CSV
and read back.  Timed, warm (a first run compiles the numba kernels):

* forward filter + RTS smoother with the IMU-rate solutions (``process(smooth=True)``);
* writing both IMU-rate solution CSVs (``solution.csv``, ``solution_smoothed.csv``);
* ``fednav tune`` on the same data (``fednav.process.tuning.tune``).

Targets: processing + IMU-rate output < 2 s, tune < 30 s.  The ratio printed is to the
data's own duration (times faster than real time).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from fednav import System, load_system
from fednav.io import read_gnss_csv, read_imu_csv
from fednav.io.csvdata import write_csv
from fednav.process.output import solution_columns, solution_decimals
from fednav.process.run import process
from fednav.process.tuning import tune
from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

ROOT = Path(__file__).resolve().parents[1]
DURATION = 437.0


def drive(folder: Path):
    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.truncated(DURATION)
    ds = simulate_dataset(cfg.model_copy(update={"velocity": None}))
    write_csv_dataset(ds, folder)
    lever = tuple(cfg.gnss.lever_m)
    return (read_imu_csv(folder / "imu.csv"),
            read_gnss_csv(folder / "gnss.csv", cfg.gnss.sigma_pos_enu_m, cfg.gnss.sigma_vel_mps,
                          lever), lever)


def best_of(n, f):
    out, best = None, float("inf")
    for _ in range(n):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return out, best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    n = ap.parse_args().repeat
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        imu, gnss, lever = drive(tmp)
        span = imu.t[-1] - imu.t[0]
        print(f"drive: {span:.0f} s, {len(imu.t)} IMU samples, {len(gnss.t)} GNSS fixes")
        cfg = load_system({
            "sensors": {"gnss": {"lever_m": lever}},
            "imu": {"gyro_arw_rad_sqrt_s": 5.8e-4, "accel_vrw_mps_sqrt_s": 2e-3,
                    "gyro_bias_radps": 1e-3, "accel_bias_mps2": 2e-2,
                    "gyro_markov_radps": 1.2e-4, "accel_markov_mps2": 2e-3,
                    "gyro_tau_s": 100.0, "accel_tau_s": 100.0}})
        process(imu, {"gnss": gnss}, cfg, smooth=True)  # compile
        res, t_proc = best_of(n, lambda: process(imu, {"gnss": gnss}, cfg, smooth=True))

        def write():
            for name, sol in (("solution.csv", res.forward),
                              ("solution_smoothed.csv", res.smoothed)):
                cols = solution_columns(sol)
                write_csv(tmp / name, cols, solution_decimals(cols))

        _, t_write = best_of(n, write)
        total = t_proc + t_write
        print(f"forward + smoother, IMU-rate solutions ({len(res.forward.t)} rows): "
              f"{t_proc:.2f} s; writing both CSVs {t_write:.2f} s; total {total:.2f} s "
              f"(target < 2 s), {span / total:.0f} x real time")
        base = System(sensors={"gnss": {"lever_m": lever}})
        tuned, t_tune = best_of(1, lambda: tune(imu, {"gnss": gnss}, base))
        print(f"fednav tune: {t_tune:.1f} s, {tuned.runs} filter runs (target < 30 s), "
              f"{span / t_tune:.0f} x real time")


if __name__ == "__main__":
    main()
