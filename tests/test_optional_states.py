"""Optional error states (fednav.ins.states): IMU scale factors and the GNSS position's
Gauss–Markov error — the model against a twin INS, both engines alike, recovery of
simulated scale factors within 3 sigma, consistency with time-correlated GNSS errors."""

from pathlib import Path

import numpy as np
import pytest
from test_error_model import numerical_jacobian, phi_of_F

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.core.config import ConfigError
from fednav.ins import error_model as em
from fednav.ins.states import StateLayout, with_optional
from fednav.ins.strapdown import Strapdown
from fednav.navigator.system import load_system, state_layout
from fednav.process import process
from fednav.process.run import errors_against, rmse
from fednav.sim.drives import ADIS16488, car_drive
from fednav.sim.trajectory import Segment, generate

EXAMPLE = Path(__file__).parents[1] / "examples" / "car-drive.yaml"
ALL = StateLayout.of({"gyro_scale": (3e-3, np.inf), "accel_scale": (2e-3, np.inf),
                      "gnss_markov": ((0.5, 0.5, 1.0), 60.0)})


def test_layout_columns_names_and_units():
    assert ALL.n == 27
    assert [ALL.start(b) for b in ("gyro_scale", "accel_scale", "gnss_markov")] == [18, 21, 24]
    assert StateLayout.of({"gnss_markov": (1.0, 10.0)}).start("gnss_markov") == 18
    names = ALL.state_names(em.STATE_NAMES)
    assert names[18:] == ("sg_x", "sg_y", "sg_z", "sa_x", "sa_y", "sa_z", "gnss_bE",
                          "gnss_bN", "gnss_bU")
    np.testing.assert_array_equal(ALL.scale(em.SCALE)[18:], [1e-6] * 6 + [1.0] * 3)
    P0 = with_optional(np.eye(18), ALL)
    np.testing.assert_allclose(np.diag(P0)[18:], [3e3**2] * 3 + [2e3**2] * 3
                               + [0.25, 0.25, 1.0])
    with pytest.raises(ValueError, match="27 states"):
        with_optional(np.eye(20), ALL)


def _process(layout, nsub=20):
    nom = em.Nominal(lat=units.deg(39.0), h=500.0, vel=np.array([20.0, -12.0, 1.0]),
                     C=att.euler_to_dcm([0.05, 0.1, units.deg(45)]),
                     fn=np.array([0.8, -1.2, 9.8]), wb=np.array([0.1, -0.2, 0.3]))
    noise = em.ImuNoiseModel(gyro_markov_sigma=units.deg_per_h(0.001), gyro_markov_tau=1800.0)
    return em.ErrorProcess(nom, 1.0, noise, nsub=nsub, layout=layout)


SINGLE = [StateLayout.of({"accel_scale": (2e-3, np.inf)}),
          StateLayout.of({"velocity_markov": (0.05, 20.0)}),
          StateLayout.of({"gyro_scale": (3e-3, np.inf), "velocity_markov": (0.05, 20.0)})]


@pytest.mark.parametrize("layout", SINGLE, ids=lambda lay: "+".join(lay.names))
def test_F_is_the_jacobian_for_a_block_that_starts_at_18(layout):
    """A block alone starts at column 18 (the scale couplings follow its start)."""
    p = _process(layout)
    np.testing.assert_allclose(numerical_jacobian(p.transition, layout.n), phi_of_F(p),
                               atol=2e-6, rtol=1e-5)
    if "accel_scale" in layout.names:
        assert np.abs(p.F_si()[3:6, 18:21]).max() > 0.1  # C diag(f_b): f_b has gravity


def test_F_is_the_jacobian_of_the_nonlinear_model_with_every_optional_state():
    p = _process(ALL)
    expected = phi_of_F(p)
    np.testing.assert_allclose(numerical_jacobian(p.transition, ALL.n), expected, atol=2e-6,
                               rtol=1e-5)
    np.testing.assert_allclose(p.Phi, expected, atol=2e-5, rtol=1e-4)
    # a Gauss-Markov block decays and is driven by 2 sigma^2 / tau
    assert p.Phi[24, 24] == pytest.approx(np.exp(-1.0 / 60.0), rel=1e-9)
    assert p.Qd[26, 26] == pytest.approx(1.0 * (1 - np.exp(-2.0 / 60.0)), rel=2e-2)
    assert p.Qd[18, 18] == 0.0  # a random constant


