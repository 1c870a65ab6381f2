"""The navigator's compiled engine against its Python loop on the same data, and which
systems each runs."""

from pathlib import Path

import numpy as np
import pytest

from fednav.filters import FilterError
from fednav.navigator import engine
from fednav.scenarios import paper002
from fednav.sensors.registry import SENSORS
from fednav.sim import runs

MAX_TIME = 120.0


@pytest.fixture(scope="module")
def scn_data():
    scn = paper002.load_scenario()
    return scn, runs.make_run_data(scn, 11, MAX_TIME)


def _with_engine(monkeypatch, name, fn):
    """``fn()`` with every Navigator built on engine ``name``."""
    with monkeypatch.context() as m:
        m.setenv("FEDNAV_ENGINE", name)
        return fn()


def _assert_same(a, b, fields, what):
    for name in fields:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name),
                                      err_msg=f"{what}: {name}")


@pytest.mark.parametrize("sharing", ["adaptive", "equal"])
def test_paper002_modes_equal_on_both_engines(monkeypatch, scn_data, sharing):
    """UKF local filters with star and SAR fixes, a master, adaptive or equal sharing:
    the compiled engine makes the Python loop's operations, bit for bit."""
    scn, data = scn_data
    scn = scn.model_copy(update={"filter": scn.filter.model_copy(update={"sharing": sharing})})
    for mode in scn.modes:
        if not mode.aiding:
            continue
        fast = _with_engine(monkeypatch, "compiled",
                            lambda m=mode: runs.run_configured_mode(scn, m, data, MAX_TIME))
        slow = _with_engine(monkeypatch, "python",
                            lambda m=mode: runs.run_configured_mode(scn, m, data, MAX_TIME))
        _assert_same(fast, slow, ("pos", "vel", "att", "sigma", "euler"), mode.name)
        assert fast.beta.keys() == slow.beta.keys()
        for k in fast.beta:
            np.testing.assert_array_equal(fast.beta[k], slow.beta[k])
        assert len(fast.fdi) == len(slow.fdi) > 0
        np.testing.assert_array_equal(fast.fdi["statistic"], slow.fdi["statistic"])
        assert list(fast.fdi["local"]) == list(slow.fdi["local"])
        np.testing.assert_array_equal(fast.fdi["t"], slow.fdi["t"])


@pytest.fixture(scope="module")
def drive(tmp_path_factory):
    """A short simulated car drive (GNSS with a lever arm, velocity sensor) as files."""
    from fednav.io import read_gnss_csv, read_imu_csv, read_velocity_csv
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    root = Path(__file__).resolve().parents[1]
    cfg = load_dataset_config(root / "examples" / "car-drive.yaml")
    cfg = cfg.model_copy(update={"segments": cfg.segments[:8]})
    d = tmp_path_factory.mktemp("drive")
    write_csv_dataset(simulate_dataset(cfg), d)
    g = read_gnss_csv(d / "gnss.csv", (1.5, 1.5, 3.0), (0.05, 0.05, 0.1), (0.3, -1.0, 1.2))
    return read_imu_csv(d / "imu.csv"), g, read_velocity_csv(d / "velocity.csv")


@pytest.mark.parametrize("filt", [
    {},                                                         # the default: KF locals
    {"fdi_alpha": {"velocity": 0.05}, "fdi_recovery": 3, "substeps": 2},
    {"type": "ukf", "alpha": 0.5},                             # unscented, linear sensors
    {"type": "sukf", "alpha": 0.5, "master": True},
    {"master": True, "sharing": "adaptive"},
    {"locals": {"velocity": {"type": "ukf"}}, "alpha": 0.5, "fdi_alpha": 0.01},
])
def test_recorded_data_equal_on_both_engines(monkeypatch, drive, filt):
    """fednav process with Kalman, unscented and mixed local filters, fault detection
    and recovery, a master filter: the IMU-rate solution, its sigmas and every
    innovation are the same on both engines."""
    from fednav import load_system
    from fednav.process import process

    imu, g, v = drive
    cfg = load_system({"imu": {"gyro_arw_deg_sqrt_h": 2.0, "accel_vrw_ug_sqrt_hz": 200.0,
                               "gyro_bias_deg_h": 200.0, "accel_bias_ug": 2000.0,
                               "gyro_markov_deg_h": 25.0, "gyro_tau_s": 100.0,
                               "accel_markov_ug": 200.0, "accel_tau_s": 100.0},
                       "filter": filt})
    out = {}
    for name in ("compiled", "python"):
        inns: list = []
        res = _with_engine(monkeypatch, name,
                           lambda inns=inns: process(imu, {"gnss": g, "velocity": v}, cfg,
                                                     smooth=True, innovations=inns))
        out[name] = (res, inns)
    (a, ia), (b, ib) = out["compiled"], out["python"]
    for sol in ("forward", "smoothed"):
        _assert_same(getattr(a, sol), getattr(b, sol),
                     ("lla", "vel", "euler", "sigma", "sigma_euler", "omega"), sol)
    assert len(ia) == len(ib) > 100
    for x, y in zip(ia, ib, strict=True):
        assert (x.local, x.t, x.accepted) == (y.local, y.t, y.accepted)
        np.testing.assert_array_equal(x.r, y.r)
        np.testing.assert_array_equal(x.S, y.S)
    fa, fb = np.array(a.forward.fdi, dtype=object), np.array(b.forward.fdi, dtype=object)
    np.testing.assert_array_equal(fa[:, [1, 3, 5]], fb[:, [1, 3, 5]])
    np.testing.assert_array_equal(fa[:, [0, 2, 4]].astype(float),
                                  fb[:, [0, 2, 4]].astype(float))


