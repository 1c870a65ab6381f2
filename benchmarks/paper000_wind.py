"""Paper 000: why the wind does not change AEKF / RAUKF in fednav, and what would.

    python benchmarks/paper000_wind.py [runs]

1. As simulated (truth, IMU and sensors all fly the same wind): the IMU measures the gust
   accelerations, so the SINS follows the wind and nothing downstream sees it.
2. The same flight with the IMU data of the *no-wind* flight (the wind-driven
   accelerations missing from the IMU, as happens when the IMU is simulated from the
   air-relative motion): the SINS misses the gusts; SAR and CNS must catch them.
3. The decoded SAR accuracy "25 m" against the alternative reading 2.5 m.
4. Air data / wind estimate at 0.2 m/s: the hard projection (CUKF) against the same
   constraint used as a measurement with its covariance (soft constraint, EKF).
"""

from __future__ import annotations

import sys

import numpy as np

from fednav.scenarios import paper000
from fednav.sim.runs import make_run_data, run_configured_mode, run_mode


def stats(scn, data, T=None):
    out = {}
    for m in scn.modes:
        r = paper000.run_statistics(run_configured_mode(scn, m, data, T))
        out[m.name] = (r["pos_mean_m"], r["vel_mean_mps"])
    return out


def main(runs: int = 3):
    scn = paper000.load_scenario()
    v = paper000.variants(scn)
    rows = {}
    for seed in range(1, runs + 1):
        d_none = make_run_data(v["none"], seed)
        d_wind = make_run_data(v["wind"], seed)
        # wind flight, IMU of the no-wind flight (same seed: same IMU errors)
        d_mix = make_run_data(v["wind"], seed)
        d_mix.dtheta, d_mix.dv = d_none.dtheta, d_none.dv
        sar = v["none"].sensors.sar.model_copy(update={"sigma_pos_m": 2.5})
        s25 = v["none"].model_copy(update={"sensors": v["none"].sensors.replace(sar=sar)})
        for name, (s, d) in {"no wind": (v["none"], d_none), "wind": (v["wind"], d_wind),
                             "wind, IMU without the wind": (v["wind"], d_mix),
                             "no wind, SAR 2.5 m": (s25, make_run_data(s25, seed))}.items():
            for mode, val in stats(s, d).items():
                rows.setdefault((name, mode), []).append(val)
        noisy = paper000.with_air_data(v["none"], sigma_airspeed_mps=0.2, wind_sigma_mps=0.2)
        dn = make_run_data(noisy, seed)
        for label, ftype in (("CUKF", "cukf"), ("EKF+c", "kf")):
            r = paper000.run_statistics(run_mode(noisy, ["sar", "star"], dn, "", None, ftype,
                                                 None, "wind"))
            rows.setdefault(("air data 0.2 m/s", label), []).append(
                (r["pos_mean_m"], r["vel_mean_mps"]))
    print(f"horizontal position / velocity error, mean over the flight and {runs} runs")
    for (name, mode), vals in rows.items():
        p, vv = np.mean(vals, axis=0)
        print(f"  {name:28s} {mode:6s} {p:8.2f} m {vv:8.3f} m/s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
