import numpy as np
import pytest

from fednav.core import attitude, units
from fednav.launch.frame import LaunchFrame
from fednav.launch.strapdown import LaunchStrapdown
from fednav.launch.trajectory import AscentProfile, Burn, Manoeuvre, generate

d = units.deg


@pytest.fixture(scope="module")
def ascent():
    fr = LaunchFrame((d(32.0), d(118.0), 0.0), d(90.0))
    prof = AscentProfile(
        fr, 500.0, burns=(Burn(0, 150, 15.0, 0.35), Burn(160, 240, 12.0, 0.4)),
        pitch=(Manoeuvre(10, 30, d(-10)), Manoeuvre(40, 110, d(-45)),
               Manoeuvre(160, 240, d(-30))),
        yaw=(Manoeuvre(200, 40, d(2)), Manoeuvre(300, 40, d(-2))))
    return prof, generate(prof, 0.02)


def test_ideal_imu_reproduces_truth_to_millimetres(ascent):
    _, tr = ascent
    ins = LaunchStrapdown(tr.frame, attitude.dcm_to_quat(tr.C[0]), tr.v[0], tr.r[0], tr.dt)
    out = ins.run(tr.dtheta, tr.dv)
    assert np.abs(out["r"] - tr.r[1:]).max() < 3e-3
    assert np.abs(out["v"] - tr.v[1:]).max() < 2e-6
    phi = attitude.misalignment(tr.C[1:], attitude.quat_to_dcm(out["q"]))
    assert units.to_arcsec(np.abs(phi).max()) < 1e-6


def test_interval_summary_matches_recorded_run(ascent):
    _, tr = ascent
    q0 = attitude.dcm_to_quat(tr.C[0])
    a = LaunchStrapdown(tr.frame, q0, tr.v[0], tr.r[0], tr.dt)
    b = LaunchStrapdown(tr.frame, q0, tr.v[0], tr.r[0], tr.dt)
    rec = a.run(tr.dtheta[:100], tr.dv[:100])
    aux = b.interval(tr.dtheta[:50], tr.dv[:50])
    aux2 = b.interval(tr.dtheta[50:100], tr.dv[50:100])
    assert np.allclose(b.state, a.state, rtol=0, atol=1e-12)
    assert np.allclose(aux[3:7], rec["q"][24]) and np.allclose(aux[7:10], rec["r"][24])
    # Summed LI specific-force increment = velocity change minus gravity.
    g = tr.frame.gravity_li(rec["r"][74])
    dv_expect = rec["v"][99] - rec["v"][49] - g * 50 * tr.dt
    assert np.allclose(aux2[0:3], dv_expect, atol=2e-4)


def test_trajectory_shape(ascent):
    prof, tr = ascent
    lla = tr.lla()
    assert lla[:, 2].min() >= -1e-6 and lla[-1, 2] > 3e5          # climbs to space
    assert np.all(np.diff(lla[:, 2]) > -1e-9)                      # never descends
    # Vertical rise: the nose is along LI y at lift-off; pitch 5 deg at the end.
    assert np.allclose(tr.C[0][:, 1], [0, 1, 0], atol=1e-12)
    nose = tr.C[-1][:, 1]
    assert abs(np.degrees(np.arctan2(nose[1], nose[0])) - 5.0) < 1e-9
    # Body rate = derivative of the attitude (central difference).
    t, h = 210.3, 1e-4
    Cd = (prof.attitude(t + h) - prof.attitude(t - h)) / (2 * h)
    W = prof.attitude(t).T @ Cd
    assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], prof.body_rate(t), atol=1e-9)


def test_off_grid_breakpoint_rejected():
    fr = LaunchFrame((d(32.0), d(118.0), 0.0), d(90.0))
    prof = AscentProfile(fr, 10.0, burns=(Burn(0, 5.013, 15.0, 0.5),))
    with pytest.raises(ValueError, match="not on the IMU grid"):
        generate(prof, 0.02)
