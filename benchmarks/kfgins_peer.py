"""A KF-GINS user's folder through fednav with no edit, against KF-GINS itself.

    python benchmarks/kfgins_peer.py [--kfgins BIN] [--work DIR] [--repeat 3]
                                     [--only sim|drive] [--gis-folder DIR]
                                     [--gis-src DIR] [--no-lowpass]

The question: a KF-GINS user's folder (IMU text, GNSS text, ``kf-gins.yaml``) run by
``fednav process kfgins FOLDER --out DIR`` as it is — is the result at least as accurate
as KF-GINS's own (``KF-GINS kf-gins.yaml``) on the same folder?  Both programs get the
SAME folder; each is run whole, as a user runs it (a fresh process each time).

**KF-GINS** (i2Nav-WHU, https://github.com/i2Nav-WHU/KF-GINS), built from its public
source in Release (-O3).  ``--kfgins`` or ``$KFGINS_BIN`` names the binary (default
``/tmp/kfgins-src/bin/KF-GINS``: its CMakeLists puts the binary in ``<source>/bin``).
When it is missing it is built (:func:`build_kfgins`)::

    git --git-dir=/work/.mirror/i2Nav-WHU+KF-GINS/repo archive HEAD -- . \\
        ':(exclude)dataset/Leador-A15.txt' ':(exclude)dataset/truth.nav' \\
        | tar -x -C /tmp/kfgins-src
    cmake -S /tmp/kfgins-src -B /tmp/kfgins-build -DCMAKE_BUILD_TYPE=Release \\
        -DCMAKE_CXX_FLAGS_RELEASE="-O3 -DNDEBUG"
    make -C /tmp/kfgins-build -j2 KF-GINS      # -> /tmp/kfgins-src/bin/KF-GINS

(the mirror lacks the dataset's large IMU file and truth: they are left out, nothing
here needs them; ``$KFGINS_SRC`` names another source tree).

**The folders** (KF-GINS's layout, as ``tests/io/test_kfgins.py`` writes one): IMU text
``t dθx dθy dθz dvx dvy dvz`` (increments over the interval that ends at ``t``, FRD, rad
and m/s, GPS seconds of the week), GNSS text ``t lat lon h σN σE σD`` (deg, m) with the
rows of the withheld windows left out (both filters coast through them), and
``kf-gins.yaml`` (``outputpath`` a folder outside, for KF-GINS).  The reference stays
outside the folder (no ``truth.nav``: fednav would compute errors, KF-GINS would not).

1. ``sim`` — a drive simulated by **gnss-ins-sim** (Aceinna), not by fednav:
   ``--gis-folder`` (a ``Sim.results`` folder), else ``tests/data/gnss-ins-sim`` when it
   spans at least :data:`MIN_SIM_S`, else one simulated here with gnss-ins-sim's own
   code from ``--gis-src``/``$GNSS_INS_SIM`` (default ``/tmp/gnss-ins-sim``, extracted
   from ``/work/.mirror/Aceinna+gnss-ins-sim/repo`` when absent) with :data:`MOTION`
   and :data:`GIS_IMU` (the yaml's IMU figures are these), read back with
   ``fednav.io.read_gnss_ins_sim``; only when gnss-ins-sim cannot be had, fednav's own
   ``examples/car-drive.yaml`` (said in the output).  GNSS withheld 30 s of every 90 s.
   Errors against the generator's truth: north/east/down, vN/vE/vD, roll/pitch/yaw.
2. ``drive`` — the real car drive of ``shared/data/rtklibexplorer-drive`` (its README):
   the MEMS IMU (g, deg/s, millisecond tick) stamped from RTKLIB's ``.tag`` file as the
   author's ``convert_imu_file.py`` does, shifted by the author's −0.125 s, low-pass
   filtered as the author does (``--no-lowpass``: raw), turned into the vehicle's FRD
   body with the author's rotation, as trapezoidal increments; GNSS from the RTKLIB
   ``.pos`` (``read_rtklib_pos(time="week")``, its per-epoch sigmas) less eleven 15 s
   windows (15 s out, 30 s in, from 40 s after the first fix to 30 s before the last:
   fednav's maintainers' protocol, the author's ``start_coast``/``coast_len``);
   ``kf-gins.yaml`` from the author's figures in KF-GINS's units (:func:`drive_yaml`).
   Errors: the solutions at the antenna (lever arm) minus the RTK-fixed epochs (Q=1).

Each table row: RMSE inside the withheld windows ("windows"; "windows 2-": all but the
first, which on the real drive opens 0.25 s after ``starttime``), outside them ("aided":
GNSS on) and over every reference epoch from ``starttime`` on ("all"), for fednav,
KF-GINS and fednav/KF-GINS per column (below 1: fednav better); the number of reference
epochs in brackets; then each window's horizontal RMSE.  Wall time: each whole process,
best of ``--repeat`` runs alternated, fednav's kernels compiled beforehand (its first run,
which compiles them once per installed version, is timed apart: :func:`pin_fednav`), and
beside them the floor of any numba program (:func:`run_floor`: a fresh Python calling
one cached trivial kernel), as a ratio to KF-GINS's whole run.

fednav's solution is read from its ``KF_GINS_Navresult.nav`` when ``--out`` has one,
else from ``solution.csv`` (``docs/conventions.md``).
"""

from __future__ import annotations

import argparse
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
DRIVE = ROOT.parent / "shared" / "data" / "rtklibexplorer-drive"
KFGINS_MIRROR = Path("/work/.mirror/i2Nav-WHU+KF-GINS/repo")
GIS_MIRROR = Path("/work/.mirror/Aceinna+gnss-ins-sim/repo")
D2R = np.pi / 180.0
WEEK_S = 604800.0
GPS_EPOCH_S = 315964800.0  # 1980-01-06 in seconds since 1970 (same clock)
#: the GPS second of the week the simulated drive starts at (a Tuesday)
SIM_WEEK_S = 2 * 86400.0 + 36000.0
#: shortest gnss-ins-sim folder worth the windows (30 s out of every 90 s)
MIN_SIM_S = 300.0