def test_the_18_states_are_the_same_with_optional_states_after_them():
    a, b = _process(StateLayout()), _process(ALL)
    np.testing.assert_array_equal(a.Phi, b.Phi[:18, :18])
    np.testing.assert_array_equal(a.Qd, b.Qd[:18, :18])
    rng = np.random.default_rng(3)
    X = rng.normal(size=(5, 18))
    Xb = np.hstack([X, np.zeros((5, 9))])
    np.testing.assert_array_equal(a.transition(X), b.transition(Xb)[:, :18])


def nav_error(s_hat, s_true):
    """[phi (rad), dv ENU (m/s), dp ENU (m)], computed minus true."""
    phi = att.misalignment(att.quat_to_dcm(s_true[0:4]), att.quat_to_dcm(s_hat[0:4]))
    dp = earth.llh_difference_enu(*s_hat[7:10], *s_true[7:10])
    return np.r_[phi, s_hat[4:7] - s_true[4:7], dp]


def test_scale_factor_errors_predicted_against_a_twin_ins():
    """An IMU reading (1 + s) of every increment, flown uncompensated beside one reading
    the truth, through turns, climbs and accelerations: Phi's chain from the scale-factor
    states alone (ds = s) predicts their difference — attitude, velocity and position —
    to a few per cent.  A sign slip in either coupling, or a body rate taken from the
    wrong axis, misses by 100 % or more."""
    segs = [Segment(3.0, accel=2.0, heading_rate=units.deg(10.0)),
            Segment(3.0, pitch_rate=units.deg(3.0), heading_rate=units.deg(-8.0)),
            Segment(2.0, roll_rate=units.deg(5.0)), Segment(2.0, roll_rate=units.deg(-5.0),
                                                            accel=-1.5)]
    tr = generate(np.array([units.deg(45.0), units.deg(7.0), 100.0]), 10.0,
                  [0.0, 0.0, units.deg(30.0)], segs, 0.01)
    sg, sa = np.array([2e-3, -3e-3, 5e-3]), np.array([1e-3, -2e-3, 3e-3])
    dth, dv = (1 + sg) * tr.dtheta, (1 + sa) * tr.dv
    ref = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt)
    bad = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt)
    n = 50
    s_ref = np.vstack([ref.state.copy(), ref.run_intervals(tr.dtheta, tr.dv, None, n)])
    s_bad = np.vstack([bad.state.copy(), bad.run_intervals(dth, dv, None, n)])
    lay = StateLayout.of({"gyro_scale": (1e-3, np.inf), "accel_scale": (1e-3, np.inf)})
    x = np.r_[np.zeros(18), sg / 1e-6, sa / 1e-6]
    scale = lay.scale(em.SCALE)
    for k in range(len(s_ref) - 1):
        sl = slice(k * n, (k + 1) * n)
        p = em.interval_process(s_bad[k], s_bad[k + 1], dv[sl].sum(axis=0), n * tr.dt,
                                em.ImuNoiseModel(), dtheta_sum=dth[sl].sum(axis=0),
                                layout=lay)
        x = p.Phi @ x
    predicted = (x * scale)[:9]
    actual = nav_error(s_bad[-1], s_ref[-1])
    for blk in (slice(0, 3), slice(3, 6), slice(6, 9)):
        big = np.abs(actual[blk]).max()
        assert big > 0
        np.testing.assert_allclose(predicted[blk], actual[blk], atol=0.03 * big)


