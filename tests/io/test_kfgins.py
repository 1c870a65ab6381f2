"""KF-GINS's files and configuration: a KF-GINS user's folder, written here in KF-GINS's
layout from a simulated drive, read back to the same samples and the same solution as
fednav's own CSV path; every key of its configuration accounted for."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_process import LEVER, make_flight  # noqa: E402

from fednav.core import units  # noqa: E402
from fednav.io import DataError  # noqa: E402
from fednav.io.kfgins import (  # noqa: E402
    read_kfgins_gnss,
    read_kfgins_imu,
    read_kfgins_nav,
    write_kfgins_nav,
)
from fednav.io.navego import FRD_TO_RFU, fednav_euler_to_navego  # noqa: E402
from fednav.navigator.system import System  # noqa: E402
from fednav.process.kfgins import KEYS, read_kfgins, translate  # noqa: E402

WEEK_S = 456_000.0  # (a GPS second of the week the drive starts at)
SECONDS = 90.0

#: KF-GINS's own template (config/kf-gins.yaml of its repository), values as published
TEMPLATE = {
    "imudatalen": 7, "imudatarate": 100, "starttime": 0, "endtime": -1,
    "initgyrbias": [0, 0, 0], "initaccbias": [0, 0, 0], "initgyrscale": [0, 0, 0],
    "initaccscale": [0, 0, 0], "initposstd": [0.1, 0.1, 0.2], "initvelstd": [0.05] * 3,
    "initattstd": [0.5, 0.5, 1.0],
    "imunoise": {"arw": [0.24] * 3, "vrw": [0.24] * 3, "gbstd": [50.0] * 3,
                 "abstd": [250.0] * 3, "gsstd": [1000.0] * 3, "asstd": [1000.0] * 3,
                 "corrtime": 1.0},
}


@pytest.fixture(scope="module")
def drive():
    return make_flight()


def write_folder(folder: Path, drive, seconds=SECONDS, gnss_columns=7, **cfg) -> Path:
    """A KF-GINS user's folder: Leador-style IMU text (increments FRD, stamped at each
    interval's end, GPS seconds of the week), GNSS-RTK text, kf-gins.yaml, truth.nav."""
    imu, gnss, ref = drive
    folder.mkdir(parents=True, exist_ok=True)
    dt = imu.period()
    n = int(seconds / dt)
    t_end = imu.t[:n] + dt + WEEK_S
    frd = FRD_TO_RFU  # (its own inverse)
    rows = np.column_stack([t_end, imu.gyro[:n] @ frd.T * dt, imu.accel[:n] @ frd.T * dt])
    np.savetxt(folder / "imu.txt", rows, fmt="%.3f" + " %.12e" * 6)
    keep = gnss.t + WEEK_S <= t_end[-1]
    lat, lon = units.to_deg(gnss.lla[keep, 0]), units.to_deg(gnss.lla[keep, 1])
    ned_sd = np.tile(gnss.sigma_pos_enu[[1, 0, 2]], (keep.sum(), 1))
    cols = [gnss.t[keep] + WEEK_S, lat, lon, gnss.lla[keep, 2]]
    if gnss_columns == 13:
        v = gnss.vel[keep]
        cols += [v[:, 1], v[:, 0], -v[:, 2], ned_sd, np.tile(gnss.sigma_vel, (keep.sum(), 1))]
    else:
        cols += [ned_sd]
    np.savetxt(folder / "gnss.txt", np.column_stack(cols), fmt="%.3f %.10f %.10f"
               + " %.4f" * (len(np.column_stack(cols)[0]) - 3))
    # the truth at the start (KF-GINS starts from a given state)
    k = int(np.searchsorted(ref.t, imu.t[1] - 1e-9))
    roll, pitch, yaw = (units.to_deg(a) for a in fednav_euler_to_navego(ref.euler[k]))
    vel = ref.vel[k]
    config = {**TEMPLATE, "imupath": "imu.txt", "gnsspath": "gnss.txt", "outputpath": ".",
              "starttime": float(t_end[0]), "initpos": [float(units.to_deg(ref.lla[k, 0])),
                                                        float(units.to_deg(ref.lla[k, 1])),
                                                        float(ref.lla[k, 2])],
              "initvel": [float(vel[1]), float(vel[0]), float(-vel[2])],
              "initatt": [float(roll), float(pitch), float(yaw % 360.0)],
              "antlever": [float(LEVER[1]), float(LEVER[0]), float(-LEVER[2])], **cfg}
    (folder / "kf-gins.yaml").write_text(yaml.safe_dump(config))
    keep = ref.t <= t_end[-1] - WEEK_S
    write_kfgins_nav(folder / "truth.nav", ref.t[keep] + WEEK_S, ref.lla[keep],
                     ref.vel[keep], ref.euler[keep])
    return folder / "kf-gins.yaml"