#: gnss-ins-sim motion definition (its CSV layout: command type, yaw, pitch, roll [deg or
#: deg/s], vx, vy, vz [m/s or m/s^2], duration [s], GPS visibility): a 10-minute car drive
#: with a static start, turns both ways, a climb and a descent, stops.
MOTION_INIT = "32.0,120.0,100.0,0,0,0,30,0,0"
MOTION = """\
1,0,0,0,0,0,0,10,1
1,0,0,0,1.5,0,0,8,1
1,0,0,0,0,0,0,30,1
3,90,0,0,0,0,0,12,1
1,0,0,0,0,0,0,35,1
3,0,4,0,0,0,0,4,1
1,0,0,0,0,0,0,25,1
3,0,-4,0,0,0,0,4,1
1,0,0,0,-1.5,0,0,6,1
1,0,0,0,0,0,0,8,1
1,0,0,0,1.0,0,0,10,1
3,-90,0,0,0,0,0,12,1
1,0,0,0,0,0,0,50,1
1,4,0,0,0,0,0,8,1
1,0,0,0,0,0,0,20,1
1,-4,0,0,0,0,0,16,1
1,0,0,0,0,0,0,20,1
1,4,0,0,0,0,0,8,1
1,0,0,0,0.5,0,0,8,1
1,0,0,0,0,0,0,60,1
3,0,-3,0,0,0,0,4,1
1,0,0,0,0,0,0,30,1
3,0,3,0,0,0,0,4,1
3,120,0,0,0,0,0,15,1
1,0,0,0,0,0,0,60,1
1,0,0,0,-1.0,0,0,8,1
3,-60,0,0,0,0,0,12,1
1,0,0,0,0,0,0,50,1
1,0,0,0,1.0,0,0,4,1
1,0,0,0,0,0,0,40,1
1,0,0,0,-1.0,0,0,10,1
1,0,0,0,0,0,0,10,1
"""
#: the simulated IMU (gnss-ins-sim's custom model: constant bias b, first-order
#: Gauss-Markov bias drift with its correlation time, white noise; no scale factor):
#: a MEMS of tactical-to-industrial grade.  The yaml gets exactly these figures.
GIS_IMU = {"gyro_b": [20.0, -15.0, 10.0],        # deg/h (constant)
           "gyro_arw": 0.25,                     # deg/sqrt(h)
           "gyro_b_stability": 5.0,              # deg/h, Gauss-Markov sigma
           "accel_b": [2.0e-3, -1.5e-3, 1.0e-3],  # m/s^2 (constant)
           "accel_vrw": 0.05,                    # m/s/sqrt(h)
           "accel_b_stability": 2.0e-4,          # m/s^2, Gauss-Markov sigma
           "corr_s": 3600.0}                     # both correlation times
GIS_GPS = {"stdp": [0.5, 0.5, 1.0], "stdv": [0.05, 0.05, 0.05], "rate_hz": 1.0}
GIS_IMU_HZ = 100.0
GIS_SEED = 7

#: the author's figures for the real drive (its README and drive_config.py)
DRIVE_FIG = {"gyro_wn_deg_s_rthz": 0.0038, "accel_wn_ug_rthz": 70.0,
             "accel_bias_psd_ug_rthz": 7.0, "gyro_bias_psd_deg_s2_rthz": 3.8e-5,
             "imu_rpy_deg": (180.0, -6.79, 185.35), "imu_t_off_s": -0.125,
             "antlever_frd_m": (0.0, -0.05, 0.0)}


# ----------------------------------------------------------------------------- KF-GINS
def build_kfgins(src: Path, build: Path) -> Path:
    """Extract KF-GINS's source from the mirror (when ``src`` has none) and build it in
    Release (-O3) under ``build``; the binary's path."""
    if not (src / "CMakeLists.txt").is_file():
        src.mkdir(parents=True, exist_ok=True)
        arch = subprocess.run(["git", f"--git-dir={KFGINS_MIRROR}", "archive", "HEAD", "--",
                               ".", ":(exclude)dataset/Leador-A15.txt",
                               ":(exclude)dataset/truth.nav"],
                              check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(src)], input=arch, check=True)
    subprocess.run(["cmake", "-S", str(src), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
                    "-DCMAKE_CXX_FLAGS_RELEASE=-O3 -DNDEBUG"], check=True,
                   stdout=subprocess.DEVNULL)
    subprocess.run(["make", "-C", str(build), "-j2", "KF-GINS"], check=True,
                   stdout=subprocess.DEVNULL)
    for cand in (src / "bin" / "KF-GINS", build / "bin" / "KF-GINS", build / "KF-GINS"):
        if cand.is_file():
            return cand
    raise SystemExit(f"KF-GINS built but its binary is not in {src / 'bin'} nor {build}")


def kfgins_binary(arg: str | None) -> Path:
    p = Path(arg or os.environ.get("KFGINS_BIN", "/tmp/kfgins-src/bin/KF-GINS"))
    if p.is_file():
        return p
    if arg or os.environ.get("KFGINS_BIN"):
        raise SystemExit(f"KF-GINS binary {p} not found")
    print(f"building KF-GINS (no {p}) ...", flush=True)
    return build_kfgins(Path(os.environ.get("KFGINS_SRC", "/tmp/kfgins-src")),
                        Path("/tmp/kfgins-build"))


# ----------------------------------------------------------------------------- folders
@dataclass
class Case:
    """One folder and what it is compared against."""

    name: str
    folder: Path
    yaml: Path
    #: reference epochs: t [s], lat/lon [rad], h, vN/vE/vD, roll/pitch/yaw [deg] (or None)
    ref: dict
    #: the withheld windows [(start, end)] [s]
    windows: list
    start: float
    #: antenna lever arm (FRD, m) the reference's positions are at (0: the IMU's point)
    lever_frd: np.ndarray
    note: str


def write_imu(path: Path, t_end, dth_frd, dv_frd) -> None:
    rows = np.column_stack([t_end, dth_frd, dv_frd])
    np.savetxt(path, rows, fmt="%.6f" + " %.12e" * 6)


def write_gnss(path: Path, t, lat_deg, lon_deg, h, sd_ned) -> None:
    rows = np.column_stack([t, lat_deg, lon_deg, h, sd_ned])
    np.savetxt(path, rows, fmt="%.3f %.10f %.10f %.4f %.4f %.4f %.4f")


def outside(t, windows) -> np.ndarray:
    keep = np.ones(len(t), dtype=bool)
    for a, b in windows:
        keep &= ~((t >= a) & (t < b))
    return keep


def gis_source(arg: str | None) -> Path | None:
    """A gnss-ins-sim source tree (its package importable from it), extracted from the
    mirror when the default place has none; None when there is none to be had."""
    p = Path(arg or os.environ.get("GNSS_INS_SIM", "/tmp/gnss-ins-sim"))
    if (p / "gnss_ins_sim" / "__init__.py").is_file():
        return p
    if arg or not GIS_MIRROR.is_dir():
        return None
    p.mkdir(parents=True, exist_ok=True)
    arch = subprocess.run(["git", f"--git-dir={GIS_MIRROR}", "archive", "HEAD"],
                          capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(p)], input=arch)
    return p if (p / "gnss_ins_sim" / "__init__.py").is_file() else None


