"""fednav.process.tuning (``fednav tune``): noise figures estimated from the data alone."""

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fednav import load_system
from fednav.cli import app
from fednav.io import read_gnss_csv, read_imu_csv
from fednav.process.tuning import (
    LR_95,
    NIS_BAND,
    evaluate,
    tune,
    white_noise,
    white_noise_floor,
)
from fednav.sim.dataset import (
    gauss_markov,
    load_dataset_config,
    process_config,
    simulate_dataset,
    write_csv_dataset,
)

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "car-drive.yaml"


def test_white_noise_density_ignores_the_motion():
    rng = np.random.default_rng(3)
    dt, n, density = 0.005, 40_000, 2e-3  # [unit sqrt(s)]
    t = dt * np.arange(n)
    motion = 0.5 * np.sin(0.3 * t)[:, None] + 5.0 * (t // 10.0)[:, None]  # smooth + steps
    x = motion + density / np.sqrt(dt) * rng.standard_normal((n, 3))
    np.testing.assert_allclose(white_noise(x, dt), density, rtol=0.03)


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """examples/car-drive.yaml, GNSS only, as CSV; its true figures."""
    cfg = load_dataset_config(EXAMPLE).model_copy(update={"velocity": None})
    ds = simulate_dataset(cfg)
    d = tmp_path_factory.mktemp("tune")
    write_csv_dataset(ds, d)
    truth = process_config(ds)
    # what a user has before tuning: the CSV reader's default GNSS sigmas, no IMU figures
    g = read_gnss_csv(d / "gnss.csv", (5.0, 5.0, 5.0), (0.1, 0.1, 0.1),
                      truth["sensors"]["gnss"]["lever_m"])
    return read_imu_csv(d / "imu.csv"), g, truth


def within(value, true, factor=1.5):
    ratio = np.asarray(value, dtype=float) / np.asarray(true, dtype=float)
    return bool(np.all((ratio <= factor) & (ratio >= 1.0 / factor)))


@pytest.mark.slow
def test_tune_recovers_the_figures_of_a_simulated_drive(drive):
    imu, g, truth = drive
    base = load_system({"sensors": {"gnss": {"lever_m": truth["sensors"]["gnss"]["lever_m"]}}})
    res = tune(imu, {"gnss": g}, base)
    fig = {f.key: f for f in res.figures}
    for key in ("sigma_pos_enu_m", "sigma_vel_mps"):
        f, true = fig[f"sensors.gnss.{key}"], truth["sensors"]["gnss"][key]
        assert within(f.value, true, 1.1), (key, f.value, true)
    for key in ("gyro_arw_rad_sqrt_s", "accel_vrw_mps_sqrt_s"):
        assert within(fig[f"imu.{key}"].value, truth["imu"][key]), key
    # The bias instabilities: recovered, or kept because the likelihood cannot tell, and
    # then the true figure is no better than the one kept.
    for key in ("gyro_markov_radps", "accel_markov_mps2"):
        f = fig[f"imu.{key}"]
        if not within(f.value, truth["imu"][key]):
            assert f.how.startswith("kept"), (key, f)
            imu_true = {**res.config.imu.model_dump(exclude_none=True), key: truth["imu"][key]}
            at_truth = evaluate(imu, {"gnss": g}, res.config.model_copy(
                update={"imu": res.config.imu.model_copy(update=imu_true)}))
            assert at_truth.loglik - res.after.loglik < LR_95, key
    assert 0.9 < res.after.nis_per_dof["gnss"] < 1.1
    assert res.before.nis_per_dof["gnss"] < 0.5  # the 5 m default was far too pessimistic
    assert res.after.loglik > res.before.loglik


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    cfg = load_dataset_config(EXAMPLE)
    d = tmp_path_factory.mktemp("short")
    write_csv_dataset(simulate_dataset(cfg.model_copy(update={"segments": cfg.segments[:6]})),
                      d)
    return d


@pytest.mark.slow
def test_cli_tune_writes_a_config_that_process_accepts(short, tmp_path):
    base = tmp_path / "base.yaml"
    base.write_text("gnss_lever_m: [0.3, -1.0, 1.2]\nimu: {gyro_arw_rad_sqrt_s: 1.0e-3}\n"
                    "fdi_alpha: {velocity: 0.01}\n")
    out = tmp_path / "tuned.yaml"
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--velocity",
                                 str(short / "velocity.csv"), "--config", str(base),
                                 "--out", str(out), "--fix", "gyro_arw_rad_sqrt_s"])
    assert r.exit_code == 0, r.output
    assert "held-back NIS/dof" in r.output and "velocity.sigma_mps" in r.output
    assert "no GNSS antenna lever arm" not in r.output
    cfg = load_system(out)  # the base config's 0.1 keys are written in today's places
    text = out.read_text()
    assert "gnss_lever_m" not in text
    assert cfg.sensors.gnss.lever_m == (0.3, -1.0, 1.2)
    assert cfg.filter.fdi_alpha == {"velocity": 0.01}
    assert cfg.imu.gyro_arw_rad_sqrt_s == 1.0e-3  # marked fixed: kept
    assert "# imu.gyro_arw_rad_sqrt_s: 0.001 -> 0.001 (kept: marked fixed)" in text
    assert cfg.sensors.velocity is None  # the file gives the velocity sigma: kept there
    assert cfg.sensors.gnss.sigma_pos_enu_m is not None  # nobody gave it: estimated
    assert cfg.imu.accel_vrw_mps_sqrt_s is not None
    assert "# held-back NIS/dof" in text
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--config", str(out), "--out",
                                 str(tmp_path / "run"), "--output-rate", "1"])
    assert r.exit_code == 0, r.output
    # --tune-sensors estimates the velocity sensor's sigma too (floored at its scatter)
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--velocity",
                                 str(short / "velocity.csv"), "--config", str(base),
                                 "--out", str(out), "--tune-sensors", "--outages", "0"])
    assert r.exit_code == 0, r.output
    assert load_system(out).sensors.velocity.sigma_mps is not None
    assert "drift through" not in r.output