def test_configured_states_and_their_errors():
    sys_ = load_system({"imu": {"gyro_scale_ppm": 1000.0, "grade": "industrial"},
                        "sensors": {"gnss": {"markov_sigma_enu_m": [0.3, 0.3, 0.6],
                                             "markov_tau_s": 30.0}},
                        "filter": {"states": ["gnss_markov", "gyro_scale", "accel_scale"]}})
    lay = state_layout(sys_)
    assert lay.names == ("gyro_scale", "accel_scale", "gnss_markov")
    np.testing.assert_allclose(lay.sigma(), [1e-3] * 3 + [3e-3] * 3 + [0.3, 0.3, 0.6])
    with pytest.raises(ConfigError, match=r"filter\.states.*imu\.accel_scale_ppm"):
        state_layout(load_system({"filter": {"states": ["accel_scale"]}}))
    with pytest.raises(ConfigError, match=r"gnss_markov needs sensors\.gnss\.markov_sigma"):
        load_system({"sensors": {"gnss": {}}, "filter": {"states": ["gnss_markov"]}})
    with pytest.raises(ConfigError, match="filter.state: error"):
        load_system({"imu": {"gyro_scale_ppm": 100.0},
                     "filter": {"state": "total", "states": ["gyro_scale"]}})
    with pytest.raises(ConfigError, match="filter.states"):
        load_system({"filter": {"states": ["odometer_scale"]}})


# ---------------------------------------------------------------- on a simulated drive
SCALED = {**ADIS16488, "random_bias": True, "gyro_scale_ppm": 5000.0,
          "accel_scale_ppm": 3000.0}


@pytest.fixture(scope="module")
def scaled_drive():
    return car_drive(heading_deg=40.0, seed=5, imu=SCALED, static_s=5.0, hill_deg=4.0)


def _with_states(system, states, imu=None, **filt):
    """``system`` with the optional ``states``, IMU keys ``imu`` and filter keys."""
    d = system.model_dump()
    d["filter"].update(states=states, **filt)
    d["imu"].update(imu or {})
    d["sensors"] = {"gnss": system.sensors.gnss.model_dump(exclude_none=True)}
    return load_system(d)


@pytest.fixture(scope="module")
def scaled_run(scaled_drive):
    d = scaled_drive
    system = _with_states(d.system, ["gyro_scale", "accel_scale"])
    return process(d.imu, {"gnss": d.gnss}, system)


def test_scale_factor_states_recover_the_simulated_scale_factors_within_3_sigma(
        scaled_drive, scaled_run):
    """The drive's drawn scale factors (5000 ppm gyro, 3000 ppm accelerometer, 1-sigma per
    axis) against the filter's estimates at the end: each axis within 3 sigma, and the
    axes the drive excites learnt — the gyro's z in the two 90 deg turns (each shows a
    scale error as 0.45 deg of heading per 0.5 %, against the heading's own sigma of a
    few tenths: sigma below half the prior's) and the accelerometer's z, which reads
    gravity (below a quarter)."""
    opt = scaled_run.optional_states
    for name, truth, prior in (("gyro_scale", scaled_drive.imu_state.gyro_scale, 5e-3),
                               ("accel_scale", scaled_drive.imu_state.accel_scale, 3e-3)):
        est, sd = opt[name]["estimate"], opt[name]["sigma"]
        assert np.all(np.abs(est - truth) <= 3.0 * sd), (name, est, truth, sd)
        assert np.all(sd <= prior * 1.0001)
    assert opt["gyro_scale"]["sigma"][2] < 5e-3 / 2
    assert opt["accel_scale"]["sigma"][2] < 3e-3 / 4


def test_scale_factor_states_help_where_the_imu_has_scale_factors(scaled_drive, scaled_run):
    """On the same drive the 18-state filter cannot explain a 0.5 % gyro scale error in
    the turns: the 24-state filter's heading is better."""
    d = scaled_drive
    plain = process(d.imu, {"gnss": d.gnss}, d.system)
    a = rmse(errors_against(plain.forward, d.reference))
    b = rmse(errors_against(scaled_run.forward, d.reference))
    assert b["yaw_deg"] < a["yaw_deg"]


@pytest.fixture(scope="module")
def gm_drive():
    return car_drive(heading_deg=200.0, seed=11, imu=ADIS16488, static_s=5.0,
                     gnss={"lever_m": (0.3, -1.0, 1.2), "sigma_pos_enu_m": (0.1, 0.1, 0.2),
                           "markov_sigma_enu_m": (0.8, 0.8, 1.5), "markov_tau_s": 60.0})