def simulate_gis(src: Path, out: Path) -> Path:
    """Run gnss-ins-sim (its own code, in a child process) on :data:`MOTION` with
    :data:`GIS_IMU`; the results folder."""
    out.mkdir(parents=True, exist_ok=True)
    motion = out.parent / "motion_def.csv"
    motion.write_text(
        "ini lat (deg),ini lon (deg),ini alt (m),ini vx_body (m/s),ini vy_body (m/s),"
        "ini vz_body (m/s),ini yaw (deg),ini pitch (deg),ini roll (deg)\n" + MOTION_INIT
        + "\ncommand type,yaw (deg),pitch (deg),roll (deg),vx_body (m/s),vy_body (m/s),"
        "vz_body (m/s),command duration (s),GPS visibility\n" + MOTION)
    f = GIS_IMU
    code = f"""
import sys, numpy as np
sys.path.insert(0, {str(src)!r})
from gnss_ins_sim.sim import imu_model, ins_sim
np.random.seed({GIS_SEED})
acc = {{'gyro_b': np.array({f['gyro_b']}), 'gyro_arw': np.array([{f['gyro_arw']}] * 3),
       'gyro_b_stability': np.array([{f['gyro_b_stability']}] * 3),
       'gyro_b_corr': np.array([{f['corr_s']}] * 3),
       'accel_b': np.array({f['accel_b']}), 'accel_vrw': np.array([{f['accel_vrw']}] * 3),
       'accel_b_stability': np.array([{f['accel_b_stability']}] * 3),
       'accel_b_corr': np.array([{f['corr_s']}] * 3)}}
imu = imu_model.IMU(accuracy=acc, axis=6, gps=True,
                    gps_opt={{'stdp': np.array({GIS_GPS['stdp']}),
                              'stdv': np.array({GIS_GPS['stdv']})}})
sim = ins_sim.Sim([{GIS_IMU_HZ}, {GIS_GPS['rate_hz']}, {GIS_IMU_HZ}], {str(motion)!r},
                  ref_frame=0, imu=imu, mode=None, env=None, algorithm=None)
sim.run(1)
sim.results({str(out)!r})
"""
    subprocess.run([sys.executable, "-c", code], check=True, stdout=subprocess.DEVNULL,
                   cwd=out.parent)
    return out


def folder_span(folder: Path) -> float:
    try:
        t = np.loadtxt(folder / "time.csv", delimiter=",", skiprows=1)
        return float(t[-1] - t[0])
    except (OSError, ValueError, IndexError):
        return 0.0


def sim_case(work: Path, args) -> Case:
    """The simulated folder (module docstring, 1)."""
    from fednav.core import units
    from fednav.io import read_gnss_ins_sim
    from fednav.io.navego import FRD_TO_RFU, fednav_euler_to_navego

    fixture = ROOT / "tests" / "data" / "gnss-ins-sim"
    notes = []
    gis = None
    if args.gis_folder:
        gis = Path(args.gis_folder)
        notes.append(f"gnss-ins-sim folder {gis} (IMU figures: GIS_IMU assumed)")
    elif folder_span(fixture) >= MIN_SIM_S:
        gis = fixture
        notes.append(f"gnss-ins-sim fixture {fixture} (IMU figures: GIS_IMU assumed)")
    else:
        if fixture.is_dir():
            notes.append(f"{fixture.relative_to(ROOT)} spans {folder_span(fixture):.0f} s, "
                         f"too short for 30 s outages every 90 s: a longer drive simulated "
                         f"with gnss-ins-sim's own code")
        src = gis_source(args.gis_src)
        if src is not None:
            gis = simulate_gis(src, work / "gis-out")
            notes.append(f"gnss-ins-sim ({src}) seed {GIS_SEED}, {GIS_IMU_HZ:g} Hz IMU, "
                         f"{GIS_GPS['rate_hz']:g} Hz GNSS sigma {GIS_GPS['stdp']} m")
    folder = work / "sim"
    folder.mkdir(parents=True, exist_ok=True)
    if gis is not None:
        rec = read_gnss_ins_sim(gis)
        imu, gnss, ref = rec.imu, rec.gnss, rec.ref
        lever_rfu = np.zeros(3)
        f = GIS_IMU
        imunoise = {"arw": [f["gyro_arw"]] * 3, "vrw": [f["accel_vrw"]] * 3,
                    "gbstd": [f["gyro_b_stability"]] * 3,
                    "abstd": [f["accel_b_stability"] / 1e-5] * 3,
                    "gsstd": [0.0] * 3, "asstd": [0.0] * 3, "corrtime": f["corr_s"] / 3600}
        init_b = {"initbgstd": [float(np.max(np.abs(f["gyro_b"])))] * 3,
                  "initbastd": [float(np.max(np.abs(f["accel_b"]))) / 1e-5] * 3}
        gsd_ned = np.array(GIS_GPS["stdp"], dtype=float)
        source = "gnss-ins-sim"
    else:  # fednav's own simulated car drive (the fallback: said so)
        from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv

        sim = work / "fednav-sim"
        subprocess.run([str(fednav_exe()), "simulate", str(ROOT / "examples" / "car-drive.yaml"),
                        "--out", str(sim)], check=True, stdout=subprocess.DEVNULL)
        d = yaml.safe_load((ROOT / "examples" / "car-drive.yaml").read_text())
        imu, ref = read_imu_csv(sim / "imu.csv"), read_reference_csv(sim / "reference.csv")
        g = d["gnss"]
        gnss = read_gnss_csv(sim / "gnss.csv", sigma_pos_enu=g["sigma_pos_enu_m"])
        lever_rfu = np.asarray(g["lever_m"], dtype=float)
        i = d["imu"]
        ug = 1e-6 * 9.80665 / 1e-5  # micro-g in mGal
        tau = i["gyro_markov_tau_s"]
        imunoise = {"arw": [i["gyro_arw_deg_sqrt_h"]] * 3,
                    "vrw": [i["accel_vrw_ug_sqrt_hz"] * 1e-6 * 9.80665 * 60] * 3,
                    "gbstd": [i["gyro_markov_deg_h"]] * 3,
                    "abstd": [i["accel_markov_ug"] * ug] * 3,
                    "gsstd": [0.0] * 3, "asstd": [0.0] * 3, "corrtime": tau / 3600}
        init_b = {"initbgstd": [float(np.hypot(i["gyro_bias_deg_h"],
                                               i["gyro_markov_deg_h"]))] * 3,
                  "initbastd": [float(np.hypot(i["accel_bias_ug"],
                                               i["accel_markov_ug"]) * ug)] * 3}
        gsd_ned = np.asarray(g["sigma_pos_enu_m"], dtype=float)[[1, 0, 2]]
        source = "fednav simulate examples/car-drive.yaml (gnss-ins-sim not available)"
        notes.append("fednav's own simulated car drive: gnss-ins-sim could not be had")
    dt = imu.period()
    t0 = float(imu.t[0])
    t_end = imu.t + dt - t0 + SIM_WEEK_S  # each row's interval ends at t + dt
    frd = FRD_TO_RFU  # (its own inverse)
    write_imu(folder / "imu.txt", t_end, imu.gyro @ frd.T * dt, imu.accel @ frd.T * dt)
    tg = gnss.t - t0 + SIM_WEEK_S
    start = float(t_end[0])
    first, last = tg[tg > start][0], tg[-1]
    windows = [(a, a + 30.0) for a in np.arange(first + 60.0, last - 30.0 - 30.0 + 1e-9, 90.0)]
    keep = outside(tg, windows) & (tg <= t_end[-1])
    write_gnss(folder / "gnss.txt", tg[keep], units.to_deg(gnss.lla[keep, 0]),
               units.to_deg(gnss.lla[keep, 1]), gnss.lla[keep, 2],
               np.tile(gsd_ned, (keep.sum(), 1)))
    # the truth at starttime (KF-GINS starts from a given state)
    tr = ref.t - t0 + SIM_WEEK_S
    k = int(np.argmin(np.abs(tr - start)))
    roll, pitch, yaw = (units.to_deg(a) for a in fednav_euler_to_navego(ref.euler[k]))
    v = ref.vel[k]
    lever_frd = lever_rfu[[1, 0, 2]] * [1, 1, -1]
    config = {"imupath": "imu.txt", "gnsspath": "gnss.txt",
              "outputpath": str(work / "kfgins-out-sim"), "imudatalen": 7,
              "imudatarate": int(round(1.0 / dt)), "starttime": start, "endtime": -1,
              "initpos": [float(units.to_deg(ref.lla[k, 0])),
                          float(units.to_deg(ref.lla[k, 1])), float(ref.lla[k, 2])],
              "initvel": [float(v[1]), float(v[0]), float(-v[2])],
              "initatt": [float(roll), float(pitch), float(yaw % 360.0)],
              "initgyrbias": [0, 0, 0], "initaccbias": [0, 0, 0],
              "initgyrscale": [0, 0, 0], "initaccscale": [0, 0, 0],
              "initposstd": [0.5, 0.5, 1.0], "initvelstd": [0.05, 0.05, 0.05],
              "initattstd": [0.5, 0.5, 1.0], **init_b,
              "imunoise": imunoise, "antlever": [float(x) for x in lever_frd]}
    (folder / "kf-gins.yaml").write_text(f"# simulated drive: {source}\n"
                                         + yaml.safe_dump(config, sort_keys=False))
    rr, rp, ry = (units.to_deg(a) for a in fednav_euler_to_navego(ref.euler))
    refd = {"t": tr, "lat": ref.lla[:, 0], "lon": ref.lla[:, 1], "h": ref.lla[:, 2],
            "vn": ref.vel[:, 1], "ve": ref.vel[:, 0], "vd": -ref.vel[:, 2],
            "roll": rr, "pitch": rp, "yaw": ry}
    return Case("simulated drive", folder, folder / "kf-gins.yaml", refd, windows, start,
                np.zeros(3), "; ".join(notes) + f"; {len(windows)} windows of 30 s")


