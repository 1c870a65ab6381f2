"""A start with no still period: the vehicle already rolling at the first sample
(docs/real-data.md, "A moving start").

    python benchmarks/moving_start.py [--gis-src DIR] [--work DIR]

gnss-ins-sim (Aceinna's generator, not fednav's: ``benchmarks/kfgins_peer.py`` runs its
own code in a child process) simulates a 5-minute car drive that starts at 10 m/s on a
heading of 30 deg, with a MEMS IMU of two grades (the ``kfgins_peer`` industrial one and
a consumer one: 1 deg/sqrt(h), 20 deg/h bias instability, 200 deg/h turn-on bias) and
5 Hz GNSS (0.5/0.5/1.0 m, 0.05 m/s).  GNSS is withheld 60-90 s after the start: the
first outage after the alignment.  ``fednav process gnss-ins-sim`` flies it:

* ``default``: what a user gets (no initial state: levelled in motion from the GNSS
  acceleration, heading from the GNSS course);
* ``truth``: started from the true attitude, position and velocity (what is left is the
  filter's convergence, not the alignment);
* ``default + nhc``: the default with the non-holonomic constraint (``sensors.nhc``; a
  wheeled vehicle's lateral and vertical velocity at its contact are zero).

Printed per grade and start: roll/pitch/yaw RMSE [deg] over the first 60 s and after the
outage (90 s on), and the largest horizontal and vertical error inside the outage [m].
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import kfgins_peer as kp  # noqa: E402

#: the two IMU grades (gnss-ins-sim's custom model, as kfgins_peer.GIS_IMU)
GRADES = {
    "industrial": dict(kp.GIS_IMU),
    "consumer": {"gyro_b": [200.0, -150.0, 100.0], "gyro_arw": 1.0,
                 "gyro_b_stability": 20.0, "accel_b": [2.0e-2, -1.5e-2, 1.0e-2],
                 "accel_vrw": 0.2, "accel_b_stability": 2.0e-3, "corr_s": 300.0}}
#: rolling at 10 m/s forward on a heading of 30 deg at the first sample
MOTION_INIT = "32.0,120.0,100.0,10,0,0,30,0,0"
MOTION = """\
1,0,0,0,0,0,0,20,1
3,90,0,0,0,0,0,12,1
1,0,0,0,0.5,0,0,10,1
1,0,0,0,0,0,0,30,1
3,-60,0,0,0,0,0,10,1
1,0,0,0,0,0,0,30,1
1,3,0,0,0,0,0,10,1
1,-3,0,0,0,0,0,10,1
1,0,0,0,-0.5,0,0,10,1
1,0,0,0,0,0,0,60,1
3,120,0,0,0,0,0,15,1
1,0,0,0,0,0,0,60,1
"""
GPS = {"stdp": [0.5, 0.5, 1.0], "stdv": [0.05, 0.05, 0.05], "rate_hz": 5.0}
#: GNSS withheld [s after the start]
OUTAGE = (60.0, 90.0)
STARTS = ("default", "truth", "default + nhc")


def simulate(src: Path, grade: str, work: Path) -> Path:
    """gnss-ins-sim's results folder for ``grade`` (kfgins_peer.simulate_gis with this
    motion, IMU and GNSS)."""
    out = work / f"gis-{grade}"
    if (out / "time.csv").is_file():
        return out
    saved = (kp.MOTION_INIT, kp.MOTION, kp.GIS_IMU, kp.GIS_GPS)
    kp.MOTION_INIT, kp.MOTION, kp.GIS_IMU, kp.GIS_GPS = MOTION_INIT, MOTION, GRADES[grade], GPS
    try:
        kp.simulate_gis(src, out)
    finally:
        kp.MOTION_INIT, kp.MOTION, kp.GIS_IMU, kp.GIS_GPS = saved
    return out


def imu_figures(f: dict) -> dict:
    """The simulated IMU's figures in fednav's ``imu:`` keys."""
    return {"gyro_arw_deg_sqrt_h": f["gyro_arw"], "accel_vrw_mps_sqrt_s": f["accel_vrw"] / 60,
            "gyro_markov_deg_h": f["gyro_b_stability"], "gyro_markov_tau_s": f["corr_s"],
            "accel_markov_mps2": f["accel_b_stability"], "accel_markov_tau_s": f["corr_s"],
            "gyro_bias_deg_h": float(np.max(np.abs(f["gyro_b"]))),
            "accel_bias_mps2": float(np.max(np.abs(f["accel_b"])))}


def run(folder: Path, grade: str, start: str) -> dict:
    from fednav import load_system
    from fednav.io import read_gnss_ins_sim
    from fednav.process.gnss_ins_sim import gnss_ins_sim_system
    from fednav.process.run import errors_against, process

    rec = read_gnss_ins_sim(folder)
    ref = rec.ref
    t0 = float(ref.t[0])
    desc = {"imu": imu_figures(GRADES[grade]),
            "sensors": {"gnss": {"outages_s": [[t0 + OUTAGE[0], t0 + OUTAGE[1]]]}}}
    if start == "truth":
        desc["initial"] = {
            "t_s": t0, "lat_deg": float(np.degrees(ref.lla[0, 0])),
            "lon_deg": float(np.degrees(ref.lla[0, 1])), "h_m": float(ref.lla[0, 2]),
            "vel_mps": [float(v) for v in ref.vel[0]],
            "euler_deg": [float(v) for v in np.degrees(ref.euler[0])],
            "sigma": {"attitude_arcsec": [36.0] * 3, "velocity_mps": [0.05] * 3,
                      "position_m": [0.5] * 3}}
    if start.endswith("nhc"):
        desc["sensors"]["nhc"] = {"sigma_mps": [0.1, 0.1]}
    system, series, _ = gnss_ins_sim_system(rec, load_system(desc))
    res = process(rec.imu, series, system)
    e = errors_against(res.forward, ref)
    t = e["t"] - t0
    att = np.degrees(np.column_stack([e["roll_rad"], e["pitch_rad"], e["yaw_rad"]]))
    first, after = t < 60.0, t >= OUTAGE[1]
    out = (t >= OUTAGE[0]) & (t < OUTAGE[1])
    return {"att60": np.sqrt(np.mean(att[first] ** 2, axis=0)),
            "att90": np.sqrt(np.mean(att[after] ** 2, axis=0)),
            "hor": float(np.max(np.hypot(e["north_m"][out], e["east_m"][out]))),
            "ver": float(np.max(np.abs(e["up_m"][out]))),
            "align": res.alignment.get("heading", "")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gis-src", help="a gnss-ins-sim source tree (default $GNSS_INS_SIM, "
                                      "else /tmp/gnss-ins-sim)")
    ap.add_argument("--work", help="working folder (default: a temporary one)")
    args = ap.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="moving-start-"))
    work.mkdir(parents=True, exist_ok=True)
    src = kp.gis_source(args.gis_src)
    if src is None:
        raise SystemExit("no gnss-ins-sim source tree (--gis-src)")
    print(f"{'':28s}{'roll/pitch/yaw 0-60 s [deg]':>30s}{'after 90 s [deg]':>24s}"
          f"{'outage max hor/ver [m]':>24s}")
    for grade in GRADES:
        folder = simulate(src, grade, work)
        for start in STARTS:
            r = run(folder, grade, start)
            print(f"{grade + ', ' + start:28s}"
                  f"{'/'.join(f'{x:.3f}' for x in r['att60']):>30s}"
                  f"{'/'.join(f'{x:.3f}' for x in r['att90']):>24s}"
                  f"{r['hor']:>15.2f}/{r['ver']:.2f}", flush=True)


if __name__ == "__main__":
    main()
