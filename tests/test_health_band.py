"""The health monitor is not blind either way: a sensor's run-mean NIS/dof outside the
band [0.5, 2] is warned with its causes ranked, each row kind is judged too (a GNSS sigma
column in millimetres hid the position rows under the velocity rows' NIS), and a warning
or refusal names the sensor whose data are wrong — found by leaving each sensor out in
turn — not the one whose innovations show it first."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_process import make_flight

from fednav import System, load_system
from fednav.core import units
from fednav.io import DataError, SensorData
from fednav.io.data import VelocityData
from fednav.navigator.health import band_warnings, local_nis, row_nis
from fednav.navigator.record import InnovationRecord
from fednav.process.run import process


@pytest.fixture(scope="module")
def flight():
    return make_flight()


def test_a_local_filter_of_a_federation_is_judged_as_the_centralized_filter():
    """A local filter among eight holds P / beta (beta = 1/8): its own S = H P H' / beta +
    R is too large, and a precise sensor's NIS against it sits near 0.5 in a consistent
    filter (the star sensor in fednav certify's air-all mode: a false alarm in 24 of 50
    runs).  The band judges beta (S - R) + R, the centralized filter's S."""
    rng = np.random.default_rng(4)
    beta, HPH, R = 0.125, np.diag([4.0, 4.0, 1.0]), np.diag([1.0, 1.0, 2.0])
    Sc = HPH + R
    recs = [InnovationRecord("star", float(i), rng.multivariate_normal(np.zeros(3), Sc),
                             HPH / beta + R, R, beta, True) for i in range(400)]
    raw = np.mean([r.r @ np.linalg.solve(r.S, r.r) / 3 for r in recs])
    (v, n), = local_nis(recs).values()
    assert raw < 0.5 and 0.9 < v < 1.1 and n == 400
    log = [(r.t, "star", float(r.r @ np.linalg.solve(r.S, r.r)), 3, np.nan, False)
           for r in recs]
    assert band_warnings(log, (0.5, 2.0))  # the local statistics: a false alarm
    assert band_warnings(log, (0.5, 2.0), means=local_nis(recs)) == []
    rows = row_nis(recs, {"star": [0, 0, 0]})["star"]
    assert all(0.85 < m < 1.15 for m, _ in rows.values())


def test_the_band_warns_both_ways_with_causes_ranked():
    rng = np.random.default_rng(3)

    def log(name, scale, n=300):  # (t, local, NIS, dof, threshold, isolated)
        return [(float(i), name, float(scale * rng.chisquare(3)), 3, np.nan, False)
                for i in range(n)]

    assert band_warnings(log("gnss", 1.0), (0.5, 2.0)) == []
    (low,) = band_warnings(log("gnss", 0.05), (0.5, 2.0))
    assert "'gnss'" in low and "1) sensors.gnss's sigma too large" in low
    (high,) = band_warnings(log("gnss", 2.8), (0.5, 2.0))
    assert "1) sensors.gnss's sigma too small" in high
    # every sensor high: the IMU figures come first
    both = band_warnings(log("gnss", 2.8) + log("star", 2.5), (0.5, 2.0))
    assert len(both) == 2 and all("1) the IMU figures too optimistic" in w for w in both)
    low = band_warnings(log("gnss", 0.05) + log("baro", 0.06), (0.5, 2.0))
    assert len(low) == 2 and all("1) the IMU figures too pessimistic" in w for w in low)
    # a constraint's NIS sits below 1 by design
    assert band_warnings(log("zupt", 0.01), (0.5, 2.0), constraints=("zupt",)) == []


def test_a_sensor_sigma_too_small_or_too_large_is_warned(flight):
    """The drive's fixes have 1 m and 0.05 m/s of noise: given as 0.4 m and 0.02 m/s the
    run's NIS/dof is above the band, given as 3 m and 0.15 m/s below it; as they are,
    inside and nothing said."""
    imu, gnss, _ = flight
    said = {}
    for k, (sp, sv) in {"small": (0.4, 0.02), "large": (3.0, 0.15), "true": (1.0, 0.05)
                        }.items():
        cfg = load_system({"sensors": {"gnss": {"sigma_pos_enu_m": sp, "sigma_vel_mps": sv}}})
        said[k] = [w for w in process(imu, {"gnss": gnss}, cfg=cfg).warnings if "band" in w]
    assert said["true"] == []
    assert len(said["small"]) == 1 and "1) sensors.gnss's sigma too small" in said["small"][0]
    assert len(said["large"]) == 1 and "1) sensors.gnss's sigma too large" in said["large"][0]