def _dcm_frd_ned(roll, pitch, yaw) -> np.ndarray:
    from fednav.io.navego import navego_dcm

    return navego_dcm(roll, pitch, yaw)


def _rodrigues(a: np.ndarray) -> np.ndarray:
    th = float(np.linalg.norm(a))
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    if th < 1e-12:
        return np.eye(3) + k
    return np.eye(3) + np.sin(th) / th * k + (1.0 - np.cos(th)) / th**2 * k @ k


def _rpy(C: np.ndarray) -> tuple[float, float, float]:
    return (float(np.arctan2(C[2, 1], C[2, 2])), float(-np.arcsin(np.clip(C[2, 0], -1, 1))),
            float(np.arctan2(C[1, 0], C[0, 0])))


def _groves_ctm(rpy) -> np.ndarray:
    """Groves' Euler_to_CTM (the author's imu_transforms.py)."""
    sphi, cphi = np.sin(rpy[0]), np.cos(rpy[0])
    sth, cth = np.sin(rpy[1]), np.cos(rpy[1])
    sps, cps = np.sin(rpy[2]), np.cos(rpy[2])
    return np.array([[cth * cps, cth * sps, -sth],
                     [-cphi * sps + sphi * sth * cps, cphi * cps + sphi * sth * sps,
                      sphi * cth],
                     [sphi * sps + cphi * sth * cps, -sphi * cps + cphi * sth * sps,
                      cphi * cth]])


