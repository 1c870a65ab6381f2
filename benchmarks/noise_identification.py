"""``fednav process``'s noise identification, before -> after, on every dataset at hand
(docs/real-data.md, "Noise identified from the recording").

    python benchmarks/noise_identification.py [--only drive,gis,rover,car,px4]
                                              [--work DIR] [--noise identify-all]

Each dataset is processed twice with the same system description, ``noise: as-given``
(the figures as given: fednav before identification) and ``noise: identify`` (or the
value of ``--noise``: ``identify-all`` identifies the sensors' sigmas too), and scored
against its reference: RMSE per column (north/east/down or up [m], velocity [m/s]),
forward and, where the dataset has it, smoothed; mean NIS/dof of every local filter; the
identified figures (ratio to the given); the identification's cost against one forward +
smoothed pass (the pass of the as-given run, timed in the same process).

* ``drive`` — the real car drive (``../shared/data/rtklibexplorer-drive``), as
  ``benchmarks/kfgins_peer.py`` builds its KF-GINS folder: the author's IMU figures, GNSS
  withheld in eleven 15 s windows; errors inside the windows ("windows") and outside
  ("aided") against the RTK-fixed epochs.
* ``gis`` — a 10-minute drive simulated by **gnss-ins-sim** (Aceinna's generator, not
  fednav's), its KF-GINS folder as ``kfgins_peer.py`` builds it (30 s withheld of every
  90 s); errors against the generator's truth.
* ``rover`` — the real planetary rover (``../shared/data/canada-planetary``): the file's
  figures (``System()``) and ``examples/canada-planetary.yaml``, GNSS alone and GNSS +
  visual velocity, forward and smoothed, against the dataset's reference.
* ``car`` — fednav's simulated ``examples/car-drive.yaml`` with its true figures, GNSS +
  velocity sensor (what the process golden flies).
* ``px4`` — the PX4 flight of ``benchmarks/px4_flight.py`` (closed-form motion, no fednav
  code; GNSS withheld 120-160 s), ``fednav process ulog`` with the flight's IMU figures.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fednav.process.identify import label as figure_label  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data"
MODES = ("as-given", "identify")
#: what the "identify" rows fly (``--noise``)
IDENTIFY = {"identify": "identify"}


def _noise(mode: str) -> str:
    return IDENTIFY.get(mode, mode)


def _with(cfg, mode):
    return cfg.model_copy(update={"noise": _noise(mode)})


def _timed_process(imu, sensors, cfg, smooth=True):
    """``process`` (forward + smoothed) and its time [s]: an as-given run is timed on its
    second call (the first may compile the kernels)."""
    from fednav.process.run import process

    for _ in range(2 if cfg.noise == "as-given" else 1):
        t0 = time.perf_counter()
        res = process(imu, sensors, cfg, smooth=smooth, force=True)
    return res, time.perf_counter() - t0


def _nis(res) -> str:
    return ", ".join(f"{k} {v['nis_per_dof']:.2f}" for k, v in res.consistency.items())


def _figures(res, base_s: float) -> str:
    """The identified figures (ratio to the given), the passes and the cost, also as a
    ratio to ``base_s``, the as-given run's forward + smoothed process [s]."""
    n = res.noise
    if n is None:
        return ""
    taken = "" if n.accepted else f" NOT TAKEN ({n.why})"
    return (", ".join(f"{figure_label(k)} x{n.identified[k] / n.prior[k]:.3g}"
                      for k in n.identified)
            + f"; {n.passes} passes, {n.cost_s:.1f} s = {n.cost_s / base_s:.2f} x the as-given "
              f"forward + smoothed process" + taken)


def _summary_figures(n) -> str:
    if not n:
        return ""
    return "; " + ", ".join(f"{figure_label(k)} x{v / n['prior'][k]:.3g}"
                            for k, v in n["identified"].items()) + (
        "" if n["accepted"] else f" NOT TAKEN ({n['why_not']})")


#: blocks [s] of the paired comparison (module docstring)
BLOCK_S = 30.0


def significance(t, e_before, e_after) -> np.ndarray:
    """Per column, the increase of the mean squared error from ``e_before`` to
    ``e_after`` (N, k; the same epochs ``t`` [s]) over its standard error from
    :data:`BLOCK_S` blocks (the errors of neighbouring epochs are not independent; the
    blocks nearly are): above 2, the column is worse beyond what another stretch of
    the same data would have given."""
    b = np.floor((np.asarray(t) - t[0]) / BLOCK_S).astype(int)
    d = np.asarray(e_after) ** 2 - np.asarray(e_before) ** 2
    ids = np.unique(b)
    m = np.array([np.nanmean(d[b == i], axis=0) for i in ids])
    if len(ids) < 2:
        return np.full(d.shape[1], np.nan)
    se = np.nanstd(m, axis=0, ddof=1) / np.sqrt(len(ids))
    mean = np.nanmean(m, axis=0)
    return np.divide(mean, se, out=np.zeros_like(mean), where=se > 0)


