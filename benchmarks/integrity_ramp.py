"""Protection levels by solution separation on a simulated drive (by hand, not in CI).

The 240 s drive of the tests (100 Hz IMU, 5 Hz GNSS at a lever arm, an ENU velocity
sensor, a 10 Hz barometer) processed with ``integrity:`` fault-free and with a GNSS
height ramp of several rates from 120 s; with three sensors and with two (no baro).
Per case: the exclusion (sensor, time), the fraction of the reference's epochs whose
error exceeds the level, the levels' medians against the errors' medians, the up RMSE,
and the cost of the run with levels against the plain run (best of 3, same process).

    python benchmarks/integrity_ramp.py
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_process import LEVER, make_flight  # noqa: E402
from test_series_route import _velocity  # noqa: E402

from fednav import System  # noqa: E402
from fednav.io.data import SensorData  # noqa: E402
from fednav.process import process  # noqa: E402
from fednav.process.output import summary  # noqa: E402


def config(integrity: bool, baro: bool = True) -> System:
    sensors = {"gnss": {"lever_m": list(LEVER)}, "velocity": {"lever_m": list(LEVER)}}
    if baro:
        sensors["baro"] = {"sigma_m": 0.3, "damping_loop": False}
    return System.model_validate({
        "imu": {"gyro_arw_deg_sqrt_h": 0.2, "accel_vrw_mps_sqrt_s": 0.002,
                "gyro_bias_deg_h": 10, "accel_bias_mps2": 0.01, "gyro_markov_deg_h": 0,
                "accel_markov_mps2": 0},
        "sensors": sensors, **({"integrity": {}} if integrity else {})})


def best(fn, n=3):
    out, ts = None, []
    for _ in range(n):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return out, min(ts)


def main() -> None:
    imu, gnss, ref = make_flight()
    rng = np.random.default_rng(3)
    tb = np.arange(0.1, ref.t[-1], 0.1)
    h = np.interp(tb, ref.t, ref.lla[:, 2]) + 0.3 * rng.standard_normal(len(tb))
    baro = SensorData("baro", "sim-baro", tb, h[:, None])
    vel = _velocity(gnss)
    process(imu, {"gnss": gnss, "velocity": vel, "baro": baro}, config(True))  # (compile)
    print("| sensors | GNSS up ramp | excluded | error > level (h / v) | misleading (v) | "
          "HPL / VPL median [m] | error median h / v [m] | up RMSE [m] | cost vs plain |")
    print("|---|---|---|---|---|---|---|---|---|")
    for with_baro in (True, False):
        for rate in (0.0, 0.05, 0.1, 0.5):
            g = replace(gnss, lla=gnss.lla.copy(), quality={})
            k = g.t > 120.0
            g.lla[k, 2] += (g.t[k] - 120.0) * rate
            data = {"gnss": g, "velocity": vel, **({"baro": baro} if with_baro else {})}
            res, t_int = best(lambda d=data, b=with_baro: process(imu, d, config(True, b)))
            _, t_plain = best(lambda d=data, b=with_baro: process(imu, d, config(False, b)))
            s = summary(res, ref, {})
            i = s["integrity"]
            ex = ", ".join(f"{e['sensor']} at {e['t_s']:.1f} s" for e in i["exclusions"]) \
                or ("none (alert)" if i["alert_fraction"] else "none")
            print(f"| {'+'.join(i['sensors'])} | {rate:g} m/s | {ex} | "
                  f"{i['horizontal_error_above_level']:.3f} / "
                  f"{i['vertical_error_above_level']:.3f} | {i['vertical_misleading']:.3f} | "
                  f"{i['hpl_m']['median']:.2f} / "
                  f"{i['vpl_m']['median']:.2f} | {i['horizontal_error_median']:.3f} / "
                  f"{i['vertical_error_median']:.3f} | {s['rmse']['up_m']:.3f} | "
                  f"{t_int / t_plain:.1f}x |")


if __name__ == "__main__":
    main()
