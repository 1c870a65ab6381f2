"""IMU grade presets (fednav.sensors.imu.GRADES): the figures a config and a data file
leave out, in order config > file > preset, for processing and simulation alike."""

import numpy as np
import pytest

from fednav.core import units
from fednav.navigator.system import imu_figures, missing_figures
from fednav.sensors.imu import GRADES, ImuConfig


def test_the_grades_are_ordered_and_complete():
    keys = set(GRADES["consumer"])
    assert all(set(g) == keys for g in GRADES.values())
    order = ["consumer", "industrial", "tactical", "navigation"]
    for k in ("gyro_bias_radps", "gyro_arw_rad_sqrt_s", "accel_bias_mps2"):
        v = [GRADES[g][k] for g in order]
        assert v == sorted(v, reverse=True), k  # each grade better than the one before
    assert GRADES["tactical"]["gyro_bias_radps"] == pytest.approx(units.deg_per_h(1.0))


def test_config_then_file_then_preset():
    class File:  # a data file's figures (NaveGo's IMU struct)
        gyro_arw = np.full(3, 1e-4)
        accel_vrw = gyro_bias = accel_bias = gyro_markov = accel_markov = None
        gyro_tau = accel_tau = None

    imu = ImuConfig(grade="tactical", gyro_bias_deg_h=3.0)
    f = imu_figures(imu, File())
    assert f["gyro_bias"] == pytest.approx(units.deg_per_h(3.0))        # the config's
    assert f["gyro_arw"] == 1e-4                                          # the file's
    assert f["accel_vrw"] == GRADES["tactical"]["accel_vrw_mps_sqrt_s"]   # the preset's
    assert not missing_figures(imu, File())
    assert "accel_vrw_mps_sqrt_s" in missing_figures(ImuConfig(gyro_bias_deg_h=3.0))


def test_a_simulation_flies_the_preset_too():
    e = ImuConfig(grade="industrial").errors(0.01)
    assert e.gyro_arw == pytest.approx(GRADES["industrial"]["gyro_arw_rad_sqrt_s"])
    assert e.accel_markov_tau == pytest.approx(300.0)
    assert ImuConfig().errors(0.01).gyro_arw == 0.0  # (no grade: unknown = 0 in a simulation)
