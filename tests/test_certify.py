"""The consistency certificate (``fednav certify``, docs/certificate.md).

Its truth (:mod:`fednav.campaign.certify_truth`) owes nothing to fednav's simulator: the
first tests check it against fednav's mechanization and sensor simulators from the
outside (two implementations agreeing); the quick tier then flies every registered
sensor x every registered filter type and form on a few runs and asserts every
combination in its chi-square band or in the documented limitations.
"""

from __future__ import annotations

import numpy as np
import pytest

from fednav.campaign import certify as cf
from fednav.campaign import certify_truth as ct
from fednav.core import attitude, earth, mounting
from fednav.filters.registry import FILTERS, square_root_names
from fednav.sensors.registry import SENSORS


@pytest.fixture(scope="module")
def land():
    """The land truth with the body turned and the IMU away from the reference point."""
    M = mounting.from_euler_deg([10.0, 170.0, 40.0])
    return ct.make_truth(cf.TRAJECTORIES["land"], cf.IMU_PERIOD_S, M.T, (0.5, -1.3, -0.6))


@pytest.fixture(scope="module")
def air():
    return ct.make_truth(cf.TRAJECTORIES["air"], cf.IMU_PERIOD_S)


def test_conventions_written_again_agree_with_fednavs():
    """The truth's own attitude and geodesy follow docs/conventions.md as fednav does."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        e = rng.uniform([-1.5, -3.1, 0.0], [1.5, 3.1, 6.2])
        assert np.allclose(ct.euler_to_dcm(e), attitude.euler_to_dcm(e), atol=1e-15)
        assert np.allclose(ct.dcm_to_euler(ct.euler_to_dcm(e)), e, atol=1e-12)
        lla = np.array([rng.uniform(-1.4, 1.4), rng.uniform(-3.1, 3.1), rng.uniform(-100, 9e3)])
        r = ct.geodetic_to_ecef(lla)
        assert np.allclose(r, earth.llh_to_ecef(*lla), atol=1e-8)
        assert np.allclose(ct.ecef_to_geodetic(r), lla, atol=[1e-14, 1e-14, 1e-8])
        assert ct.normal_gravity(lla[0], lla[2]) == pytest.approx(
            earth.gravity(lla[0], lla[2]), rel=1e-14)


@pytest.mark.parametrize("which", ["land", "air"])
def test_fednavs_free_ins_flies_the_independent_truth(which, land, air):
    """The ideal IMU increments of the closed-form motion, mechanized by fednav from the
    true start, stay on the truth: two implementations of the same physics agree (the
    land vehicle's body turned and its IMU off the reference point)."""
    import fednav
    from fednav.ins.strapdown import STATE_LLA, STATE_Q, STATE_VEL
    from fednav.navigator.navigator import InitialState

    tr = land if which == "land" else air
    system = fednav.load_system({"filter": {"period_s": cf.FILTER_PERIOD_S}})
    nav = fednav.Navigator(system, InitialState(0.0, tr.lla[0], tr.vel[0], tr.euler[0],
                                                np.eye(18)), tr.dt, record_rows=False,
                           record_covariance=False)
    nav.add_imu(tr.t[:-1], dtheta=tr.dtheta, dv=tr.dv)
    st = nav.result().states
    k = np.arange(len(st)) * int(round(cf.FILTER_PERIOD_S / tr.dt))
    dp = ct.metric_difference(st[:, STATE_LLA], tr.lla[k])
    dv = st[:, STATE_VEL] - tr.vel[k]
    phi = ct.dcm_to_rotvec(ct.quat_to_dcm(st[:, STATE_Q]) @ np.swapaxes(tr.C[k], -1, -2))
    # 120 s: under a centimetre (the free vertical channel included), 0.1 mm/s and
    # 1e-3 arcsec: far below every sensor's noise
    assert np.abs(dp).max() < 1e-2
    assert np.abs(dv).max() < 1e-4
    assert np.abs(phi).max() < 5e-9


class _Zero:
    """A generator that draws zeros: fednav's simulators without their noise."""

    def standard_normal(self, size=None):
        return np.zeros(size)


class _FednavView:
    """The independent truth in the shape fednav's simulators read (``at``)."""

    def __init__(self, tr):
        self.tr, self.t, self.dt, self.dtheta, self.vel = tr, tr.t, tr.dt, tr.dtheta, tr.vel

    def at(self, times):
        i = np.rint((np.asarray(times) - self.t[0]) / self.dt).astype(int)
        return {"lla": self.tr.lla[i], "vel": self.tr.vel[i], "euler": self.tr.euler[i],
                "wind": self.tr.wind[i]}


@pytest.mark.parametrize("name", ["gnss", "star", "sar", "baro", "sarvel", "velocity",
                                  "odometer", "dvl", "mag", "airdata"])
def test_measurement_equations_agree_with_fednavs_simulators(name, land, air):
    """Each sensor's closed-form measurement (certify_truth.measure) against fednav's
    simulator seeing the same truth through SensorView, with a lever arm and a mounting
    where the sensor takes them.  SensorView's point velocity takes the gyro's mean rate
    of the sample before (Earth rate and a half-sample lag included): millimetres per
    second at a 2 m lever."""
    from fednav.sensors.spec import SensorConfig

    tr = air if name in ("star", "sar", "sarvel", "airdata") else land
    lever_ok, mount_ok = cf._geometry_kinds(name)
    sec = dict(cf.SETUP[name].section, period_s=0.5)
    lever = np.array([1.1, -0.9, 1.3]) if lever_ok else np.zeros(3)
    M = mounting.from_euler_deg([25.0, -60.0, 130.0]) if mount_ok else None
    if lever_ok:
        sec["lever_m"] = list(lever)
    if mount_ok:
        sec["mounting"] = {"euler_deg": [25.0, -60.0, 130.0]}
    cfg: SensorConfig = SENSORS[name].config.model_validate(sec)
    series = cfg.simulate(_FednavView(tr), _Zero(), name)
    idx = np.rint(series.t / tr.dt).astype(int)
    z = ct.measure(name, tr, idx, lever, M, {**cf.SETUP[name].sigma, **{
        k: 0.0 * np.asarray(v) for k, v in cf.SETUP[name].sigma.items()
        if k not in ("inclination", "declination")}}, np.random.default_rng(0))
    got = series.z
    if name == "mag":  # (fednav's field strength is its section's: compare directions)
        z = z / np.linalg.norm(z, axis=1)[:, None]
        got = got / np.linalg.norm(got, axis=1)[:, None]
    d = z - got
    if name in ("star", "sar"):
        d[:, -1] = (d[:, -1] + np.pi) % (2 * np.pi) - np.pi
    pos = {"gnss": [0, 1], "sar": [0, 1]}.get(name, [])
    if pos:  # latitude and longitude as metres
        d[:, pos] *= 6.4e6
    tol = {"gnss": [1e-6, 1e-6, 1e-6, 3e-3, 3e-3, 3e-3], "star": 1e-10,
           "sar": [1e-6, 1e-6, 1e-10], "baro": 1e-6, "sarvel": 3e-3, "velocity": 3e-3,
           "odometer": 3e-3, "dvl": 3e-3, "mag": 1e-12, "airdata": 1e-9}[name]
    assert np.all(np.abs(d).max(axis=0) <= tol), np.abs(d).max(axis=0)


def test_the_land_vehicle_keeps_its_constraints(land):
    """Stops are exact stand-stills (all rates zero: ZUPT and ZARU hold), and the
    constraint's contact point moves only along its forward axis whatever the body's
    mounting and lever arm (to a few um/s: the point's ENU axes are those at the point,
    2 m from the IMU's)."""
    still = land.stopped
    assert still.sum() > 1500  # the two 10 s stops
    assert np.abs(land.vel[still]).max() == 0.0
    w_ie = np.einsum("nji,nj->ni", land.C[still],
                     earth.earth_rate(land.lla[still, 0]))
    assert np.abs(land.w_ib[still] - w_ie).max() < 1e-13
    M = mounting.from_euler_deg([10.0, 170.0, 40.0])
    idx = np.arange(0, len(land.t), 7)
    z = ct.measure("nhc", land, idx, (0.5, -1.3, -0.6), M, {"vel_ru": (0.0, 0.0)},
                   np.random.default_rng(0))
    assert np.abs(z).max() < 1e-5


def test_every_registered_sensor_and_filter_is_certified():
    assert cf.uncertified_sensors() == []
    names = {m.name for m in cf.modes()}
    assert set(SENSORS) <= names and {"land-all", "air-all"} <= names
    pairs = cf.filter_forms()
    assert {f for f, _ in pairs} == set(FILTERS)
    assert {f for f, form in pairs if form == "square_root"} == set(square_root_names())


def test_each_run_draws_its_own_geometry():
    """Lever arms up to 2 m exactly on the sensors whose spec takes one, mountings on
    those that take one, latencies within a filter period, rates that are whole filter
    periods; the same seed draws the same."""
    a, b = cf.run_data(11, 10.0), cf.run_data(12, 10.0)
    for name, sec in a.sections.items():
        lever_ok, mount_ok = cf._geometry_kinds(name)
        assert ("lever_m" in sec) == lever_ok
        if lever_ok:
            assert 0.0 < np.linalg.norm(sec["lever_m"]) <= cf.LEVER_MAX_M
            assert sec["lever_m"] != b.sections[name]["lever_m"]
        if not mount_ok:
            assert "mounting" not in sec
        n = sec["period_s"] / cf.FILTER_PERIOD_S
        assert abs(n - round(n)) < 1e-9
        tm = sec.get("timing", {})
        assert tm.get("latency_s", 0.0) <= cf.FILTER_PERIOD_S
        assert max(tm.get("latency_range_s", [0.0])) <= cf.FILTER_PERIOD_S
    assert any("mounting" in s for s in a.sections.values())
    c = cf.run_data.__wrapped__(11, 10.0)
    assert c.sections == a.sections
    assert np.array_equal(c.imu["land"][0], a.imu["land"][0])


def test_bands():
    lo, hi = cf.band(3.0 * 50)
    assert 0.70 < lo < 0.75 and 1.30 < hi < 1.35
    lo, hi = cf.band(1e6)
    assert 0.99 < lo < 1.0 < hi < 1.01


@pytest.mark.slow
def test_quick_tier_every_combination_in_band_or_a_documented_limitation():
    """Every registered sensor x filter type x form, a few runs of the first
    QUICK_DURATION_S: each combination in its 99 % bands, or outside only by figures
    that a documented limitation (certify.LIMITATIONS) explains."""
    cert = cf.run(cf.QUICK_RUNS, seed=1, jobs=2, duration_s=cf.QUICK_DURATION_S)
    outside = [(c["mode"], c["filter"], c["form"], p)
               for c in cert["combinations"] if c["verdict"] == "outside"
               for p, why in c["reasons"].items() if why is None]
    assert not outside, outside
    n = len(cf.modes()) * len(cf.filter_forms())
    assert len(cert["combinations"]) == n
    assert cert["verdicts"]["pass"] > n // 2


def test_command_writes_the_certificate_and_resumes(tmp_path):
    from typer.testing import CliRunner

    from fednav.cli import app

    args = ["certify", "--quick", "--filters", "kf", "--forms", "standard", "--modes",
            "gnss,zupt", "--jobs", "1", "--out", str(tmp_path)]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    import json

    cert = json.loads((tmp_path / "certificate.json").read_text())
    assert [c["mode"] for c in cert["combinations"]] == ["gnss", "zupt"]
    assert all(c["runs"] == cf.QUICK_RUNS for c in cert["combinations"])
    # the health monitor flies along: no false alarm on clean runs in band
    assert [c["health_warned_runs"] for c in cert["combinations"]] == [0, 0]
    assert "| gnss | kf | standard |" in (tmp_path / "certificate.md").read_text()
    again = CliRunner().invoke(app, args)
    assert "0 units computed, 3 reused" in again.output
    for bad, why in ((["--runs-of", "pf=x"], "TYPE=RUNS"), (["--filters", "kalman"],
                                                           "unknown 'kalman'")):
        res = CliRunner().invoke(app, ["certify", "--out", str(tmp_path), *bad])
        assert res.exit_code == 2 and why in res.output


def test_the_wind_constraint_uses_each_air_data_sample_once():
    """Air data every 1 s into 0.1 s epochs and two local filters (star, baro): each
    sample is one update per local filter, not one per epoch while it stays the latest
    (which counted one sample's noise ten times: velocity NEES 9.6)."""
    from dataclasses import replace

    data = cf.run_data(3, 20.0)
    t, ta, z = data.measurements[("airdata", "air")]
    keep = np.flatnonzero(np.isclose(np.mod(t + 1e-9, 1.0), 0.0, atol=1e-6))
    meas = {**data.measurements, ("airdata", "air"): (t[keep], ta[keep], z[keep])}
    two = cf.Mode("airdata-2", "air", ("star", "baro"), "wind")
    out = cf.fly(two, "kf", "standard", replace(data, measurements=meas))
    assert "error" not in out, out
    used = out["nis"]["airdata.constraint"][1]
    t_end = data.truth["air"].t[-1]
    assert used == 2 * np.count_nonzero(ta[keep] <= t_end + 1e-9)


def test_the_wind_constraint_in_three_local_filters_is_no_false_alarm():
    """The constraint in three local filters (star, baro, GNSS), each with
    R / w_i: its logged NIS is the whole measurement's (about 1 per dof, not w_i = 1/3
    of it), so the health monitor does not call the star sensor's sigma too large."""
    three = cf.Mode("airdata-3", "air", ("star", "baro", "gnss"), "wind")
    out = cf.fly(three, "kf", "standard", cf.run_data(1, 40.0))
    assert "error" not in out, out
    total, count, dof = out["nis"]["airdata.constraint"]
    assert 0.85 < total / (count * dof) < 1.15
    assert out["health"] == []