def read_tagged_imu(csv: Path, lowpass: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drive's IMU log stamped as the author's convert_imu_file.py stamps it: GPS
    seconds since 1970 (same clock) from the ``.tag`` header, the rows' millisecond ticks
    stretched to the tag file's span; first and last rows dropped (may be incomplete).
    Returns t, accel [g], gyro [deg/s] in the sensor's axes (low-passed when asked)."""
    with open(str(csv) + ".tag", "rb") as f:
        f.read(60)
        f.read(4)  # tick at the start
        time_time = struct.unpack("<I", f.read(4))[0]
        time_sec = struct.unpack("<d", f.read(8))[0]
        recs = np.frombuffer(f.read(), dtype="<u4").reshape(-1, 2)
    start = time_time + time_sec
    end = start + recs[-1, 0] / 1000.0
    data = np.genfromtxt(csv, delimiter=",", skip_header=1, skip_footer=1)
    data = data[np.isfinite(data).all(axis=1)]
    acc, gyro, sec = data[:, 0:3], data[:, 3:6], data[:, 6] / 1000.0
    sec = sec - sec[0]
    t = start + sec * (end - start) / (sec[-1] - sec[0])
    if lowpass:  # the author's: zero-phase 4th-order Butterworth, 10 Hz (accel z 5 Hz)
        from scipy.signal import butter, filtfilt

        def lp(x, fc, fs=100.0):
            b, a = butter(4, fc / (0.5 * fs), btype="low")
            return filtfilt(b, a, x, axis=0)
        gyro = lp(gyro, 10.0)
        acc = np.column_stack([lp(acc[:, :2], 10.0), lp(acc[:, 2], 5.0)])
    return t, acc, gyro


def drive_windows(t_first: float, t_last: float) -> list:
    """fednav's maintainers' protocol (the author's start_coast 40, end_coast 30,
    coast_len 15: out 15 s, in 30 s)."""
    out, s = [], t_first + 40.0
    while s < t_last - 30.0:
        out.append((s, min(s + 15.0, t_last - 30.0)))
        s += 45.0
    return out


def drive_yaml(folder: Path, outputpath: Path, init: dict, start: float) -> dict:
    """``kf-gins.yaml`` of the real drive: the author's figures in KF-GINS's units.

    * arw [deg/sqrt(h)] = gyro white noise 0.0038 deg/s/sqrt(Hz) x 60;
    * vrw [m/s/sqrt(h)] = accel white noise 70 ug/sqrt(Hz) x g x 60;
    * the author's biases are random walks (7 ug/sqrt(Hz), 3.8e-5 deg/s^2/sqrt(Hz));
      KF-GINS's are first-order Gauss-Markov with q = 2 sigma^2 / T: corrtime 1 h (over a
      9-minute drive, a random walk) and sigma = q_rw sqrt(T / 2): gbstd 5.8 deg/h,
      abstd 291 mGal;
    * gsstd / asstd: 1000 ppm (the author's initial scale uncertainty 0.001; a MEMS's
      scale factors are 0.1 % class);
    * initial biases from the static start: the gyros' (their mean at rest less the
      Earth's rate), the accelerometer's along the vertical (|f| against gravity);
    * initial sigmas: the biases' from what the static start leaves (gyro 20 deg/h;
      accel 0.1 m/s^2 = 10000 mGal, half the author's 0.2 m/s^2: a MEMS turn-on bias not
      separable from the tilt at rest); position/velocity the author's (0.05/0.05/0.1 m,
      0.05/0.05/0.1 m/s); attitude 1/1/2 deg (levelled at rest, heading from the GNSS
      course at speed).
    """
    g = 9.80665
    tau_h = 1.0
    gb = DRIVE_FIG["gyro_bias_psd_deg_s2_rthz"] * np.sqrt(tau_h * 3600 / 2) * 3600
    ab = DRIVE_FIG["accel_bias_psd_ug_rthz"] * 1e-6 * g * np.sqrt(tau_h * 3600 / 2) / 1e-5
    return {"imupath": "imu.txt", "gnsspath": "gnss.txt", "outputpath": str(outputpath),
            "imudatalen": 7, "imudatarate": 100, "starttime": round(start, 6),
            "endtime": -1, "initpos": init["pos"], "initvel": init["vel"],
            "initatt": init["att"], "initgyrbias": init["gyrbias"],
            "initaccbias": init["accbias"], "initgyrscale": [0, 0, 0],
            "initaccscale": [0, 0, 0], "initposstd": [0.05, 0.05, 0.1],
            "initvelstd": [0.05, 0.05, 0.1], "initattstd": [1.0, 1.0, 2.0],
            "initbgstd": [20.0] * 3, "initbastd": [10000.0] * 3,
            "imunoise": {"arw": [round(DRIVE_FIG["gyro_wn_deg_s_rthz"] * 60, 6)] * 3,
                         "vrw": [round(DRIVE_FIG["accel_wn_ug_rthz"] * 1e-6 * g * 60, 6)] * 3,
                         "gbstd": [round(float(gb), 4)] * 3,
                         "abstd": [round(float(ab), 2)] * 3,
                         "gsstd": [1000.0] * 3, "asstd": [1000.0] * 3,
                         "corrtime": tau_h},
            "antlever": list(DRIVE_FIG["antlever_frd_m"])}


def drive_case(work: Path, args) -> Case:
    """The real drive's folder (module docstring, 2)."""
    from fednav.core import earth
    from fednav.io import read_rtklib_pos

    pos = read_rtklib_pos(DRIVE / "gnss_1934_sf.pos", time="week")
    q = pos.quality["gnss_rtklib_q"]
    fixed = _rtklib_q(DRIVE / "gnss_1934_sf.pos") == 1
    tg, lla = pos.t, pos.lla
    vn, ve, vu = pos.vel[:, 1], pos.vel[:, 0], pos.vel[:, 2]
    t, acc, gyro = read_tagged_imu(DRIVE / "imu_1934.csv", lowpass=not args.no_lowpass)
    t = np.mod(t - GPS_EPOCH_S, WEEK_S) + DRIVE_FIG["imu_t_off_s"]
    grav = float(earth.gravity(lla[0, 0], lla[0, 2]))
    C = _groves_ctm(np.radians(DRIVE_FIG["imu_rpy_deg"]))
    f_b = acc @ C.T * grav                     # vehicle body FRD [m/s^2]
    w_b = np.radians(gyro) @ C.T               # [rad/s]
    # the static start: until the GNSS speed first passes 0.5 m/s
    sp = np.hypot(vn, ve)
    moving = int(np.argmax(sp > 0.5))
    t_static_end = tg[moving] - 2.0
    stat = (t >= tg[0]) & (t <= t_static_end)
    fm = f_b[stat].mean(axis=0)
    # the accelerometer bias along the vertical is seen at rest (|f| against gravity); the
    # horizontal ones are not (they and the tilt are one at rest)
    ba_z = grav - float(np.linalg.norm(fm))
    roll0 = np.arctan2(-fm[1], -fm[2])
    pitch0 = np.arctan2(fm[0], np.hypot(fm[1], fm[2]))
    # starttime: the first epoch after the static start at 1 m/s
    k0 = int(np.argmax((sp > 1.0) & (tg > tg[moving])))
    i_start = int(np.searchsorted(t, tg[k0]))
    start = float(t[i_start])
    # gyro bias at rest (Earth rate taken out once the heading is known), attitude carried
    # from the static end to the start and on to straight driving, where the course gives
    # the heading
    lat0 = lla[0, 0]
    wie_n = 7.292115e-5 * np.array([np.cos(lat0), 0.0, -np.sin(lat0)])
    bias = w_b[stat].mean(axis=0)
    i_s = int(np.searchsorted(t, t_static_end))
    i_e = int(np.searchsorted(t, start + 60.0))
    for _ in range(2):
        Cs = [_dcm_frd_ned(roll0, pitch0, 0.0)]
        for i in range(i_s + 1, i_e):
            Cs.append(Cs[-1] @ _rodrigues((w_b[i] - bias) * (t[i] - t[i - 1])))
        tc = t[i_s + 1 - 1:i_e]
        yaw_int = np.unwrap([_rpy(c)[2] for c in Cs])
        # straight, at speed: |yaw rate| < 1 deg/s over a second, speed > 5 m/s
        course = np.unwrap(np.arctan2(ve, vn))
        sel = (tg > start) & (tg < start + 60.0) & (sp > 5.0)
        rate = np.gradient(np.interp(tg, tc, yaw_int), tg)
        sel &= np.abs(rate) < np.radians(1.0)
        off = float(np.median(np.angle(np.exp(1j * (course[sel]
                                                     - np.interp(tg[sel], tc, yaw_int))))))
        C_static = _dcm_frd_ned(roll0, pitch0, off)
        bias = w_b[stat].mean(axis=0) - C_static.T @ wie_n
    i0 = i_start - (i_s + 1) + 1
    r, p, y = _rpy(Cs[i0])
    y += off
    # the first fixes: position and velocity at the start, the IMU's point
    lat_a, lon_a, h_a = (np.interp(start, tg, lla[:, j]) for j in range(3))
    v0 = [float(np.interp(start, tg, x)) for x in (vn, ve, -vu)]
    lever = np.asarray(DRIVE_FIG["antlever_frd_m"], dtype=float)
    d_ned = _dcm_frd_ned(r, p, y) @ lever
    rm, rn = earth.radii(lat_a)
    lat_i = lat_a - d_ned[0] / (rm + h_a)
    lon_i = lon_a - d_ned[1] / ((rn + h_a) * np.cos(lat_a))
    init = {"pos": [float(np.degrees(lat_i)), float(np.degrees(lon_i)),
                    float(h_a + d_ned[2])],
            "vel": v0, "att": [float(np.degrees(r)), float(np.degrees(p)),
                               float(np.degrees(y) % 360.0)],
            "gyrbias": [float(b) for b in np.round(np.degrees(bias) * 3600.0, 3)],
            "accbias": [0.0, 0.0, round(ba_z / 1e-5, 1)]}
    # the folder: trapezoidal increments over each interval, stamped at its end
    folder = work / "drive"
    folder.mkdir(parents=True, exist_ok=True)
    dts = np.diff(t)[:, None]
    write_imu(folder / "imu.txt", t[1:], 0.5 * (w_b[1:] + w_b[:-1]) * dts,
              0.5 * (f_b[1:] + f_b[:-1]) * dts)
    windows = drive_windows(float(tg[0]), float(tg[-1]))
    keep = outside(tg, windows)
    sd = pos.sigma_rows[:, :3]  # north, east, up
    write_gnss(folder / "gnss.txt", tg[keep], np.degrees(lla[keep, 0]),
               np.degrees(lla[keep, 1]), lla[keep, 2], sd[keep])
    cfg = drive_yaml(folder, work / "kfgins-out-drive", init, start)
    (folder / "kf-gins.yaml").write_text(
        "# rtklibexplorer drive_0708: MEMS IMU + u-blox RTK (see benchmarks/kfgins_peer.py)\n"
        + yaml.safe_dump(cfg, sort_keys=False))
    refd = {"t": tg[fixed], "lat": lla[fixed, 0], "lon": lla[fixed, 1], "h": lla[fixed, 2],
            "vn": vn[fixed], "ve": ve[fixed], "vd": -vu[fixed]}
    note = (f"{len(t)} IMU rows ({'low-passed as the author' if not args.no_lowpass else 'raw'}"
            f", stamps {np.median(np.diff(t)) * 1e3:.2f} ms median, "
            f"{np.min(np.diff(t)) * 1e3:.1f}-{np.max(np.diff(t)) * 1e3:.1f} ms), GNSS {q}, "
            f"{len(windows)} windows of 15 s; start {start - tg[0]:.2f} s after the first fix "
            f"(static until {tg[moving] - tg[0]:.1f} s); init att "
            f"{np.round(init['att'], 2).tolist()} deg, gyro bias at rest "
            f"{np.round(init['gyrbias'], 1).tolist()} deg/h, accel z bias "
            f"{init['accbias'][2]:.0f} mGal")
    return Case("real drive (rtklibexplorer drive_0708)", folder, folder / "kf-gins.yaml",
                refd, windows, start, lever, note)


def _rtklib_q(path: Path) -> np.ndarray:
    rows = [ln.split() for ln in path.read_text().splitlines()
            if ln.strip() and not ln.startswith("%")]
    return np.array([int(float(r[5])) for r in rows])


# ----------------------------------------------------------------------------- running
def fednav_exe() -> Path:
    p = Path(sys.executable).parent / "fednav"
    return p if p.is_file() else Path(shutil.which("fednav") or "fednav")


def run_kfgins(binary: Path, case: Case, out: Path) -> tuple[float, Path]:
    cfg = yaml.safe_load(case.yaml.read_text())
    out.mkdir(parents=True, exist_ok=True)
    assert Path(cfg["outputpath"]) == out
    t0 = time.perf_counter()
    r = subprocess.run([str(binary), case.yaml.name], cwd=case.folder, capture_output=True,
                       text=True)
    wall = time.perf_counter() - t0
    if r.returncode != 0 or not (out / "KF_GINS_Navresult.nav").is_file():
        raise SystemExit(f"KF-GINS failed on {case.folder} (exit {r.returncode}):\n"
                         f"{r.stdout[-2000:]}{r.stderr[-2000:]}")
    return wall, out / "KF_GINS_Navresult.nav"


#: the environment fednav runs in (:func:`pin_fednav`): None, the caller's
FEDNAV_ENV: dict | None = None


def pin_fednav(work: Path) -> Path:
    """Run fednav from a copy of its sources taken now, with its own kernel cache.

    fednav compiles its numba kernels once per version of its sources (a hash of every
    module names the cache folder, the 4 most recent kept): in a checkout that others
    edit while this runs, every run would compile afresh (~2 min on 2 CPUs), which is
    not what a user who installed a version sees.  The copy makes the version fixed;
    the first run compiles (timed apart, "first run"), the next ones load the kernels.
    The copy's bytecode is written (``PYTHONDONTWRITEBYTECODE`` dropped) as an install's
    is: without it every run compiled fednav's ~100 modules from source again (0.25 s
    here), which no installed fednav does."""
    global FEDNAV_ENV
    import fednav

    snap = work / "fednav-src"
    if snap.exists():
        shutil.rmtree(snap)
    shutil.copytree(Path(fednav.__file__).parent, snap / "fednav",
                    ignore=shutil.ignore_patterns("__pycache__"))
    FEDNAV_ENV = {**os.environ, "PYTHONPATH": str(snap),
                  "XDG_CACHE_HOME": str(work / "xdg-cache")}
    FEDNAV_ENV.pop("NUMBA_CACHE_DIR", None)
    FEDNAV_ENV.pop("PYTHONDONTWRITEBYTECODE", None)
    return snap


#: further options of every ``fednav process kfgins`` (``--noise``)
FEDNAV_ARGS: list[str] = []


def run_fednav(case: Case, out: Path) -> tuple[float, Path, str]:
    if out.exists():
        shutil.rmtree(out)
    t0 = time.perf_counter()
    r = subprocess.run([str(fednav_exe()), "process", "kfgins", str(case.folder), "--out",
                        str(out), *FEDNAV_ARGS], capture_output=True, text=True,
                       env=FEDNAV_ENV)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"fednav process kfgins {case.folder} failed (exit "
                         f"{r.returncode}): {(r.stderr or r.stdout).strip()[-3000:]}")
    nav = out / "KF_GINS_Navresult.nav"
    return wall, (nav if nav.is_file() else out / "solution.csv"), r.stdout + r.stderr


