"""Every key of a processing config acts or is named: ``fednav process csv`` is walked
through every key of the system description (its top level, the IMU, the filter, the
alignment, the initial state and a sensor section), each changed from the config of a
simulated drive.  A key acts (the solution or the summary changes), is named in a
warning as one the run does not use (simulation-only keys, keys whose condition is not
met), or is refused in one line naming it.  A key whose effect needs particular data (a
gap for ``imu.max_bridge_s``) names the test that shows it acting.

Before, ``sensors.gnss.outages_s`` in a processing config was accepted and ignored (2 999
of 2 999 fixes still used)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from fednav import load_system
from fednav.cli import app
from fednav.navigator.system import System
from fednav.sensors.registry import SENSORS
from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

ROOT = Path(__file__).resolve().parents[1]
TESTS = Path(__file__).resolve().parent

#: key -> how the walk shows it: ("acts" | "named" | "refused", value[, {the setting it
#: acts with: the reference run has it too}]) or ("covered", "test_file.py::test_name")
#: for a key whose effect needs other data.
WALK = {
    # the IMU (process.yaml gives the SI figures: an alternative key replaces its twin)
    "imu.gyro_bias_deg_h": ("acts", 20.0),
    # (a static start's levelling bounds the bias sigma: the config's acts below it)
    "imu.gyro_bias_radps": ("acts", 2e-5),
    "imu.gyro_markov_deg_h": ("acts", 50.0),
    "imu.gyro_markov_radps": ("acts", 1e-4),
    "imu.gyro_markov_tau_s": ("acts", 30.0),
    "imu.gyro_tau_s": ("acts", 30.0),
    "imu.gyro_arw_deg_sqrt_h": ("acts", 0.5),
    "imu.gyro_arw_rad_sqrt_s": ("acts", 1e-3),
    "imu.gyro_white_deg_h": ("acts", 300.0),
    "imu.gyro_bias_rw_deg_h_sqrt_h": ("acts", 50.0),
    "imu.accel_bias_ug": ("acts", 5000.0),
    "imu.accel_bias_mps2": ("acts", 0.05),
    "imu.accel_markov_ug": ("acts", 500.0),
    "imu.accel_markov_mps2": ("acts", 5e-3),
    "imu.accel_markov_tau_s": ("acts", 30.0),
    "imu.accel_tau_s": ("acts", 30.0),
    "imu.accel_white_ug": ("acts", 5000.0),
    "imu.accel_vrw_ug_sqrt_hz": ("acts", 500.0),
    "imu.accel_vrw_mps_sqrt_s": ("acts", 0.01),
    "imu.accel_bias_rw_ug_sqrt_h": ("acts", 500.0),
    "imu.gyro_scale_ppm": ("named", 3000.0),
    "imu.accel_scale_ppm": ("named", 3000.0),
    "imu.gyro_scale_tau_s": ("named", 3600.0),
    "imu.accel_scale_tau_s": ("named", 3600.0),
    "imu.random_bias": ("named", True),
    "imu.max_bridge_s": ("covered", "io/test_sensor_files.py::"
                                    "test_jittered_and_missing_imu_stamps_keep_every_increment"),
    "imu.mounting": ("refused", "FRD"),
    "imu.grade": ("named", "tactical"),
    # which sensors, the constraint
    "aiding": ("acts", ["gnss"]),
    "constraint": ("refused", "wind"),
    # the filter
    "filter.type": ("acts", "ukf"),
    "filter.locals": ("acts", {"velocity": {"type": "ukf"}}),
    "filter.form": ("acts", "square_root"),
    "filter.state": ("refused", "total"),  # (no total-state model of the velocity sensor)
    "filter.architecture": ("acts", "centralized"),
    "filter.period_s": ("acts", 0.4),
    "filter.alpha": ("named", 0.5),
    "filter.beta": ("named", 0.0),
    "filter.kappa": ("named", 1.0),
    "filter.sharing": ("acts", "adaptive"),
    "filter.fixed_factors": ("named", {"gnss": 0.7, "velocity": 0.3}),
    "filter.master": ("acts", True),
    "filter.reset": ("acts", False),
    "filter.substeps": ("acts", 3),
    "filter.fdi_alpha": ("acts", 0.3),
    "filter.fdi_recovery": ("named", 3),
    "filter.fdi_readmit_s": ("named", 2.0),
    "filter.grid_level": ("named", 2),
    "filter.pf.particles": ("named", 500),
    "filter.pf.resample_threshold": ("named", 0.8),
    "filter.pf.roughening": ("named", 0.2),
    "filter.pf.progressive_correction": ("named", False),
    "filter.pf.seed": ("named", 3),
    "filter.accel_bias": ("acts", "gauss_markov"),
    "filter.q_adaptation": ("acts", {"time_constant_s": 10.0, "max_scale": 100.0}),
    "filter.states": ("refused", ["gyro_scale"]),  # (it needs imu.gyro_scale_ppm)
    # alignment, initial state, outputs
    "alignment.initial_attitude": ("acts", "coarse"),
    "alignment.initial_attitude_sigma_deg": ("acts", [2.0, 2.0, 10.0]),
    "alignment.coarse_heading_deg": ("acts", 10.0),
    # (with a static start, align levels over the stillness: coarse_seconds is coarse's)
    "alignment.coarse_seconds": ("acts", 5.0, {"alignment.initial_attitude": "coarse"}),
    "initial": ("acts", "INITIAL"),  # (the drive's first reference row)
    "health.nis_band": ("acts", [0.99, 1.01]),  # (the drive's NIS/dof lies outside it)
    "integrity": ("acts", {"alert_limit_horizontal_m": 40.0}),  # (levels in the summary)
    "smoother": ("acts", True),
    "noise": ("acts", "as-given"),  # (the summary's noise entry goes)
    "output_rate_hz": ("acts", 2.0),
    "files": ("acts", "FILES"),  # (the velocity file named there, not by --velocity)
    "sensors": ("acts", None),  # (its sections: SECTION below)
}

#: A sensor section's keys, walked on the GNSS section.
SECTION = {
    "period_s": ("named", 0.5),
    "timing.latency_s": ("named", 0.2),
    "timing.latency_range_s": ("named", [0.1, 0.2]),
    "timing.latency_list_s": ("named", [0.1, 0.2]),
    "timing.sequential": ("refused", True),  # (it needs a latency)
    "timing.delay_compensation": ("named", "none"),  # (the file has no t_arrival_s)
    "timing.curve_fit_degree": ("named", 1),
    "timing.curve_fit_points": ("named", 4),
    "outages_s": ("acts", [[60.0, 90.0]]),
    "lever_m": ("acts", [0.0, 0.0, 0.0]),
    "mounting": ("refused", "FRD"),
    "sigma_pos_enu_m": ("acts", [3.0, 3.0, 6.0]),
    "sigma_vel_mps": ("acts", 0.3),
    "time_offset_s": ("acts", 0.1),
    "velocity_latency_s": ("acts", 0.1),
    "markov_sigma_enu_m": ("named", 1.0),
    "markov_tau_s": ("named", 60.0),
    "measures": ("acts", "position"),
}


def _keys(model, prefix="") -> list[str]:
    """Every key of a config model, sections walked into (a dict-valued or optional
    section counts as one key)."""
    import typing

    from pydantic import BaseModel

    out = []
    for name, f in model.model_fields.items():
        sub = [] if typing.get_origin(f.annotation) is dict else [
            a for a in (f.annotation, *typing.get_args(f.annotation))
            if isinstance(a, type) and issubclass(a, BaseModel)]
        if sub and f.default is not None and name not in ("initial",):
            out += _keys(sub[0], f"{prefix}{name}.")
        else:
            out.append(f"{prefix}{name}")
    return out


def test_the_walk_covers_every_key_of_the_schema():
    """A new key of the system description must join the walk (and act or be named)."""
    assert sorted(_keys(System)) == sorted(WALK)
    assert sorted(_keys(SENSORS["gnss"].config)) == sorted(SECTION)
    # every sensor's common keys are the section walked here
    common = set(_keys(SENSORS["star"].config)) - {"sigma_arcsec"}
    assert common <= set(SECTION)
    for key, (how, what, *_) in {**WALK, **SECTION}.items():
        if how == "covered":
            file, name = what.split("::")
            assert f"def {name}(" in (TESTS / file).read_text(), (key, what)


def _set(cfg: dict, key: str, value) -> dict:
    out = copy.deepcopy(cfg)
    d = out
    *path, last = key.split(".")
    for p in path:
        d = d.setdefault(p, {})
    d[last] = value
    if path == ["imu"]:  # (a figure's other key goes: one key per figure)
        from fednav.sensors.imu import FIGURES

        for eng, _, si in FIGURES.values():
            if last in (eng, si):
                d.pop(si if last == eng else eng, None)
        if last in ("gyro_white_deg_h",):
            d.pop("gyro_arw_rad_sqrt_s", None)
        if last in ("accel_white_ug",):
            d.pop("accel_vrw_mps_sqrt_s", None)
    return out


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    folder = tmp_path_factory.mktemp("drive")
    cfg = load_dataset_config(ROOT / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={"segments": cfg.segments[:10]})
    write_csv_dataset(simulate_dataset(cfg), folder)
    return folder


def _run(drive: Path, out: Path, cfg: dict, velocity: bool = True):
    out.mkdir()
    (out / "c.yaml").write_text(yaml.safe_dump(cfg))
    args = ["process", "csv", "--imu", str(drive / "imu.csv"), "--gnss",
            str(drive / "gnss.csv"), "--ref", str(drive / "reference.csv"), "--config",
            str(out / "c.yaml"), "--out", str(out / "o")]
    if velocity:
        args += ["--velocity", str(drive / "velocity.csv")]
    r = CliRunner().invoke(app, args)
    if r.exit_code:
        return r, None
    s = json.loads((out / "o" / "summary.json").read_text())
    s.pop("run_time_s")
    s.pop("inputs")
    s.get("noise", {}).pop("cost_s", None)  # (a time, as run_time_s)
    sol = (out / "o" / "solution.csv").read_text()
    return r, (s, sol)


def _value(drive: Path, value):
    """The walk's value, the drive's own where it needs them."""
    if value == "INITIAL":
        ref = np.genfromtxt(drive / "reference.csv", delimiter=",", names=True)
        r = ref[0]
        return {"t_s": float(r["t_s"]), "lat_deg": float(r["lat_deg"]),
                "lon_deg": float(r["lon_deg"]), "h_m": float(r["h_m"]),
                "vel_mps": [float(r["vE_mps"]), float(r["vN_mps"]), float(r["vU_mps"])],
                "euler_deg": [float(r["pitch_deg"]), float(r["roll_deg"]),
                              float(r["heading_deg"])],
                "sigma": {"attitude_arcsec": [600.0, 600.0, 3600.0], "velocity_mps": 0.1,
                          "position_m": 1.0}}
    if value == "FILES":
        return {"velocity": str(drive / "velocity.csv")}
    return value


@pytest.mark.slow
def test_every_key_acts_or_is_named_or_refused(drive, tmp_path):
    base = yaml.safe_load((drive / "process.yaml").read_text())
    r, ref = _run(drive, tmp_path / "base", base)
    assert ref is not None, r.output
    assert "not used on recorded data" not in r.output, r.output
    cases = [(k, v) for k, v in WALK.items() if k != "sensors"]
    cases += [(f"sensors.gnss.{k}", v) for k, v in SECTION.items()]
    silent = []
    for i, (key, (how, value, *with_)) in enumerate(cases):
        if how == "covered":
            continue
        start, ref_i = base, ref
        for k, v in (with_[0] if with_ else {}).items():
            start = _set(start, k, v)
        if with_:
            _, ref_i = _run(drive, tmp_path / f"w{i}", start)
        cfg = _set(start, key, _value(drive, value))
        r, got = _run(drive, tmp_path / f"k{i}", cfg, velocity=key != "files")
        text = " ".join(r.output.split())  # (the console wraps long lines)
        if got is None:
            ok = how == "refused" and r.exit_code == 2 and key.split(".")[-1] in text
            if not ok:
                silent.append(f"{key}: exit {r.exit_code}: {text[-200:]}")
            continue
        named = "not used on recorded data" in text and key in text
        changed = got != ref_i
        if key == "files":  # (acts: the same run as the file given by its option)
            changed = got == ref_i
        if how == "named" and not named:
            silent.append(f"{key}: not named ({'changed' if changed else 'no effect'})")
        elif how == "acts" and not changed:
            silent.append(f"{key}: no effect")
        elif how == "refused":
            silent.append(f"{key}: accepted")
    assert not silent, "\n".join(silent)


def test_outages_in_a_processing_config_withhold_the_fixes_and_score_inside(drive, tmp_path):
    base = yaml.safe_load((drive / "process.yaml").read_text())
    cfg = _set(base, "sensors.gnss.outages_s", [[60.0, 90.0]])
    r, got = _run(drive, tmp_path / "o", cfg)
    assert got is not None, r.output
    s = got[0]
    n_in = int(np.sum((np.loadtxt(drive / "gnss.csv", delimiter=",", skiprows=1,
                                  usecols=0) >= 60.0)
                      & (np.loadtxt(drive / "gnss.csv", delimiter=",", skiprows=1,
                                    usecols=0) < 90.0)))
    assert n_in > 100 and s["data_quality"]["gnss_withheld_in_outages"] == n_in
    (row,) = s["outages"]["gnss"]
    assert row["window_s"] == [60.0, 90.0] and row["rows"] > 0
    # the drift inside the outage is larger than over the whole run
    assert row["rmse"]["north_m"] > s["rmse"]["north_m"]
    assert "inside the gnss outage 60-90 s" in r.output
    # the fixes inside were not used: the GNSS local filter's measurements dropped by them
    r0, ref = _run(drive, tmp_path / "b", base)
    assert ref[0]["consistency"]["gnss"]["measurements"] - s["consistency"]["gnss"][
        "measurements"] == n_in
    load_system(cfg)  # (the config stays a valid description)
