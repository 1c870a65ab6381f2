"""A 24-hour SINS/CNS/SAR flight (run by hand: ``python benchmarks/day_flight.py [--hours H]``).

Paper 002's system (federated UKF, star sensor and SAR every 5 s, baro loop) on a cruise
of ``--hours`` hours (the paper's climb, then level cruise east at 400 m/s, 100 Hz IMU:
once around the Earth along 39 deg N).
Reports whether the numerics stay steady: the filter's 1-sigma in filter units
(largest/smallest ratio over the states; its square bounds the condition of the
diagonal) and the navigation errors in the first and the last hour. (The INS quaternion
is renormalised every IMU sample and after every feedback, so its norm is 1 to rounding
by construction.)
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hours", type=float, default=24.0)
    args = ap.parse_args()
    from fednav.core import units
    from fednav.scenarios import paper002
    from fednav.sim.runs import make_run_data, run_configured_mode

    scn = paper002.load_scenario()
    segs = list(scn.segments[:3])
    # one-hour pieces: the truth integrator works segment by segment
    total = args.hours * 3600.0 - 60.0
    pieces = [min(3600.0, total - k * 3600.0) for k in range(int(np.ceil(total / 3600.0)))]
    cruise = [scn.segments[3].model_copy(update={"duration_s": d, "name": f"cruise {k}"})
              for k, d in enumerate(pieces)]
    # heading east: a day at 400 m/s on the paper's 45 deg heading would reach the pole
    start = scn.start.model_copy(update={"heading_deg": 90.0})
    scn = scn.model_copy(update={"segments": [*segs, *cruise], "start": start})
    mode = next(m for m in scn.modes if m.name == "SINS/CNS/SAR")
    t0 = time.perf_counter()
    tr = scn.trajectory()
    t1 = time.perf_counter()
    data = make_run_data(scn, 1)
    res = run_configured_mode(scn, mode, data)
    t2 = time.perf_counter()
    hour = res.t < 3600.0
    last = res.t > res.t[-1] - 3600.0
    from fednav.ins import error_model as em

    s = res.sigma / em.SCALE                      # filter units, as the filter holds them
    s = s[:, ~np.all(np.isnan(s), axis=0)]
    ratio = s.max(axis=1) / s.min(axis=1)
    print(f"{args.hours:g} h flight, {len(tr.t) - 1} IMU samples: truth {t1 - t0:.0f} s, "
          f"SINS/CNS/SAR run {t2 - t1:.0f} s")
    for name, m in (("first hour", hour), ("last hour", last)):
        print(f"{name}: position error RMS {np.sqrt(np.mean(res.pos[m] ** 2, axis=0))} m, "
              f"attitude RMS {units.to_arcsec(np.sqrt(np.mean(res.att[m] ** 2, axis=0)))} arcsec, "
              f"sigma max/min {ratio[m].max():.3g}")
    print(f"all finite: {np.isfinite(res.pos).all() and np.isfinite(res.att).all()}; "
          f"sigma max/min over the day {ratio.min():.3g} .. {ratio.max():.3g}")


if __name__ == "__main__":
    main()