def test_cli_tune_bad_input_is_one_line(short, tmp_path):
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(tmp_path / "none.csv"),
                                 "--gnss", str(short / "gnss.csv"), "--out",
                                 str(tmp_path / "t.yaml")])
    assert r.exit_code == 2 and "none.csv" in r.output and "Traceback" not in r.output
    bad = tmp_path / "bad.yaml"
    bad.write_text("imu: {gyro_arw: 1}\n")
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--config", str(bad)])
    assert r.exit_code == 2 and "gyro_arw" in r.output
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--fix", "lever_m"])
    assert r.exit_code == 2 and "--fix lever_m" in r.output and "Traceback" not in r.output


# -- a drive like the maintainers' car: a vibrating MEMS IMU (white noise 30 x its data
# sheet), GNSS positions with time-correlated errors, a known antenna lever arm

#: the data sheet's figures of the drive's IMU: white noise 30 x, bias instability 5 x
#: too optimistic (the true figures: process.yaml of the drive)
def datasheet(truth: dict) -> dict:
    return {k: v / 30 if k.endswith("sqrt_s") else v / 5 if "markov" in k else v
            for k, v in truth["imu"].items()}


@pytest.fixture(scope="module")
def gm_drive(tmp_path_factory):
    """A 336 s car drive, GNSS only: white 0.5 m + Gauss-Markov 1 m (60 s) position
    errors; the receiver reports the whole error's sigma (process.yaml)."""
    cfg = load_dataset_config(EXAMPLE)
    cfg = cfg.model_copy(update={
        "velocity": None, "segments": cfg.segments[:20],
        "imu": cfg.imu.model_copy(update={"gyro_arw_deg_sqrt_h": 10.0,
                                          "accel_vrw_ug_sqrt_hz": 2000.0}),
        "gnss": cfg.gnss.model_copy(update={"sigma_pos_enu_m": (0.5, 0.5, 1.0),
                                            "markov_sigma_enu_m": (1.0, 1.0, 2.0),
                                            "markov_tau_s": 60.0})})
    d = tmp_path_factory.mktemp("gm")
    ds = simulate_dataset(cfg)
    write_csv_dataset(ds, d)
    truth = process_config(ds)
    g = truth["sensors"]["gnss"]
    gnss = read_gnss_csv(d / "gnss.csv", g["sigma_pos_enu_m"], g["sigma_vel_mps"],
                         g["lever_m"])
    return read_imu_csv(d / "imu.csv"), gnss, truth, d


def in_band(nis: dict) -> bool:
    return all(NIS_BAND[0] <= v <= NIS_BAND[1] for v in nis.values())


