"""The navigator's streaming API: sample by sample, in blocks, with measurements late
and out of order within ``hold_s`` — the same result as one batch, to 1e-9 relative, in
the compiled engine and in the Python loop; ``solution()`` mid-stream; ``result()``'s
IMU-rate solution and consistency."""

import numpy as np
import pytest
from test_process import make_flight

from fednav import Navigator, NavResult, System, load_system
from fednav.process.run import prepare

RTOL = 1e-9


@pytest.fixture(scope="module")
def drive():
    imu, gnss, ref = make_flight()
    return imu, gnss, ref


def _prep(drive, seconds: float, **filt):
    imu, gnss, _ = drive
    cfg = load_system({"filter": filt}) if filt else System()
    prep = prepare(imu, {"gnss": gnss}, cfg)
    n = int(round(seconds / prep.dt))
    n -= n % prep.n_per
    prep.t, prep.gyro, prep.accel = prep.t[:n], prep.gyro[:n], prep.accel[:n]
    return prep


def _events(prep, delay_s=None, rng=None):
    """Every measurement as (arrival, sensor, t, z, R): at its time of validity, or late by
    up to ``delay_s`` and shuffled."""
    ev = []
    for name in prep.series:
        t, z, R = prep.rows(name)
        for i in range(len(t)):
            late = 0.0 if delay_s is None else rng.uniform(0.0, delay_s)
            ev.append((t[i] + late, name, t[i], z[i], R[i]))
    order = sorted(range(len(ev)), key=lambda j: ev[j][0])
    return [ev[j] for j in order]


def _stream(prep, block: int, delay_s=None, hold_s=0.0, seed=0, engine="auto",
            probe=None):
    """Feed IMU samples ``block`` at a time; before each block the measurements that have
    arrived by its last sample's time (with ``hold_s`` 0 the block's epochs run at once)."""
    nav = prep.navigator(hold_s=hold_s, engine=engine)
    ev = _events(prep, delay_s, np.random.default_rng(seed))
    j, n, snap = 0, len(prep.t), None
    for a in range(0, n, block):
        b = min(a + block, n)
        while j < len(ev) and ev[j][0] <= prep.t[b - 1] + 1e-9:
            _, name, t, z, R = ev[j]
            nav.add_measurement(name, t, z, R=R)
            j += 1
        if block == 1:
            nav.add_imu(prep.t[a], prep.gyro[a], prep.accel[a])
        else:
            nav.add_imu(prep.t[a:b], prep.gyro[a:b], prep.accel[a:b])
        if probe is not None and a + block == probe:
            snap = nav.solution()
    for _, name, t, z, R in ev[j:]:
        nav.add_measurement(name, t, z, R=R)
    return nav.result(), snap


def _batch(prep, engine="auto") -> NavResult:
    return prep.feed(prep.navigator(engine=engine)).result()


def _differences(a: NavResult, b: NavResult) -> list[str]:
    """What differs between two results beyond 1e-9 relative: epochs, states, covariances,
    IMU-rate rows, the FDI log (empty when they are the same)."""
    def close(x, y, atol):
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        return x.shape == y.shape and bool(np.all(np.abs(x - y) <= atol + RTOL * np.abs(y)))

    out = []
    if len(a.t) != len(b.t):
        return [f"epochs {len(a.t)} vs {len(b.t)}"]
    for name, x, y, atol in (("states", a.states, b.states, 0.0), ("P", a.P, b.P, 1e-300),
                             *((f"rows {k}", a.rows[k], b.rows[k], 1e-12)
                               for k in (a.rows or {})),
                             ("fdi statistics", [e[2] for e in a.fdi],
                              [e[2] for e in b.fdi], 0.0)):
        if not close(x, y, atol):
            out.append(name)
    if [e[:2] for e in a.fdi] != [e[:2] for e in b.fdi]:
        out.append("fdi times and filters")
    return out


@pytest.mark.parametrize("block", [1, 7, 100])
def test_stream_equals_batch_compiled(drive, block):
    prep = _prep(drive, 120.0)
    ref = _batch(prep)
    assert ref.engine == "compiled"
    res, _ = _stream(prep, block)
    assert not _differences(res, ref)


def test_late_out_of_order_measurements_within_hold_equal_batch(drive):
    prep = _prep(drive, 120.0)
    ref = _batch(prep)
    res, _ = _stream(prep, 1, delay_s=0.9, hold_s=1.0, seed=4)
    assert res.data_quality["late_measurements_dropped"] == 0
    assert not _differences(res, ref)


def test_measurements_later_than_hold_are_dropped_and_counted(drive):
    from fednav.navigator.navigator import LateMeasurementWarning

    prep = _prep(drive, 60.0)
    with pytest.warns(LateMeasurementWarning, match=r"^gnss: .* dropped .*latency_s"):
        res, _ = _stream(prep, 1, delay_s=0.9, hold_s=0.0, seed=4)
    assert res.data_quality["late_measurements_dropped"] > 0


