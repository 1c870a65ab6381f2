"""The optional error states (``filter.states``) on simulated car drives that have what
they model, beside the 18-state filter (by hand, not in CI).

    python benchmarks/error_states.py [--seeds 5]

Two kinds of drive (``fednav.sim.drives.car_drive``: ~100 s, two 90 deg turns, a stop;
ADIS16488-class IMU, 5 Hz GNSS at a roof antenna):

* **scale factors** — the IMU's gyro and accelerometer scale factors drawn per run
  (1-sigma 5000 and 3000 ppm), 4 deg hills; the 18-state filter against
  ``[gyro_scale, accel_scale]`` told those sigmas.  Also: the estimates against the drawn
  values (|error| / sigma).
* **correlated GNSS** — fixes whose error is a 60 s Gauss–Markov wander (0.8/0.8/1.5 m)
  beside 0.1/0.1/0.2 m white noise, the file's sigma the whole error's; white noise of
  that sigma against ``[gnss_markov]`` told the wander's figures.

* **drifting velocity sensor** — ``examples/car-drive.yaml``'s first 223 s with a
  velocity sensor whose error is a 30 s Gauss–Markov drift (0.1/0.1/0.05 m/s beside
  0.03 m/s white), GNSS withheld over 100-160 s; white noise against
  ``[velocity_markov]`` with the figures ``fednav simulate`` writes (seeds 1..3 at most).

Prints per kind the forward and smoothed RMSE (mean over the seeds) and the GNSS NIS/dof
of the position and velocity rows; for the velocity sensor, per seed, its rows' NIS/dof
and the horizontal RMS error through the outage.
"""

from __future__ import annotations

import argparse

import numpy as np

from fednav.navigator.system import load_system
from fednav.process import process
from fednav.process.run import errors_against, rmse
from fednav.sim.drives import ADIS16488, car_drive

KEYS = ("east_m", "north_m", "up_m", "ve_mps", "vn_mps", "vu_mps", "pitch_deg", "roll_deg",
        "yaw_deg")


def with_states(system, states, imu=None):
    d = system.model_dump()
    d["filter"]["states"] = states
    d["imu"].update(imu or {})
    d["sensors"] = {"gnss": system.sensors.gnss.model_dump(exclude_none=True)}
    return load_system(d)


def run(drive, system):
    inn = []
    res = process(drive.imu, {"gnss": drive.gnss}, system, smooth=True, innovations=inn)
    r2 = np.array([i.r**2 / np.diag(i.S) for i in inn if i.local == "gnss"]).mean(axis=0)
    return (rmse(errors_against(res.forward, drive.reference)),
            rmse(errors_against(res.smoothed, drive.reference)), r2, res.optional_states)