def test_every_key_is_accounted_for(tmp_path, drive):
    cfg = write_folder(tmp_path / "d", drive, initbgstd=[80.0, 80.0, 80.0],
                       unexpected_key=3)
    tr = translate(cfg)
    fates = {k.key: k for k in tr.keys}
    assert set(KEYS) <= set(fates)  # every key KF-GINS reads
    assert fates["unexpected_key"].fate == "unknown"
    assert fates["outputpath"].fate == "ignored"
    assert all(k.fate in ("used", "translated", "ignored", "unknown") for k in tr.keys)
    s = tr.system
    # units: deg/sqrt(h) as is; m/s/sqrt(h) / 60; deg/h; mGal 1e-5; h -> s; ppm
    assert s["imu"]["gyro_arw_deg_sqrt_h"] == 0.24
    assert s["imu"]["accel_vrw_mps_sqrt_s"] == pytest.approx(0.24 / 60.0)
    assert s["imu"]["gyro_markov_deg_h"] == 50.0
    assert s["imu"]["accel_markov_mps2"] == pytest.approx(250e-5)
    assert s["imu"]["gyro_markov_tau_s"] == 3600.0
    assert s["imu"]["gyro_bias_deg_h"] == pytest.approx(np.sqrt(80.0**2 - 50.0**2))
    assert s["imu"]["gyro_scale_ppm"] == 1000.0
    assert s["filter"] == {"accel_bias": "gauss_markov",
                           "states": ["gyro_scale", "accel_scale"]}
    # frames: the lever arm FRD -> RFU, the velocity NED -> ENU
    np.testing.assert_allclose(s["sensors"]["gnss"]["lever_m"], LEVER)
    _, _, ref = drive
    k = int(np.searchsorted(ref.t, drive[0].t[1] - 1e-9))
    np.testing.assert_allclose(s["initial"]["vel_mps"], ref.vel[k], atol=1e-12)
    np.testing.assert_allclose(s["initial"]["euler_deg"][:2], units.to_deg(ref.euler[k, :2]),
                               atol=1e-9)
    assert s["initial"]["euler_deg"][2] == pytest.approx(units.to_deg(ref.euler[k, 2]) % 360)
    # Euler sigmas [roll 0.5, pitch 0.5, yaw 1.0] deg: the tilts' misalignment sigma is the
    # same 0.5 deg whatever the heading (equal roll and pitch), the heading's 1 deg (level)
    att = np.asarray(s["initial"]["sigma"]["attitude_arcsec"]) / 3600.0
    np.testing.assert_allclose(att[:2], 0.5, rtol=0.02)
    assert att[2] == pytest.approx(1.0, rel=0.05)
    assert s["initial"]["sigma"]["position_m"] == [0.1, 0.1, 0.2]


def test_files_read_back_to_the_same_samples(tmp_path, drive):
    imu, gnss, _ = drive
    cfg = write_folder(tmp_path / "d", drive, gnss_columns=13)
    tr = translate(cfg)
    k = read_kfgins_imu(tr.imu, start_s=tr.start_s, rate_hz=tr.rate_hz)
    n = len(k.t)
    # the first row ends at starttime: its interval starts one period before
    np.testing.assert_allclose(k.t - WEEK_S, imu.t[:n], atol=2e-6)
    np.testing.assert_allclose(k.gyro, imu.gyro[:n], rtol=1e-8, atol=1e-14)  # (stamps)
    np.testing.assert_allclose(k.accel, imu.accel[:n], rtol=1e-8, atol=1e-12)
    assert k.mounting_name == "FRD"
    g = read_kfgins_gnss(tr.gnss, lever=LEVER, start_s=tr.start_s)
    m = len(g.t)
    first = int(np.searchsorted(gnss.t + WEEK_S, g.t[0] - 1e-6))
    np.testing.assert_allclose(g.lla[:, :2], gnss.lla[first:first + m, :2], atol=1e-10)
    np.testing.assert_allclose(g.vel, gnss.vel[first:first + m], atol=1e-4)
    np.testing.assert_allclose(g.sigma_rows[0], np.r_[gnss.sigma_pos_enu[[1, 0, 2]],
                                                      gnss.sigma_vel])
    assert read_kfgins_gnss(tr.gnss, velocity=False).vel is None


