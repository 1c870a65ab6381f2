"""The health monitor against corrupted data: every corruption of
:func:`fednav.sim.corruptions.families` applied to clean simulated drives, each run through
``fednav.process.process`` and classified:

- ``refused``: the run ended with one line (a ``DataError``);
- ``warned``: it ran, with a warning the clean run did not have;
- ``silent, within 3σ``: no new word, and the errors against the truth stay within the
  clean run's 3σ (the corruption did no harm: e.g. a 10 % scale on a vertical velocity
  the receiver reports with 5 cm/s σ);
- ``SILENT, OUTSIDE 3σ``: no new word and a solution outside the clean run's 3σ — what
  must never happen.

"Outside" means: for some error (east/north/up, vE/vN/vU, pitch/roll/heading), the share
of epochs beyond 3× the clean run's σ exceeds the clean run's own share by more than
2 points.  Prints one line per corruption, the detection rate (corruptions outside 3σ that
were refused or warned about) and the false-alarm count on the clean drives (target: 100 %
and 0), and the monitor's cost per filter epoch against the epoch's time.

    python benchmarks/health.py [--quick]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from fednav.io.data import DataError
from fednav.navigator.health import run_health
from fednav.process import errors_against, process
from fednav.process.run import flown_fixes, imu_figures, prepare
from fednav.sim.corruptions import families
from fednav.sim.drives import ADIS16405, ADIS16488, car_drive

COMPONENTS = {"north_m": ("sigma", 7), "east_m": ("sigma", 6), "up_m": ("sigma", 8),
              "vn_mps": ("sigma", 4), "ve_mps": ("sigma", 3), "vu_mps": ("sigma", 5),
              "pitch_rad": ("sigma_euler", 0), "roll_rad": ("sigma_euler", 1),
              "yaw_rad": ("sigma_euler", 2)}


def drives(quick: bool = False):
    """Clean drives: (name, Drive)."""
    out = [("ADIS16405 static start", car_drive(30.0, 0.0, seed=1, static_s=10.0)),
           ("ADIS16488 moving start", car_drive(200.0, 3.0, seed=2, imu=ADIS16488))]
    if not quick:
        out.append(("ADIS16405 moving start, hills", car_drive(120.0, 5.0, seed=3, imu=ADIS16405,
                                                              hill_deg=4.0)))
    return out


def beyond(sol, clean, ref) -> dict[str, float]:
    """Share of reference epochs (1 Hz) where each error exceeds 3x the clean run's σ."""
    e = errors_against(sol, ref)
    keep = np.r_[True, np.diff(np.floor(e["t"])) > 0]
    t = e["t"][keep]
    out = {}
    for k, (attr, j) in COMPONENTS.items():
        s = np.interp(t, clean.t, getattr(clean, attr)[:, j])
        out[k] = float(np.mean(np.abs(e[k][keep]) > 3.0 * s))
    return out


def classify(d, corruption, clean_res, clean_beyond) -> tuple[str, str]:
    try:
        imu, gnss = corruption.apply(d.imu, d.gnss)  # the loader's own checks may refuse
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = process(imu, {"gnss": gnss}, d.system)
    except DataError as exc:
        return "refused", str(exc)
    except Exception as exc:  # noqa: BLE001 - a traceback is a finding
        return "CRASH", f"{type(exc).__name__}: {exc}"
    new = [w for w in res.warnings if w not in clean_res.warnings]
    if new:
        return "warned", new[0]
    try:
        b = beyond(res.forward, clean_res.forward, d.reference)
    except DataError as exc:
        return "SILENT, OUTSIDE 3σ", str(exc)
    worst = max(b, key=lambda k: b[k] - clean_beyond[k])
    if b[worst] - clean_beyond[worst] > 0.02:
        return "SILENT, OUTSIDE 3σ", f"{worst}: {100 * b[worst]:.0f} % beyond 3σ"
    return "silent, within 3σ", ""


def monitor_cost(d, repeats: int = 7) -> tuple[float, float]:
    """Seconds per filter epoch of ``process`` without the monitor and of the monitor
    (:func:`run_health` as ``process`` calls it: GNSS as flown, the forward solution and
    the IMU figures), each the least of ``repeats`` runs (a busy machine only adds)."""
    prep = prepare(d.imu, {"gnss": d.gnss}, d.system)
    gnss, figures = flown_fixes(d.gnss, prep.system), imu_figures(d.imu, prep.system)
    runs, mons = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = process(d.imu, {"gnss": d.gnss}, d.system)
        runs.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        run_health(res.forward.fdi, d.imu, gnss, res.forward, figures, True, [])
        mons.append(time.perf_counter() - t0)
    n = max(res.epochs, 1)
    return (min(runs) - min(mons)) / n, min(mons) / n


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two drives instead of three")
    args = ap.parse_args(argv)
    counts: dict[str, int] = {}
    false_alarms, harmful, caught = 0, 0, 0
    for name, d in drives(args.quick):
        clean = process(d.imu, {"gnss": d.gnss}, d.system)
        if clean.warnings:
            false_alarms += len(clean.warnings)
            print(f"[{name}] FALSE ALARM on clean data: {clean.warnings}")
        cb = beyond(clean.forward, clean.forward, d.reference)
        for c in families():
            verdict, why = classify(d, c, clean, cb)
            counts[verdict] = counts.get(verdict, 0) + 1
            if verdict != "silent, within 3σ":
                harmful += 1
                caught += verdict in ("refused", "warned")
            print(f"[{name}] {c.family:12s} {c.name:46s} {verdict:18s} {why[:110]}")
    print()
    for k, v in sorted(counts.items()):
        print(f"{k:20s} {v}")
    print(f"detection: {caught} of {harmful} corruptions that were refused, warned about or "
          f"moved the solution outside 3σ ({100 * caught / max(harmful, 1):.1f} %)")
    print(f"false alarms on the clean drives: {false_alarms}")
    for name, d in drives(args.quick):
        run, mon = monitor_cost(d)
        print(f"monitor cost [{name}]: {1e6 * mon:.1f} µs per filter epoch against "
              f"{1e6 * run:.0f} µs for the rest of process ({100 * mon / run:.1f} %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
