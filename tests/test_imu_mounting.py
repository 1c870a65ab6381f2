"""``imu.mounting``: an IMU logged in forward-right-down, north-east-down or
forward-left-up axes gives the same run as the right-forward-up file once its mounting is
declared, and without it is refused (gravity on the wrong axis) or warned (the vehicle
speeds up along another axis), naming the mounting that fits.

Before, an FRD file read as RFU ran with roll 179 deg and heading 90 deg off, with only a
0.7 deg roll warning and a false GNSS time-offset hint."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from test_process import make_flight

from fednav import load_system
from fednav.core import mounting
from fednav.io import DataError, read_imu_csv
from fednav.process.checks import check_mounting
from fednav.process.run import errors_against, process, rmse


def _write(path, imu, letters):
    """``imu`` (RFU) written as a fednav IMU CSV in the axes ``letters``."""
    M = mounting.from_letters(letters)  # C_file^b: file = M^T body
    g, a = imu.gyro @ M, imu.accel @ M
    pd.DataFrame({"t_s": imu.t, "gyro_x_radps": g[:, 0], "gyro_y_radps": g[:, 1],
                  "gyro_z_radps": g[:, 2], "accel_x_mps2": a[:, 0], "accel_y_mps2": a[:, 1],
                  "accel_z_mps2": a[:, 2]}).to_csv(path, index=False, float_format="%.17g")


@pytest.fixture(scope="module")
def flight():
    return make_flight()


@pytest.mark.parametrize("letters", ["FRD", "NED", "FLU", "LBU"])
def test_a_file_in_other_axes_reads_as_the_rfu_file(tmp_path, flight, letters):
    imu = flight[0]
    _write(tmp_path / "rfu.csv", imu, "RFU")
    _write(tmp_path / "other.csv", imu, letters)
    ref = read_imu_csv(tmp_path / "rfu.csv")
    got = read_imu_csv(tmp_path / "other.csv", mounting=letters)
    assert np.allclose(got.gyro, ref.gyro, rtol=0, atol=1e-15)
    assert np.allclose(got.accel, ref.accel, rtol=0, atol=1e-13)
    assert got.quality["imu_mounting"] == letters
    # the configured mounting acts on data read without it (process turns them)
    as_read = read_imu_csv(tmp_path / "other.csv")
    cfg = load_system({"imu": {"mounting": letters}})
    from fednav.process.checks import mounted_imu

    assert np.allclose(mounted_imu(as_read, cfg.imu.mounting).accel, ref.accel, atol=1e-13)


def test_euler_mounting_turns_the_axes():
    """A mounting given as Euler angles, in the vehicle's convention: an IMU turned 90 deg
    to the left (heading -90 deg) has its y axis toward the body's left and its x axis
    forward, which is FLU."""
    M = mounting.parse({"euler_deg": [0.0, 0.0, -90.0]})
    assert np.allclose(M, mounting.from_letters("FLU"), atol=1e-15)
    assert mounting.letters_of(M) == "FLU"


@pytest.mark.slow
def test_process_is_the_same_with_the_mounting_declared(tmp_path, flight):
    imu, gnss, ref = flight
    _write(tmp_path / "rfu.csv", imu, "RFU")
    _write(tmp_path / "frd.csv", imu, "FRD")
    base = {"alignment": {"initial_attitude": "coarse"}}
    a = process(read_imu_csv(tmp_path / "rfu.csv"), {"gnss": gnss}, cfg=load_system(base))
    b = process(read_imu_csv(tmp_path / "frd.csv"), {"gnss": gnss},
                cfg=load_system({**base, "imu": {"mounting": "FRD"}}))
    ea, eb = rmse(errors_against(a.forward, ref)), rmse(errors_against(b.forward, ref))
    for k, v in ea.items():
        assert eb[k] == pytest.approx(v, rel=1e-6, abs=1e-9), k


@pytest.mark.parametrize("letters", ["FRD", "NED", "RBD", "LFD"])
def test_gravity_on_another_axis_is_refused_naming_the_fit(tmp_path, flight, letters):
    imu, gnss, _ = flight
    _write(tmp_path / "imu.csv", imu, letters)
    wrong = read_imu_csv(tmp_path / "imu.csv")  # read as right-forward-up
    with pytest.raises(DataError) as e:
        check_mounting(wrong, gnss)
    msg = str(e.value)
    assert "\n" not in msg and "imu.mounting: RFU" in msg and "gravity" in msg
    fit = msg.split("imu.mounting: ")[-1].split()[0]
    # the fit named is the file's true axes (the GNSS tells forward from the others)
    assert np.array_equal(mounting.from_letters(fit), mounting.from_letters(letters)), msg
    # and process refuses the run (one line), with the fit it names
    with pytest.raises(DataError, match=f"imu.mounting: {fit} fits"):
        process(wrong, {"gnss": gnss})


def test_a_yawed_imu_is_warned_naming_the_fit(tmp_path, flight):
    """FLU read as RFU: gravity is right, but the car speeds up along the body's -right
    axis (the file's x is forward)... the warning names FLU."""
    imu, gnss, _ = flight
    _write(tmp_path / "imu.csv", imu, "FLU")
    w = check_mounting(read_imu_csv(tmp_path / "imu.csv"), gnss)
    assert len(w) == 1 and "imu.mounting: FLU fits" in w[0], w
    # declared, nothing is said
    assert check_mounting(read_imu_csv(tmp_path / "imu.csv", mounting="FLU"), gnss) == []
    assert check_mounting(imu, gnss) == []