def _print(name: str, cols, rows: dict, notes: list[str], errs: dict | None = None) -> None:
    print(f"== {name}")
    print(f"{'':28s}" + "".join(f"{c:>9s}" for c in cols))
    for label, v in rows.items():
        print(f"{label:28s}" + "".join(f"{x:9.4g}" for x in v))
    pairs = [k for k in rows if k.startswith("identify")]
    for k in pairs:
        base = rows[k.replace("identify", "as-given")]
        print(f"{k.replace('identify', 'after/before'):28s}"
              + "".join(f"{a / b:9.2f}" for a, b in zip(rows[k], base, strict=True)))
        part = k.removeprefix("identify ")
        if errs and part in errs:
            z = significance(*errs[part])
            print(f"{'  increase / its SE':28s}" + "".join(f"{x:9.1f}" for x in z)
                  + ("   WORSE (> 2 SE): " + ", ".join(c for c, x in zip(cols, z,
                                                                           strict=True)
                                                       if x > 2) if np.any(z > 2) else ""))
    for n in notes:
        print("   " + n)
    print(flush=True)


def _kfgins_case(case) -> tuple[dict, list[str]]:
    """A kfgins_peer case through fednav's Python API, both modes."""
    import kfgins_peer as kp

    from fednav.process.kfgins import read_kfgins

    d = read_kfgins(case.folder)
    rows, notes, raw, walls = {}, [], {}, {}
    for mode in MODES:
        res, wall = _timed_process(d["imu"], d["sensors"], _with(d["system"], mode))
        for part, (t, e) in kp.fednav_parts(res.forward, case).items():
            rows[f"{mode} {part}"] = np.sqrt(np.nanmean(e ** 2, axis=0))
            raw.setdefault(part, [t]).append(e)
        walls[mode] = wall
        notes.append(f"{mode}: NIS/dof {_nis(res)}; forward + smoothed {wall:.1f} s" + (
            f"; {_figures(res, walls['as-given'])}" if res.noise else ""))
    return rows, notes, raw


def drive(work: Path) -> None:
    import kfgins_peer as kp

    if not kp.DRIVE.is_dir():
        print(f"no {kp.DRIVE}: the real drive is skipped\n")
        return
    case = kp.drive_case(work, argparse.Namespace(no_lowpass=False))
    rows, notes, raw = _kfgins_case(case)
    _print("real drive (rtklibexplorer drive_0708), forward, GNSS withheld in 11 x 15 s",
           ("N", "E", "D", "vN", "vE", "vD"), rows, notes, raw)


def gis(work: Path) -> None:
    import kfgins_peer as kp

    case = kp.sim_case(work, argparse.Namespace(gis_folder=None, gis_src=None))
    rows, notes, raw = _kfgins_case(case)
    _print(f"{case.name}, forward, GNSS withheld 30 s of every 90 s",
           ("N", "E", "D", "vN", "vE", "vD"), rows, notes, raw)


def _navego_cases(cfgs: dict, sensor_sets: dict, ref, outage=None) -> None:
    from fednav.process.run import errors_against, rmse

    keys = ("north_m", "east_m", "up_m", "vn_mps", "ve_mps", "vu_mps")
    for cname, cfg in cfgs.items():
        for sname, (imu, sensors) in sensor_sets.items():
            rows, notes, raw, walls = {}, [], {}, {}
            for mode in MODES:
                res, wall = _timed_process(imu, sensors, _with(cfg, mode))
                walls[mode] = wall
                for sol in (res.forward, res.smoothed):
                    e = errors_against(sol, ref)
                    r = rmse(e)
                    rows[f"{mode} {sol.label}"] = np.array([r[k] for k in keys])
                    raw.setdefault(sol.label, [e["t"]]).append(
                        np.column_stack([e[k] for k in keys]))
                    if outage is not None and sensors["gnss"].t[-1] - sensors["gnss"].t[0] \
                            > len(sensors["gnss"].t) * 0.06:  # (the sparse file)
                        m = (e["t"] > outage[0]) & (e["t"] < outage[1])
                        notes.append(f"{mode} {sol.label}: largest horizontal error in "
                                     f"{outage[0]:g}-{outage[1]:g} s "
                                     f"{np.hypot(e['north_m'][m], e['east_m'][m]).max():.1f} m")
                notes.append(f"{mode}: NIS/dof {_nis(res)}; forward + smoothed {wall:.1f} s"
                             + (f"; {_figures(res, walls['as-given'])}" if res.noise else ""))
            _print(f"{cname}: {sname}", ("N", "E", "U", "vN", "vE", "vU"), rows, notes, raw)


