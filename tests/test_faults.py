import numpy as np
import pytest

from fednav.core import earth
from fednav.sensors import Fault, Gnss, inject_faults
from fednav.sim.trajectory import Segment, generate


@pytest.fixture(scope="module")
def gnss_series():
    tr = generate([0.5, 2.0, 50.0], 100.0, [0, 0, 1.5], [Segment(100.0)], 0.1)
    return Gnss(8.0, 0.2, 1.0).simulate(tr, np.random.default_rng(0))


def test_step_fault_on_position_and_velocity(gnss_series):
    f = Fault("gnss", 40.0, 70.0, 5.0)
    out = inject_faults(gnss_series, [f])
    d = earth.llh_difference_enu(out.z[:, 0], out.z[:, 1], out.z[:, 2],
                                 *gnss_series.z[:, :3].T)
    inside = f.active(out.t)
    assert inside.sum() == 31
    np.testing.assert_allclose(d[inside], [[40.0, 40.0, 40.0]] * 31, atol=1e-6)  # 5 x 8 m
    np.testing.assert_allclose(out.z[inside, 3:] - gnss_series.z[inside, 3:], 1.0)  # 5 x 0.2
    np.testing.assert_array_equal(out.z[~inside], gnss_series.z[~inside])


def test_ramp_fault_on_selected_components(gnss_series):
    f = Fault("gnss", 50.0, 60.0, 2.0, kind="ramp", components=(3,))
    out = inject_faults(gnss_series, [f])
    dv = out.z[:, 3] - gnss_series.z[:, 3]
    np.testing.assert_allclose(dv[gnss_series.t == 55.0], 0.2)  # half way: 0.5 * 2 * 0.2
    np.testing.assert_allclose(dv[gnss_series.t == 60.0], 0.4)
    assert np.all(out.z[:, [0, 1, 2, 4, 5]] == gnss_series.z[:, [0, 1, 2, 4, 5]])


def test_other_sensor_untouched_and_validation(gnss_series):
    assert inject_faults(gnss_series, [Fault("sar", 1.0, 2.0, 3.0)]) is gnss_series
    with pytest.raises(ValueError, match="end"):
        Fault("gnss", 5.0, 5.0, 1.0)
    with pytest.raises(ValueError, match="component 7"):
        inject_faults(gnss_series, [Fault("gnss", 1.0, 2.0, 1.0, components=(7,))])


# -- the fault models a campaign draws per run (issue: integrity) ------------------------

def _horizontal(out, ref):
    d = earth.llh_difference_enu(out.z[:, 0], out.z[:, 1], out.z[:, 2], *ref.z[:, :3].T)
    return d[:, 0], d[:, 1]  # east, north [m]


def test_spoofing_pulls_position_and_velocity_consistently(gnss_series):
    """The position pulled along the bearing to size x sigma at the end and held; the
    velocity offset is the pull's rate while it grows (a spoofer's ramp: the receiver's
    position and velocity agree)."""
    f = Fault("gnss", 30.0, 70.0, 10.0, kind="spoofing", bearing=np.radians(30.0))
    out = inject_faults(gnss_series, [f])
    e, n = _horizontal(out, gnss_series)
    t = gnss_series.t
    grow = (t > 30.0) & (t < 70.0)
    # 10 x 8 m along 30 deg from north at the end, held after
    np.testing.assert_allclose(np.hypot(e, n)[t >= 70.0], 80.0, rtol=1e-6)
    np.testing.assert_allclose(np.arctan2(e, n)[t >= 70.0], np.radians(30.0), atol=1e-6)
    dv = out.z[:, 3:5] - gnss_series.z[:, 3:5]  # (vE, vN)
    # the velocity offset is the time derivative of the position offset
    np.testing.assert_allclose(dv[grow, 0], np.gradient(e, t)[grow], atol=1e-6)
    np.testing.assert_allclose(dv[grow, 1], np.gradient(n, t)[grow], atol=1e-6)
    assert np.all(dv[t > 70.0] == 0) and np.all(out.z[t < 30.0] == gnss_series.z[t < 30.0])
    np.testing.assert_array_equal(out.z[:, 2], gnss_series.z[:, 2])  # (height untouched)


