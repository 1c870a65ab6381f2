"""The IMU sample convention at the seams between the simulator, the readers and the
navigator.

:class:`fednav.io.ImuData` and the navigator take a sample's rates to hold over the
interval that *starts* at its stamp (a rates file's convention; an increments file,
stamped at the interval's end as loggers stamp it, is moved to the start by
:meth:`~fednav.io.ImuData.from_increments`, docs/data-formats.md).  Until this was
pinned, fednav's own simulator stamped its rates at the interval's *end*: every
simulated drive (``fednav simulate``, the car and town drives) was integrated one IMU
period late, 11 mm/s off the truth within 30 s of a perfect IMU with no aiding (and the
INS saw a -0.011 s GNSS velocity latency that was this period).  These tests pin each
seam with a perfect IMU: the simulated samples, and the navigator fed by what ``fednav
process`` prepares."""

from dataclasses import replace

import numpy as np
import pytest

from fednav.ins.strapdown import Strapdown
from fednav.process.run import prepare
from fednav.sim.drives import town_drive

#: an IMU without errors (the simulator's ideal increments)
PERFECT = {"random_bias": False, "gyro_bias_deg_h": 0.0, "gyro_markov_deg_h": 0.0,
           "gyro_markov_tau_s": 100.0, "gyro_arw_deg_sqrt_h": 0.0, "accel_bias_ug": 0.0,
           "accel_markov_ug": 0.0, "accel_markov_tau_s": 100.0, "accel_vrw_ug_sqrt_hz": 0.0}
N = 3000  # samples compared (30 s at 100 Hz)


@pytest.fixture(scope="module")
def drive():
    return town_drive(2, 40.0, imu=PERFECT)


def _free_run(d, imu):
    """The navigator fed by ``prepare`` from the true state at its start, no
    measurement (a free INS): its velocity rows and the truth at the same stamps."""
    prep = prepare(imu, {"gnss": d.gnss}, d.system)
    i = int(np.argmin(np.abs(d.reference.t - prep.initial.t)))
    assert abs(d.reference.t[i] - prep.initial.t) < 1e-9
    prep.initial = replace(prep.initial, lla=d.reference.lla[i], vel=d.reference.vel[i],
                           euler=d.reference.euler[i], gyro_bias=None)
    nav = prep.navigator(record_rows=True, record_covariance=True)
    nav.add_imu(prep.t, prep.gyro, prep.accel)
    return nav.result().rows["vel"][1:N + 1], d.reference.vel[i + 1:i + 1 + N]


def test_the_simulated_samples_hold_from_their_stamps(drive):
    d = drive
    dt = d.imu.period()
    assert d.imu.t[0] == d.reference.t[0] == 0.0  # (the simulation's start)
    sd = Strapdown(d.reference.lla[0], d.reference.vel[0], d.reference.euler[0], dt)
    v = sd.run(d.imu.gyro[:N] * dt, d.imu.accel[:N] * dt)["vel"]
    assert np.abs(v - d.reference.vel[1:N + 1]).max() < 1e-6


def test_the_navigator_integrates_each_sample_over_its_own_interval(drive):
    v, truth = _free_run(drive, drive.imu)
    assert np.abs(v - truth).max() < 1e-5


def test_increments_stamped_at_their_end_are_refused_not_integrated_late(drive):
    """A stream that passes a logger's stamps (the end of each interval) as they are:
    its first sample lies a period after the start, one line says so and how to pass
    them (rather than a silent period of lag)."""
    prep = prepare(drive.imu, {"gnss": drive.gnss}, drive.system)
    nav = prep.navigator()
    dt = prep.dt
    with pytest.raises(ValueError, match=r"first sample is stamped .* passed at t - dt"):
        nav.add_imu(prep.t[:10] + dt, dtheta=prep.gyro[:10] * dt, dv=prep.accel[:10] * dt)
    nav.add_imu(prep.t[:10], dtheta=prep.gyro[:10] * dt, dv=prep.accel[:10] * dt)  # (so)


def test_the_convention_in_code_integrates_and_centres_each_sample():
    """fednav.core.samples: a sample held from its stamp adds ``x_k (t_k+1 - t_k)`` from
    the next stamp on; as a point it stands at its interval's middle."""
    from fednav.core.samples import held_integral, midpoints

    t = np.array([0.0, 0.1, 0.3, 0.4])
    x = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0], [7.0, 8.0]])
    np.testing.assert_allclose(held_integral(t, x), [[0, 0], [0.1, 0.2], [0.7, 1.0],
                                                     [1.2, 1.6]])
    np.testing.assert_allclose(held_integral(t, x[:, 0]), [0, 0.1, 0.7, 1.2])
    np.testing.assert_allclose(midpoints(np.arange(4) * 0.01), np.arange(4) * 0.01 + 0.005)