def read_solution(path: Path) -> dict:
    """A solution as t, lat/lon [rad], h, vN/vE/vD, roll/pitch/yaw [deg]: KF-GINS's
    ``.nav`` (its own output or fednav's export) or fednav's ``solution.csv``."""
    if path.suffix == ".nav":
        a = np.loadtxt(path)
        return {"t": a[:, 1], "lat": a[:, 2] * D2R, "lon": a[:, 3] * D2R, "h": a[:, 4],
                "vn": a[:, 5], "ve": a[:, 6], "vd": a[:, 7], "roll": a[:, 8],
                "pitch": a[:, 9], "yaw": a[:, 10]}
    import pandas as pd

    from fednav.io.navego import fednav_euler_to_navego

    df = pd.read_csv(path)

    def col(name: str) -> np.ndarray:  # (docs name them vE, pitch; the file vE_mps ...)
        c = next(c for c in df.columns if c == name or c.split("_")[0] == name)
        return df[c].to_numpy(dtype=float)

    eul = np.radians(np.column_stack([col("pitch"), col("roll"), col("heading")]))
    roll, pitch, yaw = fednav_euler_to_navego(eul)
    return {"t": col("t"), "lat": np.radians(col("lat")), "lon": np.radians(col("lon")),
            "h": col("h"), "vn": col("vN"), "ve": col("vE"), "vd": -col("vU"),
            "roll": np.degrees(roll), "pitch": np.degrees(pitch), "yaw": np.degrees(yaw)}


