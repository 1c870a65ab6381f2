import numpy as np
import pytest

from fednav.core import attitude as att
from fednav.core import earth, units
from fednav.sim.trajectory import Segment, body_rate_from_euler_rates, generate


def test_body_rate_matches_dcm_derivative():
    rng = np.random.default_rng(0)
    e = rng.uniform(-1, 1, 3)
    rates = rng.uniform(-0.1, 0.1, 3)
    h = 1e-6
    C0, C1 = att.euler_to_dcm(e - h * rates), att.euler_to_dcm(e + h * rates)
    dC = (C1 - C0) / (2 * h)
    W = att.euler_to_dcm(e).T @ dC  # [omega_nb^b x]
    w = np.array([W[2, 1], W[0, 2], W[1, 0]])
    np.testing.assert_allclose(body_rate_from_euler_rates(e, rates), w, atol=1e-8)


def test_stationary_imu_senses_gravity_and_earth_rate():
    lat = units.deg(39.0)
    tr = generate([lat, units.deg(117.0), 0.0], 0.0, [0, 0, 0], [Segment(1.0)], 0.01)
    f = tr.dv.sum(0)
    w = tr.dtheta.sum(0)
    np.testing.assert_allclose(f, [0, 0, earth.gravity(lat, 0.0)], atol=1e-9)
    np.testing.assert_allclose(w, [0, earth.OMEGA_IE * np.cos(lat), earth.OMEGA_IE * np.sin(lat)],
                               atol=1e-15)


def test_segments_and_validation():
    tr = generate([0.5, 2.0, 100.0], 100.0, [0, 0, units.deg(90)],
                  [Segment(10.0, accel=2.0), Segment(5.0, pitch_rate=units.deg(1))], 0.01)
    assert len(tr.t) == 1501
    np.testing.assert_allclose(np.linalg.norm(tr.vel[1000]), 120.0)
    assert tr.euler[-1, 0] == pytest.approx(units.deg(5))
    # Flying east at 100 m/s: longitude grows, latitude stays.
    assert tr.lla[-1, 1] > 2.0 and abs(tr.lla[1000, 0] - 0.5) < 1e-9
    with pytest.raises(ValueError, match="segment 0"):
        generate([0.5, 2.0, 0.0], 10.0, [0, 0, 0], [Segment(0.015)], 0.01)
    with pytest.raises(ValueError, match="speed negative"):
        generate([0.5, 2.0, 0.0], 10.0, [0, 0, 0], [Segment(10.0, accel=-2.0)], 0.01)