def test_nav_file_round_trip_and_plot_script_layout(tmp_path, drive):
    _, _, ref = drive
    p = write_kfgins_nav(tmp_path / "x.nav", ref.t[:500], ref.lla[:500], ref.vel[:500],
                         ref.euler[:500])
    a = np.loadtxt(p)  # what KF-GINS's plot_navresult.py does
    assert a.shape == (500, 11)
    assert (a[:, 0] == 0).all()
    np.testing.assert_allclose(a[:, 5], ref.vel[:500, 1], atol=1e-4)  # north
    np.testing.assert_allclose(a[:, 7], -ref.vel[:500, 2], atol=1e-4)  # down
    back = read_kfgins_nav(p)
    np.testing.assert_allclose(back.lla[:, :2], ref.lla[:500, :2], atol=1e-11)
    np.testing.assert_allclose(back.euler, ref.euler[:500], atol=1e-9)


def test_same_solution_as_the_csv_path(tmp_path, drive):
    """The folder through the KF-GINS readers and the same samples and fixes written as
    fednav CSV files, read back with fednav's CSV readers: the same solution with the
    translated description; against the truth, as good as the simulation allows."""
    from fednav.io import read_gnss_csv, read_imu_csv
    from fednav.io.csvdata import write_csv
    from fednav.process import process

    cfg = write_folder(tmp_path / "d", drive)
    data = read_kfgins(cfg)
    imu, g, system = data["imu"], data["sensors"]["gnss"], data["system"]
    res = process(imu, data["sensors"], system)
    c = tmp_path / "csv"
    c.mkdir()
    write_csv(c / "imu.csv", {"t_s": imu.t, **{
        f"{k}_{a}_{u}": v[:, i] for k, v, u in (("gyro", imu.gyro, "radps"),
                                                ("accel", imu.accel, "mps2"))
        for i, a in enumerate("xyz")}}, significant=17)
    write_csv(c / "gnss.csv", {
        "t_s": g.t, "lat_deg": units.to_deg(g.lla[:, 0]), "lon_deg": units.to_deg(g.lla[:, 1]),
        "h_m": g.lla[:, 2], "sigma_north_m": g.sigma_rows[:, 0],
        "sigma_east_m": g.sigma_rows[:, 1], "sigma_up_m": g.sigma_rows[:, 2]}, significant=17)
    imu_c = read_imu_csv(c / "imu.csv")
    g_c = read_gnss_csv(c / "gnss.csv", lever=g.lever)
    np.testing.assert_array_equal(imu_c.gyro, imu.gyro)
    np.testing.assert_array_equal(g_c.lla, g.lla)
    res_c = process(imu_c, {"gnss": g_c}, system)
    a, b = res.forward, res_c.forward
    np.testing.assert_allclose(a.t, b.t, rtol=0, atol=1e-9)
    # (the KF-GINS path integrates the file's own increments; the CSV path their rates:
    # equal to rounding)
    np.testing.assert_allclose(a.lla[:, :2], b.lla[:, :2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.lla[:, 2], b.lla[:, 2], rtol=0, atol=1e-6)
    np.testing.assert_allclose(a.vel, b.vel, rtol=0, atol=1e-6)
    np.testing.assert_allclose(a.sigma, b.sigma, rtol=1e-6, atol=1e-12)
    ref = data["ref"]
    assert ref is not None and any("truth.nav" in w for w in data["warnings"])
    from fednav.process.evaluation import errors_against, rmse

    r = rmse(errors_against(a, ref))
    assert r["east_m"] < 1.0 and r["north_m"] < 1.0  # (1 m GNSS noise)


def test_cli_runs_the_folder_and_writes_the_nav_file(tmp_path, drive):
    from typer.testing import CliRunner

    from fednav.cli import app

    cfg = write_folder(tmp_path / "d", drive, seconds=60.0)
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["process", "kfgins", str(cfg.parent), "--out", str(out)])
    assert r.exit_code == 0, r.output
    nav = np.loadtxt(out / "KF_GINS_Navresult.nav")
    assert nav.shape[1] == 11
    s = json.loads((out / "summary.json").read_text())
    assert s["rmse"]["east_m"] < 3.0
    r = CliRunner().invoke(app, ["process", "kfgins", str(cfg), "--keys"])
    assert r.exit_code == 0 and "imunoise.corrtime" in r.output