@pytest.mark.slow
def test_tune_keeps_held_back_nis_in_band_with_correlated_gnss_errors(gm_drive):
    imu, gnss, truth, _ = gm_drive
    g = truth["sensors"]["gnss"]
    base = load_system({"imu": datasheet(truth), "sensors": {"gnss": g}})
    res = tune(imu, {"gnss": gnss}, base)
    assert res.before.nis_held["gnss"] > 2.0  # the data sheet: overconfident
    assert res.accepted and in_band(res.after.nis_held), res.summary()
    assert res.after.loglik_held > res.before.loglik_held
    assert not res.warnings
    # the receiver's sigma and the lever arm are kept
    c = res.config.sensors.gnss
    assert c.sigma_pos_enu_m == tuple(g["sigma_pos_enu_m"])
    assert c.sigma_vel_mps == tuple(g["sigma_vel_mps"])
    assert c.lever_m == tuple(g["lever_m"])
    # the base's figures were the start, not a constraint: the white noise is raised to
    # (at least) what the sample scatter supports, which is the true figure here
    fig = {f.key: f for f in res.figures}
    for key in ("gyro_arw_rad_sqrt_s", "accel_vrw_mps_sqrt_s"):
        f = fig[f"imu.{key}"]
        assert f.value >= f.floor and within(f.value, truth["imu"][key], 1.1), (key, f)
        assert res.config.imu.si(key.split("_")[0] + ("_arw" if "gyro" in key else "_vrw")) \
            == f.value
    # the drift through the outages it simulated (2 x 30 s, in held-back blocks) is
    # reported, not scored: over so few outages it is much a matter of chance
    assert len(res.outages) == 2 and all(res.blocks.held(np.mean(w)) for w in res.outages)
    assert len(res.drift_before) == len(res.drift_after) == 2
    assert np.all(np.isfinite(res.drift_after)) and "drift through 2" in res.summary()[2]


@pytest.mark.slow
def test_tune_never_makes_the_held_back_fit_worse(gm_drive):
    imu, gnss, truth, _ = gm_drive
    base = load_system(truth)  # already right
    res = tune(imu, {"gnss": gnss}, base, outages=0)
    assert res.after.loglik_held >= res.before.loglik_held
    assert in_band(res.after.nis_held)
    if not res.accepted:  # then the base's figures are what it gives back
        for k, v in truth["imu"].items():
            assert res.config.imu.model_dump()[k] == pytest.approx(v, rel=1e-12), k
        assert any("held-back" in n for n in res.notes)
    else:
        assert res.tuned.loglik_held >= res.before.loglik_held


@pytest.mark.slow
def test_tuned_sensor_sigma_never_falls_below_the_data_scatter(gm_drive):
    imu, gnss, truth, _ = gm_drive
    base = load_system({"imu": datasheet(truth), "sensors": {"gnss": truth["sensors"]["gnss"]}})
    res = tune(imu, {"gnss": gnss}, base, tune_sensors=True, outages=0)
    fig = {f.key: f for f in res.figures}
    pos, vel = fig["sensors.gnss.sigma_pos_enu_m"], fig["sensors.gnss.sigma_vel_mps"]
    # the floors: the white parts (0.5, 0.5, 1.0 m; 0.05, 0.05, 0.1 m/s)
    assert within(pos.floor, [0.5, 0.5, 1.0], 1.15) and within(vel.floor, [0.05, 0.05, 0.1],
                                                                 1.15)
    for f in (pos, vel):
        assert f.how.startswith("innovation covariance") and np.all(
            np.asarray(f.value) >= np.asarray(f.floor) * (1 - 1e-9)), f
    # matching a time-correlated error drives the sigma toward its white part: below the
    # receiver's, which the default keeps
    assert np.all(np.asarray(pos.value) < np.asarray(pos.start))
    assert res.after.loglik_held >= res.before.loglik_held and in_band(res.after.nis_held)