def _gnss_nis_per_row(drive, states):
    inn = []
    res = process(drive.imu, {"gnss": drive.gnss}, _with_states(drive.system, states),
                  innovations=inn)
    r2 = np.array([i.r**2 / np.diag(i.S) for i in inn if i.local == "gnss"])
    return res, r2.mean(axis=0)


def test_gnss_markov_state_makes_time_correlated_fixes_consistent(gm_drive):
    """Fixes whose error is mostly a 60 s Gauss–Markov wander (0.8/0.8/1.5 m beside 0.1/
    0.1/0.2 m white; the file's sigma is the whole error's, as a receiver reports it).
    Taken as white noise, the position rows' NIS/dof is far below 1 (the innovations see
    only the wander's increments: 0.1-0.3 here); with the Gauss–Markov state every row is
    in [0.5, 2], the position error is no larger and its 3-sigma contains it."""
    d = gm_drive
    _, white = _gnss_nis_per_row(d, [])
    assert white[:3].max() < 0.5, white
    res, nis = _gnss_nis_per_row(d, ["gnss_markov"])
    assert np.all((nis >= 0.5) & (nis <= 2.0)), nis
    err = errors_against(res.forward, d.reference)
    plain = rmse(errors_against(process(d.imu, {"gnss": d.gnss}, d.system).forward, d.reference))
    got = rmse(err)
    for k in ("east_m", "north_m", "up_m"):
        assert got[k] <= 1.02 * plain[k], (k, got[k], plain[k])
    sd = res.forward.sigma[:, 6:9]
    for j, k in enumerate(("east_m", "north_m", "up_m")):
        s = np.interp(err["t"], res.forward.t, sd[:, j])
        assert np.mean(np.abs(err[k]) <= 3.0 * s) > 0.95, k


@pytest.mark.parametrize("filt", [{"type": "kf"}, {"type": "ukf"},
                                  {"type": "kf", "form": "square_root"}])
def test_both_engines_fly_the_optional_states_alike(monkeypatch, gm_drive, filt):
    """Every optional state at once (27 states): the compiled engine and the Python loop
    give the same solution, innovations and final estimates, to the bit."""
    d = gm_drive
    system = _with_states(d.system, ["gyro_scale", "accel_scale", "gnss_markov"],
                          {"gyro_scale_ppm": 3000.0, "accel_scale_ppm": 3000.0}, **filt)
    out = {}
    for name in ("compiled", "python"):
        inn: list = []
        with monkeypatch.context() as m:
            m.setenv("FEDNAV_ENGINE", name)
            out[name] = (process(d.imu, {"gnss": d.gnss}, system, smooth=True, innovations=inn),
                         inn)
    (a, ia), (b, ib) = out["compiled"], out["python"]
    for sol in ("forward", "smoothed"):
        for f in ("lla", "vel", "euler", "sigma"):
            np.testing.assert_array_equal(getattr(getattr(a, sol), f),
                                          getattr(getattr(b, sol), f), err_msg=f"{sol} {f}")
    assert len(ia) == len(ib) > 100
    for x, y in zip(ia, ib, strict=True):
        np.testing.assert_array_equal(x.r, y.r)
        np.testing.assert_array_equal(x.S, y.S)
    for k in a.optional_states:
        for q in ("estimate", "sigma"):
            np.testing.assert_array_equal(a.optional_states[k][q], b.optional_states[k][q])


def test_a_centralized_filter_flies_the_optional_states_like_the_federated_one(gm_drive):
    """One sensor: the centralized filter (Python loop, stacked models) and the federated
    one (compiled) are the same estimator, up to rounding."""
    d = gm_drive
    states, imu = ["gnss_markov", "gyro_scale"], {"gyro_scale_ppm": 2000.0}
    fed = process(d.imu, {"gnss": d.gnss}, _with_states(d.system, states, imu))
    cen = process(d.imu, {"gnss": d.gnss}, _with_states(d.system, states, imu,
                                                    architecture="centralized"))
    np.testing.assert_allclose(cen.forward.vel, fed.forward.vel, atol=1e-6)
    for k in fed.optional_states:
        np.testing.assert_allclose(cen.optional_states[k]["estimate"],
                                   fed.optional_states[k]["estimate"], rtol=1e-5, atol=1e-9)


