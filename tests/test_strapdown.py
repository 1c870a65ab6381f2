import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.ins.strapdown import BaroLoop, Strapdown
from fednav.scenarios import paper002
from fednav.sim.trajectory import Segment, generate


def nav_errors(out, tr):
    lla = out["lla"]
    dp = earth.llh_difference_enu(lla[:, 0], lla[:, 1], lla[:, 2],
                                  tr.lla[1:, 0], tr.lla[1:, 1], tr.lla[1:, 2])
    dv = out["vel"] - tr.vel[1:]
    phi = att.misalignment(tr.dcm[1:], att.quat_to_dcm(out["q"]))
    return dp, dv, phi


def test_ideal_imu_reproduces_paper002_flight():
    """Ideal IMU through the mechanization: 1200 s at 400 m/s within 1 m, 0.01 m/s, 1 arcsec."""
    tr = paper002.load_scenario().trajectory()
    assert tr.t[-1] == pytest.approx(1200.0)
    ins = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt)
    dp, dv, phi = nav_errors(ins.run(tr.dtheta, tr.dv), tr)
    assert np.abs(dp).max() < 1.0
    assert np.abs(dv).max() < 0.01
    assert units.to_arcsec(np.abs(phi).max()) < 1.0


def test_schuler_oscillation_period():
    lat = units.deg(39.0)
    dt, T = 0.1, 6000.0
    tr = generate([lat, units.deg(117.0), 0.0], 0.0, [0, 0, 0], [Segment(T)], dt)
    ins = Strapdown(tr.lla[0], [0.0, 0.1, 0.0], tr.euler[0], dt, baro=BaroLoop(10.0, 3))
    out = ins.run(tr.dtheta, tr.dv, h_ref=tr.lla[:-1, 2])
    vn = out["vel"][:, 1]
    t = tr.t[1:]
    zc = t[np.flatnonzero(np.sign(vn[1:]) != np.sign(vn[:-1]))]
    assert len(zc) >= 2
    period = 2 * (zc[1] - zc[0])
    rm, rn = earth.radii(lat)
    expected = 2 * np.pi * np.sqrt(np.sqrt(rm * rn) / earth.gravity(lat, 0.0))
    assert expected / 60 == pytest.approx(84.4, abs=0.3)
    assert period == pytest.approx(expected, rel=0.01)
    # Position error amplitude v0 / omega_s.
    dn = (out["lla"][:, 0] - lat) * (rm)
    assert np.abs(dn).max() == pytest.approx(0.1 * expected / (2 * np.pi), rel=0.03)


def test_baro_loop_bounds_vertical_error():
    tr = generate([0.6, 2.0, 1000.0], 0.0, [0, 0, 0], [Segment(600.0)], 0.1)
    ins = Strapdown(tr.lla[0] + [0, 0, 30.0], [0, 0, 0.5], tr.euler[0], 0.1, baro=BaroLoop(10.0, 2))
    h_ref = np.full(len(tr.t) - 1, np.nan)
    h_ref[::10] = tr.lla[:-1:10, 2]  # 1 Hz baro
    out = ins.run(tr.dtheta, tr.dv, h_ref=h_ref)
    assert abs(out["lla"][-1, 2] - 1000.0) < 0.01
    with pytest.raises(ValueError, match="order"):
        BaroLoop(10.0, 4).gains()


def test_correct_removes_errors():
    ins = Strapdown([0.6, 2.0, 100.0], [10.0, 0, 0], [0.1, 0.2, 1.0], 0.01)
    C0, v0, p0 = ins.dcm, ins.vel, ins.lla
    phi = np.array([1e-4, -2e-4, 3e-4])
    ins.state[0:4] = att.dcm_to_quat(att.apply_misalignment(C0, phi))
    ins.state[4:7] += [0.1, 0.2, 0.3]
    rm, rn = earth.radii(0.6)
    ins.state[7] += 5.0 / (rm + 100)
    ins.correct(phi, np.array([0.1, 0.2, 0.3]), np.array([0.0, 5.0, 0.0]))
    np.testing.assert_allclose(ins.dcm, C0, atol=1e-10)
    np.testing.assert_allclose(ins.vel, v0, atol=1e-12)
    np.testing.assert_allclose(ins.lla, p0, atol=1e-12)


def test_bad_shapes_are_reported():
    ins = Strapdown([0.6, 2.0, 100.0], [0, 0, 0], [0, 0, 0], 0.01)
    with pytest.raises(ValueError, match="dtheta and dv"):
        ins.run(np.zeros((5, 3)), np.zeros((4, 3)))


def test_baro_loop_does_not_lag_in_a_fast_climb():
    """1 Hz baro while climbing at ~140 m/s: the held INS-baro difference adds no lag."""
    tr = generate([0.6, 2.0, 300.0], 400.0, [units.deg(20), 0, 0], [Segment(60.0)], 0.01)
    h_ref = np.full(len(tr.t) - 1, np.nan)
    h_ref[::100] = tr.lla[:-1:100, 2]
    ins = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], 0.01, baro=BaroLoop(20.0, 2))
    out = ins.run(tr.dtheta, tr.dv, h_ref=h_ref)
    assert np.abs(out["lla"][:, 2] - tr.lla[1:, 2]).max() < 0.01


def test_baro_loop_takes_the_barometers_lever_arm():
    """A barometer at lever l measures the height of its own point, h + (C_b^n l)_up: the
    loop told l keeps the INS on the IMU's height in a 20 deg climb; not told, it pulls the
    INS by (C l)_up (the sign check: the lever's up component moves it the other way)."""
    tr = generate([0.6, 2.0, 300.0], 100.0, [units.deg(20), 0, 0], [Segment(60.0)], 0.01)
    lever = np.array([0.5, 3.0, 1.0])
    h_sensor = tr.lla[:-1, 2] + (tr.dcm[:-1] @ lever)[:, 2]
    h_ref = np.full(len(tr.t) - 1, np.nan)
    h_ref[::10] = h_sensor[::10]
    err = {}
    for told in (True, False):
        loop = BaroLoop(5.0, 2, tuple(lever) if told else (0.0, 0.0, 0.0))
        ins = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], 0.01, baro=loop)
        assert ins.baro_loop.shape == (6,) and ins.baro_gains.shape == (3,)
        out = ins.run(tr.dtheta, tr.dv, h_ref=h_ref)
        err[told] = out["lla"][-1, 2] - tr.lla[-1, 2]
    up = (tr.dcm[-1] @ lever)[2]
    assert abs(up) > 0.1
    assert abs(err[True]) < 0.01
    assert err[False] == pytest.approx(up, abs=0.05)


def test_compiled_quat_to_dcm_matches_numpy():
    from fednav.ins.strapdown import quat_to_dcm_nb

    q = att.euler_to_quat([0.3, -0.2, 4.0])
    np.testing.assert_allclose(quat_to_dcm_nb(q), att.quat_to_dcm(q), atol=1e-15)
