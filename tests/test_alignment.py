"""Initial alignment (fednav.ins.alignment): levelling, heading from the GNSS course carried
back by the gyro, the tilt/bias coupling of the initial covariance."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.ins.alignment import (
    align,
    coarse_level,
    heading_from_course,
    level_in_motion,
    static_span,
)
from fednav.ins.stops import stationary, still_spans
from fednav.io.data import GnssData, ImuData
from fednav.process import process
from fednav.sim.drives import ADIS16405, ADIS16488, car_drive, heading_containment

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
    hc = heading_from_course(imu.t, imu.gyro, np.array([0.0, 0.0, 1.0]),
                             np.r_[0.0, 0.0, earth.OMEGA_IE * np.sin(LAT)],
                             gnss.t, gnss.vel, 0.0, sigma_v=0.05)
    # the course after the turn is 30 - 40 = -10 deg; carried back it is the 30 deg start
    assert units.to_deg(hc.heading) == pytest.approx(30.0, abs=0.05)
    assert hc.t_first > 20.0 and hc.follows
    # sigma: the course's (0.05 m/s over 1.25..5 m/s, a few epochs averaged), no floor here
    assert units.deg(0.1) < hc.sigma < units.deg(2.0)


def test_a_course_that_does_not_follow_the_gyro_is_not_a_heading():
    """An IMU mounted 90 deg off the direction of travel that turns while the vehicle
    drives straight: the course is refused; the heading is the file's, with a note naming
    the likely causes (a warning naming them when there is no file heading)."""
    imu, gnss = _static_then_drive(heading0_deg=30.0, turn_deg=0.0)
    t = imu.t
    wobble = units.deg(20.0) * np.sin(2 * np.pi * t / 15.0)  # heading the gyro sees
    gyro = imu.gyro.copy()
    gyro[:, 2] -= np.gradient(wobble, t)
    bad = ImuData("sim", t, gyro, imu.accel)
    a = align(bad, gnss, 0.0, 0, 0.01, 1e-4, 1e-3, 0.02, file_euler=units.deg([0, 0, 33.0]),
              file_sigma=units.deg([2.0, 2.0, 10.0]))
    assert a.report["heading"].startswith("file (the GNSS course does not follow the gyro")
    assert a.report["course_scatter"] > 9.0
    assert not any("does not follow" in w for w in a.warnings)  # the file's heading: a note
    a = align(bad, gnss, 0.0, 0, 0.01, 1e-4, 1e-3, 0.02)
    assert any("does not follow the gyro's heading" in w and "unknown" in w
               for w in a.warnings)
    assert a.sigma[2] == pytest.approx(np.pi / np.sqrt(3.0))  # unknown: uniform


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
    still = stationary(imu.gyro, imu.accel, 0.01, 1e-4, 1e-3)
    T = static_span(gnss.t, gnss.vel, 0.0, imu.t, still)
    assert T == pytest.approx(19.4)  # GNSS faster than 0.5 m/s at 20.4 s, less 1 s
    assert a.gyro_bias_sigma == pytest.approx(1e-4 / np.sqrt(T))


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
    still = GnssData("still", gnss.t, gnss.lla, gnss.vel * 0.0, gnss.sigma_pos_enu,
                     gnss.sigma_vel, gnss.lever)
    a = align(imu, still, 0.0, 0, 0.01, 1e-4, 1e-3, 0.02)
    assert a.euler[2] == 0.0 and any("never moves" in w for w in a.warnings)
    assert a.sigma[2] == pytest.approx(np.pi / np.sqrt(3.0))  # honest: any heading


def test_levelling_in_motion_undoes_the_known_acceleration():
    """A body pitched 3 deg and rolled -2 deg, accelerating forward at 1.5 m/s^2 and
    turning (0.4 m/s^2 to the left): the level-frame specific force gives the tilt back
    exactly; levelling as if still would be 8.7 deg off in pitch."""
    euler = units.deg(np.array([3.0, -2.0, 0.0]))
    g = 9.81
    f_level = np.array([-0.4, 1.5, g])
    f_body = att.euler_to_dcm(euler).T @ f_level
    np.testing.assert_allclose(level_in_motion(f_body, f_level), euler, atol=1e-12)
    assert abs(units.to_deg(coarse_level(f_body)[0]) - 3.0) > 8.0


def test_stand_still_detector():
    rng = np.random.default_rng(4)
    dt, arw, vrw = 0.01, units.deg_per_sqrt_h(2.0), 2e-3
    n = 6000
    gyro = rng.standard_normal((n, 3)) * arw / np.sqrt(dt)
    accel = np.array([0.0, 0.0, 9.8]) + rng.standard_normal((n, 3)) * vrw / np.sqrt(dt)
    moving = (np.arange(n) >= 3000) & (np.arange(n) < 4000)
    gyro[moving, 2] += units.deg(5.0)  # a turn
    still = stationary(gyro, accel, dt, arw, vrw)
    assert still[:2900].mean() > 0.99 and still[4100:].mean() > 0.99
    assert not still[3050:3950].any()
    spans = still_spans(np.arange(n) * dt, still, min_s=5.0)
    assert len(spans) == 2 and spans[0][0] == 0.0
    # figures that hold the vibration of motion (a tuned config's, 30 x the data
    # sheet): the recording's quiet windows set the noise at rest instead, and the
    # vibrating drive between the stops is not called still
    shake = rng.standard_normal((n, 3)) * 30 * vrw / np.sqrt(dt)
    driving = (np.arange(n) >= 2000) & (np.arange(n) < 5000)
    loud = accel + driving[:, None] * shake
    assert stationary(gyro, accel + 0 * shake, dt, arw, 30 * vrw)[:2900].mean() > 0.99
    still = stationary(gyro, loud, dt, arw, 30 * vrw)
    assert not still[2050:4950].any() and still[:1900].mean() > 0.99
    # a navigation-grade gyro at rest reads the Earth rate far above its noise: still
    nav = np.tile(earth.earth_rate(LAT), (n, 1)) + rng.standard_normal((n, 3)) * 1e-7
    assert stationary(nav, accel, dt, 1e-6, vrw).mean() > 0.99


def _start_errors(d, res):
    i = int(np.searchsorted(d.reference.t, res.forward.t[0] - 1e-9))  # (the start's epoch)
    assert abs(d.reference.t[i] - res.forward.t[0]) < 1e-9
    e = res.forward.euler[0] - d.reference.euler[i]
    e[2] = np.angle(np.exp(1j * e[2]))
    return np.abs(e) / res.forward.sigma_euler[0]


@pytest.mark.slow
@settings(max_examples=25, deadline=None, derandomize=True)
@given(heading=st.floats(0.0, 360.0), speed=st.sampled_from([0.0, 0.02, 0.5, 3.0, 12.0]),
       accel=st.floats(0.2, 2.0), static=st.sampled_from([0.0, 5.0]),
       grade=st.sampled_from(["16405", "16488"]), seed=st.integers(1, 10_000))
def test_alignment_sigma_contains_the_error_from_any_start(heading, speed, accel, static,
                                                           grade, seed):
    """Issue 26: moving and static starts facing any direction, defaults only.  The
    alignment's 3-sigma contains its pitch, roll and heading error, and the filter's
    heading 3-sigma contains the heading error at (almost) every epoch after it: a
    consistent filter's error leaves 3 sigma now and then (docs/recorded-data.md gives
    the figures over 40 drives)."""
    d = car_drive(heading, speed, seed=seed, static_s=static, accel_mps2=accel,
                  imu=ADIS16405 if grade == "16405" else ADIS16488)
    res = process(d.imu, {"gnss": d.gnss}, d.system)
    assert np.all(_start_errors(d, res) <= 3.0), res.alignment
    inside, worst = heading_containment(res.forward, d.reference)
    assert inside >= 0.9 and worst < 5.0


def test_a_moving_start_levels_from_the_gnss_acceleration():
    """The issue's case: rolling at 0.02 m/s and pulling away at 1 m/s^2, no static
    period.  Before, the levelling ignored the acceleration: 5.8 deg of pitch error with
    a claimed sigma of 2 deg."""
    d = car_drive(30.0, 0.02, seed=3)
    res = process(d.imu, {"gnss": d.gnss}, d.system)
    assert res.alignment["levelling"].startswith("in motion")
    pitch_err = units.to_deg(res.forward.euler[0, 0] - d.reference.euler[0, 0])
    assert abs(pitch_err) < 0.7 and np.all(_start_errors(d, res) <= 3.0)


def test_a_standing_vehicle_keeps_an_unknown_heading_in_its_solution():
    """Never faster than a course can tell: the heading is unknown at the start and the
    solution says so throughout (the linearised filter would otherwise shrink its heading
    sigma to ~12 deg through the lever arm while ~40 deg off)."""
    import dataclasses

    d = car_drive(77.0, 0.0, seed=4, static_s=60.0)
    m, mg = d.imu.t < 40.0, d.gnss.t < 40.0
    imu = ImuData("still", d.imu.t[m], d.imu.gyro[m], d.imu.accel[m], d.imu.errors)
    gnss = dataclasses.replace(d.gnss, t=d.gnss.t[mg], lla=d.gnss.lla[mg],
                               vel=d.gnss.vel[mg], quality={})
    res = process(imu, {"gnss": gnss}, d.system, smooth=True)
    assert res.alignment["heading"].startswith("unknown")
    assert any("never moves" in w for w in res.warnings)
    for sol in (res.forward, res.smoothed):
        assert np.all(sol.sigma_euler[:, 2] >= np.pi / np.sqrt(3.0) - 1e-12)


def test_levelling_in_motion_matches_the_velocity_change_over_a_longer_window(monkeypatch):
    """Issue 40 item 3: a town drive already rolling at 8 m/s, turning and changing speed
    from the start (fednav's town drive, ADIS16488-class IMU, 1.5 m / 0.05 m/s fixes
    at 5 Hz).  Matching the specific force carried in the start's body frame against the
    GNSS velocity's change over 12 s (the window the 20 deg/h gyro can carry) levels
    3-4x closer than the mean specific force over the first 2 s (measured over 8 drives:
    RMS pitch/roll 0.066/0.052 deg against 0.223/0.156), within its 3 sigma (0.047 deg)."""
    import fednav.ins.alignment as al
    from fednav.process.run import prepare
    from fednav.sim.drives import town_drive

    def tilt_errors():
        out, sig = [], []
        for seed in range(1, 7):
            d = town_drive(seed, 60.0, imu=ADIS16488)
            p = prepare(d.imu, {"gnss": d.gnss}, d.system)
            i = int(np.searchsorted(d.reference.t, p.initial.t - 1e-9))
            out.append(p.alignment.euler[:2] - d.reference.euler[i, :2])
            sig.append(p.alignment.sigma[0])
            assert p.alignment.report["levelling"].startswith("in motion"), p.alignment.report
        return np.array(out), np.array(sig)

    new, sig = tilt_errors()
    monkeypatch.setattr(al, "velocity_match_level", lambda *a, **k: None)
    old, _ = tilt_errors()
    rms_new, rms_old = np.sqrt(np.mean(new**2, axis=0)), np.sqrt(np.mean(old**2, axis=0))
    assert np.all(rms_new < 0.5 * rms_old), (units.to_deg(rms_new), units.to_deg(rms_old))
    assert np.all(units.to_deg(rms_new) < 0.1)
    assert np.all(np.abs(new) <= 3.0 * sig[:, None])


def test_the_body_frame_velocity_of_a_turning_body():
    """The kernel against the closed form: a body turning at 0.3 rad/s about its up axis
    with a constant specific force along its right axis integrates, in the start's frame,
    to ``c / w (sin wT, 1 - cos wT, 0)`` (measured within 2e-5 m/s over 10 s at 100 Hz)."""
    from fednav.ins.strapdown import body_frame_velocity

    dt, n, w, c = 0.01, 1000, 0.3, 2.0
    out, q = np.zeros((n, 3)), np.zeros((n, 4))
    body_frame_velocity(np.tile([0.0, 0.0, w * dt], (n, 1)), np.tile([c * dt, 0.0, 0.0],
                                                                        (n, 1)), out, q)
    T = n * dt
    np.testing.assert_allclose(out[-1], c / w * np.array([np.sin(w * T), 1 - np.cos(w * T),
                                                          0.0]), atol=5e-5)
    np.testing.assert_allclose(att.quat_to_euler(q[-1])[2] % (2 * np.pi),
                               (-w * T) % (2 * np.pi), atol=1e-9)


def test_velocity_matching_leaves_out_fixes_without_a_velocity():
    """Fixes whose velocity is missing (NaN: a receiver's epoch without Doppler) inside the
    levelling window are left out, never carried into the tilt."""
    import dataclasses

    from fednav.ins.alignment import velocity_match_level
    from fednav.sim.drives import town_drive

    d = town_drive(3, 40.0, imu=ADIS16488)
    vel = d.gnss.vel.copy()
    vel[[0, 5, 30, 58, 60], :] = np.nan
    fixes = dataclasses.replace(d.gnss, vel=vel, quality={})
    i0 = int(np.searchsorted(d.imu.t, fixes.t[0] - 1e-9))
    out = velocity_match_level(d.imu, fixes, float(d.imu.t[i0]), i0, 0.01,
                               float(d.reference.euler[i0, 2]), units.deg(0.2),
                               units.deg(20.0) / 3600.0, 1e-4, 1e-3, 5e-3)
    assert out is not None and np.all(np.isfinite(out[0]))
    assert np.all(np.abs(out[0][:2] - d.reference.euler[i0, :2]) < units.deg(0.3))


def test_velocity_matching_integrates_from_the_start_sample():
    """A perfect IMU and near-perfect velocities on a town drive whose speed changes from
    the start: the tilt within 0.005 deg.  Integrating from
    the sample after the start (each sample holds from its stamp) left the pitch 0.015 deg
    off here (0.07 deg against a sigma of 0.01 deg on a sharper start)."""
    from fednav.ins.alignment import velocity_match_level
    from fednav.sim.drives import town_drive

    perfect = {"random_bias": False, "gyro_bias_deg_h": 0.0, "gyro_markov_deg_h": 0.0,
               "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 0.0, "accel_bias_ug": 0.0,
               "accel_markov_ug": 0.0, "accel_markov_tau_s": 100.0,
               "accel_vrw_ug_sqrt_hz": 0.0}
    d = town_drive(3, 40.0, imu=perfect, gnss={"sigma_pos_enu_m": (0.01, 0.01, 0.01),
                                               "sigma_vel_mps": (1e-4, 1e-4, 1e-4),
                                               "lever_m": (0.3, -1.0, 1.2)})
    i0 = int(np.searchsorted(d.imu.t, d.gnss.t[0] - 1e-9))
    out = velocity_match_level(d.imu, d.gnss, float(d.imu.t[i0]), i0, 0.01,
                               float(d.reference.euler[i0, 2]), units.deg(0.01),
                               units.deg(20.0) / 3600.0, 1e-4, 1e-3, 5e-3)
    assert out is not None
    err = units.to_deg(np.abs(out[0][:2] - d.reference.euler[i0, :2]))
    assert np.all(err < 0.005), err


def test_positions_alone_keep_the_two_second_levelling():
    """Velocities from position differences are one-sided at the start (a fix in the first
    second carries the velocity of ~1 s later): velocity matching on them would pitch a
    car pulling away 0.3 deg off with a sigma of 0.2 deg, so a file of positions alone
    keeps the 2 s mean acceleration."""
    import dataclasses

    d = car_drive(30.0, 12.0, seed=2, imu=ADIS16488)
    res = process(d.imu, {"gnss": dataclasses.replace(d.gnss, vel=None, quality={})},
                  d.system)
    assert "mean acceleration" in res.alignment["levelling"], res.alignment
    with_vel = process(d.imu, {"gnss": d.gnss}, d.system)
    assert "velocity's change" in with_vel.alignment["levelling"], with_vel.alignment
