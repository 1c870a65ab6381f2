import numpy as np
import pytest

from fednav.core import units
from fednav.sensors import Barometer, ImuErrors, MeasurementSeries, StarSensor, corrupt_imu
from fednav.sim.trajectory import Segment, generate


def test_imu_error_statistics():
    rng = np.random.default_rng(7)
    n, dt = 200_000, 0.01
    z = np.zeros((n, 3))
    err = ImuErrors(gyro_bias=units.deg_per_h(0.01), gyro_markov_sigma=1e-5, gyro_markov_tau=1.0,
                    accel_bias=units.micro_g(100), accel_vrw=1e-3)
    dth, dv, st = corrupt_imu(z, z, dt, err, rng)
    # Markov part: stationary sigma and lag-1 correlation exp(-dt/tau); 2000 s of data
    # are 2000 correlation times, so the sample std is within a few per cent.
    mk = st.gyro_bias - units.deg_per_h(0.01)
    assert mk.std() == pytest.approx(1e-5, rel=0.05)
    c = np.corrcoef(mk[:-1, 0], mk[1:, 0])[0, 1]
    assert c == pytest.approx(np.exp(-dt / 1.0), abs=1e-3)
    # White noise on velocity increments: vrw * sqrt(dt) per sample, plus the bias.
    assert (dv - units.micro_g(100) * dt).std() == pytest.approx(1e-3 * np.sqrt(dt), rel=0.01)
    # Reproducible from the seed.
    d2, _, _ = corrupt_imu(z, z, dt, err, np.random.default_rng(7))
    np.testing.assert_array_equal(dth, d2)


def test_star_and_baro_series():
    tr = generate([0.6, 2.0, 100.0], 50.0, [0, 0, 0.5], [Segment(20.0)], 0.01)
    rng = np.random.default_rng(0)
    s = StarSensor(units.arcsec(3.0), 5.0).simulate(tr, rng)
    np.testing.assert_allclose(s.t, [5, 10, 15, 20])
    assert s.z.shape == (4, 3)
    b = Barometer(2.0, 1.0).simulate(tr, rng)
    np.testing.assert_allclose(b.t, np.arange(1.0, 20.5, 1.0))
    assert b.z.shape == (20, 1)


def test_series_validation():
    with pytest.raises(ValueError, match="strictly increasing"):
        MeasurementSeries("sar", [1.0, 1.0], np.zeros((2, 3)), np.ones(3))
    with pytest.raises(ValueError, match="non-finite"):
        MeasurementSeries("sar", [1.0, 2.0], [[np.nan] * 3, [0] * 3], np.ones(3))


def test_imu_per_axis_parameters():
    rng = np.random.default_rng(2)
    n, dt = 100_000, 0.01
    z = np.zeros((n, 3))
    err = ImuErrors(gyro_bias=(1e-6, 2e-6, 3e-6), accel_vrw=(1e-3, 0.0, 2e-3),
                    gyro_markov_sigma=(0.0, 1e-5, 0.0), gyro_markov_tau=(np.inf, 20.0, 5.0),
                    gyro_bias_rw=(0.0, 0.0, 1e-7))
    dth, dv, st = corrupt_imu(z, z, dt, err, rng)
    assert np.all(st.gyro_bias[:, 0] == 1e-6)  # constant only
    assert (st.gyro_bias[:, 1] - 2e-6).std() == pytest.approx(1e-5, rel=0.15)
    assert np.ptp(st.gyro_bias[:, 2]) > 0  # random walk on z only
    np.testing.assert_allclose(dv.std(axis=0) / np.sqrt(dt), [1e-3, 0.0, 2e-3], rtol=0.02)
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        corrupt_imu(np.zeros((5, 2)), np.zeros((5, 2)), dt, err, rng)


def test_gnss_and_sar_noise_statistics():
    from fednav.core import earth
    from fednav.sensors import Gnss, SarMatcher

    tr = generate([0.6, 2.0, 100.0], 50.0, [0, 0, 0.5], [Segment(2000.0)], 0.1)
    rng = np.random.default_rng(4)
    g = Gnss((5.0, 8.0, 10.0), 0.2, 1.0).simulate(tr, rng)  # east, north, up
    truth = tr.at(g.t)
    d = earth.llh_difference_enu(g.z[:, 0], g.z[:, 1], g.z[:, 2], *truth["lla"].T)
    # the series' sigma follows z (lat, lon, h): north, east, up.
    np.testing.assert_allclose(d.std(axis=0), [5.0, 8.0, 10.0], rtol=0.06)
    np.testing.assert_allclose((g.z[:, 3:] - truth["vel"]).std(axis=0), 0.2, rtol=0.06)
    np.testing.assert_allclose(g.sigma, [8.0, 5.0, 10.0, 0.2, 0.2, 0.2])
    s = SarMatcher(3.0, units.deg(0.1), 1.0).simulate(tr, rng)
    d = earth.llh_difference_enu(s.z[:, 0], s.z[:, 1], 0.0, *tr.at(s.t)["lla"][:, :2].T, 0.0)
    np.testing.assert_allclose(d[:, :2].std(axis=0), 3.0, rtol=0.06)


def test_markov_recursion_is_lfilter_to_the_bit():
    """The Gauss-Markov drift is filtered by a compiled loop in place of
    scipy.signal.lfilter (kept out of the worker processes); same operations, same bits."""
    from scipy.signal import lfilter

    from fednav.sensors.imu import _ar1

    rng = np.random.default_rng(3)
    for a in (0.0, 0.5, 0.9999944444598766, -0.3):
        e = rng.standard_normal(5000) * 10.0 ** rng.uniform(-9, 6)
        assert np.array_equal(_ar1(e, a), lfilter([1.0], [1.0, -a], e))
