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
