"""Initial alignment (fednav.ins.alignment): levelling, heading from the GNSS course carried
back by the gyro, the tilt/bias coupling of the initial covariance."""

import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.ins.alignment import align, coarse_level, heading_from_course, static_span
from fednav.io.data import GnssData, ImuData

LAT = units.deg(45.0)


def _static_then_drive(heading0_deg=30.0, turn_deg=40.0, bias=(0.0, 0.0, 0.0)):
    """20 s static (level, heading0), then a 40 deg turn to the left in 4 s while
    accelerating, then straight at 5 m/s: IMU at 100 Hz, GNSS at 5 Hz."""
    dt = 0.01
    t = np.arange(0.0, 40.0, dt)
    rate = np.where((t >= 20.0) & (t < 24.0), units.deg(turn_deg) / 4.0, 0.0)  # about up
    # sample i is the rate over [t_i, t_i+1]; left turn: heading falls
    heading = units.deg(heading0_deg) - np.r_[0.0, np.cumsum(rate[:-1])] * dt
    w_ie = np.array([0.0, earth.OMEGA_IE * np.cos(LAT), earth.OMEGA_IE * np.sin(LAT)])
    C = att.euler_to_dcm(np.column_stack([np.zeros_like(t), np.zeros_like(t), heading]))
    gyro = np.einsum("kji,j->ki", C, w_ie) + np.asarray(bias)  # C_n^b w_ie + bias
    gyro[:, 2] += rate
    accel = np.tile([0.0, 0.0, earth.gravity(LAT, 0.0)], (len(t), 1))
    imu = ImuData("sim", t, gyro, accel)
    tg = np.arange(0.0, 40.0, 0.2)
    speed = np.clip((tg - 20.0) * 1.25, 0.0, 5.0)
    hg = np.interp(tg, t, heading)
    vel = np.column_stack([speed * np.sin(hg), speed * np.cos(hg), np.zeros_like(tg)])
    lla = np.tile([LAT, 0.0, 10.0], (len(tg), 1))
    return imu, GnssData("sim", tg, lla, vel, np.ones(3), np.full(3, 0.05), np.zeros(3))


def test_heading_from_the_course_is_carried_back_through_the_turn():
    imu, gnss = _static_then_drive(heading0_deg=30.0, turn_deg=40.0)
    h, scatter, t_first = heading_from_course(imu.t, imu.gyro, np.array([0.0, 0.0, 1.0]),
                                              np.r_[0.0, 0.0, earth.OMEGA_IE * np.sin(LAT)],
                                              gnss.t, gnss.vel, 0.0)
    # the course after the turn is 30 - 40 = -10 deg; carried back it is the 30 deg start
    assert units.to_deg(h) == pytest.approx(30.0, abs=0.05)
    assert t_first > 20.0 and scatter < units.deg(0.05)


def test_align_levels_estimates_the_gyro_bias_and_finds_the_heading():
    bias = np.array([2e-4, -1e-4, 3e-4])  # rad/s, ~40-60 deg/h
    imu, gnss = _static_then_drive(heading0_deg=200.0, turn_deg=-30.0, bias=bias)
    a = align(imu, gnss, 0.0, 0, 0.01, gyro_arw=1e-4, accel_noise=1e-3,
              accel_bias_sigma=0.02)
    assert a.report["levelling"].startswith("static")
    assert units.to_deg(a.euler[2]) == pytest.approx(200.0, abs=0.1)
    np.testing.assert_allclose(a.euler[:2], 0.0, atol=1e-9)
    # static gyro mean = bias + C_n^b w_ie
    np.testing.assert_allclose(a.gyro_bias, bias, atol=2e-7)  # 0.04 deg/h
    assert a.gyro_bias_sigma == pytest.approx(1e-4 / np.sqrt(static_span(gnss.t, gnss.vel, 0.0)))


def test_levelling_tilt_error_is_the_accelerometer_bias_over_g():
    """A bias of 2 mg on the body x (right) axis tilts the levelled roll by -bias/g; the
    alignment's coupling A predicts the platform-angle error A nabla exactly (first order)."""
    imu, gnss = _static_then_drive(heading0_deg=60.0, turn_deg=0.0)
    nabla = np.array([0.0196, 0.0, 0.0])
    biased = ImuData("sim", imu.t, imu.gyro, imu.accel + nabla)
    a = align(biased, gnss, 0.0, 0, 0.01, 1e-4, 1e-3, 0.02)
    C_true = att.euler_to_dcm(np.r_[0.0, 0.0, units.deg(60.0)])
    phi = att.misalignment(C_true, att.euler_to_dcm(a.euler))
    np.testing.assert_allclose(phi[:2], a.tilt_bias @ nabla, atol=2e-6)
    assert units.to_deg(a.euler[1]) == pytest.approx(-units.to_deg(0.0196 / 9.8), rel=1e-2)


def test_coarse_levelling_signs():
    # nose up by 5 deg: gravity reaction tilts toward +y (forward) in the body frame
    g = 9.8
    f = [0.0, g * np.sin(units.deg(5.0)), g * np.cos(units.deg(5.0))]
    np.testing.assert_allclose(units.to_deg(coarse_level(f)[:2]), [5.0, 0.0], atol=1e-9)
    f = [-g * np.sin(units.deg(4.0)), 0.0, g * np.cos(units.deg(4.0))]  # right wing down
    np.testing.assert_allclose(units.to_deg(coarse_level(f)[:2]), [0.0, 4.0], atol=1e-9)


def test_a_vehicle_that_never_moves_gets_a_warning():
    imu, gnss = _static_then_drive()
    still = GnssData("still", gnss.t, gnss.lla, gnss.vel * 0.0, gnss.sigma_pos,
                     gnss.sigma_vel, gnss.lever)
    a = align(imu, still, 0.0, 0, 0.01, 1e-4, 1e-3, 0.02)
    assert a.euler[2] == 0.0 and any("never moves" in w for w in a.warnings)