def rover(work: Path) -> None:
    from fednav import System, load_system
    from fednav.io import (
        read_navego_gnss,
        read_navego_imu,
        read_navego_reference,
        read_navego_visual,
    )

    data = SHARED / "canada-planetary"
    if not data.is_dir():
        print(f"no {data}: the rover is skipped\n")
        return
    imu = read_navego_imu(data / "imu_planetary.mat")
    g = read_navego_gnss(data / "gnss_planetary.mat")
    gs = read_navego_gnss(data / "gnss_sparse_planetary.mat")
    vis = read_navego_visual(data / "visual_planetary.mat")
    ref = read_navego_reference(data / "gnss_planetary_r.mat")
    _navego_cases({"rover, file figures": System(),
                   "rover, examples/canada-planetary.yaml":
                       load_system(ROOT / "examples" / "canada-planetary.yaml")},
                  {"GNSS": (imu, {"gnss": g}), "GNSS + visual": (imu, {"gnss": g,
                                                                      "velocity": vis}),
                   "sparse GNSS (no GNSS 100-200 s)": (imu, {"gnss": gs})},
                  ref, outage=(100.0, 200.0))


def car(work: Path) -> None:
    import yaml

    from fednav import load_system
    from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv, read_velocity_csv
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    folder = work / "car-drive"
    folder.mkdir(parents=True, exist_ok=True)
    write_csv_dataset(simulate_dataset(load_dataset_config(ROOT / "examples"
                                                           / "car-drive.yaml")), folder)
    cfg = load_system(yaml.safe_load((folder / "process.yaml").read_text()))
    gc = cfg.sensors.gnss
    gnss = read_gnss_csv(folder / "gnss.csv", gc.sigma_pos_enu_m, gc.sigma_vel_mps,
                         gc.lever_m)
    imu = read_imu_csv(folder / "imu.csv", cfg.imu.max_bridge_s)
    vel = read_velocity_csv(folder / "velocity.csv")
    _navego_cases({"car-drive (fednav's simulator), true figures": cfg},
                  {"GNSS + velocity": (imu, {"gnss": gnss, "velocity": vel})},
                  read_reference_csv(folder / "reference.csv"))


def px4(work: Path) -> None:
    import px4_flight as flight
    import px4_moving as pm
    import yaml

    log = work / "flight.ulg"
    flight.build(log)
    rows, notes = {}, []
    for mode in MODES:
        cfg = work / f"px4-{mode}.yaml"
        cfg.write_text(yaml.safe_dump({"imu": flight.imu_config(), "noise": _noise(mode)}))
        out = work / f"px4-{mode}"
        pm.run_fednav(log, out, cfg)
        s = pm.score(pm.read_solution(out / "solution.csv"))
        for part in pm.WINDOWS:
            rows[f"{mode} {part}"] = np.r_[s[part]["pos"]["rms"], s[part]["vel"]["rms"]]
        summ = json.loads((out / "summary.json").read_text())
        notes.append(f"{mode}: NIS/dof " + ", ".join(
            f"{k} {v['nis_per_dof']:.2f}" for k, v in summ["consistency"].items())
            + _summary_figures(summ.get("noise")))
    _print("PX4 flight (benchmarks/px4_flight.py), forward, GNSS withheld 120-160 s",
           ("E", "N", "U", "vE", "vN", "vU"), rows, notes)


CASES = {"drive": drive, "gis": gis, "rover": rover, "car": car, "px4": px4}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated: " + ",".join(CASES))
    ap.add_argument("--work", help="working folder (default: a temporary one)")
    ap.add_argument("--noise", default="identify", choices=("identify", "identify-all"),
                    help="what the identified rows fly (default: identify)")
    args = ap.parse_args()
    IDENTIFY["identify"] = args.noise
    work = Path(args.work or tempfile.mkdtemp(prefix="noise-id-"))
    work.mkdir(parents=True, exist_ok=True)
    for name in (args.only.split(",") if args.only else CASES):
        CASES[name](work)


if __name__ == "__main__":
    main()
