"""fednav.process.tuning (``fednav tune``): noise figures estimated from the data alone."""

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fednav import load_system
from fednav.cli import app
from fednav.io import read_gnss_csv, read_imu_csv
from fednav.process.tuning import LR_95, evaluate, tune, white_noise
from fednav.sim.dataset import (
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


def test_tune_recovers_the_figures_of_a_simulated_drive(drive):
    imu, g, truth = drive
    base = load_system({"sensors": {"gnss": {"lever_m": truth["sensors"]["gnss"]["lever_m"]}}})
    res = tune(imu, g, None, base)
    fig = {f.key: f for f in res.figures}
    for key in ("sigma_pos_m", "sigma_vel_mps"):
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
            at_truth = evaluate(imu, g, None, res.config.model_copy(
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


def test_cli_tune_writes_a_config_that_process_accepts(short, tmp_path):
    base = tmp_path / "base.yaml"
    base.write_text("gnss_lever_m: [0.3, -1.0, 1.2]\nimu: {gyro_arw_rad_sqrt_s: 1.0e-3}\n"
                    "fdi_alpha: {velocity: 0.01}\n")
    out = tmp_path / "tuned.yaml"
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--velocity",
                                 str(short / "velocity.csv"), "--config", str(base),
                                 "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "NIS/dof before -> after" in r.output and "velocity.sigma_mps" in r.output
    assert "no GNSS antenna lever arm" not in r.output
    cfg = load_system(out)  # the base config's 0.1 keys are written in today's places
    assert "gnss_lever_m" not in out.read_text()
    assert cfg.sensors.gnss.lever_m == (0.3, -1.0, 1.2)
    assert cfg.filter.fdi_alpha == {"velocity": 0.01}
    assert cfg.imu.gyro_arw_rad_sqrt_s == 1.0e-3  # set in the base config: kept
    assert cfg.sensors.velocity.sigma_mps is not None
    assert cfg.imu.accel_vrw_mps_sqrt_s is not None
    assert "# imu.gyro_arw_rad_sqrt_s: 0.001 -> 0.001 (kept: set in the config)" in \
        out.read_text()
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(short / "imu.csv"), "--gnss",
                                 str(short / "gnss.csv"), "--config", str(out), "--out",
                                 str(tmp_path / "run"), "--output-rate", "1"])
    assert r.exit_code == 0, r.output


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


def test_tune_says_when_no_lever_arm_is_set(short, tmp_path):
    from fednav.io import read_gnss_csv, read_imu_csv
    from fednav.process.tuning import tune

    imu = read_imu_csv(short / "imu.csv")
    gnss = read_gnss_csv(short / "gnss.csv")
    res = tune(imu, gnss, None, load_system({"imu": {"gyro_arw_rad_sqrt_s": 1e-3,
                                                     "accel_vrw_mps_sqrt_s": 1e-2}}),
               matching_passes=1)
    assert any(n.startswith("no GNSS antenna lever arm is set") for n in res.notes)
