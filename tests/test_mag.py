"""The magnetometer heading sensor (``fednav.sensors.mag``): its residual from a
noise-free simulated field is zero at any attitude, its sign (INS - sensor), its Jacobian
against finite differences of the residual over the platform error, the sigma-point
prediction, the file layout, and a GNSS + magnetometer run on a simulated drive."""

import types

import numpy as np
import pytest

from fednav import load_system
from fednav.core import attitude as att
from fednav.core import units
from fednav.core.units import ARCMIN
from fednav.ins.error_model import N_STATES
from fednav.io import SensorData, read_sensor_csv, write_sensor_csv
from fednav.sensors import registry
from fednav.sensors.mag import GAUSS, MagConfig, MagHeading, Magnetometer, azimuth, field_enu
from fednav.sensors.measurement import NavSnapshot

DEG = units.deg(1.0)
INC, DEC = units.deg(64.0), units.deg(3.5)
#: [pitch, roll, heading] [deg]: level, tilted, headings near 0 and 360, steep
ATTITUDES = [(0.0, 0.0, 0.0), (0.0, 0.0, 359.99), (5.0, -10.0, 0.01), (-20.0, 30.0, 359.5),
             (12.0, 45.0, 90.0), (-35.0, -60.0, 200.0), (60.0, 10.0, 270.0),
             (3.0, 170.0, 45.0)]


def _truth(euler_deg):
    """A truth whose attitude is ``euler_deg`` (one row per time 0, 1, 2 ...)."""
    e = units.deg(np.atleast_2d(np.asarray(euler_deg, dtype=float)))
    return types.SimpleNamespace(t=np.arange(len(e), dtype=float),
                                 at=lambda t: {"euler": e[np.asarray(t, dtype=int)]})


def _nav(euler_rad) -> NavSnapshot:
    return NavSnapshot(np.array([0.8, 0.1, 100.0]), np.zeros(3),
                       att.euler_to_dcm(np.asarray(euler_rad, dtype=float)))


def _field(euler_deg):
    """Noise-free body fields [T] of the attitudes ``euler_deg`` (the simulator's)."""
    sim = Magnetometer(0.0, INC, DEC, 0.5 * GAUSS, 1.0)
    tr = _truth(euler_deg)
    return sim.simulate(tr, np.random.default_rng(0), t=tr.t).z


def test_noise_free_field_gives_zero_residual_at_any_attitude():
    model = MagHeading(DEC, INC)
    z = _field(ATTITUDES)
    for e, zi in zip(ATTITUDES, z, strict=True):
        C = att.euler_to_dcm(units.deg(np.asarray(e)))
        np.testing.assert_allclose(zi, C.T @ field_enu(INC, DEC, 0.5 * GAUSS), atol=1e-18)
        y = model.residual(_nav(units.deg(np.asarray(e))), zi)
        assert y.shape == (1,)
        assert abs(y[0]) < 1e-9, (e, y)


def test_residual_is_ins_minus_sensor_in_arcmin():
    """An INS heading 1 deg larger than the truth: +60 arcmin (and -1 deg: -60), also
    across north; the residual is the azimuth of the measured field in the INS frame."""
    model = MagHeading(DEC, INC)
    for e in ATTITUDES:
        z = _field([e])[0]
        for d, want in ((1.0, 60.0), (-1.0, -60.0)):
            est = units.deg(np.asarray(e) + [0.0, 0.0, d])
            y = model.residual(_nav(est), z)[0]
            assert y == pytest.approx(want, abs=1e-7), (e, d)
            az = azimuth(att.euler_to_dcm(est) @ z) - DEC
            assert y == pytest.approx(float(att.wrap_pi(az)) / ARCMIN, abs=1e-7)


def _residual_at(model, C, z, phi_arcmin):
    """The residual with the INS attitude exp(-[phi x]) C (phi in filter units)."""
    C_hat = att.apply_misalignment(C, np.asarray(phi_arcmin, dtype=float) * ARCMIN)
    return model.residual(NavSnapshot(np.zeros(3), np.zeros(3), C_hat), z)[0]


def test_jacobian_matches_finite_differences_of_the_residual():
    model = MagHeading(DEC, INC)
    step = 1.0  # arcmin
    for e in ATTITUDES:
        C = att.euler_to_dcm(units.deg(np.asarray(e)))
        z = _field([e])[0]
        H = model.H(_nav(units.deg(np.asarray(e))))
        assert H.shape == (1, N_STATES) and not H[0, 3:].any()
        fd = [(_residual_at(model, C, z, step * np.eye(3)[j])
               - _residual_at(model, C, z, -step * np.eye(3)[j])) / (2 * step)
              for j in range(3)]
        np.testing.assert_allclose(H[0, :3], fd, atol=1e-6)
        # the tilt compensation's share: tan(I) times the tilt across magnetic north
        np.testing.assert_allclose(H[0, :3], [np.tan(INC) * np.sin(DEC),
                                              np.tan(INC) * np.cos(DEC), 1.0], atol=1e-12)
        # (the heading row of the Euler-error Jacobian alone does not describe it)
        assert np.abs(att.euler_error_jacobian(units.deg(np.asarray(e)))[2]
                      - H[0, :3]).max() > 0.1


