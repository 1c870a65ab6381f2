"""Speed of the navigator on recorded data, as ratios to baselines timed in the same run.

    python benchmarks/bench_navigator.py [--repeat 3] [--seconds 600] [--velocity]

The data: the drive of ``examples/car-drive.yaml`` (600 s, 200 Hz IMU, 5 Hz GNSS; the
velocity sensor too with ``--velocity``), simulated, written as CSV and read back, as a
user's files would be.  Timed warm (a first run compiles), best of ``--repeat``:

* baselines — the strapdown alone over the same IMU samples (one compiled call, with and
  without keeping every sample), and FilterPy's UKF doing 2 400 steps (predict + update,
  16 states, the FilterPy step of ``bench_core.py``);
* ``fednav process``'s forward filter with its IMU-rate solution and sigmas, with the
  RTS smoother, and ``fednav tune``;
* the streaming API: the same data fed in blocks of 100 samples, and one sample at a time
  (measurements added as they become due; the feed is laid out beforehand, so the time is
  the navigator's), against the one-block (batch) run.

Targets (issue 24): forward <= 3 x the strapdown and <= 0.33 x FilterPy's 2 400 steps;
smoother <= 2 x forward; tune <= 5 x forward per filter run and <= 5 x FilterPy's 2 400
steps; blocks of 100 within 1.5 x batch per sample (issue 39: 1.25 x), single samples
within 20 x.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROOT = Path(__file__).resolve().parents[1]


def best_of(n, f):
    out, best = None, float("inf")
    for _ in range(n):
        t0 = time.perf_counter()
        out = f()
        best = min(best, time.perf_counter() - t0)
    return out, best


def drive(folder: Path, seconds: float, velocity: bool):
    from fednav.io import read_gnss_csv, read_imu_csv, read_velocity_csv
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.truncated(seconds)
    write_csv_dataset(simulate_dataset(cfg), folder)
    g = read_gnss_csv(folder / "gnss.csv", cfg.gnss.sigma_pos_enu_m, cfg.gnss.sigma_vel_mps,
                      cfg.gnss.lever_m)
    v = read_velocity_csv(folder / "velocity.csv") if velocity else None
    return read_imu_csv(folder / "imu.csv"), g, v


def schedule(prep, block: int) -> list:
    """The stream of the prepared data ``block`` IMU samples at a time: per block the
    measurements due before its last sample (sensor, t, z, R) and the block's samples;
    built beforehand, so the timing is the navigator's alone."""
    rows = {name: prep.rows(name) for name in prep.series}
    meas = sorted((t, name, i) for name, (ts, _, _) in rows.items()
                  for i, t in enumerate(ts))
    out, j, n = [], 0, len(prep.t)
    for a in range(0, n, block):
        b = min(a + block, n)
        due = []
        while j < len(meas) and meas[j][0] <= prep.t[b - 1] + 1e-9:
            _, name, i = meas[j]
            t, z, R = rows[name]
            due.append((name, t[i], z[i], R[i]))
            j += 1
        if block == 1:
            out.append((due, prep.t[a], prep.gyro[a], prep.accel[a]))
        else:
            out.append((due, prep.t[a:b], prep.gyro[a:b], prep.accel[a:b]))
    rest = [(name, rows[name][0][i], rows[name][1][i], rows[name][2][i])
            for _, name, i in meas[j:]]
    return out, rest


def stream(prep, plan):
    """Feed a :func:`schedule` to a navigator; its result."""
    nav = prep.navigator(record_rows=True, record_covariance=True)
    blocks, rest = plan
    for due, t, gyro, accel in blocks:
        for name, tm, z, R in due:
            nav.add_measurement(name, tm, z, R=R)
        nav.add_imu(t, gyro, accel)
    for name, tm, z, R in rest:
        nav.add_measurement(name, tm, z, R=R)
    return nav.result()