COLS = ("N", "E", "D", "vN", "vE", "vD", "roll", "pitch", "yaw")


def fednav_parts(s, case) -> dict:
    """A fednav ``Solution``'s errors against ``case``'s reference (:func:`errors`) inside
    its withheld windows and outside: ``{"windows": (t, e), "aided": (t, e)}``, ``e``
    N/E/D [m] and vN/vE/vD [m/s]."""
    from fednav.io.navego import fednav_euler_to_navego

    roll, pitch, yaw = fednav_euler_to_navego(s.euler)
    sol = {"t": s.t, "lat": s.lla[:, 0], "lon": s.lla[:, 1], "h": s.lla[:, 2],
           "vn": s.vel[:, 1], "ve": s.vel[:, 0], "vd": -s.vel[:, 2],
           "roll": np.degrees(roll), "pitch": np.degrees(pitch), "yaw": np.degrees(yaw)}
    e, t = errors(sol, case)
    inside = ~outside(t, case.windows)
    return {part: (t[m], e[m][:, :6]) for part, m in (("windows", inside),
                                                      ("aided", ~inside))}


def errors(sol: dict, case: Case) -> tuple[np.ndarray, np.ndarray]:
    """The solution minus the reference at the reference's epochs from starttime on
    (interpolated in time; the solution taken to the reference's point): (n, 9) errors
    in :data:`COLS` order (attitude NaN without a reference attitude), and the epochs."""
    from fednav.core import earth

    ref = case.ref
    t = ref["t"]
    sel = (t >= case.start) & (t >= sol["t"][0]) & (t <= sol["t"][-1])
    t = t[sel]
    yaw_u = np.degrees(np.unwrap(np.radians(sol["yaw"])))
    s = {k: np.interp(t, sol["t"], yaw_u if k == "yaw" else sol[k])
         for k in ("lat", "lon", "h", "vn", "ve", "vd", "roll", "pitch", "yaw")}
    lat, lon, h = s["lat"].copy(), s["lon"].copy(), s["h"].copy()
    vn, ve, vd = s["vn"].copy(), s["ve"].copy(), s["vd"].copy()
    if np.any(case.lever_frd):
        C = _dcm_frd_ned(np.radians(s["roll"]), np.radians(s["pitch"]), np.radians(s["yaw"]))
        d = C @ case.lever_frd
        rm, rn = earth.radii(lat)
        lat = lat + d[:, 0] / (rm + h)
        lon = lon + d[:, 1] / ((rn + h) * np.cos(lat))
        h = h - d[:, 2]
        # the lever arm's velocity from the heading's rate (the turn dominates a car's)
        yr = np.gradient(np.radians(yaw_u), sol["t"])
        w = np.interp(t, sol["t"], yr)
        wb = np.column_stack([np.zeros_like(w), np.zeros_like(w), w])
        dv = np.einsum("nij,nj->ni", C, np.cross(wb, case.lever_frd))
        vn, ve, vd = vn + dv[:, 0], ve + dv[:, 1], vd + dv[:, 2]
    rm, rn = earth.radii(ref["lat"][sel])
    e = np.full((len(t), 9), np.nan)
    e[:, 0] = (lat - ref["lat"][sel]) * (rm + ref["h"][sel])
    e[:, 1] = (lon - ref["lon"][sel]) * (rn + ref["h"][sel]) * np.cos(ref["lat"][sel])
    e[:, 2] = -(h - ref["h"][sel])
    e[:, 3] = vn - ref["vn"][sel]
    e[:, 4] = ve - ref["ve"][sel]
    e[:, 5] = vd - ref["vd"][sel]
    if "roll" in ref:
        for j, k in ((6, "roll"), (7, "pitch"), (8, "yaw")):
            e[:, j] = (s[k] - ref[k][sel] + 180.0) % 360.0 - 180.0
    return e, t


def rmse(e: np.ndarray) -> np.ndarray:
    """Per column; NaN for a column without values (no reference attitude)."""
    out = np.full(e.shape[1], np.nan)
    have = np.isfinite(e).any(axis=0)
    if len(e):
        out[have] = np.sqrt(np.nanmean(e[:, have] ** 2, axis=0))
    return out