def test_tune_with_the_gnss_markov_state_keeps_the_held_back_nis_in_band(gm_drive):
    """``fednav tune`` on fixes with time-correlated errors and a lever arm, the base
    config selecting the Gauss–Markov state: the held-back blocks' NIS/dof is in [0.5, 2]
    before and after (as white noise it is about 0.6), and the tuned config keeps the
    states, their figures and the lever arm."""
    import yaml

    from fednav.process.tuning import config_yaml, tune

    d = gm_drive
    base = _with_states(d.system, ["gnss_markov", "gyro_scale"], {"gyro_scale_ppm": 1000.0})
    res = tune(d.imu, {"gnss": d.gnss}, base)
    for ev in (res.before, res.after):
        assert 0.5 <= ev.nis_held["gnss"] <= 2.0, ev.nis_held
    out = yaml.safe_load(config_yaml(res, base.model_dump(exclude_none=True)))
    tuned = load_system(out)
    assert tuned.filter.states == ["gnss_markov", "gyro_scale"]
    assert tuned.imu.gyro_scale_ppm == 1000.0
    assert tuned.sensors.gnss.markov_tau_s == 60.0
    assert tuned.sensors.gnss.lever_m == (0.3, -1.0, 1.2)


def test_the_estimates_reach_summary_json_and_the_printed_run(gm_drive, monkeypatch):
    """``summary.json`` ``error_states`` in ppm and metres, per axis, and one printed line
    per block with its unit (not eaten as markup)."""
    from rich.console import Console

    from fednav import cli
    from fednav.process.output import summary

    d = gm_drive
    res = process(d.imu, {"gnss": d.gnss}, _with_states(
        d.system, ["gyro_scale", "gnss_markov"], {"gyro_scale_ppm": 1000.0}))
    s = summary(res, d.reference, {})
    assert set(s["error_states"]) == {"gyro_scale_ppm", "gnss_markov_enu_m"}
    g = s["error_states"]["gyro_scale_ppm"]
    np.testing.assert_allclose(g["estimate"], res.optional_states["gyro_scale"]["estimate"]
                               * 1e6, atol=1e-6)
    assert all(0 < x <= 1000.0 * 1.0001 for x in g["sigma"])
    con = Console(record=True, width=200)
    monkeypatch.setattr(cli, "console", con)
    cli._print_process(s)
    text = con.export_text()
    assert "gyro scale x/y/z [ppm] at the end: " in text
    assert "gnss markov E/N/U [m] at the end: " in text


@pytest.fixture(scope="module")
def visual_drive(tmp_path_factory):
    """examples/car-drive.yaml's first 223 s with a velocity sensor whose error is mostly
    a 30 s Gauss–Markov drift (0.1/0.1/0.05 m/s beside 0.03 m/s white; the file's sigma
    the whole error's), written and read back as CSV, GNSS withheld over 100-160 s."""
    from fednav.io import read_gnss_csv, read_imu_csv, read_reference_csv, read_velocity_csv
    from fednav.process.tuning import withheld
    from fednav.sim.dataset import (
        VelocitySimConfig,
        load_dataset_config,
        simulate_dataset,
        write_csv_dataset,
    )

    cfg = load_dataset_config(EXAMPLE)
    cfg = cfg.model_copy(update={"segments": cfg.segments[:13], "velocity": VelocitySimConfig(
        sigma_mps=(0.03, 0.03, 0.03), markov_sigma_mps=(0.1, 0.1, 0.05), markov_tau_s=30.0)})
    d = tmp_path_factory.mktemp("visual")
    write_csv_dataset(simulate_dataset(cfg), d)
    system = load_system(d / "process.yaml")
    gc = system.sensors.gnss
    gnss = withheld(read_gnss_csv(d / "gnss.csv", gc.sigma_pos_enu_m, gc.sigma_vel_mps,
                                  gc.lever_m), [(100.0, 160.0)])
    return (read_imu_csv(d / "imu.csv"), gnss, read_velocity_csv(d / "velocity.csv"),
            read_reference_csv(d / "reference.csv"), system)