def test_which_systems_the_engine_runs(scn_data):
    scn, _ = scn_data
    mode = next(m for m in scn.modes if m.name == "SINS/CNS/SAR")
    base = scn.system_for(mode)
    why = engine.why_not_compiled
    assert why(base, ["star", "sar"], SENSORS) is None
    f = base.filter
    cases = {
        "'sghqf' filters": base.model_copy(update={"filter": f.model_copy(
            update={"type": "sghqf"})}),
        "a centralized filter": base.model_copy(update={"filter": f.model_copy(
            update={"architecture": "centralized"})}),
        "federation without reset": base.model_copy(update={"filter": f.model_copy(
            update={"reset": False})}),
        "the total-state navigator": base.model_copy(update={"filter": f.model_copy(
            update={"state": "total"})}),
        "'aekf' filters": base.model_copy(update={"filter": type(f).model_validate(
            {**f.model_dump(), "locals": {"star": {"type": "aekf"}}})}),
    }
    for reason, system in cases.items():
        assert why(system, ["star", "sar"], SENSORS) == reason
    late = base.sensors.replace(sar=base.sensors.sar.model_copy(update={
        "timing": base.sensors.sar.timing.model_copy(update={"delay_compensation":
                                                              "curve_fit"})}))
    assert why(base.model_copy(update={"sensors": late}), ["star", "sar"], SENSORS) == \
        "delay compensation 'curve_fit' (sar)"


@pytest.mark.parametrize("name", ["compiled", "python"])
def test_failure_names_the_filter_and_step(monkeypatch, scn_data, name):
    scn, data = scn_data
    bad = runs.RunData(**{**data.__dict__, "dtheta": data.dtheta.copy()})
    bad.dtheta[250] = np.nan
    mode = next(m for m in scn.modes if m.name == "SINS/SAR")
    monkeypatch.setenv("FEDNAV_ENGINE", name)
    with pytest.raises(FilterError, match=r"strapdown INS at step 3: navigation state "
                                          r"became non-finite"):
        runs.run_configured_mode(scn, mode, bad, MAX_TIME)


@pytest.mark.parametrize("kind", ["star", "sar"])
def test_attitude_kernels_against_the_euler_functions(kind):
    """The star and SAR kernels (residual and sigma-point prediction) against the
    attitude module's Euler-angle functions, on random attitudes (headings across
    0 / 2 pi, steep pitch), positions and sigma points."""
    from fednav.core import attitude as att
    from fednav.core import earth
    from fednav.core.units import ARCMIN
    from fednav.ins import error_model as em
    from fednav.sensors import MODELS, NavSnapshot

    rng = np.random.default_rng(5)
    model = MODELS[kind]
    for _ in range(50):
        euler = np.array([rng.uniform(-1.4, 1.4), rng.uniform(-3.1, 3.1),
                          rng.uniform(0.0, 2 * np.pi)])
        C = att.euler_to_dcm(euler)
        lla = np.array([rng.uniform(-1.2, 1.2), rng.uniform(-3.1, 3.1), rng.uniform(0, 9e3)])
        nav = NavSnapshot(lla=lla, vel=np.zeros(3), C=C)
        e = att.dcm_to_euler(C)
        if kind == "star":
            z = e + rng.normal(0, 1e-4, 3)
            want = att.euler_difference(e, z) / ARCMIN
        else:
            z = np.r_[lla[:2] + rng.normal(0, 1e-6, 2), (euler[2] + rng.normal(0, 0.01))
                      % (2 * np.pi)]
            rm, rn = earth.radii(lla[0])
            want = np.r_[(lla[1] - z[1]) * (rn + lla[2]) * np.cos(lla[0]),
                         (lla[0] - z[0]) * (rm + lla[2]), att.wrap_pi(e[2] - z[2]) / ARCMIN]
        np.testing.assert_allclose(model.residual(nav, z), want, rtol=1e-12, atol=1e-9)
        X = rng.normal(0, 30.0, (37, 18))  # filter units: arcmin, m/s, m, ...
        phi = X[:, :3] * em.SCALE[:3]
        Cs = att.misalignment_dcm(-phi) @ C  # exp([phi x]) C: the attitude each corrects
        de = att.euler_difference(e, att.dcm_to_euler(Cs)) / ARCMIN
        want = de if kind == "star" else np.column_stack([X[:, 6], X[:, 7], de[:, 2]])
        np.testing.assert_allclose(model.h(X, nav), want, rtol=1e-9, atol=1e-9)