@pytest.mark.slow
def test_tune_keeps_a_figure_marked_fixed(gm_drive):
    imu, gnss, truth, _ = gm_drive
    sheet = datasheet(truth)
    base = load_system({"imu": sheet, "sensors": {"gnss": truth["sensors"]["gnss"]}})
    res = tune(imu, {"gnss": gnss}, base, fixed=["imu.gyro_arw_rad_sqrt_s", "accel_markov_ug"],
               outages=0)
    fig = {f.key: f for f in res.figures}
    f = fig["imu.gyro_arw_rad_sqrt_s"]
    assert f.value == sheet["gyro_arw_rad_sqrt_s"] and f.how.startswith("kept: marked fixed")
    assert "below the floor" in f.how
    assert res.config.imu.gyro_arw_rad_sqrt_s == sheet["gyro_arw_rad_sqrt_s"]
    assert res.config.imu.accel_markov_mps2 == sheet["accel_markov_mps2"]
    assert fig["imu.accel_vrw_mps_sqrt_s"].value > 10 * sheet["accel_vrw_mps_sqrt_s"]


@pytest.mark.slow
def test_tune_says_when_no_lever_arm_is_set(gm_drive, tmp_path):
    imu, _, truth, d = gm_drive
    gnss = read_gnss_csv(d / "gnss.csv")
    res = tune(imu, {"gnss": gnss}, load_system({"imu": truth["imu"]}), matching_passes=1,
               outages=0)
    assert any(n.startswith("no GNSS antenna lever arm is set") for n in res.warnings)
    base = tmp_path / "base.yaml"
    base.write_text("imu: {gyro_arw_deg_sqrt_h: 0.3}\n")
    out = tmp_path / "tuned.yaml"
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(d / "imu.csv"), "--gnss",
                                 str(d / "gnss.csv"), "--config", str(base), "--out", str(out),
                                 "--outages", "0"])
    assert r.exit_code == 0, r.output
    err = getattr(r, "stderr", r.output)
    assert "warning: no GNSS antenna lever arm is set" in err
    # in the table's output too (each row's "why" is one line under the table)
    assert any("sensors.gnss.lever_m" in line and "WARNING" in line
               for line in r.output.splitlines()), r.output
    assert "# WARNING: no GNSS antenna lever arm" in out.read_text()


def test_white_noise_floor_sees_through_vibration():
    rng = np.random.default_rng(5)
    dt, n, density = 0.005, 60_000, 2e-3
    t = dt * np.arange(n)
    vib = 0.3 * np.sin(2 * np.pi * 40.0 * t)[:, None]  # 40 Hz engine vibration
    x = 0.5 * np.sin(0.3 * t)[:, None] + vib + density / np.sqrt(dt) * rng.standard_normal(
        (n, 3))
    assert np.all(white_noise(x, dt) > 5 * density)  # the sample scatter holds it
    assert white_noise_floor(x, dt, 40) == pytest.approx(density, rel=0.1)


def test_gauss_markov_gnss_errors_are_off_by_default():
    cfg = load_dataset_config(EXAMPLE)
    cfg = cfg.model_copy(update={"segments": cfg.segments[:3]})
    a = simulate_dataset(cfg)
    on = cfg.model_copy(update={"gnss": cfg.gnss.model_copy(
        update={"markov_sigma_enu_m": (2.0, 1.0, 0.0), "markov_tau_s": 30.0})})
    b = simulate_dataset(on)
    # its own random stream: every other draw is the same with it
    np.testing.assert_array_equal(a.gyro, b.gyro)
    np.testing.assert_array_equal(a.gnss_vel, b.gnss_vel)
    np.testing.assert_array_equal(a.vel, b.vel)
    assert np.any(a.gnss_lla[:, :2] != b.gnss_lla[:, :2])
    np.testing.assert_array_equal(a.gnss_lla[:, 2], b.gnss_lla[:, 2])  # (up: sigma 0)
    assert process_config(a)["sensors"]["gnss"]["sigma_pos_enu_m"] == [1.5, 1.5, 3.0]
    assert process_config(b)["sensors"]["gnss"]["sigma_pos_enu_m"] == pytest.approx(
        [np.hypot(1.5, 2.0), np.hypot(1.5, 1.0), 3.0])  # east, north, up
    x = gauss_markov(100_000, 0.2, [1.0, 2.0], 10.0, np.random.default_rng(1))
    np.testing.assert_allclose(x.std(axis=0), [1.0, 2.0], rtol=0.05)
    lag = 50  # 10 s: correlation exp(-1)
    assert np.corrcoef(x[:-lag, 0], x[lag:, 0])[0, 1] == pytest.approx(np.exp(-1), abs=0.05)
