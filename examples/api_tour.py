"""A tour of fednav's Python API, notebook style: run it as a script, or cell by cell
(``# %%``) in VS Code, Spyder or Jupyter (from the repository's root).

    python examples/api_tour.py [--out FOLDER]

It simulates a short car drive (nothing to download), writes it as recorded files and
then does what a user does with their own recording: read the files, configure the
system, process them in one call and as a stream, evaluate the solution against the
truth and plot it.  The files and plots go to FOLDER (default: a new temporary folder);
files already there are never overwritten (the tour stops instead).  About 10 s once
the kernels are compiled (the first run compiles them, ~20 s).  The API: docs/api.md.
"""

# %% Set-up
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

import fednav
from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

#: this file's folder (the example scenario beside it; a notebook: run from the repository)
HERE = Path(globals().get("__file__", "examples/api_tour.py")).resolve().parent
#: the files the tour writes into its folder
WRITES = ("imu.csv", "gnss.csv", "velocity.csv", "reference.csv", "process.yaml",
          "errors.png", "track.png")


def output_folder(argv: list[str] | None = None) -> Path:
    """The folder of ``--out`` (made if missing; refused if it holds one of the files the
    tour writes), else a new temporary folder."""
    ap = argparse.ArgumentParser(description="A tour of fednav's Python API.")
    ap.add_argument("--out", type=Path, default=None,
                    help="folder for the simulated files and the plots (default: a new "
                         "temporary folder)")
    args, _ = ap.parse_known_args(argv)  # (a notebook kernel's own arguments ignored)
    if args.out is None:
        return Path(tempfile.mkdtemp(prefix="fednav-tour-"))
    taken = [n for n in WRITES if (args.out / n).exists()]
    if taken:
        sys.exit(f"error: {args.out} already holds {', '.join(taken)}; the tour does not "
                 f"overwrite files: give another --out")
    args.out.mkdir(parents=True, exist_ok=True)
    return args.out


# %% Where the tour writes
out = output_folder()
print(f"fednav {fednav.__version__}: the tour writes into {out}")

# %% 1. Data: a simulated drive written as recorded files
# The first 100 s of examples/car-drive.yaml (static start, pull away, a turn) with a
# 100 Hz MEMS IMU, 5 Hz GNSS at a roof antenna and a velocity sensor; `fednav
# simulate examples/car-drive.yaml --out DIR` writes the same files
# (fednav.sim.dataset is what `fednav simulate` runs).

scenario = load_dataset_config(HERE / "car-drive.yaml")
scenario = scenario.model_copy(update={"segments": scenario.segments[:5],
                                       "imu_period_s": 0.01})
for f in write_csv_dataset(simulate_dataset(scenario), out):
    print("  wrote", f.name)

# %% 2. Configure: a system description from YAML, a dict or Python
# process.yaml holds the simulated IMU's noise figures and the GNSS receiver's sigmas
# and lever arm (body right-forward-up [m]).  load_system validates it (one-line
# errors naming the key); a System is an immutable pydantic model: model_copy changes
# a copy.
system = fednav.load_system(out / "process.yaml")
system = system.model_copy(update={"smoother": True})      # also run the RTS smoother
g = system.sensors.gnss
print(f"IMU gyro ARW {system.imu.gyro_arw_rad_sqrt_s:.2e} rad/sqrt(s); GNSS 1-sigma "
      f"{g.sigma_pos_enu_m} m, lever arm {g.lever_m} m")

# %% 3. Read the files (SI units and fednav's frames from here on)
imu = fednav.read_imu_csv(out / "imu.csv")           # rates or increments, body RFU
gnss = fednav.read_gnss_csv(out / "gnss.csv", g.sigma_pos_enu_m, g.sigma_vel_mps,
                            g.lever_m)
truth = fednav.read_reference_csv(out / "reference.csv")
print(f"IMU {len(imu.t)} samples at {1 / np.median(np.diff(imu.t)):.0f} Hz, "
      f"GNSS {len(gnss.t)} fixes, reference {len(truth.t)} rows")

# %% 4. Process in one call (what `fednav process csv` runs)
# Checks, alignment (levelling at the static start, heading from the GNSS course),
# the federated filter at every GNSS epoch, the solution at every IMU sample with its
# 1-sigma, and the smoothed solution.
res = fednav.process_data(imu, {"gnss": gnss}, system, smooth=True)   # sensors by name
fwd = res.forward
print(f"{res.epochs} filter epochs in {res.run_time_s:.2f} s; alignment: "
      f"{res.alignment.get('heading')}")
for w in res.warnings:
    print("  warning:", w)
lat, lon, h = np.degrees(fwd.lla[-1, 0]), np.degrees(fwd.lla[-1, 1]), fwd.lla[-1, 2]
print(f"last fix {lat:.6f} deg, {lon:.6f} deg, {h:.1f} m; horizontal 1-sigma "
      f"{np.hypot(*fwd.sigma[-1, 6:8]):.2f} m")

# %% 5. Process as a stream: the Navigator fed sample by sample
# prepare() does the checks, the alignment and the initial state of process(); the
# navigator then takes each measurement when it arrives and each IMU sample; its
# solution() is the latest state at any time.  The result equals the batch run's.
prep = fednav.prepare(imu, {"gnss": gnss}, system)
nav = prep.navigator()
tg, zg, Rg = prep.rows("gnss")      # lat, lon [rad], h [m], ENU velocity [m/s]; R per fix
j = 0
for i in range(len(prep.t)):
    while j < len(tg) and tg[j] <= prep.t[i]:
        nav.add_measurement("gnss", tg[j], zg[j], R=Rg[j])
        j += 1
    nav.add_imu(prep.t[i], prep.gyro[i], prep.accel[i])
    if i == len(prep.t) // 2:
        snap = nav.solution()
        print(f"mid-stream at t = {snap.t:.2f} s: heading "
              f"{np.degrees(snap.euler[2]):.2f} deg, 1-sigma east/north "
              f"{snap.sigma[6]:.2f}/{snap.sigma[7]:.2f} m")
for k in range(j, len(tg)):  # fixes stamped after the last IMU sample (the last epoch)
    nav.add_measurement("gnss", tg[k], zg[k], R=Rg[k])
result = nav.result()
stream = result.forward
same = np.array_equal(stream.lla, fwd.lla) and np.array_equal(stream.vel, fwd.vel)
print(f"stream ({result.engine} engine): {len(stream.t)} solution rows, "
      f"{'equal to' if same else 'DIFFERENT FROM'} the batch run's")
print("consistency (mean NIS per degree of freedom):",
      {k: round(v["nis_per_dof"], 2) for k, v in result.consistency.items()})
print("health:", result.health(imu, gnss) or "no warning")

# %% 6. Evaluate against the truth
# errors_against moves the solution to the reference's point and time and returns
# east/north/up [m], velocity [m/s] and attitude [rad] errors (ENU, as the solution);
# rmse sums them up (attitude in degrees).
rms = fednav.rmse(fednav.errors_against(fwd, truth))
rms_smoothed = fednav.rmse(fednav.errors_against(res.smoothed, truth))
for key in ("east_m", "north_m", "up_m", "yaw_deg"):
    print(f"RMSE {key:8s} forward {rms[key]:.3f}  smoothed {rms_smoothed[key]:.3f}")

# %% 7. Plot
for f in (fednav.plot_errors(res, truth, out / "errors.png"),
          fednav.plot_track(res, gnss, truth, out / "track.png")):
    print("  wrote", f)