def table(title, rows):
    print(f"\n{title}")
    print(f"{'':34s}" + "".join(f"{k:>10s}" for k in KEYS))
    for name, vals in rows:
        print(f"{name:34s}" + "".join(f"{np.mean([v[k] for v in vals]):10.3f}" for k in KEYS))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    a = ap.parse_args(argv)
    seeds = range(1, a.seeds + 1)
    sf = {**ADIS16488, "gyro_scale_ppm": 5000.0, "accel_scale_ppm": 3000.0}
    out = {k: ([], [], [], []) for k in ("18", "sf")}
    ratio = []
    for s in seeds:
        d = car_drive(heading_deg=40.0 + 67.0 * s, seed=s, imu=sf, static_s=5.0, hill_deg=4.0)
        for key, states in (("18", []), ("sf", ["gyro_scale", "accel_scale"])):
            f, sm, r2, opt = run(d, with_states(d.system, states))
            for lst, v in zip(out[key], (f, sm, r2, opt), strict=True):
                lst.append(v)
            if opt:
                for name, truth in (("gyro_scale", d.imu_state.gyro_scale),
                                    ("accel_scale", d.imu_state.accel_scale)):
                    ratio.append(np.abs(opt[name]["estimate"] - truth) / opt[name]["sigma"])
    table(f"scale factors drawn (5000 / 3000 ppm 1-sigma), {len(seeds)} drives: forward",
          [("18 states", out["18"][0]), ("+ gyro_scale, accel_scale", out["sf"][0])])
    table("  smoothed", [("18 states", out["18"][1]),
                         ("+ gyro_scale, accel_scale", out["sf"][1])])
    for key in ("18", "sf"):
        print(f"  GNSS NIS/dof per row ({key}):", np.round(np.mean(out[key][2], axis=0), 2))
    r = np.array(ratio)
    print(f"  scale-factor estimates: |error|/sigma max {r.max():.2f}, "
          f"{100 * np.mean(r <= 3.0):.0f} % of axes within 3 sigma")

    gm = {"lever_m": (0.3, -1.0, 1.2), "sigma_pos_enu_m": (0.1, 0.1, 0.2),
          "markov_sigma_enu_m": (0.8, 0.8, 1.5), "markov_tau_s": 60.0}
    out = {k: ([], [], []) for k in ("18", "gm")}
    for s in seeds:
        d = car_drive(heading_deg=200.0 + 67.0 * s, seed=10 + s, imu=ADIS16488,
                      static_s=5.0, gnss=gm)
        for key, states in (("18", []), ("gm", ["gnss_markov"])):
            f, sm, r2, _ = run(d, with_states(d.system, states))
            for lst, v in zip(out[key], (f, sm, r2), strict=True):
                lst.append(v)
    table(f"GNSS errors correlated (60 s Gauss-Markov), {len(seeds)} drives: forward",
          [("white noise of the whole sigma", out["18"][0]),
           ("+ gnss_markov", out["gm"][0])])
    table("  smoothed", [("white noise of the whole sigma", out["18"][1]),
                         ("+ gnss_markov", out["gm"][1])])
    for key in ("18", "gm"):
        print(f"  GNSS NIS/dof per row ({key}):", np.round(np.mean(out[key][2], axis=0), 2))
    drifting_velocity(min(a.seeds, 3))


def drifting_velocity(n_seeds):
    import tempfile
    from pathlib import Path

    from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv, read_velocity_csv
    from fednav.process.tuning import withheld
    from fednav.sim.dataset import (
        VelocitySimConfig,
        load_dataset_config,
        simulate_dataset,
        write_csv_dataset,
    )

    cfg = load_dataset_config(Path(__file__).parents[1] / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={"segments": cfg.segments[:13], "velocity": VelocitySimConfig(
        sigma_mps=(0.03, 0.03, 0.03), markov_sigma_mps=(0.1, 0.1, 0.05), markov_tau_s=30.0)})
    print("\ndrifting velocity sensor, GNSS withheld 100-160 s: velocity NIS/dof per row; "
          "horizontal RMS in the outage, forward / smoothed [m]")
    for seed in range(1, n_seeds + 1):
        d = Path(tempfile.mkdtemp())
        write_csv_dataset(simulate_dataset(cfg.model_copy(update={"seed": seed})), d)
        system = load_system(d / "process.yaml")
        gc = system.sensors.gnss
        gnss = withheld(read_gnss_csv(d / "gnss.csv", gc.sigma_pos_enu_m, gc.sigma_vel_mps,
                                      gc.lever_m), [(100.0, 160.0)])
        imu, vel = read_imu_csv(d / "imu.csv"), read_velocity_csv(d / "velocity.csv")
        ref = read_reference_csv(d / "reference.csv")
        for states in ([], ["velocity_markov"]):
            dump = system.model_dump(exclude_none=True)
            dump["filter"]["states"] = states
            inn = []
            res = process(imu, {"gnss": gnss, "velocity": vel}, load_system(dump), smooth=True,
                          innovations=inn)
            nis = np.array([i.r**2 / np.diag(i.S) for i in inn if i.local == "velocity"])
            drift = []
            for sol in (res.forward, res.smoothed):
                e = errors_against(sol, ref)
                m = (e["t"] > 100.0) & (e["t"] < 160.0)
                drift.append(np.sqrt(np.mean(e["east_m"][m] ** 2 + e["north_m"][m] ** 2)))
            print(f"  seed {seed} {states or 'white noise'}: NIS/dof "
                  f"{np.round(nis.mean(axis=0), 2)}, outage {drift[0]:.2f} / {drift[1]:.2f}")


if __name__ == "__main__":
    main()