def test_a_sigma_column_in_millimetres_is_named(flight):
    imu, gnss, _ = flight
    rows = np.column_stack([np.full((len(gnss.t), 3), 1000.0),
                            np.full((len(gnss.t), 3), 0.05)])
    res = process(imu, {"gnss": replace(gnss, sigma_rows=rows)})
    assert any("position rows" in w and "millimetres" in w for w in res.warnings), \
        res.warnings
    assert not any("position rows" in w for w in process(imu, {"gnss": gnss}).warnings)


def _sensors(ref, rng):
    """A star sensor (1 Hz), a barometer (1 Hz) and a velocity sensor (10 Hz) from the
    drive's truth, with their noise."""
    i1 = np.arange(100, len(ref.t), 100)
    star = SensorData("star", "sim star", ref.t[i1], ref.euler[i1]
                      + rng.standard_normal((len(i1), 3)) * units.arcsec(20.0))
    baro = SensorData("baro", "sim baro", ref.t[i1], ref.lla[i1, 2:3]
                      + rng.standard_normal((len(i1), 1)) * 0.5)
    i10 = np.arange(10, len(ref.t), 10)
    vel = VelocityData("sim velocity", ref.t[i10], ref.vel[i10] + rng.standard_normal(
        (len(i10), 3)) * 0.05, np.tile(np.eye(3) * 0.05**2, (len(i10), 1, 1)), np.zeros(3))
    return star, baro, vel


CFG = {"sensors": {"star": {"sigma_arcsec": 20.0}, "baro": {"sigma_m": 0.5,
                                                             "damping_loop": False},
                   "velocity": {"sigma_mps": [0.05, 0.05, 0.05]}}}


@pytest.mark.slow
@pytest.mark.parametrize("bad", ["star", "baro", "velocity"])
def test_the_sensor_whose_file_is_wrong_is_named(flight, bad):
    """Each sensor's file corrupted in turn in a GNSS + star + baro + velocity system:
    the star heading in degrees, the baro in feet, the velocity's east and north
    swapped.  What the run says (a refusal or its warnings) names that sensor as the
    culprit."""
    imu, gnss, ref = flight
    star, baro, vel = _sensors(ref, np.random.default_rng(5))
    cfg = load_system(CFG)
    clean = process(imu, {"gnss": gnss, "velocity": vel, "star": star, "baro": baro}, cfg)
    assert not any("likely culprit" in w for w in clean.warnings), clean.warnings
    if bad == "star":
        z = star.z.copy()
        z[:, 2] = np.degrees(z[:, 2]) % (2 * np.pi)  # degrees read as radians
        star = replace(star, z=z)
    elif bad == "baro":
        baro = replace(baro, z=baro.z / 0.3048)
    else:
        vel = replace(vel, vel=vel.vel[:, [1, 0, 2]])
    try:
        res = process(imu, {"gnss": gnss, "velocity": vel, "star": star, "baro": baro}, cfg)
        text = " ".join(res.warnings)
    except DataError as e:
        text = str(e)
    assert f"the {bad} data are the likely culprit" in text, text


def test_the_stream_says_the_same_once(flight):
    """Navigator.health(): the band's warning, through the warnings module, once."""
    import warnings

    from fednav.navigator.navigator import HealthWarning
    from fednav.process.run import prepare

    imu, gnss, _ = flight
    cfg = load_system({"sensors": {"gnss": {"sigma_pos_enu_m": 3.0, "sigma_vel_mps": 0.15}}})
    prep = prepare(imu, {"gnss": gnss}, cfg=cfg)
    nav = prep.feed(prep.navigator(innovations=True))
    with pytest.warns(HealthWarning, match="outside the band"):
        said = nav.health()
    assert any("1) sensors.gnss's sigma too large" in w for w in said)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HealthWarning)
        assert nav.health() == said  # (the same list; nothing said again)


def test_the_summary_reports_the_centralized_nis_beside_the_gates(flight):
    """``summary.json``'s ``consistency``: ``nis_per_dof`` against the centralized
    filter's innovation covariance (what the band judges), ``gate_nis_per_dof`` the local
    filter's own — smaller in a sharing federation, equal with one local filter."""
    from fednav.process.output import summary

    imu, gnss, ref = flight
    star, baro, vel = _sensors(ref, np.random.default_rng(5))
    res = process(imu, {"gnss": gnss, "velocity": vel, "star": star, "baro": baro},
                  load_system(CFG))
    c = summary(res, None, {})["consistency"]
    assert set(c) == {"gnss", "velocity", "star", "baro"}
    for k, v in c.items():
        assert v["gate_nis_per_dof"] < v["nis_per_dof"], (k, v)
        assert 0.5 < v["nis_per_dof"] < 2.0, (k, v)  # (a consistent run)
    alone = summary(process(imu, {"gnss": gnss}, System()), None, {})["consistency"]
    assert alone["gnss"]["nis_per_dof"] == pytest.approx(alone["gnss"]["gate_nis_per_dof"],
                                                         rel=1e-9)
