"""Exclusion in the stream (``IntegrityNavigator``) against the batch (by hand, not in CI).

The 240 s drive of the tests (100 Hz IMU, 5 Hz GNSS, an ENU velocity sensor, a 10 Hz
barometer) fed to the stream in blocks of 500 IMU samples with a snapshot after each,
fault-free and with a GNSS height ramp of several rates from 120 s.  Per case: when a
test trips, which sensor the stream excludes and when, which the batch (``fednav
process`` with ``integrity:``) excludes and when, and the largest height error of the
stream's output after its exclusion.  Then the cost of feeding the drive (best of 3,
same process): one navigator, the stream with detection only (its pair navigators
dropped), and with exclusion.

    python benchmarks/integrity_stream.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_integrity import _cfg, _ramp, _stream_levels  # noqa: E402
from test_process import make_flight  # noqa: E402
from test_series_route import _velocity  # noqa: E402

from fednav.core import earth  # noqa: E402
from fednav.io.data import SensorData  # noqa: E402
from fednav.navigator import Navigator  # noqa: E402
from fednav.navigator.integrity_stream import IntegrityNavigator  # noqa: E402
from fednav.process import process  # noqa: E402
from fednav.process.output import summary  # noqa: E402
from fednav.process.run import prepare  # noqa: E402


def drive():
    imu, gnss, ref = make_flight()
    rng = np.random.default_rng(3)
    tb = np.arange(0.1, ref.t[-1], 0.1)
    h = np.interp(tb, ref.t, ref.lla[:, 2]) + 0.3 * rng.standard_normal(len(tb))
    return imu, gnss, _velocity(gnss), SensorData("baro", "sim-baro", tb, h[:, None]), ref


def feed(prep, kind: str) -> float:
    """Seconds to feed ``prep`` in blocks of 500 samples, a snapshot after each."""
    kw = dict(imu_errors=prep.imu_errors, record_rows=False, record_covariance=False)
    if kind == "navigator":
        nav = Navigator(prep.system, prep.initial, prep.dt, **kw)
    else:
        nav = IntegrityNavigator(prep.system, prep.initial, prep.dt, **kw)
        if kind == "detection":
            nav.pairs = {}
    for s in prep.series.values():
        nav.add_series(s)
    t0 = time.perf_counter()
    for a in range(0, len(prep.t), 500):
        b = min(a + 500, len(prep.t))
        nav.add_imu(prep.t[a:b], prep.gyro[a:b], prep.accel[a:b])
        nav.solution()
    return time.perf_counter() - t0


def main() -> None:
    imu, gnss, vel, baro, ref = drive()
    print("| ramp | test trips | stream excludes | batch excludes | height error after |")
    print("|---|---|---|---|---|")
    for rate in (0.0, 0.05, 0.1, 0.5):
        sensors = {"gnss": _ramp(gnss, rate) if rate else gnss, "velocity": vel,
                   "baro": baro}
        nav, snaps = _stream_levels(prepare(imu, sensors, _cfg()))
        trip = next((s.levels["tripped_s"] for s in snaps if s.levels["tripped_s"]), None)
        out = [s for s in snaps if s.levels["excluded"] is not None]
        batch = summary(process(imu, sensors, _cfg()), ref, {})["integrity"]["exclusions"]
        up = [abs(np.asarray(earth.llh_difference_enu(
            *s.lla, *ref.lla[np.searchsorted(ref.t, s.t)]))[2]) for s in out]
        stream = f"{nav.excluded} at {out[0].levels['excluded_s']:.1f} s" if out else "none"
        by_batch = ", ".join("{} at {:.1f} s".format(e["sensor"], e["t_s"]) for e in batch)
        after = f"{max(up):.2f} m" if up else "—"
        print(f"| {rate:g} m/s | {trip} | {stream} | {by_batch or 'none'} | {after} |")
    prep = prepare(imu, {"gnss": gnss, "velocity": vel, "baro": baro}, _cfg())
    kinds = ("navigator", "detection", "exclusion")
    for k in kinds:
        feed(prep, k)  # (warm)
    best = {k: min(feed(prep, k) for _ in range(3)) for k in kinds}
    print("feeding the drive, best of 3: " + ", ".join(f"{k} {v:.3f} s" for k, v in
                                                       best.items())
          + f"; exclusion / detection {best['exclusion'] / best['detection']:.2f}")


if __name__ == "__main__":
    main()