def main() -> None:
    from bench_core import best_of as best_of_calls
    from bench_core import toy_models

    from fednav import load_system
    from fednav.ins.strapdown import Strapdown
    from fednav.process import process
    from fednav.process.run import prepare, solution
    from fednav.process.tuning import tune

    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--velocity", action="store_true")
    args = ap.parse_args()
    n = args.repeat
    with tempfile.TemporaryDirectory() as tmp:
        imu, gnss, vel = drive(Path(tmp), args.seconds, args.velocity)
    cfg = load_system({"sensors": {"gnss": {"lever_m": list(map(float, gnss.lever))}},
                       "imu": {"gyro_arw_rad_sqrt_s": 5.8e-4, "accel_vrw_mps_sqrt_s": 2e-3,
                               "gyro_bias_radps": 1e-3, "accel_bias_mps2": 2e-2,
                               "gyro_markov_radps": 1.2e-4, "accel_markov_mps2": 2e-3,
                               "gyro_tau_s": 100.0, "accel_tau_s": 100.0}})
    span = imu.t[-1] - imu.t[0]
    N = len(imu.t)
    print(f"drive: {span:.0f} s, {N} IMU samples, {len(gnss.t)} GNSS fixes"
          + (f", {len(vel.t)} velocity fixes" if vel is not None else ""))

    # Baselines.
    dt = imu.period()
    dth, dvv = np.ascontiguousarray(imu.gyro * dt), np.ascontiguousarray(imu.accel * dt)

    def strapdown(record):
        ins = Strapdown(np.array([0.89, -1.99, 1050.0]), np.zeros(3), np.zeros(3), dt)
        return ins.run(dth, dvv, record=record)

    strapdown(True)
    _, t_sd = best_of(n, lambda: strapdown(False))
    _, t_sd_rec = best_of(n, lambda: strapdown(True))
    step_ref = toy_models(16, 3, 0)[-1]
    t_fp = 2400 * best_of_calls(step_ref, 3, 100)
    print(f"baselines: strapdown alone {t_sd * 1e3:.1f} ms ({t_sd / N * 1e9:.0f} ns/sample; "
          f"keeping every sample {t_sd_rec * 1e3:.1f} ms); FilterPy 2400 UKF steps "
          f"{t_fp:.3f} s")

    # fednav process: forward, smoother.
    process(imu, {"gnss": gnss, "velocity": vel}, cfg)  # compile
    fwd, t_fwd = best_of(n, lambda: process(imu, {"gnss": gnss, "velocity": vel}, cfg))
    _, t_smo = best_of(n, lambda: process(imu, {"gnss": gnss, "velocity": vel}, cfg, smooth=True))
    print(f"process forward, IMU-rate solution ({len(fwd.forward.t)} rows, {fwd.epochs} "
          f"epochs): {t_fwd:.3f} s = {t_fwd / t_sd:.1f} x strapdown (target <= 3), "
          f"{t_fwd / t_fp:.2f} x FilterPy 2400 steps (target <= 0.33), "
          f"{t_fwd / N * 1e6:.2f} us/sample")
    print(f"process with smoother: {t_smo:.3f} s = {t_smo / t_fwd:.2f} x forward "
          f"(target <= 2)")

    # The same data through the navigator: one block, blocks of 100, single samples.
    prep = prepare(imu, {"gnss": gnss, "velocity": vel}, cfg)
    batch, t_batch = best_of(n, lambda: prep.feed(prep.navigator(
        record_rows=True, record_covariance=True)).result())
    plan100, plan1 = schedule(prep, 100), schedule(prep, 1)
    b100, t_b100 = best_of(n, lambda: stream(prep, plan100))
    one, t_one = best_of(n, lambda: stream(prep, plan1))
    for name, r in (("blocks of 100", b100), ("single samples", one)):
        same = all(np.array_equal(getattr(batch, f), getattr(r, f)) for f in ("states", "P"))
        assert same, f"{name}: not the batch's result"
    per = t_batch / len(prep.t)
    print(f"navigator: one block {t_batch:.3f} s ({per * 1e6:.2f} us/sample; "
          f"solution {t_fwd - t_batch:.3f} s more); blocks of 100 "
          f"{t_b100 / t_batch:.2f} x batch per sample (target <= 1.25, issue 39); "
          f"one sample at a time "
          f"{t_one / t_batch:.1f} x (target <= 20), {len(prep.t) / t_one:.0f} samples/s; "
          f"results equal to the batch's")
    del solution

    # fednav tune.
    base = load_system({"sensors": {"gnss": {"lever_m": list(map(float, gnss.lever))}}})
    tuned, t_tune = best_of(1, lambda: tune(imu, {"gnss": gnss, "velocity": vel}, base))
    print(f"tune: {t_tune:.2f} s, {tuned.runs} filter runs = "
          f"{t_tune / tuned.runs / t_fwd:.2f} x forward per run (target <= 5), "
          f"{t_tune / t_fp:.2f} x FilterPy 2400 steps (target <= 5)")


if __name__ == "__main__":
    main()