def test_the_command_does_not_import_pandas(tmp_path, drive):
    """``fednav process kfgins`` reads plain text with numpy and prints its tables without
    the campaign reports: pandas is not imported (0.25 s of a 1.7 s command; issue 39).
    A file pandas must explain still gets its one line (test_bad_folders_...)."""
    import subprocess
    import sys

    cfg = write_folder(tmp_path / "d", drive, seconds=20.0)
    code = ("import sys; from fednav.cli import app; "
            f"app(['process', 'kfgins', {str(cfg.parent)!r}, '--out', "
            f"{str(tmp_path / 'out')!r}], standalone_mode=False); "
            "print('pandas' in sys.modules)")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip().splitlines()[-1] == "False", res.stdout[-2000:]


@pytest.mark.parametrize(("text", "message"), [
    ("1 2 3 4 5 6 7\n1 2 3 4 5 6\n1 2 3 4 5 6 7 8\n", "Expected 7 fields in line 3"),
    ("1 2 3 4 5 6 7\n2 nan 3 4 5 6 7\n", "row 2 has fewer numbers")])
def test_rows_that_numpy_would_take_wrongly_are_refused(tmp_path, text, message):
    """Rows of other widths whose numbers add up to whole rows, and 'nan' text: refused
    with pandas' line, as before the numpy reader."""
    from fednav.io.kfgins import read_table

    f = tmp_path / "imu.txt"
    f.write_text(text)
    with pytest.raises(DataError, match=message):
        read_table(f, "IMU", (7,))


def test_known_initial_errors_are_taken_out_of_the_increments(tmp_path, drive):
    cfg = write_folder(tmp_path / "d", drive, initgyrbias=[36.0, 0.0, 0.0],
                       initaccscale=[0.0, 0.0, 1000.0])
    tr = translate(cfg)
    assert tr.fate("initgyrbias").fate == "translated"
    plain = read_kfgins_imu(tr.imu, start_s=tr.start_s)
    k = read_kfgins_imu(tr.imu, start_s=tr.start_s, known_errors=tr.known_errors)
    # 36 deg/h on FRD x = fednav forward (y): taken out
    np.testing.assert_allclose(plain.gyro[:, 1] - k.gyro[:, 1], units.deg_per_h(36.0),
                               rtol=1e-6)
    np.testing.assert_allclose(k.gyro[:, 0], plain.gyro[:, 0])
    # 1000 ppm on FRD z = fednav up (sign flips, the scale does not)
    np.testing.assert_allclose(k.accel[:, 2], plain.accel[:, 2] / 1.001, rtol=1e-12)