def test_stream_equals_batch_in_the_python_loop(drive):
    """A system the compiled engine does not run (adaptive EKF locals)."""
    prep = _prep(drive, 40.0, type="aekf")
    ref = _batch(prep)
    assert ref.engine == "python"
    res, _ = _stream(prep, 1, delay_s=0.5, hold_s=0.6, seed=2)
    assert not _differences(res, ref)
    res, _ = _stream(prep, 33)
    assert not _differences(res, ref)


def test_python_loop_equals_the_compiled_engine_on_the_stream(drive):
    prep = _prep(drive, 40.0)
    a, _ = _stream(prep, 10, engine="python")
    b, _ = _stream(prep, 10, engine="compiled")
    assert (a.engine, b.engine) == ("python", "compiled")
    assert not _differences(a, b)


def test_solution_mid_stream_is_the_rows_of_the_result(drive):
    prep = _prep(drive, 60.0)
    probe = 5 * prep.n_per * 10 + 7  # between epochs
    res, snap = _stream(prep, 1, probe=probe)
    assert snap.t == pytest.approx(prep.t[0] + probe * prep.dt)
    np.testing.assert_allclose(snap.lla, res.rows["lla"][probe], rtol=1e-12)
    np.testing.assert_allclose(snap.vel, res.rows["vel"][probe], rtol=1e-9, atol=1e-12)
    fwd = res.forward
    np.testing.assert_allclose(snap.euler, fwd.euler[probe], atol=1e-12)
    k = probe // prep.n_per  # the last epoch before the probe: sigma of its estimate
    np.testing.assert_allclose(snap.sigma, fwd.sigma[k * prep.n_per], rtol=1e-9)


def test_result_gives_the_imu_rate_solution_and_consistency(drive):
    prep = _prep(drive, 60.0)
    res = _batch(prep)
    fwd = res.forward
    assert len(fwd.t) == len(prep.t) + 1 and fwd.sigma.shape == (len(fwd.t), 9)
    assert np.all(np.isfinite(fwd.sigma)) and np.all(fwd.sigma > 0)
    assert res.smoothed is None
    c = res.consistency
    assert set(c) == {"gnss"} and c["gnss"]["measurements"] == len(res.fdi)
    smooth = prep.system.model_copy(update={"smoother": True})
    nav = Navigator(smooth, prep.initial, prep.dt, imu_errors=prep.imu_errors)
    res = prep.feed(nav).result()
    assert res.smoothed is not None
    assert np.all(res.smoothed.sigma[1:-1] <= res.forward.sigma[1:-1] * (1 + 1e-9))


def test_the_motion_alone_is_the_solutions_motion(drive):
    """imu_rate(sigmas=False) (what the velocity-latency pass reads) gives the same
    forward and smoothed motion, bit for bit, and NaN sigmas."""
    from fednav.navigator.solution import imu_rate

    prep = _prep(drive, 60.0)
    out = prep.feed(prep.navigator(record_rows=True, record_covariance=True)).result()
    full = imu_rate(out, smooth=True)
    lean = imu_rate(out, smooth=True, sigmas=False)
    for a, b in zip(full, lean, strict=True):
        for k in ("t", "lla", "vel", "euler", "omega"):
            np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
        assert np.isnan(b.sigma).all() and np.isnan(b.sigma_euler).all()
        assert b.sigma.shape == a.sigma.shape and b.sigma_euler.shape == a.sigma_euler.shape


def test_bad_stream_input_is_one_line(drive):
    prep = _prep(drive, 10.0)
    nav = prep.navigator()
    nav.add_imu(prep.t[0], prep.gyro[0], prep.accel[0])
    with pytest.raises(ValueError, match=r"^add_imu: sample 1 is stamped .*\(a gap"):
        nav.add_imu(prep.t[0] + 3 * prep.dt, prep.gyro[1], prep.accel[1])
    with pytest.raises(ValueError, match=r"unknown sensor 'lidar'; registered: "):
        nav.add_measurement("lidar", 0.0, [1.0])


# ------------------------------------------------------------ review fixes, pinned
def _baro_prep(drive, seconds: float, offset: float):
    """The drive with a damping, aiding barometer whose heights fall ``offset`` [s] after
    IMU sample times (a logger's own clock)."""
    from fednav.io.sensorfile import SensorData

    imu, gnss, ref = drive
    tb = np.arange(1.0, seconds, 1.0) + offset
    h = np.interp(tb, ref.t, ref.lla[:, 2]) + np.random.default_rng(3).normal(0, 0.3, len(tb))
    cfg = load_system({"sensors": {"baro": {"sigma_m": 0.3, "damping_loop": True}}})
    prep = prepare(imu, {"gnss": gnss, "baro": SensorData("baro", "b", tb, h[:, None])}, cfg)
    n = int(round(seconds / prep.dt))
    n -= n % prep.n_per
    prep.t, prep.gyro, prep.accel = prep.t[:n], prep.gyro[:n], prep.accel[:n]
    return prep