def test_false_match_jumps_and_stays_drift_keeps_growing_burst_is_noise(gnss_series):
    t = gnss_series.t
    fm = inject_faults(gnss_series, [Fault("gnss", 40.0, 50.0, 4.0, kind="false_match",
                                           bearing=np.pi / 2)])
    e, n = _horizontal(fm, gnss_series)
    np.testing.assert_allclose(e[t >= 40.0], 32.0, rtol=1e-6)  # east, 4 x 8 m, stays
    np.testing.assert_allclose(n, 0.0, atol=1e-6)
    assert np.all(e[t < 40.0] == 0)
    dr = inject_faults(gnss_series, [Fault("gnss", 20.0, 30.0, 1.0, kind="drift",
                                           components=(2,))])
    dh = dr.z[:, 2] - gnss_series.z[:, 2]
    np.testing.assert_allclose(dh[t == 90.0], 8.0 * 7.0)  # 1 sigma per 10 s, for 70 s
    b = Fault("gnss", 10.0, 90.0, 3.0, kind="burst", components=(3,), seed=4)
    bu = inject_faults(gnss_series, [b])
    dv = bu.z[:, 3] - gnss_series.z[:, 3]
    inside = b.active(t)
    assert np.all(dv[~inside] == 0)
    assert 0.5 < np.std(dv[inside]) / (3.0 * 0.2) < 1.5 and abs(np.mean(dv[inside])) < 0.3
    np.testing.assert_array_equal(inject_faults(gnss_series, [b]).z, bu.z)  # (its seed)


def test_misidentification_jumps_the_attitude_with_drawn_signs():
    from fednav.sensors.base import MeasurementSeries

    star = MeasurementSeries("star", np.arange(0.0, 10.0), np.zeros((10, 3)),
                             np.radians([0.01, 0.01, 0.02]))
    f = Fault("star", 3.0, 6.0, 50.0, kind="misidentification", signs=(1.0, -1.0, 1.0))
    d = inject_faults(star, [f]).z
    np.testing.assert_allclose(d[4], np.radians([0.5, -0.5, 1.0]))
    assert np.all(d[:3] == 0) and np.all(d[7:] == 0)


def test_fault_draws_per_run_and_their_checks():
    from fednav.core.config import ConfigError
    from fednav.sim.scenario import FaultConfig

    fc = FaultConfig(sensor="sar", kind="false_match", start_s={"between": [100, 400]},
                     duration_s={"between": [30, 60]}, size_sigma={"between": [5, 20]})
    a = [fc.fault(np.random.default_rng([s, 1])) for s in range(50)]
    starts = np.array([f.start for f in a])
    assert 100 <= starts.min() and starts.max() <= 400 and len(set(starts)) == 50
    assert all(30 <= f.end - f.start <= 60 and 5 <= f.size_sigma <= 20 for f in a)
    assert len({round(f.bearing, 9) for f in a}) == 50
    assert fc.fault(np.random.default_rng([3, 1])) == a[3]  # (reproducible per run)
    for bad, match in [({"kind": "spoofing", "sensor": "baro"}, "baro sensor measures no "
                                                                "latitude"),
                       ({"kind": "misidentification", "sensor": "baro"}, "no angle"),
                       ({"end_s": 50.0}, "end_s or duration_s"),
                       ({"duration_s": None}, "end_s or duration_s")]:
        d = {"sensor": "sar", "start_s": 10.0, "duration_s": 5.0, "size_sigma": 3.0, **bad}
        with pytest.raises((ValueError, ConfigError), match=match):
            FaultConfig(**d)
