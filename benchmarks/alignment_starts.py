"""Does the alignment's sigma contain its error, from any start?  Random car drives
(:func:`fednav.sim.drives.car_drive`: any start heading, moving or static starts, gentle or
hard pull-away, ADIS16405 or ADIS16488 class), processed with fednav's defaults.

    python benchmarks/alignment_starts.py [--drives 40] [--seed 1]

Per drive: the levelling used, the start errors over the alignment's sigma (pitch,
roll, heading), and the forward filter's heading 3-sigma containment over its epochs
with the largest |error| / sigma.  The last lines: the RMS over the drives of each
forward RMSE, and: the largest start ratio, the least
containment and the largest excursion over all drives.  Issue 26's target: the start
ratios within 3; the containment is reported (a consistent filter's error leaves its
3 sigma now and then).
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from fednav.process import errors_against, process, rmse
from fednav.sim.drives import ADIS16405, ADIS16488, car_drive, heading_containment

KEYS = ("north_m", "east_m", "up_m", "vn_mps", "ve_mps", "roll_deg", "pitch_deg", "yaw_deg")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drives", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    warnings.filterwarnings("ignore")
    rng = np.random.default_rng(args.seed)
    worst, errs = [], []
    for _ in range(args.drives):
        h, acc = rng.uniform(0.0, 360.0), rng.uniform(0.2, 2.0)
        v = float(rng.choice([0.0, 0.02, rng.uniform(0.0, 12.0)]))
        seed, static = int(rng.integers(1, 10_000)), float(rng.choice([0.0, 0.0, 5.0]))
        grade = "16405" if rng.random() < 0.5 else "16488"
        d = car_drive(h, v, seed=seed, imu=ADIS16405 if grade == "16405" else ADIS16488,
                      static_s=static, accel_mps2=acc)
        res = process(d.imu, {"gnss": d.gnss}, d.system)
        i = int(np.searchsorted(d.reference.t, res.forward.t[0] - 1e-9))  # (the start's
        # own epoch: the first fix, not the simulation's first sample)
        e0 = res.forward.euler[0] - d.reference.euler[i]
        e0[2] = np.angle(np.exp(1j * e0[2]))
        ratio0 = np.abs(e0) / res.forward.sigma_euler[0]
        inside, most = heading_containment(res.forward, d.reference)
        worst.append((ratio0.max(), inside, most))
        e = rmse(errors_against(res.forward, d.reference))
        errs.append([e[k] for k in KEYS])
        print(f"heading {h:6.1f} speed {v:5.2f} pull {acc:4.2f} static {static:3.0f} "
              f"ADIS{grade}  {res.alignment['levelling'][:9]:9s}  start/sigma "
              f"{np.array2string(ratio0, precision=2)}  heading 3-sigma {100 * inside:5.1f} % "
              f"(max {most:.2f})")
    w = np.array(worst)
    print(f"largest start error / sigma {w[:, 0].max():.2f}; least containment "
          f"{100 * w[:, 1].min():.1f} %; {int(np.sum(w[:, 1] == 1.0))} of {len(w)} drives "
          f"100 %; largest excursion {w[:, 2].max():.2f} sigma")
    m = np.sqrt(np.mean(np.square(errs), axis=0))
    print("forward RMSE over all drives: " + ", ".join(f"{k} {v:.3f}"
                                                       for k, v in zip(KEYS, m, strict=True)))


if __name__ == "__main__":
    main()
