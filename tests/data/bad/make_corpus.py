"""Regenerate the bad-input corpus (run by hand: ``python tests/data/bad/make_corpus.py``).

Writes ``good/`` (a 20 s simulated car drive: 25 Hz IMU, 1 Hz GNSS with velocity, a
velocity sensor, a reference, a processing config, the same in NaveGo .mat files and a
short paper-002 scenario) and one file per bad case beside this script, plus
``cases.yaml``: for every case the command, the exit status and the one line it must
print. ``tests/test_bad_input.py`` replays the cases. Paths in ``cases.yaml`` are
relative to this folder, ``{out}`` is the test's output folder.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import scipy.io
import yaml

from fednav.core import units
from fednav.io.navego import FRD_TO_RFU
from fednav.sensors import ImuErrors, corrupt_imu
from fednav.sim.trajectory import Segment, generate

HERE = Path(__file__).parent
GOOD = HERE / "good"


def write_table(path: Path, cols: dict, sep=",", newline="\n", bom=False):
    names = list(cols)
    rows = np.column_stack([np.asarray(cols[n], dtype=float) for n in names])
    lines = [sep.join(names)] + [sep.join(f"{v:.9g}" for v in r) for r in rows]
    text = newline.join(lines) + newline
    path.write_bytes((("\ufeff" if bom else "") + text).encode("utf-8"))
    return path


def make_good():
    segs = [Segment(6.0), Segment(14.0, heading_rate=units.deg(8.0))]
    dt = 0.04
    tr = generate(np.array([units.deg(45.0), units.deg(-75.0), 50.0]), 8.0,
                  [0.0, 0.0, units.deg(45.0)], segs, dt)
    rng = np.random.default_rng(3)
    err = ImuErrors(gyro_bias=units.deg_per_h(20.0), accel_bias=units.milli_g(1.0),
                    gyro_arw=units.deg_per_sqrt_h(0.1), accel_vrw=5e-4)
    dth, dv, _ = corrupt_imu(tr.dtheta, tr.dv, dt, err, rng)
    t = tr.t[1:]
    imu = {"t_s": t, "gyro_x_radps": dth[:, 0] / dt, "gyro_y_radps": dth[:, 1] / dt,
           "gyro_z_radps": dth[:, 2] / dt, "accel_x_mps2": dv[:, 0] / dt,
           "accel_y_mps2": dv[:, 1] / dt, "accel_z_mps2": dv[:, 2] / dt}
    tg = np.arange(1.0, 20.0, 1.0)
    s = tr.at(tg)
    noise = rng.standard_normal((len(tg), 3))
    lat = units.to_deg(s["lla"][:, 0]) + noise[:, 0] * 0.5 / 111_000.0
    lon = units.to_deg(s["lla"][:, 1]) + noise[:, 1] * 0.5 / 78_700.0
    gnss = {"t_s": tg, "lat_deg": lat, "lon_deg": lon, "h_m": s["lla"][:, 2] + noise[:, 2] * 0.5,
            "vE_mps": s["vel"][:, 0], "vN_mps": s["vel"][:, 1], "vU_mps": s["vel"][:, 2]}
    vel = {"t_s": tg, "vE_mps": s["vel"][:, 0], "vN_mps": s["vel"][:, 1],
           "vU_mps": s["vel"][:, 2], "sigma_vE_mps": np.full(len(tg), 0.1),
           "sigma_vN_mps": np.full(len(tg), 0.1), "sigma_vU_mps": np.full(len(tg), 0.1)}
    ref = {"t_s": tg, "lat_deg": units.to_deg(s["lla"][:, 0]),
           "lon_deg": units.to_deg(s["lla"][:, 1]), "h_m": s["lla"][:, 2],
           "vE_mps": s["vel"][:, 0], "vN_mps": s["vel"][:, 1], "vU_mps": s["vel"][:, 2],
           "pitch_deg": units.to_deg(s["euler"][:, 0]), "roll_deg": units.to_deg(s["euler"][:, 1]),
           "heading_deg": units.to_deg(s["euler"][:, 2])}
    GOOD.mkdir(parents=True, exist_ok=True)
    write_table(GOOD / "imu.csv", imu)
    write_table(GOOD / "gnss.csv", gnss)
    write_table(GOOD / "velocity.csv", vel)
    write_table(GOOD / "ref.csv", ref)
    cfg = {"imu": {"gyro_arw_rad_sqrt_s": float(units.deg_per_sqrt_h(0.1)),
                   "accel_vrw_mps_sqrt_s": 5e-4,
                   "gyro_bias_radps": float(units.deg_per_h(20.0)),
                   "accel_bias_mps2": float(units.milli_g(1.0)),
                   "gyro_markov_radps": 1e-6, "accel_markov_mps2": 1e-5,
                   "gyro_tau_s": 1000.0, "accel_tau_s": 1000.0},
           "sensors": {"gnss": {"sigma_pos_enu_m": [0.5, 0.5, 0.5],
                                "sigma_vel_mps": [0.05, 0.05, 0.05]}},
           "alignment": {"initial_attitude": "coarse"}}
    (GOOD / "cfg.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    # NaveGo .mat (FRD body, NED, radians)
    e3 = np.ones(3)
    scipy.io.savemat(GOOD / "imu.mat", {"imu": {
        "t": t, "wb": (dth / dt) @ FRD_TO_RFU.T, "fb": (dv / dt) @ FRD_TO_RFU.T,
        "arw": units.deg_per_sqrt_h(0.1) * e3, "vrw": 5e-4 * e3,
        "gb_sta": units.deg_per_h(20.0) * e3, "ab_sta": units.milli_g(1.0) * e3,
        "gb_dyn": 1e-6 * e3, "ab_dyn": 1e-5 * e3, "gb_corr": 1000.0 * e3,
        "ab_corr": 1000.0 * e3, "ini_align": [0.0, 0.0, units.deg(45.0)],
        "ini_align_err": units.deg(np.array([1.0, 1.0, 5.0]))}})
    ned = np.column_stack([s["vel"][:, 1], s["vel"][:, 0], -s["vel"][:, 2]])
    g = {"t": tg, "lat": units.deg(lat), "lon": units.deg(lon), "h": gnss["h_m"], "vel": ned,
         "stdm": [0.5, 0.5, 0.5], "stdv": [0.05, 0.05, 0.05], "larm": [0.0, 0.0, 0.0]}
    scipy.io.savemat(GOOD / "gnss.mat", {"gnss": g})
    r = {"t": tg, "lat": s["lla"][:, 0], "lon": s["lla"][:, 1], "h": s["lla"][:, 2],
         "vel": ned}
    scipy.io.savemat(GOOD / "ref.mat", {"ref": r})
    return imu, gnss, vel, ref, cfg, g, r


def lines(path: Path) -> list[str]:
    return path.read_text().splitlines()


def main():
    for p in HERE.iterdir():
        if p.is_dir():
            shutil.rmtree(p)
        elif p.name not in ("make_corpus.py",):
            p.unlink()
    imu, gnss, vel, ref, cfg, g, r = make_good()
    cases = []
    G = "good"

    def csv_case(cid, argv, exit_code, message, note=""):
        cases.append({"id": cid, "family": "csv", "argv": argv, "exit": exit_code,
                      "message": message, "note": note})

    def proc(imu_p=f"{G}/imu.csv", gnss_p=f"{G}/gnss.csv", extra=(), cfg_p=f"{G}/cfg.yaml"):
        return ["process", "csv", "--imu", imu_p, "--gnss", gnss_p, "--config", cfg_p,
                *extra]

    def variant(name, base, change, **kw):
        cols = {k: np.array(v, dtype=float) for k, v in base.items()}
        change(cols)
        return write_table(HERE / name, cols, **kw).name

    def edit(name, src, fn):
        text = fn((GOOD / src).read_text())
        (HERE / name).write_text(text)
        return name

    n = len(imu["t_s"])
    # --- CSV: faulty samples inside a stream (policy: bridged / skipped, counted)
    f = variant("imu-nan-row.csv", imu, lambda c: c["gyro_y_radps"].__setitem__(200, np.nan))
    csv_case("csv-imu-nan-row", proc(f), 0, "data: imu samples bridged 1")
    f = variant("imu-inf-row.csv", imu, lambda c: c["accel_z_mps2"].__setitem__(300, np.inf))
    csv_case("csv-imu-inf-row", proc(f), 0, "data: imu samples bridged 1")
    f = variant("imu-absurd.csv", imu, lambda c: c["gyro_z_radps"].__setitem__(250, 1e30))
    csv_case("csv-imu-absurd-1e30", proc(f), 0, "data: imu samples bridged 1")
    f = variant("imu-nan-run.csv", imu, lambda c: c["gyro_x_radps"].__setitem__(
        slice(100, 110), np.nan))
    csv_case("csv-imu-nan-run", proc(f), 2,
             f"error: {f}: 10 faulty IMU samples in a row (NaN/inf or absurd) from t = 4.040000 "
             "s to 4.400000 s: 0.400 s, more than imu_max_bridge_s = 0.1 s")
    f = edit("imu-empty-cell.csv", "imu.csv",
             lambda t: "\n".join(x if i != 50 else ",".join(x.split(",")[:3] + [""] +
                                                           x.split(",")[4:])
                                 for i, x in enumerate(t.splitlines())) + "\n")
    csv_case("csv-imu-empty-cell", proc(f), 0, "data: imu samples bridged 1")
    f = variant("gnss-nan-row.csv", gnss, lambda c: c["lat_deg"].__setitem__(5, np.nan))
    csv_case("csv-gnss-nan-row", proc(gnss_p=f), 0, "data: gnss epochs skipped 1")
    f = variant("gnss-inf-row.csv", gnss, lambda c: c["vN_mps"].__setitem__(7, -np.inf))
    csv_case("csv-gnss-inf-row", proc(gnss_p=f), 0, "data: gnss epochs skipped 1")
    f = variant("gnss-absurd.csv", gnss, lambda c: c["h_m"].__setitem__(9, 1e30))
    csv_case("csv-gnss-absurd-1e30", proc(gnss_p=f), 0, "data: gnss epochs skipped 1")
    f = variant("gnss-all-nan.csv", gnss, lambda c: c["lat_deg"].__setitem__(slice(None), np.nan))
    csv_case("csv-gnss-all-nan", proc(gnss_p=f), 2,
             f"error: {f}: no usable GNSS row (all have NaN/inf or fail the sanity checks)")
    f = variant("velocity-nan-row.csv", vel, lambda c: c["vE_mps"].__setitem__(3, np.nan))
    csv_case("csv-velocity-nan-row", proc(extra=["--velocity", f]), 0,
             "data: velocity epochs skipped 1")
    f = variant("velocity-zero-sigma.csv", vel, lambda c: c["sigma_vN_mps"].__setitem__(4, 0.0))
    csv_case("csv-velocity-zero-sigma-row", proc(extra=["--velocity", f]), 0,
             "data: velocity epochs skipped 1")
    f = variant("ref-nan-row.csv", ref, lambda c: c["h_m"].__setitem__(6, np.nan))
    csv_case("csv-reference-nan-row", proc(extra=["--ref", f]), 0,
             "data: reference rows skipped 1")
    # --- CSV: files that are not what they claim
    for kind, src in (("imu", "imu.csv"), ("gnss", "gnss.csv")):
        (HERE / f"{kind}-empty.csv").write_text("")
        a = proc(f"{kind}-empty.csv") if kind == "imu" else proc(gnss_p=f"{kind}-empty.csv")
        need = ("t_s, gyro_x_radps, gyro_y_radps, gyro_z_radps, accel_x_mps2, accel_y_mps2, "
                "accel_z_mps2" if kind == "imu"
                else "t_s, lat_deg, lon_deg, h_m, vE_mps, vN_mps, vU_mps")
        csv_case(f"csv-{kind}-empty", a, 2,
                 f"error: {kind}-empty.csv: empty file (expected a header row: {need})")
        f = edit(f"{kind}-header-only.csv", src, lambda t: t.splitlines()[0] + "\n")
        a = proc(f) if kind == "imu" else proc(gnss_p=f)
        csv_case(f"csv-{kind}-header-only", a, 2, f"error: {f}: no data rows (header only)")
        f = edit(f"{kind}-single-row.csv", src, lambda t: "\n".join(t.splitlines()[:2]) + "\n")
        a = proc(f) if kind == "imu" else proc(gnss_p=f)
        csv_case(f"csv-{kind}-single-row", a, 2,
                 f"error: {f}: field 't_s' needs at least 2 samples, got 1" if kind == "imu"
                 else f"error: {f}: field 't' needs at least 2 samples, got 1")
        f = edit(f"{kind}-semicolons.csv", src, lambda t: t.replace(",", ";"))
        a = proc(f) if kind == "imu" else proc(gnss_p=f)
        csv_case(f"csv-{kind}-semicolons", a, 2,
                 f"error: {f}: columns are separated by ';': fednav's CSV files use ','")
        f = edit(f"{kind}-text.csv", src, lambda t: t.replace(
            t.splitlines()[4].split(",")[2], "abc", 1))
        a = proc(f) if kind == "imu" else proc(gnss_p=f)
        col = "gyro_y_radps" if kind == "imu" else "lon_deg"
        csv_case(f"csv-{kind}-non-numeric", a, 2,
                 f"error: {f}: column '{col}' has a non-numeric value 'abc' at data row 4")
    f = variant("imu-missing-column.csv", imu, lambda c: c.pop("accel_y_mps2"))
    csv_case("csv-imu-missing-column", proc(f), 2,
             f"error: {f}: missing column(s) accel_y_mps2 (have t_s, gyro_x_radps, gyro_y_radps, "
             "gyro_z_radps, accel_x_mps2, accel_z_mps2; increments instead of rates: "
             "dtheta_x_rad ... dv_z_mps)")
    f = variant("gnss-missing-column.csv", gnss, lambda c: c.pop("h_m"))
    csv_case("csv-gnss-missing-column", proc(gnss_p=f), 2,
             f"error: {f}: missing column(s) h_m (have t_s, lat_deg, lon_deg, vE_mps, vN_mps, "
             "vU_mps)")
    f = variant("imu-misspelt-column.csv", imu, lambda c: c.__setitem__(
        "gyro_x_rads", c.pop("gyro_x_radps")))
    csv_case("csv-imu-misspelt-column", proc(f), 2,
             f"error: {f}: missing column(s) gyro_x_radps (have t_s, gyro_y_radps, gyro_z_radps, "
             "accel_x_mps2, accel_y_mps2, accel_z_mps2, gyro_x_rads; increments instead of "
             "rates: dtheta_x_rad ... dv_z_mps)")
    f = variant("imu-extra-column.csv", imu, lambda c: c.__setitem__(
        "temperature_c", np.full(n, 21.5)))
    csv_case("csv-imu-unknown-extra-column", proc(f), 0, "filter epochs in",
             "extra columns are ignored (documented in docs/data-formats.md)")
    f = variant("imu-bom.csv", imu, lambda c: None, bom=True)
    csv_case("csv-imu-utf8-bom", proc(f), 0, "filter epochs in", "a UTF-8 BOM is accepted")
    f = variant("gnss-bom.csv", gnss, lambda c: None, bom=True)
    csv_case("csv-gnss-utf8-bom", proc(gnss_p=f), 0, "filter epochs in")
    f = variant("imu-crlf.csv", imu, lambda c: None, newline="\r\n")
    csv_case("csv-imu-windows-line-endings", proc(f), 0, "filter epochs in",
             "Windows line endings are accepted")
    f = variant("gnss-crlf.csv", gnss, lambda c: None, newline="\r\n")
    csv_case("csv-gnss-windows-line-endings", proc(gnss_p=f), 0, "filter epochs in")
    f = variant("imu-backwards.csv", imu, lambda c: c["t_s"].__setitem__(120, c["t_s"][100]))
    csv_case("csv-imu-time-backwards", proc(f), 2,
             f"error: {f}: field 't_s' is not increasing at row 120 (4.800000 s then 4.040000 s)")
    f = variant("imu-duplicate-time.csv", imu, lambda c: c["t_s"].__setitem__(
        121, c["t_s"][120]))
    csv_case("csv-imu-duplicate-time", proc(f), 2,
             f"error: {f}: field 't_s' is not increasing at row 121 (4.840000 s then 4.840000 s)")
    f = variant("gnss-backwards.csv", gnss, lambda c: c["t_s"].__setitem__(8, 2.0))
    csv_case("csv-gnss-time-backwards", proc(gnss_p=f), 2,
             f"error: {f}: field 't' is not increasing at row 8 (8.000000 s then 2.000000 s)")
    f = variant("gnss-duplicate-time.csv", gnss, lambda c: c["t_s"].__setitem__(9, 9.0))
    csv_case("csv-gnss-duplicate-time", proc(gnss_p=f), 2,
             f"error: {f}: field 't' is not increasing at row 9 (9.000000 s then 9.000000 s)")
    keep = np.r_[0:200, 260:n]
    f = variant("imu-gap.csv", {k: np.asarray(v)[keep] for k, v in imu.items()}, lambda c: None)
    csv_case("csv-imu-gap", proc(f), 2,
             f"error: {f}: IMU sampling has a gap of 2.440000 s between t = 8.000000 s and "
             "10.440000 s (median interval 0.040000 s; gaps up to imu.max_bridge_s = 0.1 s "
             "are bridged)")
    f = variant("imu-nan-time.csv", imu, lambda c: c["t_s"].__setitem__(30, np.nan))
    csv_case("csv-imu-nan-time", proc(f), 2,
             f"error: {f}: field 't_s' has NaN/inf values (first at row 30)")
    f = variant("gnss-outside-imu.csv", gnss, lambda c: c["t_s"].__iadd__(1000.0))
    csv_case("csv-gnss-outside-imu-span", proc(gnss_p=f), 2,
             "error: good/imu.csv: IMU data does not overlap the GNSS data")
    f = variant("ref-outside.csv", ref, lambda c: c["t_s"].__iadd__(1000.0))
    csv_case("csv-reference-outside-span", proc(extra=["--ref", f]), 2,
             f"error: {f}: reference does not overlap the solution in time")
    f = variant("imu-gyro-degps.csv", imu, lambda c: [c.__setitem__(k, np.degrees(c[k]))
                                                      for k in ("gyro_x_radps", "gyro_y_radps",
                                                                "gyro_z_radps")])
    csv_case("csv-imu-gyro-in-degps", proc(f), 2, "looks like deg/s; fednav expects rad/s")
    f = variant("imu-accel-g.csv", imu, lambda c: [c.__setitem__(k, c[k] / 9.80665)
                                                   for k in ("accel_x_mps2", "accel_y_mps2",
                                                             "accel_z_mps2")])
    csv_case("csv-imu-accel-in-g", proc(f), 2, "looks like g; fednav expects m/s^2")
    f = variant("gnss-lat-rad.csv", gnss, lambda c: [c.__setitem__(k, np.radians(c[k]))
                                                     for k in ("lat_deg", "lon_deg")])
    # (the GNSS at the wrong latitude: the innovations say the data are wrong, and the
    # refusal names the input check's hint)
    csv_case("csv-gnss-latitude-in-radians-with-reference",
             proc(gnss_p=f, extra=["--ref", f"{G}/ref.csv"]), 2,
             "latitude/longitude in radians where degrees are expected?")
    csv_case("csv-gnss-latitude-in-radians", proc(gnss_p=f), 2,
             "latitude/longitude in radians where degrees are expected?")
    csv_case("csv-gnss-latitude-in-radians-forced", proc(gnss_p=f, extra=["--force"]), 0,
             "latitude/longitude in radians where degrees are expected?")
    csv_case("csv-imu-missing-file", proc("no-such-imu.csv"), 2,
             "error: IMU file no-such-imu.csv: not found")
    csv_case("csv-gnss-missing-file", proc(gnss_p="no-such-gnss.csv"), 2,
             "error: GNSS file no-such-gnss.csv: not found")
    (HERE / "imu-binary.csv").write_bytes(bytes(range(256)) * 4)
    csv_case("csv-imu-binary", proc("imu-binary.csv"), 2,
             "error: imu-binary.csv: not a UTF-8 text file")
    csv_case("csv-imu-is-a-folder", proc(G), 2, "error: IMU file good: is a folder, not a file")
    # --- NaveGo .mat
    def mat_case(cid, argv, exit_code, message):
        cases.append({"id": cid, "family": "navego", "argv": argv, "exit": exit_code,
                      "message": message, "note": ""})

    def nav(imu_p=f"{G}/imu.mat", gnss_p=f"{G}/gnss.mat", extra=()):
        return ["process", "navego", "--imu", imu_p, "--gnss", gnss_p, *extra]

    data = (GOOD / "imu.mat").read_bytes()
    (HERE / "imu-truncated.mat").write_bytes(data[: len(data) // 3])
    mat_case("mat-imu-truncated", nav("imu-truncated.mat"), 2, "error: IMU file imu-truncated.mat: "
             "not a MATLAB v5 .mat file")
    (HERE / "imu-text.mat").write_text("this is not a mat file\n")
    mat_case("mat-imu-not-mat", nav("imu-text.mat"), 2,
             "error: IMU file imu-text.mat: not a MATLAB v5 .mat file")
    mat_case("mat-imu-is-a-folder", nav(G), 2, "error: IMU file good: is a folder, not a file")
    mat_case("mat-swapped-files", nav(f"{G}/gnss.mat", f"{G}/imu.mat"), 2,
             "error: good/gnss.mat: missing field 'fb'")
    scipy.io.savemat(HERE / "imu-other-struct.mat", {"data": {"x": [1, 2, 3]}})
    mat_case("mat-imu-different-struct", nav("imu-other-struct.mat"), 2,
             "error: imu-other-struct.mat: missing field 't'")
    def fields(struct):
        """The fields of the good ``struct``.mat."""
        s = scipy.io.loadmat(GOOD / f"{struct}.mat", squeeze_me=True,
                             struct_as_record=False)[struct]
        return {k: getattr(s, k) for k in s._fieldnames}

    def mat_variant(struct, name, **upd):
        """``name``: the good ``struct``.mat with the fields in ``upd`` replaced."""
        scipy.io.savemat(HERE / name, {struct: {**fields(struct), **upd}})
        return name

    base = fields("imu")

    f = mat_variant("imu", "imu-shape.mat", fb=base["fb"][:, :2])
    mat_case("mat-imu-wrong-shape", nav(f), 2, f"error: {f}: field 'fb' has shape 500x2, "
                                                "expected Nx3")
    f = mat_variant("imu", "imu-rows.mat", wb=base["wb"][:-5])
    mat_case("mat-imu-row-count", nav(f), 2, f"error: {f}: field 'wb' has 495 rows but 't' has 500")
    wb = base["wb"].copy()
    wb[40, 2] = np.nan
    f = mat_variant("imu", "imu-nan-row.mat", wb=wb)
    mat_case("mat-imu-nan-row", nav(f), 0, "data: imu samples bridged 1")
    wb = base["wb"].copy()
    wb[40:60] = np.nan
    f = mat_variant("imu", "imu-nan-rows.mat", wb=wb)
    mat_case("mat-imu-nan-rows", nav(f), 2,
             f"error: {f}: 20 faulty IMU samples in a row (NaN/inf or absurd) from t = 1.640000 s "
             "to 2.400000 s: 0.800 s, more than imu_max_bridge_s = 0.1 s")
    f = mat_variant("imu", "imu-neg-figure.mat", vrw=-np.ones(3))
    mat_case("mat-imu-negative-noise", nav(f), 2,
             f"error: {f}: field 'vrw' must be 3 non-negative finite numbers, got "
             "[-1. -1. -1.]")
    gbase = fields("gnss")

    f = mat_variant("gnss", "gnss-zero-std.mat", stdm=np.zeros(3))
    mat_case("mat-gnss-zero-std", nav(gnss_p=f), 2,
             f"error: {f}: GNSS standard deviations must be positive")
    f = mat_variant("gnss", "gnss-negative-std.mat", stdv=-0.1 * np.ones(3))
    mat_case("mat-gnss-negative-std", nav(gnss_p=f), 2,
             f"error: {f}: GNSS standard deviations must be positive")
    lat = gbase["lat"].copy()
    lat[4] = np.nan
    f = mat_variant("gnss", "gnss-nan-row.mat", lat=lat)
    mat_case("mat-gnss-nan-row", nav(gnss_p=f), 0, "data: gnss epochs skipped 1")
    f = mat_variant("gnss", "gnss-degrees.mat", lat=np.degrees(gbase["lat"]),
                    lon=np.degrees(gbase["lon"]))
    mat_case("mat-gnss-degrees-not-radians", nav(gnss_p=f), 2,
             f"error: {f}: no usable GNSS row (all have NaN/inf or fail the sanity checks)")
    f = mat_variant("gnss", "gnss-lengths.mat", lon=gbase["lon"][:-2])
    mat_case("mat-gnss-length-mismatch", nav(gnss_p=f), 2,
             f"error: {f}: fields 'lat', 'lon', 'h' have different lengths [19, 17, 19]")
    mat_variant("ref", "ref-late.mat", t=fields("ref")["t"] + 5000.0)
    mat_case("mat-reference-no-overlap", nav(extra=["--ref", "ref-late.mat"]), 2,
             "error: ref-late.mat: reference does not overlap the solution in time")
    scipy.io.savemat(HERE / "imu-two-structs.mat", {"a": {"t": [1.0]}, "b": {"t": [2.0]}})
    mat_case("mat-two-structs", nav("imu-two-structs.mat"), 2,
             "error: IMU file imu-two-structs.mat: expected one struct, found ['a', 'b']")
    # --- YAML: processing config and scenario
    def yaml_case(cid, argv, exit_code, message):
        cases.append({"id": cid, "family": "yaml", "argv": argv, "exit": exit_code,
                      "message": message, "note": ""})

    good_cfg = (GOOD / "cfg.yaml").read_text()
    good = yaml.safe_load(good_cfg)

    def with_keys(**sections):
        """The good config with keys added to its sections (a new section when absent)."""
        d = {k: dict(v) if isinstance(v, dict) else v for k, v in good.items()}
        for sec, keys in sections.items():
            if isinstance(keys, dict):
                d[sec] = {**d.get(sec, {}), **keys}
            else:
                d[sec] = keys
        return yaml.safe_dump(d, sort_keys=False)

    for cid, text, msg in (
        ("unknown-key", good_cfg + "gnss_sigma: [1, 1, 1]\n", "key 'gnss_sigma': unknown key"),
        ("unknown-sensor", with_keys(sensors={"gps": {"sigma_pos_enu_m": 1.0}}),
         "key 'sensors.gps': unknown sensor (registered: airdata, baro, "),
        ("unknown-sensor-key", with_keys(sensors={"gnss": {"sigma_pos": 1.0}}),
         "key 'sensors.gnss.sigma_pos': unknown key"),
        ("wrong-type", with_keys(filter={"period_s": "fast"}),
         "key 'filter.period_s': Input should be a valid number, unable to parse string as a "
         "number (got 'fast')"),
        ("negative-noise", good_cfg.replace("accel_vrw_mps_sqrt_s: 0.0005",
                                            "accel_vrw_mps_sqrt_s: -0.0005"),
         "key 'imu.accel_vrw_mps_sqrt_s': Input should be greater than or equal to 0 "
         "(got -0.0005)"),
        ("zero-period", with_keys(filter={"period_s": 0}),
         "key 'filter.period_s': Input should be greater than 0 (got 0)"),
        ("negative-period", with_keys(filter={"period_s": -1}),
         "key 'filter.period_s': Input should be greater than 0 (got -1)"),
        ("list-not-mapping", "- a\n- b\n", "expected a mapping at the top level"),
        ("nan-value", with_keys(alignment={"coarse_heading_deg": float("nan")}),
         "key 'alignment.coarse_heading_deg': Input should be a finite number (got nan)"),
        ("inf-value", with_keys(alignment={"coarse_seconds": float("inf")}),
         "key 'alignment.coarse_seconds': Input should be a finite number (got inf)"),
        ("unknown-filter-name", with_keys(filter={"fdi_alpha": {"gps": 0.01}}),
         "key 'filter.fdi_alpha': unknown local filter 'gps'; local filters are named after "
         "their sensor"),
        ("unknown-filter-type", with_keys(filter={"type": "ekf2"}),
         "key 'filter.type': unknown filter 'ekf2'; registered: aasghqf, aekf, cekf, cukf, "
         "ekf, kf, pf, raukf, sghqf, sukf, ukf"),
        ("both-units", good_cfg.replace("accel_vrw_mps_sqrt_s: 0.0005",
                                        "accel_vrw_mps_sqrt_s: 0.0005\n  "
                                        "accel_vrw_ug_sqrt_hz: 50"),
         "key 'imu': give accel_vrw_ug_sqrt_hz or accel_vrw_mps_sqrt_s, not both"),
        ("old-and-new-gnss-key", with_keys(sensors={"gnss": {
            **good["sensors"]["gnss"], "sigma_pos_m": [0.5, 0.5, 0.5]}}),
         "key 'sensors.gnss': 'sigma_pos_m' ([north, east, up]) and 'sigma_pos_enu_m' "
         "([east, north, up]) are the same setting; give sigma_pos_enu_m only"),
        ("not-yaml", "imu: [1, 2\n", "not valid YAML (while parsing a flow sequence)"),
        ("zero-bridge", with_keys(imu={"max_bridge_s": 0}),
         "key 'imu.max_bridge_s': Input should be greater than 0 (got 0)"),
    ):
        (HERE / f"cfg-{cid}.yaml").write_text(text)
        yaml_case(f"yaml-config-{cid}", proc(cfg_p=f"cfg-{cid}.yaml"), 2,
                  f"error: processing config file cfg-{cid}.yaml: {msg}")
    (HERE / "cfg-empty.yaml").write_text("")
    yaml_case("yaml-config-empty", proc(cfg_p="cfg-empty.yaml"), 0,
              "warning: good/imu.csv: no IMU error figures in the file or the config: the "
              "'consumer' MEMS preset is assumed")
    # the old key (issue 29: [north, east, up], now sigma_pos_enu_m) still runs, warned
    gnss = good["sensors"]["gnss"]
    (HERE / "cfg-old-gnss-key.yaml").write_text(with_keys(sensors={"gnss": {
        "sigma_pos_m": gnss["sigma_pos_enu_m"], "sigma_vel_mps": gnss["sigma_vel_mps"]}}))
    yaml_case("yaml-config-old-gnss-key", proc(cfg_p="cfg-old-gnss-key.yaml"), 0,
              "warning: sensors.gnss.sigma_pos_m [north, east, up] is now "
              "sensors.gnss.sigma_pos_enu_m [east, north, up]: read and reordered for one "
              "more release")
    yaml_case("yaml-config-missing", proc(cfg_p="no-such.yaml"), 2,
              "error: processing config file no-such.yaml: not found")
    yaml_case("yaml-config-is-a-folder", proc(cfg_p=G), 2,
              "error: processing config file good: is a folder, not a file")
    (HERE / "cfg-not-utf8.yaml").write_bytes(b"filter: {period_s: 0.1}\n# \xff\xfe\n")
    yaml_case("yaml-config-not-utf8", proc(cfg_p="cfg-not-utf8.yaml"), 2,
              "error: processing config file cfg-not-utf8.yaml: not a UTF-8 text file")
    yaml_case("yaml-tune-config-is-a-folder",
              ["tune", "csv", "--imu", f"{G}/imu.csv", "--gnss", f"{G}/gnss.csv", "--config", G,
               "--out", "{out}/tuned.yaml"], 2,
              "error: processing config file good: is a folder, not a file")
    yaml_case("yaml-dataset-scenario-is-a-folder", ["simulate", G, "--out", "{out}/ds"], 2,
              "error: dataset scenario file good: is a folder, not a file")
    from fednav.scenarios import paper002

    scn = yaml.safe_load(Path(paper002.__file__).with_suffix(".yaml").read_text())

    def scenario(cid, data, msg):
        p = HERE / f"scenario-{cid}.yaml"
        p.write_text(data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False))
        yaml_case(f"yaml-scenario-{cid}", ["reproduce", "002", "--scenario", p.name, "--runs",
                                          "1", "--jobs", "1"], 2,
                  f"error: scenario file {p.name}: {msg}")

    import copy

    def mod(fn):
        d = copy.deepcopy(scn)
        fn(d)
        return d

    scenario("unknown-key", mod(lambda d: d.__setitem__("filtr", {"type": "ukf"})),
             "key 'filtr': unknown key")
    scenario("wrong-type", mod(lambda d: d.__setitem__("imu_period_s", "fast")),
             "key 'imu_period_s': Input should be a valid number, unable to parse string as a "
             "number (got 'fast')")
    scenario("negative-noise", mod(lambda d: d["sensors"]["star"].__setitem__(
        "sigma_arcsec", -3.0)), "key 'sensors.star.sigma_arcsec': Input should be greater than 0 "
                                "(got -3.0)")
    scenario("zero-noise", mod(lambda d: d["sensors"]["sar"].__setitem__("sigma_pos_m", 0)),
             "key 'sensors.sar.sigma_pos_m': Input should be greater than 0 (got 0)")
    scenario("zero-period", mod(lambda d: d["sensors"]["sar"].__setitem__("period_s", 0)),
             "key 'sensors.sar.period_s': Input should be greater than 0 (got 0)")
    scenario("nan-value", "" + yaml.safe_dump(mod(lambda d: d.__setitem__(
        "imu_period_s", 0.01)), sort_keys=False).replace("imu_period_s: 0.01",
                                                         "imu_period_s: .nan"),
             "key 'imu_period_s': Input should be a finite number (got nan)")
    scenario("unknown-filter", mod(lambda d: d["filter"].__setitem__("type", "ekf2")),
             "key 'filter.type': unknown filter 'ekf2'; registered:")
    scenario("unknown-aiding", mod(lambda d: d["modes"][1].__setitem__("aiding", ["gps"])),
             "key 'modes.1.aiding': unknown aiding sensor 'gps'; registered:")
    scenario("list-not-mapping", "- 1\n- 2\n", "expected a mapping at the top level")
    scenario("empty", "", "key 'name': missing value (and 4 more)")
    (HERE / "scenario-not-utf8.yaml").write_bytes("paper: '002'\nname: caf\u00e9\n"
                                                  .encode("latin-1"))
    yaml_case("yaml-scenario-not-utf8", ["reproduce", "002", "--scenario",
                                         "scenario-not-utf8.yaml", "--runs", "1", "--jobs", "1"],
              2, "error: scenario file scenario-not-utf8.yaml: not a UTF-8 text file")
    yaml_case("yaml-scenario-is-a-folder", ["reproduce", "002", "--scenario", G, "--runs", "1",
                                            "--jobs", "1"], 2,
              "error: scenario file good: is a folder, not a file")
    # --- CLI
    def cli_case(cid, argv, exit_code, message):
        cases.append({"id": cid, "family": "cli", "argv": argv, "exit": exit_code,
                      "message": message, "note": ""})

    cli_case("cli-runs-zero", ["reproduce", "002", "--runs", "0"], 2,
             "error: --runs must be at least 1, got 0")
    cli_case("cli-jobs-zero", ["reproduce", "002", "--jobs", "0"], 2,
             "error: --jobs must be at least 1, got 0")
    cli_case("cli-max-time-negative", ["reproduce", "002", "--max-time", "-5"], 2,
             "error: --max-time must be at least 1 s, got -5.0")
    cli_case("cli-unknown-paper", ["reproduce", "042"], 2, "error: unknown paper '042'; available:")
    cli_case("cli-dask-address-without-port", ["reproduce", "002", "--runs", "1", "--max-time",
                                               "10", "--dask", "localhost"], 2,
             "error: Dask scheduler address 'localhost':")
    cli_case("cli-dask-nothing-listening", ["reproduce", "002", "--runs", "1", "--max-time",
                                            "10", "--dask", "tcp://127.0.0.1:1"], 2,
             "error: Dask scheduler tcp://127.0.0.1:1: cannot connect (nothing listens on")
    (HERE / "a-file").write_text("not a folder\n")
    cli_case("cli-out-is-a-file", [*proc(), "--out", "a-file"], 2,
             "error: output folder a-file: a file of that name exists")
    cli_case("cli-reproduce-out-is-a-file", ["reproduce", "002", "--out", "a-file"], 2,
             "error: output folder a-file: a file of that name exists")
    cli_case("cli-out-unwritable", [*proc(), "--out", "/proc/fednav-cannot-write-here"], 2,
             "error: output folder /proc/fednav-cannot-write-here:")
    # an output folder holding one of the command's inputs where it would write
    (HERE / "sim-out").mkdir()
    shutil.copy(HERE.parents[2] / "examples" / "car-drive.yaml", HERE / "sim-out" / "process.yaml")
    cli_case("cli-simulate-out-holds-its-scenario",
             ["simulate", "sim-out/process.yaml", "--out", "sim-out"], 2,
             "error: --out sim-out: writing there would overwrite the scenario file "
             "sim-out/process.yaml, an input; choose another output folder")
    (HERE / "campaign-out").mkdir()
    shutil.copy(HERE.parents[2] / "src" / "fednav" / "scenarios" / "paper002.yaml",
                HERE / "campaign-out" / "summary.json")
    cli_case("cli-reproduce-scenario-where-it-writes",
             ["reproduce", "002", "--scenario", "campaign-out/summary.json", "--out",
              "campaign-out"], 2,
             "error: --out campaign-out: writing there would overwrite the scenario file "
             "campaign-out/summary.json, an input")
    cli_case("cli-simulate-seed-negative", ["simulate", "002", "--seed", "-1"], 2,
             "error: --seed must be 0 .. 2^63-1, got -1")
    sp = HERE / "with space"
    sp.mkdir()
    shutil.copy(GOOD / "imu.csv", sp / "imu data.csv")
    cli_case("cli-paths-with-spaces", proc("with space/imu data.csv",
                                           extra=["--out", "{out}/out dir"]), 0,
             "filter epochs in")
    (HERE / "cases.yaml").write_text(yaml.safe_dump(cases, sort_keys=False, width=120,
                                                    allow_unicode=True))
    print(f"{len(cases)} cases")


if __name__ == "__main__":
    main()
