import numpy as np
import pytest

from fednav.core import earth


def test_radii_equator_and_pole():
    rm, rn = earth.radii(0.0)
    assert rn == pytest.approx(earth.A)
    assert rm == pytest.approx(earth.A * (1 - earth.E2))
    rm, rn = earth.radii(np.pi / 2)
    assert rm == pytest.approx(rn)  # at the pole both equal a / sqrt(1 - e2)
    assert rn == pytest.approx(earth.A / np.sqrt(1 - earth.E2))


def test_normal_gravity_known_values():
    # WGS-84 normal gravity: 9.7803253 at the equator, 9.8321849 at the poles.
    assert earth.gravity(0.0, 0.0) == pytest.approx(9.7803253359, abs=1e-9)
    assert earth.gravity(np.pi / 2, 0.0) == pytest.approx(9.8321849379, abs=1e-7)
    # Free-air gradient ~ -3.086e-6 /s^2 per metre.
    dg = earth.gravity(np.deg2rad(45), 1000.0) - earth.gravity(np.deg2rad(45), 0.0)
    assert dg == pytest.approx(-3.086e-3, rel=2e-3)


def test_rates():
    lat = np.deg2rad(39.0)
    w = earth.earth_rate(lat)
    assert np.linalg.norm(w) == pytest.approx(earth.OMEGA_IE)
    assert w[0] == 0 and w[2] > 0
    rm, rn = earth.radii(lat)
    wen = earth.transport_rate(lat, 0.0, [100.0, 50.0, 0.0])
    np.testing.assert_allclose(wen, [-50 / rm, 100 / rn, 100 * np.tan(lat) / rn])


def test_llh_difference_matches_ecef_distance():
    lat, lon, h = np.deg2rad(39.0), np.deg2rad(117.0), 500.0
    d = earth.llh_difference_enu(lat + 1e-6, lon + 2e-6, h + 3, lat, lon, h)
    dist = np.linalg.norm(earth.llh_to_ecef(lat + 1e-6, lon + 2e-6, h + 3)
                          - earth.llh_to_ecef(lat, lon, h))
    assert np.linalg.norm(d) == pytest.approx(dist, rel=1e-5)


def test_north_turn_is_earth_rate_at_rest_and_transport_rate_moving_east():
    """North's turn about up: W sin(lat) t at rest; plus vE tan(lat) / (RN + h) t moving
    east along a parallel (its sign with the hemisphere's)."""
    t = np.linspace(0.0, 100.0, 101)
    for lat in (np.radians(45.0), np.radians(-60.0)):
        lla = np.column_stack([np.full_like(t, lat), np.zeros_like(t), np.full_like(t, 100.0)])
        rest = earth.north_turn(t, lla, np.zeros((len(t), 3)))
        assert rest[-1] == pytest.approx(earth.OMEGA_IE * np.sin(lat) * 100.0, rel=1e-12)
        east = earth.north_turn(t, lla, np.tile([250.0, 0.0, 0.0], (len(t), 1)))
        _, rn = earth.radii(lat)
        assert east[-1] - rest[-1] == pytest.approx(250.0 * np.tan(lat) / (rn + 100.0) * 100.0,
                                                    rel=1e-12)


def test_one_point_gives_the_arrays_values_to_the_bit():
    """``llh_to_ecef`` and ``enu_to_ecef`` take a quicker path for one point (a raw GNSS
    epoch's antenna): the same arithmetic as for arrays (equal to the bit here; within
    2 ulp allowed, for a numpy whose one-element sine took another loop)."""
    rng = np.random.default_rng(7)
    lat, lon = rng.uniform(-1.57, 1.57, 500), rng.uniform(-np.pi, np.pi, 500)
    h = rng.uniform(-400.0, 2e4, 500)
    xyz, C = earth.llh_to_ecef(lat, lon, h), earth.enu_to_ecef(lat, lon)
    for i in range(len(lat)):
        np.testing.assert_array_max_ulp(earth.llh_to_ecef(lat[i], lon[i], h[i]), xyz[i], 2)
        np.testing.assert_array_max_ulp(earth.enu_to_ecef(float(lat[i]), lon[i]), C[i], 2)
    assert earth.llh_to_ecef(0.8, 0.1, np.array([1.0, 2.0])).shape == (2, 3)
    assert earth.enu_to_ecef(0.8, 0.1).shape == (3, 3)
