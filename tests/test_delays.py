"""Delayed measurements: timing, INS-increment carry-back, curve fit, and the four
strategies in closed loop (paper-004 flight, shortened)."""

import numpy as np
import pytest

from fednav.core import earth, units
from fednav.core.config import ConfigError
from fednav.ins.strapdown import Strapdown
from fednav.scenarios import paper004
from fednav.sensors import Latency, NavSnapshot, measurement_times, sequential_times
from fednav.sensors.delays import InsIncrements, curve_fit_value
from fednav.sim.runs import make_run_data, run_mode
from fednav.sim.scenario import load_scenario
from fednav.sim.trajectory import Segment, generate


def test_latency_kinds_and_sequential_chaining():
    rng = np.random.default_rng(0)
    assert np.all(Latency.fixed(2.0).draw(3, rng) == 2.0)
    u = Latency.uniform(1.0, 6.0).draw(1000, rng)
    assert 1.0 <= u.min() and u.max() <= 6.0 and abs(u.mean() - 3.5) < 0.2
    np.testing.assert_allclose(Latency.from_list([1, 2]).draw(5, rng), [1, 2, 1, 2, 1])
    t, ta = sequential_times(1.0, 100.0, Latency.uniform(1.0, 6.0), rng, grid=0.02)
    np.testing.assert_allclose(t[1:], np.round(ta[:-1] / 0.02) * 0.02, atol=1e-9)
    assert np.all(ta > t) and t[-1] <= 100.0
    t, ta = measurement_times(0.0, 10.0, 1.0, Latency.fixed(0.5), False, rng)
    np.testing.assert_allclose(ta - t, 0.5)
    with pytest.raises(ValueError, match="low <= high"):
        Latency.uniform(3.0, 1.0)


def test_timing_config_errors_are_one_line(tmp_path):
    import yaml

    from fednav.scenarios import scenario_path

    d = yaml.safe_load(scenario_path("paper004").read_text())
    d["sensors"]["sar"]["timing"] = {"latency_s": 1.0, "latency_range_s": [1, 2]}
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="only one of latency_s"):
        load_scenario(p)
    d["sensors"]["sar"]["timing"] = {"sequential": True}
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="sequential timing needs a latency"):
        load_scenario(p)
    d["sensors"]["sar"]["timing"] = {"delay_compensation": "magic"}
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="delay_compensation"):
        load_scenario(p)


def test_curve_fit_is_exact_on_polynomials_and_unwraps_angles():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    z = np.column_stack([3 * t**2 - t + 2, np.mod(6.2 + 0.05 * t, 2 * np.pi)])
    out = curve_fit_value(t, z, 4.5, 2, 4, angles=(1,))
    assert out[0] == pytest.approx(3 * 4.5**2 - 4.5 + 2)
    assert np.mod(out[1], 2 * np.pi) == pytest.approx(np.mod(6.2 + 0.225, 2 * np.pi))
    assert curve_fit_value(t[:1], z[:1], 9.0, 2, 4)[0] == z[0, 0]  # one value: hold it


def test_ins_increment_carries_the_ins_back_to_the_capture_instant():
    """Ideal IMU in a turning, accelerating climb: the INS at epoch k carried back to t_c
    by eq. 6 must land on the truth at t_c (to the eq.'s first-order fractional term)."""
    truth = generate([units.deg(32), units.deg(118), 1000.0], 200.0, [0, 0, 0],
                     [Segment(5.0), Segment(10.0, accel=2.0, heading_rate=units.deg(2.0),
                                            pitch_rate=units.deg(0.5))], 0.02)
    ins = Strapdown(truth.lla[0], truth.vel[0], truth.euler[0], truth.dt)
    n_per = 50
    incs = InsIncrements(15, 0.0, 1.0)
    for e in range(1, 16):
        s0 = ins.state.copy()
        C0 = ins.dcm
        ins.run(truth.dtheta[(e - 1) * n_per:e * n_per], truth.dv[(e - 1) * n_per:e * n_per],
                record=False)
        incs.record(e, s0[7:10], s0[4:7], C0, ins.lla, ins.vel, ins.dcm)
    nav = NavSnapshot(ins.lla, ins.vel, ins.dcm)
    from fednav.core import attitude as att

    # (t_c, position / velocity / attitude tolerance): exact on epochs; the fractional term
    # uses the *next* interval's increment (eq. 6), off by the change of velocity in a
    # manoeuvre: here a 2 m/s^2, 2 deg/s turn -> metres, against ~2 km flown since t_c.
    for t_c, tol_p, tol_v in ((2.5, 0.05, 0.01), (10.0, 0.05, 0.01), (9.5, 6.0, 4.0),
                              (12.3, 6.0, 4.0)):
        back = incs.carry_back(nav, 15, t_c)
        i = round(t_c / truth.dt)
        d = earth.llh_difference_enu(*back.lla, *truth.lla[i])
        assert np.linalg.norm(d) < tol_p, t_c
        assert np.linalg.norm(back.vel - truth.vel[i]) < tol_v, t_c
        assert np.abs(att.misalignment(att.euler_to_dcm(truth.euler[i]), back.C)).max() \
            < units.deg(0.5), t_c


