"""A stream whose GNSS fixes arrive late, against the batch: RMSE against the truth.

    python benchmarks/stream_latency.py [--seconds 600] [--latency 0.3] [--jitter-ms 2]

The drive of ``examples/car-drive.yaml`` (200 Hz IMU, 5 Hz GNSS, filter period 0.2 s),
simulated and read back from its CSV files.  The batch: ``fednav.process_data`` with
every fix at its time of validity.  The streams: the same prepared data fed one IMU
sample at a time, each fix added when it arrives — ``--latency`` seconds after its time
of validity, with ``t_arrival`` — as flight software would:

* ``undeclared``: the system says nothing of the latency (what fednav 0.1 did with any
  system: each fix used at the first epoch after its arrival, ``interpolate`` reaching
  back only within that epoch's interval);
* ``undeclared, hold_s``: the same with ``Navigator(hold_s=latency + 0.2)``;
* ``declared``: ``sensors.gnss.timing.latency_s`` set to the latency (the navigator holds
  each epoch that long and uses each fix at its time of validity);
* ``recompute``: undeclared, ``sensors.gnss.timing.delay_compensation: recompute``;
* ``declared, jittered IMU``: declared, the IMU stamps jittered by up to
  ``--jitter-ms`` (uniform), the stream integrating each sample over its own interval;
  against the batch on the same jittered samples (resampled by ``regular_imu``, the
  fixes on time, the same start).

Prints the RMSE of position (east, north, up), velocity (east, north) and attitude (roll,
pitch, yaw) of each run and its ratio to the batch's.  Figures in CHANGELOG.md (issue 38).
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KEYS = ("east_m", "north_m", "up_m", "ve_mps", "vn_mps", "roll_deg", "pitch_deg", "yaw_deg")


def drive(folder: Path, seconds: float):
    """The car drive (its first ``seconds``) written as CSV and read back."""
    import fednav
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.truncated(seconds)
    write_csv_dataset(simulate_dataset(cfg), folder)
    system = fednav.load_system(folder / "process.yaml")
    g = system.sensors.gnss
    imu = fednav.read_imu_csv(folder / "imu.csv")
    gnss = fednav.read_gnss_csv(folder / "gnss.csv", g.sigma_pos_enu_m, g.sigma_vel_mps,
                                g.lever_m)
    return system, imu, gnss, fednav.read_reference_csv(folder / "reference.csv")


def with_timing(system, **timing):
    g = system.sensors.gnss
    g = g.model_copy(update={"timing": g.timing.model_copy(update=timing)})
    return system.model_copy(update={"sensors": system.sensors.replace(gnss=g)})


def stream(prep, latency: float, jitter: np.ndarray | None = None, **options):
    """Feed ``prep`` one IMU sample at a time; each fix when it arrives (``latency``
    after its time of validity, told by ``t_arrival``).  ``jitter``: added to the IMU
    stamps [s]."""
    nav = prep.navigator(**options)
    tg, zg, Rg = prep.rows("gnss")
    ta = tg + latency
    stamps = prep.t if jitter is None else prep.t + jitter
    j = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for i in range(len(prep.t)):
            while j < len(tg) and ta[j] <= stamps[i] + 1e-9:
                nav.add_measurement("gnss", tg[j], zg[j], R=Rg[j], t_arrival=ta[j])
                j += 1
            nav.add_imu(stamps[i], prep.gyro[i], prep.accel[i])
        for k in range(j, len(tg)):
            nav.add_measurement("gnss", tg[k], zg[k], R=Rg[k], t_arrival=ta[k])
        return nav.result()


def main() -> None:
    import fednav
    from fednav.io.data import regular_imu

    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--latency", type=float, default=0.3)
    ap.add_argument("--jitter-ms", type=float, default=2.0)
    args = ap.parse_args()
    L = args.latency
    with tempfile.TemporaryDirectory() as tmp:
        system, imu, gnss, truth = drive(Path(tmp), args.seconds)

    def rmse(sol):
        r = fednav.rmse(fednav.errors_against(sol, truth))
        return np.array([r[k] for k in KEYS])

    batch = rmse(fednav.process_data(imu, {"gnss": gnss}, cfg=system).forward)
    runs = {"batch (fixes on time)": batch}
    prep = fednav.prepare(imu, {"gnss": gnss}, cfg=system)
    runs["stream, undeclared"] = rmse(stream(prep, L).forward)
    runs["stream, undeclared, hold_s"] = rmse(stream(prep, L, hold_s=L + 0.2).forward)
    runs["stream, recompute"] = rmse(stream(fednav.prepare(imu, {"gnss": gnss}, cfg=with_timing(
        system, delay_compensation="recompute")), L).forward)
    declared = fednav.prepare(imu, {"gnss": gnss}, cfg=with_timing(system, latency_s=L))
    runs["stream, declared latency_s"] = rmse(stream(declared, L).forward)
    dt = declared.dt
    jit = np.random.default_rng(0).uniform(-1e-3, 1e-3, len(declared.t)) * args.jitter_ms
    jit[0] = 0.0
    # the batch on the same jittered samples: resampled onto the grid of their median
    # interval (what read_imu_csv does), fixes on time, the same start and filter
    t_j, g_j, a_j, _ = regular_imu("jittered", declared.t + jit, declared.gyro,
                                   declared.accel, 0.1)
    dt_j = float(np.median(np.diff(declared.t + jit)))
    nav = fednav.Navigator(declared.system, declared.initial, dt_j,
                           imu_errors=declared.imu_errors)
    tg, zg, Rg = declared.rows("gnss")
    nav.add_measurements("gnss", tg, zg, R=Rg)
    nav.add_imu(t_j, g_j, a_j)
    runs["batch, jittered IMU"] = rmse(nav.result().forward)
    jittered = replace(declared, dt=dt_j)
    try:
        runs["stream, declared, jittered IMU"] = rmse(stream(jittered, L, jit).forward)
    except ValueError as e:  # (fednav 0.1: uniform sampling only)
        print(f"stream, declared, jittered IMU: {e}")
    print(f"drive: {imu.t[-1] - imu.t[0]:.0f} s, IMU {1 / dt:.0f} Hz, {len(gnss.t)} GNSS "
          f"fixes arriving {L:g} s late; IMU jitter +-{args.jitter_ms:g} ms")
    head = "".join(f"{k:>11}" for k in KEYS)
    print(f"{'RMSE':34}{head}")
    for name, r in runs.items():
        print(f"{name:34}" + "".join(f"{x:11.3f}" for x in r))
    print(f"{'ratio to the batch':34}")
    for name, r in runs.items():
        print(f"{name:34}" + "".join(f"{x:11.2f}" for x in r / batch))


if __name__ == "__main__":
    main()
