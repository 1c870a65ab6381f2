"""Fixes on another clock phase than the IMU's: the filter's epoch grid against the GNSS
stamps (by hand, not in CI).

    python benchmarks/epoch_phase.py [--seeds 8] [--shift-ms -2]
    PYTHONPATH=OLD/src python benchmarks/epoch_phase.py   # another fednav, to compare

Simulated car drives (``fednav.sim.drives.car_drive``, ADIS16405 class, 5 Hz GNSS) whose
IMU time stamps are moved by ``--shift-ms`` against the fixes (an IMU clock a little
ahead: its first sample just before the first fix).  Prints per column the mean forward
and smoothed RMSE over the seeds and the latest use of a fix after its stamp.  Before
commit e96eac7 the epoch grid started at the IMU sample nearest the first fix, and with
the IMU 2 ms ahead every fix waited a whole filter period for its epoch.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from fednav.process import errors_against, prepare, process, rmse
from fednav.sim.drives import car_drive

KEYS = ("east_m", "north_m", "up_m", "ve_mps", "vn_mps", "vu_mps", "pitch_deg", "roll_deg",
        "yaw_deg")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--shift-ms", type=float, default=-2.0)
    a = ap.parse_args(argv)
    fwd, smo, late = [], [], []
    for seed in range(1, a.seeds + 1):
        d = car_drive(heading_deg=30.0 + 41.0 * seed, seed=seed, static_s=5.0)
        imu = replace(d.imu, t=d.imu.t + a.shift_ms * 1e-3)
        prep = prepare(imu, {"gnss": d.gnss}, d.system)
        t0, T = prep.initial.t, prep.system.filter.period_s
        k = np.ceil((d.gnss.t - t0) / T - 1e-9)
        late.append(float(np.max((t0 + T * k - d.gnss.t)[k > 0])))
        res = process(imu, {"gnss": d.gnss}, d.system, smooth=True)
        fwd.append(rmse(errors_against(res.forward, d.reference)))
        smo.append(rmse(errors_against(res.smoothed, d.reference)))
    print(f"IMU stamps {a.shift_ms:+g} ms against the fixes, {a.seeds} drives; a fix is used "
          f"at most {1e3 * max(late):.0f} ms after its stamp")
    print(f"{'':10s}" + "".join(f"{k:>11s}" for k in KEYS))
    for name, rows in (("forward", fwd), ("smoothed", smo)):
        print(f"{name:10s}" + "".join(f"{np.mean([r[k] for r in rows]):11.4f}" for k in KEYS))


if __name__ == "__main__":
    main()
