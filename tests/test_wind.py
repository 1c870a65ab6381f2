"""Wind field and flight through the air mass (paper 000)."""

import numpy as np
import pytest

from fednav.core import earth, units
from fednav.ins.strapdown import Strapdown
from fednav.sim.trajectory import Segment, generate
from fednav.sim.wind import Episode, WindField, wind_vector


def test_west_wind_blows_east():
    np.testing.assert_allclose(wind_vector(10.0, units.deg(270.0)), [10.0, 0.0, 0.0],
                               atol=1e-12)
    np.testing.assert_allclose(wind_vector(5.0, 0.0), [0.0, -5.0, 0.0], atol=1e-12)


def test_episode_speeds_and_directions_stay_in_their_ranges():
    ep = Episode(200.0, 800.0, (5.0, 10.0), (units.deg(225), units.deg(315)), 20.0)
    wf = WindField(10.0, units.deg(270), [ep], ramp=10.0, rng=np.random.default_rng(3))
    t = np.arange(0.0, 1000.0, 0.5)
    w, dw = wf(t)
    dist = w - wind_vector(10.0, units.deg(270))
    settled = np.zeros(len(t), bool)
    for t0 in np.arange(200.0, 800.0, 20.0):
        settled |= (t >= t0 + 10.0) & (t < t0 + 20.0)
    sp = np.linalg.norm(dist[settled], axis=1)
    assert sp.min() >= 5.0 - 1e-9 and sp.max() <= 10.0 + 1e-9
    frm = np.degrees(np.arctan2(-dist[settled, 0], -dist[settled, 1])) % 360
    assert frm.min() >= 225 - 1e-6 and frm.max() <= 315 + 1e-6
    np.testing.assert_allclose(dist[t < 200], 0.0, atol=1e-12)
    np.testing.assert_allclose(dist[t > 810], 0.0, atol=1e-12)
    # the derivative is the derivative
    h = 1e-4
    tt = np.array([205.0, 333.0, 805.0])
    num = (wf(tt + h)[0] - wf(tt - h)[0]) / (2 * h)
    np.testing.assert_allclose(wf(tt)[1], num, atol=1e-5)
    with pytest.raises(ValueError, match="numpy Generator"):
        WindField(1.0, 0.0, [ep])


def test_flight_through_wind_is_consistent_with_its_imu():
    ep = Episode(20.0, 80.0, (5.0, 10.0), (units.deg(225), units.deg(315)), 10.0)
    wf = WindField(10.0, units.deg(270), [ep], ramp=5.0, rng=np.random.default_rng(0))
    tr = generate([units.deg(34.2), units.deg(109.0), 20000.0], 20.0, [0, 0, units.deg(90)],
                  [Segment(100.0)], 0.01, wind=wf)
    # ground velocity = air velocity (20 m/s east) + wind
    np.testing.assert_allclose(tr.vel - tr.wind, np.tile([20.0, 0.0, 0.0], (len(tr.t), 1)),
                               atol=1e-9)
    ins = Strapdown(tr.lla[0], tr.vel[0], tr.euler[0], tr.dt)
    out = ins.run(tr.dtheta, tr.dv)
    d = earth.llh_difference_enu(*out["lla"][-1], *tr.lla[-1])
    assert np.linalg.norm(d) < 1e-3 and np.abs(out["vel"][-1] - tr.vel[-1]).max() < 1e-6