@pytest.fixture(scope="module")
def short():
    scn = paper004.load_scenario()
    return scn, make_run_data(scn, 3, max_time=400.0)


def _hstd(r):
    return float(np.hypot(*r.pos[:, :2].std(axis=0)))


def test_strategies_rank_as_the_paper_says(short):
    scn, data = short
    aid = ["sar", "sarvel", "baro"]
    s = {m: _hstd(run_mode(scn, aid, data, m, 400.0, delay=m))
         for m in ("none", "curve_fit", "ins_increment", "recompute")}
    assert s["none"] > 10 * s["curve_fit"]
    assert s["curve_fit"] > s["ins_increment"]
    assert s["recompute"] < 1.2 * s["ins_increment"]


def test_without_latency_the_compensations_change_nothing(short):
    scn, _ = short
    sensors = {n: scn.sensors[n].model_copy(update={"timing": scn.sensors[n].timing.model_copy(
        update={"latency_range_s": None, "sequential": False})}) for n in ("sar", "sarvel")}
    scn0 = scn.model_copy(update={"sensors": scn.sensors.replace(**sensors)})
    data = make_run_data(scn0, 3, max_time=200.0)
    ref = run_mode(scn0, ["sar", "sarvel", "baro"], data, "", 200.0)
    for how in ("ins_increment", "recompute"):
        sensors2 = {n: scn0.sensors[n].model_copy(update={"timing": scn0.sensors[
            n].timing.model_copy(update={"delay_compensation": how})}) for n in ("sar", "sarvel")}
        scn2 = scn0.model_copy(update={"sensors": scn0.sensors.replace(**sensors2)})
        r = run_mode(scn2, ["sar", "sarvel", "baro"], data, "", 200.0)
        np.testing.assert_allclose(r.pos, ref.pos, atol=1e-9)


def test_centralized_equals_federated_reset(short):
    """Stacked H/R in one KF == one local KF per sensor with fusion-reset (linear KF)."""
    scn, data = short
    fed = scn.model_copy(update={"filter": scn.filter.model_copy(
        update={"architecture": "federated"})})
    a = run_mode(scn, ["sar", "sarvel", "baro"], data, "", 300.0, delay="ins_increment")
    b = run_mode(fed, ["sar", "sarvel", "baro"], data, "", 300.0, delay="ins_increment")
    np.testing.assert_allclose(a.pos, b.pos, atol=1e-6)
    np.testing.assert_allclose(a.vel, b.vel, atol=1e-8)


def test_measurement_sets_vary_per_epoch(short):
    scn, data = short
    r = run_mode(scn, ["sar", "sarvel", "baro"], data, "", 400.0, delay="ins_increment")
    dofs = set(r.fdi["dof"])
    # baro alone (1), baro+velocity (3), baro+fix (4), all three (6) all occur
    assert {1, 3, 4, 6} <= dofs


def test_gnss_with_latency_gets_the_same_treatment(short):
    from fednav.sensors import GnssConfig

    scn, _ = short
    g = GnssConfig.model_validate({"sigma_pos_enu_m": 5.0, "sigma_vel_mps": 0.1, "period_s": 1.0,
                                   "timing": {"latency_s": 2.0}})
    scn_g = scn.model_copy(update={"sensors": scn.sensors.replace(gnss=g)})
    data = make_run_data(scn_g, 4, max_time=300.0)
    none = _hstd(run_mode(scn_g, ["gnss", "baro"], data, "", 300.0, delay="none"))
    inc = _hstd(run_mode(scn_g, ["gnss", "baro"], data, "", 300.0, delay="ins_increment"))
    assert inc < 0.2 * none
