"""A stream flight software can use (issue 38): jittered real-time IMU stamps, late
measurements used at their time of validity up to the latency the system declares (and
said once when later), the solution at a chosen time, P0 from sigmas, bad input as one
line.  On the 240 s drive of ``test_process`` (100 Hz IMU, 5 Hz GNSS)."""

import numpy as np
import pytest

from fednav import InitialState, load_system
from fednav.core import units
from fednav.navigator.system import initial_covariance


# --------------------------------------------------------------------- 4. P0 from sigmas
def test_initial_state_from_sigmas_is_the_hand_written_p0():
    lla, vel, euler = np.array([0.7, -1.3, 50.0]), np.array([1.0, 2.0, 0.0]), np.zeros(3)
    ini = InitialState.from_sigmas(3.0, lla, vel, euler, attitude_deg=[0.1, 0.1, 1.0],
                                   velocity_mps=0.1, position_m=[2.0, 2.0, 4.0],
                                   gyro_bias_deg_h=10.0, accel_bias_mg=[1.0, 1.0, 2.0],
                                   gyro_markov_deg_h=0.5)
    # by hand, filter units: arcmin, m/s, m, deg/h, deg/h, mg
    P0 = np.diag(np.r_[[6.0, 6.0, 60.0], [0.1] * 3, [2.0, 2.0, 4.0], [10.0] * 3,
                       [0.5] * 3, [1.0, 1.0, 2.0]] ** 2)
    np.testing.assert_allclose(ini.P0, P0, rtol=1e-12, atol=0)
    assert ini.t == 3.0 and ini.gyro_bias is None
    # the processing path's conversion, bias sigmas from the system's IMU figures
    system = load_system({"imu": {"grade": "industrial"}})
    ini = InitialState.from_sigmas(0.0, lla, vel, euler, attitude_deg=0.5, velocity_mps=0.2,
                                   position_m=3.0, system=system)
    np.testing.assert_array_equal(ini.P0, initial_covariance(
        system, 0.01, units.deg(np.full(3, 0.5)), 0.2, 3.0))
    with pytest.raises(ValueError, match=r"^InitialState.from_sigmas: position_m has 2 "
                                         r"values \(shape \(2,\)\); give one or three "
                                         r"\(east, north, up\)$"):
        InitialState.from_sigmas(0.0, lla, vel, euler, attitude_deg=0.5, velocity_mps=0.2,
                                 position_m=[1.0, 2.0], system=system)
    with pytest.raises(ValueError, match=r"^InitialState.from_sigmas: attitude_deg must be "
                                         r">= 0"):
        InitialState.from_sigmas(0.0, lla, vel, euler, attitude_deg=-1.0, velocity_mps=0.2,
                                 position_m=1.0, system=system)
    with pytest.raises(ValueError, match=r"give gyro_bias_deg_h and accel_bias_mg, or "
                                         r"system="):
        InitialState.from_sigmas(0.0, lla, vel, euler, attitude_deg=0.5, velocity_mps=0.2,
                                 position_m=1.0)
    with pytest.raises(ValueError, match=r"latitude 40 is not in radians"):
        InitialState.from_sigmas(0.0, [40.0, -75.0, 0.0], vel, euler, attitude_deg=0.5,
                                 velocity_mps=0.2, position_m=1.0, system=system)


