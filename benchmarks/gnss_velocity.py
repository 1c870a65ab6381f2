"""Does the GNSS velocity help, and does taking its latency out? Every dataset at hand
(docs/real-data.md, "The GNSS velocity and its latency").

    python benchmarks/gnss_velocity.py [--only drive,rover,car,gis,cost] [--work DIR]

Each dataset is processed with ``fednav process``'s defaults three ways:

* ``position``: the receiver's positions alone (``sensors.gnss.measures: position``);
* ``stamped``: positions and velocities, the velocities at their stamps
  (``velocity_latency_s: 0``, fednav before it took the latency out);
* ``default``: positions and velocities, the latency fednav sees from the positions
  taken out where it is confident (``velocity_latency_s`` left to the data).

and scored against its reference: RMSE per column (north/east/down or up [m], velocity
[m/s]), with each column's increase of the mean squared error over its standard error
from 30 s blocks against ``default`` (above 2: worse beyond what another stretch of the
same data would give).

* ``drive`` — the real car drive (``../shared/data/rtklibexplorer-drive``): the folder
  ``benchmarks/kfgins_peer.py`` builds (the author's IMU figures, GNSS withheld in eleven
  15 s windows), its fixes given their velocities from the RTKLIB solution (u-blox
  Doppler); errors inside the windows and outside against the RTK-fixed epochs, the
  reference velocities (the same receiver's) moved back by the latency its positions
  show (0.127 s: scored at their time of validity).
* ``rover`` — the real planetary rover (``../shared/data/canada-planetary``), its GNSS
  (the reference plus white noise: no receiver latency), with the file's figures and
  ``examples/canada-planetary.yaml``.
* ``car`` — fednav's simulated ``examples/car-drive.yaml`` (true figures), GNSS alone,
  its velocities on time and 0.1 s late (a lag the simulation adds: what the default's
  rule must take out).  Its 1.5 m fixes are too noisy for the positions' differences,
  and its few speed changes too few for the INS (``fednav.process.latency``).
* ``gis`` — gnss-ins-sim (Aceinna's generator, not fednav's) simulating a 10-min
  town drive (:func:`town_motion`) with ``kfgins_peer``'s industrial
  IMU, its receiver at 5 Hz with 1.5/1.5/3 m positions, the velocities on time and
  0.1 s late.
* ``cost`` — ``process``'s run time with and without the check against the INS.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from noise_identification import SHARED, significance  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: the gnss-ins-sim case's position noise, east/north/up [m]: too noisy for the positions'
#: differences to see a latency
GIS_NOISY_M = (1.5, 1.5, 3.0)
#: the three ways (module docstring) and the GNSS section's settings of each
WAYS = {"position": {"measures": "position"},
        "stamped": {"measures": "position_velocity", "velocity_latency_s": 0.0},
        "default": {"measures": "position_velocity"}}


def _way(system, way: str):
    from fednav import load_system

    d = system.model_dump(exclude_unset=True)
    g = {**d.get("sensors", {}).get("gnss", {}), **WAYS[way]}
    if way == "default":
        g.pop("velocity_latency_s", None)
    return load_system({**d, "sensors": {**d.get("sensors", {}), "gnss": g}})


def _print(name: str, cols, rows: dict, errs: dict, notes: list[str]) -> None:
    print(f"== {name}")
    print(f"{'':24s}" + "".join(f"{c:>9s}" for c in cols))
    for label, v in rows.items():
        print(f"{label:24s}" + "".join(f"{x:9.4g}" for x in v))
    for part, (t, by_way) in errs.items():
        for way in ("position", "stamped"):
            if way not in by_way:
                continue
            ratio = rows[f"{way} {part}"] / rows[f"default {part}"]
            z = significance(t, by_way["default"], by_way[way])
            print(f"{way + '/default ' + part:24s}" + "".join(f"{x:9.2f}" for x in ratio))
            print(f"{'  increase / its SE':24s}" + "".join(f"{x:9.1f}" for x in z))
    for n in notes:
        print("   " + n)
    print(flush=True)


def _note(way: str, res) -> str:
    q = res.data_quality
    seen = q.get("gnss_velocity_latency_seen_s")
    by = q.get("gnss_velocity_latency_seen_by")
    lat = ("" if seen is None or by is None else
           f"; latency seen {seen:+.3f} s (+-{q['gnss_velocity_latency_sigma_s']:.3f} by "
           f"the {by}), taken out {q['gnss_velocity_latency_applied_s']:.3f} s")
    nis = ", ".join(f"{k} {v['nis_per_dof']:.2f}" for k, v in res.consistency.items())
    return f"{way}: NIS/dof {nis}{lat}"


def drive(work: Path) -> None:
    import kfgins_peer as kp

    from fednav.io import read_rtklib_pos
    from fednav.process.kfgins import read_kfgins
    from fednav.process.run import ins_velocity_latency, process, velocity_latency

    if not kp.DRIVE.is_dir():
        print(f"no {kp.DRIVE}: the real drive is skipped\n")
        return
    case = kp.drive_case(work, argparse.Namespace(no_lowpass=False))
    d = read_kfgins(case.folder)
    folder_fixes = d["sensors"]["gnss"]
    pos = read_rtklib_pos(kp.DRIVE / "gnss_1934_sf.pos", time="week")
    keep = np.isin(np.round(pos.t, 3), np.round(folder_fixes.t, 3))
    assert keep.sum() == len(folder_fixes.t), "the folder's fixes are the solution's epochs"
    fixes = replace(pos, t=pos.t[keep], lla=pos.lla[keep], vel=pos.vel[keep],
                    sigma_rows=pos.sigma_rows[keep], lever=folder_fixes.lever, quality={})
    # the reference velocities are the receiver's, late by the latency its positions
    # show: scored at their time of validity (the velocity of t is the one stamped t + L)
    lag, sigma = velocity_latency(pos)
    ins = ins_velocity_latency(d["imu"], {**d["sensors"], "gnss": fixes},
                               _way(d["system"], "default"))
    tr = case.ref["t"]
    case.ref.update({k: np.interp(tr + lag, tr, case.ref[k]) for k in ("vn", "ve", "vd")})
    rows, errs, notes = {}, {}, []
    for way in WAYS:
        res = process(d["imu"], {**d["sensors"], "gnss": fixes}, _way(d["system"], way))
        for part, (t, e) in kp.fednav_parts(res.forward, case).items():
            rows[f"{way} {part}"] = np.sqrt(np.nanmean(e ** 2, axis=0))
            errs.setdefault(part, (t, {}))[1][way] = e
        notes.append(_note(way, res))
    notes.append(f"the latency against the INS (a pass on the positions alone): "
                 f"{ins[0]:+.3f} s (+-{ins[1]:.3f}); from the positions' differences "
                 f"{lag:+.3f} s (+-{sigma:.3f})")
    _print("real drive (rtklibexplorer drive_0708), forward, GNSS withheld in 11 x 15 s",
           ("N", "E", "D", "vN", "vE", "vD"), rows, errs, notes)


def _navego_like(name: str, imu, sensors: dict, system, ref) -> None:
    from fednav.process.run import errors_against, process, rmse

    keys = ("north_m", "east_m", "up_m", "vn_mps", "ve_mps", "vu_mps")
    rows, errs, notes = {}, {}, []
    for way in WAYS:
        res = process(imu, sensors, _way(system, way), smooth=True, force=True)
        for sol in (res.forward, res.smoothed):
            e = errors_against(sol, ref)
            r = rmse(e)
            rows[f"{way} {sol.label}"] = np.array([r[k] for k in keys])
            errs.setdefault(sol.label, (e["t"], {}))[1][way] = np.column_stack(
                [e[k] for k in keys])
        notes.append(_note(way, res))
    _print(name, ("N", "E", "U", "vN", "vE", "vU"), rows, errs, notes)


def rover(work: Path) -> None:
    from fednav import System, load_system
    from fednav.io import read_navego_gnss, read_navego_imu, read_navego_reference

    data = SHARED / "canada-planetary"
    if not data.is_dir():
        print(f"no {data}: the rover is skipped\n")
        return
    imu = read_navego_imu(data / "imu_planetary.mat")
    g = read_navego_gnss(data / "gnss_planetary.mat")
    ref = read_navego_reference(data / "gnss_planetary_r.mat")
    for cname, cfg in {"rover, file figures": System(),
                       "rover, examples/canada-planetary.yaml":
                           load_system(ROOT / "examples" / "canada-planetary.yaml")}.items():
        _navego_like(f"{cname}: GNSS", imu, {"gnss": g}, cfg, ref)


def car(work: Path) -> None:
    import yaml

    from fednav import load_system
    from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    folder = work / "car-drive"
    folder.mkdir(parents=True, exist_ok=True)
    write_csv_dataset(simulate_dataset(load_dataset_config(ROOT / "examples"
                                                           / "car-drive.yaml")), folder)
    raw = yaml.safe_load((folder / "process.yaml").read_text())
    raw["aiding"] = ["gnss"]
    cfg = load_system(raw)
    gc = cfg.sensors.gnss
    gnss = read_gnss_csv(folder / "gnss.csv", gc.sigma_pos_enu_m, gc.sigma_vel_mps,
                         gc.lever_m)
    imu = read_imu_csv(folder / "imu.csv", cfg.imu.max_bridge_s)
    ref = read_reference_csv(folder / "reference.csv")
    for label, g in (("on time", gnss), ("0.1 s late", _late(gnss, 0.1))):
        _navego_like(f"car-drive (fednav's simulator), GNSS velocities {label}", imu,
                     {"gnss": g}, cfg, ref)


def _late(fixes, lag: float):
    """``fixes`` with its velocities ``lag`` seconds old (interpolated between fixes)."""
    return replace(fixes, vel=np.column_stack([np.interp(fixes.t - lag, fixes.t,
                                                         fixes.vel[:, j])
                                               for j in range(3)]), quality={})


def town_motion(seconds: float = 600.0, seed: int = 11) -> str:
    """gnss-ins-sim's motion commands (type 1: rates and body accelerations held for a
    duration) for a town drive from 8 m/s: the speed changing every 1-4 s (up to
    1.5 m/s^2, between 3 and 15 m/s) with turns between (6-12 s at up to 9 deg/s), the
    speed changes a receiver's latency shows in (``fednav.process.latency``): the
    segments of :func:`fednav.sim.drives.town_segments`."""
    from fednav.sim.drives import town_segments

    lines = [f"1,0,0,0,{s['accel_mps2']:.4f},0,0,{s['duration_s']},1" if s["name"] == "speed"
             else f"1,{s['heading_rate_deg_s']:.4f},0,0,0,0,0,{s['duration_s']},1"
             for s in town_segments(np.random.default_rng(seed), seconds)]
    return "\n".join(lines) + "\n"


def gis(work: Path) -> None:
    import kfgins_peer as kp
    from moving_start import imu_figures

    from fednav import load_system
    from fednav.io import read_gnss_ins_sim
    from fednav.process.gnss_ins_sim import gnss_ins_sim_system

    src = kp.gis_source(None)
    if src is None:
        print("no gnss-ins-sim source tree ($GNSS_INS_SIM): its drive is skipped\n")
        return
    folder = work / "gis-noisy"
    if not (folder / "time.csv").is_file():
        saved = kp.GIS_GPS, kp.MOTION_INIT, kp.MOTION
        kp.GIS_GPS = {**kp.GIS_GPS, "stdp": list(GIS_NOISY_M), "rate_hz": 50.0}
        kp.MOTION_INIT, kp.MOTION = "32.0,120.0,100.0,8,0,0,30,0,0", town_motion()
        try:
            kp.simulate_gis(src, folder)
        finally:
            kp.GIS_GPS, kp.MOTION_INIT, kp.MOTION = saved
    rec = read_gnss_ins_sim(folder)
    system, series, _ = gnss_ins_sim_system(rec, load_system({"imu": imu_figures(
        kp.GIS_IMU)}))
    g = series["gnss"]  # (50 Hz: each 5 Hz fix takes the velocity simulated lag earlier,
    for lag in (0.0, 0.1):  # its own noise kept, where interpolating would average it)
        k = int(round(lag * 50.0))
        i = np.arange(max(k, 9), len(g.t), 10)
        fixes = replace(g, t=g.t[i], lla=g.lla[i], vel=g.vel[i - k], quality={},
                        sigma_rows=None if g.sigma_rows is None else g.sigma_rows[i])
        _navego_like(f"gnss-ins-sim 10-min town drive, {GIS_NOISY_M[0]} m positions at "
                     f"5 Hz, velocities {lag} s late", rec.imu, {**series, "gnss": fixes},
                     system, rec.ref)


def cost(work: Path) -> None:
    """``process``'s run time with and without the check against the INS (best of 3,
    alternated in one process) on the rover (file's figures) and a 152 s simulated car
    drive (1.5 m fixes): what the pass on the positions alone costs."""
    import time

    import fednav.process.run as pr
    from fednav import System
    from fednav.io import read_navego_gnss, read_navego_imu
    from fednav.sim.drives import car_drive

    cases = {}
    data = SHARED / "canada-planetary"
    if data.is_dir():
        cases["rover"] = (read_navego_imu(data / "imu_planetary.mat"),
                          {"gnss": read_navego_gnss(data / "gnss_planetary.mat")}, System())
    d = car_drive(30.0, 10.0, seed=5, static_s=60.0)
    cases["car, 152 s"] = (d.imu, {"gnss": d.gnss}, d.system)
    checked = pr.with_ins_latency
    for name, (imu, sensors, system) in cases.items():
        best = {}
        for way in ("without", "with") * 3:
            pr.with_ins_latency = checked if way == "with" else (lambda i, s, c, p: p)
            t0 = time.perf_counter()
            pr.process(imu, sensors, system, force=True)
            best[way] = min(best.get(way, np.inf), time.perf_counter() - t0)
        pr.with_ins_latency = checked
        print(f"{name}: process {best['without']:.3f} s without the check against the "
              f"INS, {best['with']:.3f} s with it ({best['with'] / best['without']:.2f}x)")


CASES = {"drive": drive, "rover": rover, "car": car, "gis": gis, "cost": cost}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated: " + ",".join(CASES))
    ap.add_argument("--work", help="working folder (default: a temporary one)")
    args = ap.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="gnss-velocity-"))
    work.mkdir(parents=True, exist_ok=True)
    for name in (args.only.split(",") if args.only else CASES):
        CASES[name](work)


if __name__ == "__main__":
    main()