def test_velocity_markov_state_follows_a_drifting_velocity_sensor(visual_drive):
    """A velocity sensor whose error drifts (visual odometry): as white noise of its
    whole sigma its rows' NIS/dof is 0.2-0.4 and the solution drifts through a 60 s GNSS
    outage; with the ``velocity_markov`` state (the figures ``fednav simulate`` wrote into
    process.yaml) each row is in [0.5, 2] and the outage's horizontal error is smaller,
    forward and smoothed."""
    imu, gnss, vel, ref, system = visual_drive
    assert system.sensors.velocity.markov_tau_s == 30.0
    out = {}
    for states in ([], ["velocity_markov"]):
        d = system.model_dump(exclude_none=True)
        d["filter"]["states"] = states
        inn = []
        res = process(imu, {"gnss": gnss, "velocity": vel}, load_system(d), smooth=True,
                      innovations=inn)
        nis = np.array([i.r**2 / np.diag(i.S) for i in inn if i.local == "velocity"])
        drift = []
        for sol in (res.forward, res.smoothed):
            e = errors_against(sol, ref)
            m = (e["t"] > 100.0) & (e["t"] < 160.0)
            drift.append(float(np.sqrt(np.mean(e["east_m"][m]**2 + e["north_m"][m]**2))))
        out[bool(states)] = nis.mean(axis=0), drift
    (white, d0), (gm, d1) = out[False], out[True]
    assert white.max() < 0.5, white
    assert np.all((gm >= 0.5) & (gm <= 2.0)), gm
    assert d1[0] < 0.8 * d0[0] and d1[1] < 0.8 * d0[1], (d0, d1)


def test_both_engines_fly_the_velocity_markov_state_alike(monkeypatch, visual_drive):
    imu, gnss, vel, ref, system = visual_drive
    d = system.model_dump(exclude_none=True)
    d["filter"]["states"] = ["velocity_markov", "gnss_markov"]
    d["sensors"]["gnss"].update(markov_sigma_enu_m=0.5, markov_tau_s=100.0)
    system = load_system(d)
    out = {}
    for name in ("compiled", "python"):
        with monkeypatch.context() as m:
            m.setenv("FEDNAV_ENGINE", name)
            out[name] = process(imu, {"gnss": gnss, "velocity": vel}, system)
    a, b = out["compiled"], out["python"]
    np.testing.assert_array_equal(a.forward.lla, b.forward.lla)
    np.testing.assert_array_equal(a.forward.sigma, b.forward.sigma)
    for k in ("velocity_markov", "gnss_markov"):
        np.testing.assert_array_equal(a.optional_states[k]["estimate"],
                                      b.optional_states[k]["estimate"])


def test_an_imu_without_figures_gets_the_preset_and_its_scale_figure(gm_drive):
    """A recording with no IMU figures: ``process`` assumes the grade preset (and says
    so); selected scale-factor states take the preset's figure when the config gives
    none, and a config giving only the scale-factor sigmas still gets the preset for the
    noise figures (they are not noise figures)."""
    from dataclasses import replace

    d = gm_drive
    imu = replace(d.imu, errors=None)
    gnss = {"gnss": d.system.sensors.gnss.model_dump(exclude_none=True)}
    for imu_keys, expect in (({}, 10_000.0), ({"gyro_scale_ppm": 2000.0}, 2000.0)):
        system = load_system({"imu": imu_keys, "sensors": gnss,
                              "filter": {"states": ["gyro_scale"]}})
        res = process(imu, {"gnss": d.gnss}, system)
        assert any("preset is assumed" in w for w in res.warnings), res.warnings
        sd = res.optional_states["gyro_scale"]["sigma"]
        assert sd.max() <= expect * 1e-6 * 1.0001 and sd.max() > 0.5 * expect * 1e-6