def test_bad_folders_and_files_are_one_line(tmp_path, drive):
    from fednav.core.config import ConfigError
    from fednav.process.kfgins import find_config

    with pytest.raises(ConfigError, match="no KF-GINS configuration"):
        find_config(tmp_path)
    cfg = write_folder(tmp_path / "d", drive, seconds=20.0)
    text = yaml.safe_load(cfg.read_text())
    del text["imunoise"]["corrtime"]
    bad = tmp_path / "d" / "bad.yaml"
    bad.write_text(yaml.safe_dump(text))
    with pytest.raises(ConfigError, match="missing imunoise.corrtime"):
        translate(bad)
    with pytest.raises(ConfigError, match="several|2 KF-GINS"):
        find_config(tmp_path / "d")
    text = yaml.safe_load(cfg.read_text())
    text["imudatarate"] = 200
    cfg.write_text(yaml.safe_dump(text))
    bad.unlink()
    with pytest.warns(UserWarning, match="imudatarate says 200 Hz"):
        read_kfgins(cfg)
    (tmp_path / "six.txt").write_text("1 2 3 4 5 6\n2 3 4 5 6 7\n")
    with pytest.raises(DataError, match="6 columns; a KF-GINS IMU file has 7"):
        read_kfgins_imu(tmp_path / "six.txt")
    (tmp_path / "g.txt").write_text("1 2 3 4 5 6 7\n2 3 4 5 6\n")
    with pytest.raises(DataError, match="row 2 has fewer numbers"):
        read_kfgins_gnss(tmp_path / "g.txt")
    (tmp_path / "t.txt").write_text("time lat lon\n")
    with pytest.raises(DataError, match="not a KF-GINS GNSS file"):
        read_kfgins_gnss(tmp_path / "t.txt")


def test_an_imu_clock_off_its_rate_drifts_the_epochs_against_the_fixes():
    """25 samples of an IMU 294 ppm slow span 0.250073 s against fixes 0.25 s apart: over
    2 000 epochs the grid drifts 0.15 s — warned, with the period that bounds the wait;
    the KF-GINS translation sets that period itself (KF-GINS updates at each fix)."""
    from types import SimpleNamespace

    from fednav.navigator.system import System
    from fednav.process.run import epoch_drift

    dt = 0.0100029
    gnss = SimpleNamespace(t=np.arange(0.0, 500.0, 0.25))
    q = {}
    w = epoch_drift(System(), gnss, 25 * dt, dt, 2000, q)
    assert len(w) == 1 and "drift against the GNSS fixes" in w[0]
    assert "0.0500145 s, 5 IMU samples" in w[0]
    assert q["epoch_drift_s"] == pytest.approx(2000 * 25 * 2.9e-6, rel=1e-3)
    assert epoch_drift(System(), gnss, 25 * 0.01, 0.01, 2000, {}) == []  # (no drift)
    fixed = System.model_validate({"filter": {"period_s": 0.05}})
    assert epoch_drift(fixed, gnss, 25 * dt, dt, 2000, {}) == []  # (the user chose)


def test_the_translation_updates_within_a_fifth_of_the_fix_interval(tmp_path, drive):
    cfg = write_folder(tmp_path / "d", drive, seconds=20.0)
    data = read_kfgins(cfg)
    assert data["system"].filter.period_s == pytest.approx(0.04)  # 100 Hz IMU, 5 Hz fixes
    user = System.model_validate({"filter": {"period_s": 0.2},
                                  "sensors": {"gnss": {"timing": {"latency_s": 0.0}}}})
    data = read_kfgins(cfg, user)
    assert data["system"].filter.period_s == 0.2  # (--config wins)
    np.testing.assert_allclose(data["sensors"]["gnss"].lever, LEVER)  # (kept)


def test_scale_factors_are_gauss_markov_as_kfgins_models_them(tmp_path, drive):
    """gsstd with corrtime: Gauss–Markov scale states (stationary sigma, correlation
    time, process noise 2 sigma^2 / tau); gsstd 0 with initsgstd: random constants."""
    from fednav.navigator.system import state_layout

    cfg = write_folder(tmp_path / "d", drive, seconds=20.0)
    system = System.model_validate(translate(cfg).system)
    layout = state_layout(system)
    blocks = {name: (sigma, tau) for name, sigma, tau, _ in layout.blocks}
    assert blocks["gyro_scale"] == ((1e-3,) * 3, 3600.0)
    assert blocks["accel_scale"] == ((1e-3,) * 3, 3600.0)
    text = yaml.safe_load(cfg.read_text())
    text["imunoise"]["gsstd"] = [0.0] * 3
    text["initsgstd"] = [500.0] * 3
    cfg.write_text(yaml.safe_dump(text))
    tr = translate(cfg)
    layout = state_layout(System.model_validate(tr.system))
    blocks = {name: (sigma, tau) for name, sigma, tau, _ in layout.blocks}
    assert blocks["gyro_scale"] == ((5e-4,) * 3, float("inf"))
    assert tr.fate("imunoise.gsstd").detail.startswith("zero: the gyro scale factors")
