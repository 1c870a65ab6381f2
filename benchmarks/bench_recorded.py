"""Speed of the papers' system on recorded files, against the same run inside
``fednav reproduce`` timed in the same process.

    python benchmarks/bench_recorded.py [--paper 002] [--mode SINS/CNS/SAR] [--seed 1]
                                        [--repeat 3] [--max-time SECONDS]

The data: run ``seed`` of the paper, mode ``mode`` (paper 002: 1200 s, 100 Hz IMU, star
sensor, SAR, baro, federated UKF with a master filter), written by ``fednav simulate``
into a temporary folder.  Timed warm (a first run compiles), best of ``--repeat``:

* baseline — the run as ``fednav reproduce`` flies it
  (:func:`fednav.sim.runs.run_configured_mode` on the run's data: the navigator, the
  errors at the statistics epochs);
* reading the files (IMU, each sensor, reference, system.yaml);
* processing them (:func:`fednav.process.process`: the same navigator plus what
  ``fednav process`` gives on top: the IMU-rate solution with its sigmas, which needs
  each interval's transition and noise kept);
* writing the outputs (solution.csv, errors.csv, plots, summary.json).

Targets (issue 25): processing <= 2 x the reproduce run; reading <= processing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_navigator import best_of  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paper", default="002")
    ap.add_argument("--mode", default="SINS/CNS/SAR")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--max-time", type=float, default=None)
    a = ap.parse_args()

    from fednav.io import read_imu_csv, read_reference_csv, read_sensor_csv
    from fednav.navigator.system import load_system
    from fednav.process import output, process
    from fednav.scenarios import paper_module
    from fednav.sim.export import find_mode, write_run
    from fednav.sim.runs import make_run_data, run_configured_mode

    scn = paper_module(a.paper).EXPERIMENT.load_scenario()
    mode = find_mode(scn, a.mode)
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        write_run(scn, a.seed, mode, d / "sim", a.max_time)
        data = make_run_data(scn, a.seed, a.max_time)

        def reproduce_run():
            return run_configured_mode(scn, mode, data, a.max_time)

        def read():
            cfg = load_system(d / "sim" / "system.yaml")
            sensors = {n: read_sensor_csv(n, d / "sim" / f) for n, f in cfg.files.items()
                       if n not in ("imu", "reference")}
            return (cfg, read_imu_csv(d / "sim" / "imu.csv", cfg.imu.max_bridge_s), sensors,
                    read_reference_csv(d / "sim" / "reference.csv"))

        cfg, imu, sensors, ref = read()
        reproduce_run()
        process(imu, {**sensors}, cfg)  # compile
        _, t_rep = best_of(a.repeat, reproduce_run)
        _, t_read = best_of(a.repeat, read)
        res, t_proc = best_of(a.repeat, lambda: process(imu, {**sensors}, cfg))
        _, t_out = best_of(1, lambda: output.write(d / "out", res, ref, {}))
    n = len(imu.t)
    print(f"paper {a.paper}, mode {mode.name}, seed {a.seed}: {n} IMU samples, "
          f"{res.epochs} filter epochs")
    print(f"reproduce run (baseline) {t_rep:8.3f} s")
    print(f"read files               {t_read:8.3f} s  {t_read / t_proc:5.2f} x processing "
          f"(target <= 1)")
    print(f"process                  {t_proc:8.3f} s  {t_proc / t_rep:5.2f} x reproduce "
          f"(target <= 2)")
    print(f"write outputs            {t_out:8.3f} s  {t_out / t_rep:5.2f} x reproduce")


if __name__ == "__main__":
    main()