def test_sigma_point_prediction_is_the_exact_residual_of_the_error():
    """h(phi) is the residual an INS misaligned by phi sees (field as configured), and
    H x to first order."""
    model = MagHeading(DEC, INC)
    rng = np.random.default_rng(2)
    X = np.zeros((6, N_STATES))
    X[:, :3] = rng.normal(0.0, 30.0, (6, 3))  # arcmin
    X[:, 3:] = rng.normal(0.0, 1.0, (6, N_STATES - 3))  # not seen by the magnetometer
    for e in ATTITUDES[:4]:
        C = att.euler_to_dcm(units.deg(np.asarray(e)))
        z = _field([e])[0]
        nav = _nav(units.deg(np.asarray(e)))
        h = model.h(X, nav)
        assert h.shape == (6, 1)
        want = [_residual_at(model, C, z, x[:3]) for x in X]
        np.testing.assert_allclose(h[:, 0], want, atol=1e-8)
    small = X * 1e-3
    np.testing.assert_allclose(model.h(small, nav)[:, 0], small @ model.H(nav)[0],
                               rtol=1e-3, atol=1e-9)
    assert model.h(np.zeros(N_STATES), nav)[0, 0] == pytest.approx(0.0, abs=1e-12)


def test_simulated_noise_gives_the_configured_heading_sigma():
    cfg = MagConfig(sigma_heading_deg=2.0, inclination_deg=INC / DEG,
                    declination_deg=DEC / DEG, period_s=0.1)
    n = 20000
    e = np.tile([[10.0, -20.0, 300.0]], (n, 1))
    series = cfg.sensor().simulate(_truth(e), np.random.default_rng(1), t=np.arange(n))
    assert series.kind == "mag" and series.z.shape == (n, 3)
    np.testing.assert_allclose(series.sigma, [units.deg(2.0)])
    y = np.array([cfg.model().residual(_nav(units.deg(e[0])), z)[0] for z in series.z[:4000]])
    assert np.std(y) * ARCMIN == pytest.approx(units.deg(2.0), rel=0.05)
    assert abs(np.mean(y)) < 5.0  # arcmin


def test_config_noise_and_registry():
    s = load_system({"sensors": {"mag": {"sigma_heading_deg": 1.5, "declination_deg": -4.0}},
                     "aiding": ["mag"]})
    cfg = s.sensors.mag
    assert isinstance(cfg, MagConfig) and cfg.inclination_deg == 60.0
    np.testing.assert_allclose(cfg.sigma(), [units.deg(1.5)])
    np.testing.assert_allclose(cfg.model().R(cfg.sigma()), [[90.0**2]])
    assert s.aiding_sensors() == ["mag"] and "mag" in registry.names(aiding=True)
    assert not registry.spec("mag").compiled


def test_file_round_trip_with_its_heading_sigma_column(tmp_path):
    cfg = MagConfig(sigma_heading_deg=1.0, period_s=0.5)
    tr = _truth([(1.0, 2.0, 3.0)] * 10)
    series = cfg.sensor().simulate(tr, np.random.default_rng(3), t=np.arange(10.0))
    p = write_sensor_csv(tmp_path / "mag.csv", series, sigma=True)
    assert p.read_text().splitlines()[0] == ("t_s,magR_gauss,magF_gauss,magU_gauss,"
                                             "sigma_heading_deg")
    data = read_sensor_csv("mag", p)
    np.testing.assert_allclose(data.z, series.z, rtol=1e-14)
    np.testing.assert_allclose(data.sigma, np.full((10, 3), units.deg(1.0)), rtol=1e-14)
    assert 0.3 < np.linalg.norm(data.z[0]) / GAUSS < 0.7  # gauss in the file, tesla in z


def test_gnss_and_magnetometer_hold_the_heading_on_a_simulated_drive():
    """The drive of test_process starts 2 deg off in heading and goes straight for 20 s
    (heading unobservable from GNSS): the magnetometer brings it in at once."""
    from test_process import make_flight

    from fednav.navigator.solution import consistency
    from fednav.process import errors_against, process
    from fednav.process.run import prepare

    imu, gnss, ref = make_flight()
    unwrapped = np.unwrap(ref.euler, axis=0)

    def at(t):
        return {"euler": np.column_stack([np.interp(t, ref.t, unwrapped[:, j])
                                          for j in range(3)])}

    truth = types.SimpleNamespace(t=ref.t, at=at)
    sec = {"sigma_heading_deg": 0.5, "declination_deg": 8.0, "inclination_deg": 65.0,
           "period_s": 0.1}
    series = MagConfig(**sec).sensor().simulate(truth, np.random.default_rng(3))
    data = SensorData("mag", "sim-mag", series.t, series.z)
    base = {"alignment": {"initial_attitude": "file"}}
    cfg = load_system({**base, "sensors": {"mag": sec}})
    assert prepare(imu, {"gnss": gnss, "mag": data}, cfg).navigator().engine == "python"
    res = process(imu, {"gnss": gnss, "mag": data}, cfg)
    without = process(imu, {"gnss": gnss}, load_system(base))

    def yaw_rms(r, a, b):
        e = errors_against(r.forward, ref)
        m = (e["t"] >= a) & (e["t"] < b)
        return float(units.to_deg(np.sqrt(np.mean(e["yaw_rad"][m] ** 2))))

    assert yaw_rms(without, 5.0, 20.0) > 1.5          # GNSS alone: still 2 deg off
    assert yaw_rms(res, 5.0, 20.0) < 0.8               # tilt unobservable yet: tan(I) x it
    assert yaw_rms(res, 60.0, 240.0) < 0.1
    assert yaw_rms(res, 60.0, 240.0) < 0.5 * yaw_rms(without, 60.0, 240.0)
    c = consistency(res.forward.fdi)
    assert set(c) == {"gnss", "mag"} and 0.5 < c["mag"]["nis_per_dof"] < 2.0