def test_a_damping_barometer_streamed_one_value_at_a_time_equals_the_batch(drive):
    prep = _baro_prep(drive, 60.0, 0.0)
    ref = _batch(prep)
    d = prep.series["baro"]
    R = prep.system.sensors.baro.model().R(prep.system.sensors.baro.sigma())
    nav = prep.navigator()
    ev = sorted([(t, "gnss", t, z, r) for t, z, r in zip(*prep.rows("gnss"),
                                                          strict=True)]
                + [(t, "baro", t, z, R) for t, z in zip(d.t, d.z, strict=True)],
                key=lambda e: e[0])
    j = 0
    for i in range(len(prep.t)):
        while j < len(ev) and ev[j][0] <= prep.t[i] + 1e-9:
            _, name, t, z, r = ev[j]
            nav.add_measurement(name, t, z, R=r)
            j += 1
        nav.add_imu(prep.t[i], prep.gyro[i], prep.accel[i])
    for _, name, t, z, r in ev[j:]:  # (those of the last epoch's time)
        nav.add_measurement(name, t, z, R=r)
    res = nav.result()
    assert np.isfinite(nav._h_ref.view).sum() == len(d.t)  # every height reached the loop
    assert not _differences(res, ref)


def test_baro_heights_between_imu_samples_feed_the_damping_loop(drive):
    prep = _baro_prep(drive, 30.0, 0.0013)  # 1.3 ms after the samples
    nav = prep.feed(prep.navigator())
    used = np.isfinite(nav._h_ref.view).sum()
    assert used == np.count_nonzero(prep.series["baro"].t < prep.t[-1] + prep.dt)


def test_a_free_ins_applies_the_initial_imu_compensation(drive):
    from fednav import InitialState

    prep = _prep(drive, 20.0)
    free = prep.system.model_copy(update={"aiding": [], "sensors":
                                          prep.system.sensors.replace(gnss=None)})
    bias = np.array([1e-3, -2e-3, 5e-4])
    ini = prep.initial
    a = Navigator(free, ini, prep.dt)
    a.add_imu(prep.t, prep.gyro, prep.accel)
    b = Navigator(free, InitialState(ini.t, ini.lla, ini.vel, ini.euler, ini.P0,
                                     gyro_bias=bias), prep.dt)
    b.add_imu(prep.t, prep.gyro + bias, prep.accel)
    np.testing.assert_allclose(b.result().states, a.result().states, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.solution().lla, a.solution().lla, rtol=1e-12)


def test_unix_time_stamps_keep_measurements_at_their_epoch(drive):
    prep = _prep(drive, 10.0)
    nav = prep.navigator()
    nav.t0 = 1.7e9
    t = nav.t0 + 3 * nav.T
    assert nav._epoch_of(np.nextafter(t, np.inf)) == 3
    assert nav._epoch_of(t) == 3 and nav._epoch_of(t + 1e-5) == 4


def test_no_complete_epoch_yet_is_a_one_line_error(drive):
    prep = _prep(drive, 10.0)
    nav = prep.navigator()
    nav.add_imu(prep.t[:3], prep.gyro[:3], prep.accel[:3])
    with pytest.raises(ValueError, match="one complete filter epoch"):
        _ = nav.result().forward


def test_the_total_state_navigator_runs_with_the_default_records():
    from fednav.scenarios import paper003
    from fednav.sim.runs import _initial_state, make_run_data
    from fednav.sim.scenario import ModeConfig

    scn = paper003.load_scenario()
    data = make_run_data(scn, 1, 20.0)
    truth = scn.trajectory(20.0)
    system = scn.system_for(ModeConfig(name="FUKF", aiding=["gnss", "star"],
                                       filter="total-ukf"))
    nav = Navigator(system, _initial_state(scn, truth, data), truth.dt)
    s = data.series["gnss"]
    with pytest.raises(ValueError, match="total-state navigator takes .* sigma, not R"):
        nav.add_measurement("gnss", s.t[0], s.z[0], R=np.eye(6))
    for a in ("gnss", "star"):
        nav.add_series(data.series[a])
    nav.add_imu(truth.t[:-1], dtheta=data.dtheta[:len(truth.t) - 1],
                dv=data.dv[:len(truth.t) - 1])
    res = nav.result()
    assert res.rows is None and len(res.t) > 10 and np.isfinite(res.states).all()


def test_a_sensor_that_delivered_nothing_is_no_error():
    """A stop detector before the first stop, an empty file after screening: no rows."""
    imu, gnss, _ = make_flight()
    prep = prepare(imu, {"gnss": gnss}, System())
    nav = prep.feed(prep.navigator())
    before = nav.result().states.copy()
    nav.add_measurements("gnss", np.zeros(0), np.zeros((0, 6)), sigma=np.ones(6))
    np.testing.assert_array_equal(nav.result().states, before)