def table(case: Case, res: dict, walls: dict) -> str:
    att = "roll" in case.ref
    cols = COLS if att else COLS[:6]
    units_ = ["m"] * 3 + ["m/s"] * 3 + ["deg"] * 3
    head = f"{'':26s}" + "".join(f"{c + ' [' + u + ']':>13s}"
                                 for c, u in zip(cols, units_, strict=False))
    lines = [f"== {case.name}: {case.folder}", f"   {case.note}", head]
    for where in ("windows", "windows 2-", "aided", "all"):
        f, k = res["fednav"][where], res["KF-GINS"][where]
        n = res["n"][where]
        for who, v in (("fednav", f), ("KF-GINS", k), ("fednav/KF-GINS", f / k)):
            lab = f"{where} ({n})" if who == "fednav" else ""
            lines.append(f"{lab:19s}{who:>7s}" if who != "fednav/KF-GINS" else
                         f"{'':12s}{who:>14s}")
            lines[-1] += "".join(f"{x:13.3f}" if who != "fednav/KF-GINS" else f"{x:13.2f}"
                                 for x in v[:len(cols)])
    lines.append(f"{'windows, each':26s}horizontal RMSE [m] fednav | KF-GINS: " + "  ".join(
        f"{a:.2f}|{b:.2f}" for a, b in zip(res["per_window"]["fednav"],
                                            res["per_window"]["KF-GINS"], strict=True)))
    wf, wk = min(walls["fednav"]), min(walls["KF-GINS"])
    lines.append(f"{'wall time [s]':26s}fednav {wf:.2f}  KF-GINS {wk:.2f}  ratio {wf / wk:.1f} "
                 f"(whole process, best of {len(walls['fednav'])} alternated; the machine "
                 f"was shared)")
    wn = min(walls["floor"])
    lines.append(f"{'numba floor [s]':26s}{wn:.2f} = {wn / wk:.2f} x KF-GINS (a fresh Python "
                 f"calling one cached trivial numba kernel, timed alike: what fednav pays "
                 f"before its own work)")
    return "\n".join(lines)


#: the floor of any numba program (:func:`run_floor`): one cached, trivial kernel
FLOOR_KERNEL = '''import numba


@numba.njit(cache=True)
def one(n):
    s = 0.0
    for i in range(n):
        s += i
    return s
'''


def run_floor(work: Path) -> float:
    """Wall time [s] of a fresh Python that imports numba and calls one kernel from
    numba's cache (a trivial loop, compiled by the first call here): what every
    numba-compiled program pays before its own work — the interpreter, numba's import
    and its first dispatch, which sets up its compiler's registries even to load a
    cached kernel.  Timed beside the two programs, as they are."""
    folder = work / "numba-floor"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "floor_kernel.py").write_text(FLOOR_KERNEL)
    env = {**os.environ, "PYTHONPATH": str(folder),
           "NUMBA_CACHE_DIR": str(folder / "cache")}
    cmd = [sys.executable, "-c", "import floor_kernel; floor_kernel.one(3)"]
    if not (folder / "cache").is_dir():
        subprocess.run(cmd, check=True, env=env)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env=env)
    return time.perf_counter() - t0


def compare(case: Case, binary: Path, work: Path, repeat: int) -> str:
    walls = {"fednav": [], "KF-GINS": [], "floor": []}
    nav = {}
    log = ""
    kf_out = Path(yaml.safe_load(case.yaml.read_text())["outputpath"])
    first = None
    if FEDNAV_ENV is not None and not (work / "xdg-cache").is_dir():
        first, _, _ = run_fednav(case, work / f"fednav-out-{case.folder.name}")
    for _ in range(repeat):
        w, nav["KF-GINS"] = run_kfgins(binary, case, kf_out)
        walls["KF-GINS"].append(w)
        w, nav["fednav"], log = run_fednav(case, work / f"fednav-out-{case.folder.name}")
        walls["fednav"].append(w)
        walls["floor"].append(run_floor(work))
    res = {"n": {}, "per_window": {}}
    for who in ("fednav", "KF-GINS"):
        e, t = errors(read_solution(nav[who]), case)
        inw = ~outside(t, case.windows)
        later = inw & (t >= case.windows[0][1])
        res[who] = {"windows": rmse(e[inw]), "windows 2-": rmse(e[later]),
                    "aided": rmse(e[~inw]), "all": rmse(e)}
        res["n"] = {"windows": int(inw.sum()), "windows 2-": int(later.sum()),
                    "aided": int((~inw).sum()), "all": len(t)}
        res["per_window"][who] = [float(np.sqrt(np.mean(e[(t >= a) & (t < b), 0] ** 2
                                                        + e[(t >= a) & (t < b), 1] ** 2)))
                                  for a, b in case.windows]
    out = table(case, res, walls)
    if first is not None:
        out += (f"\n   fednav's first run (compiling its kernels, once per installed "
                f"version): {first:.1f} s")
    out += f"\n   fednav read {nav['fednav'].name}"
    warn = [ln for ln in log.splitlines() if "warning" in ln.lower() or "KF-GINS conf" in ln]
    if warn:
        out += "\n   fednav said: " + " | ".join(w.strip() for w in warn[:6])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kfgins", help="KF-GINS binary (default $KFGINS_BIN, else "
                                     "/tmp/kfgins-src/bin/KF-GINS, built when missing)")
    ap.add_argument("--work", help="working folder (default: a temporary one, kept)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=("sim", "drive"))
    ap.add_argument("--gis-folder", help="a gnss-ins-sim results folder to use")
    ap.add_argument("--gis-src", help="a gnss-ins-sim source tree (default $GNSS_INS_SIM, "
                                      "else /tmp/gnss-ins-sim)")
    ap.add_argument("--no-lowpass", action="store_true",
                    help="the real drive's IMU as logged (default: the author's low-pass)")
    ap.add_argument("--no-pin", action="store_true",
                    help="run fednav from the checkout itself (default: from a copy of its "
                         "sources with its own kernel cache, pin_fednav)")
    ap.add_argument("--noise", choices=("identify", "as-given"),
                    help="fednav process's --noise (default: its own default)")
    args = ap.parse_args()
    if args.noise:
        FEDNAV_ARGS.extend(["--noise", args.noise])
    binary = kfgins_binary(args.kfgins)
    work = Path(args.work or tempfile.mkdtemp(prefix="kfgins-peer-"))
    work.mkdir(parents=True, exist_ok=True)
    if not args.no_pin:
        snap = pin_fednav(work)
    print(f"KF-GINS {binary}; fednav {fednav_exe()}"
          + ("" if args.no_pin else f" on a copy of its sources ({snap})")
          + f"; work folder {work}", flush=True)
    cases = []
    if args.only in (None, "sim"):
        cases.append(sim_case(work, args))
    if args.only in (None, "drive"):
        if DRIVE.is_dir():
            cases.append(drive_case(work, args))
        else:
            print(f"no {DRIVE}: the real drive is skipped")
    for case in cases:
        print(compare(case, binary, work, args.repeat), flush=True)
        print()


if __name__ == "__main__":
    main()
