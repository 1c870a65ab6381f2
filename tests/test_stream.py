"""A stream flight software can use (issue 38): jittered real-time IMU stamps, late
measurements used at their time of validity up to the latency the system declares (and
said once when later), the solution at a chosen time, P0 from sigmas, bad input as one
line.  On the 240 s drive of ``test_process`` (100 Hz IMU, 5 Hz GNSS)."""

import warnings
from dataclasses import replace

import numpy as np
import pytest
from test_process import make_flight

from fednav import InitialState, Navigator, System, load_system
from fednav.core import earth, units
from fednav.io.data import regular_imu
from fednav.navigator.navigator import LateMeasurementWarning, declared_latency
from fednav.navigator.system import initial_covariance
from fednav.process.run import errors_against, prepare, rmse


@pytest.fixture(scope="module")
def drive():
    return make_flight()


def _prep(drive, seconds: float, cfg: System | None = None):
    imu, gnss, _ = drive
    prep = prepare(imu, {"gnss": gnss}, cfg or System())
    n = int(round(seconds / prep.dt))
    n -= n % prep.n_per
    prep.t, prep.gyro, prep.accel = prep.t[:n], prep.gyro[:n], prep.accel[:n]
    return prep


def _latency(seconds: float, **timing) -> System:
    return load_system({"sensors": {"gnss": {"timing": {"latency_s": seconds, **timing}}}})


def _stream(prep, nav, latency: float, *, arrival: bool = True, stamps=None,
            block: int = 1, upto: int | None = None):
    """Feed ``nav`` ``block`` IMU samples at a time (the first ``upto``), each GNSS fix
    once it has arrived (``latency`` after its time of validity; told with ``t_arrival``
    when ``arrival``, else just added late); the rest of the fixes at the end unless
    ``upto``."""
    tg, zg, Rg = prep.rows("gnss")
    ta = tg + latency
    stamps = prep.t if stamps is None else stamps
    j, n = 0, len(stamps) if upto is None else upto
    for a in range(0, n, block):
        b = min(a + block, n)
        while j < len(tg) and ta[j] <= stamps[b - 1] + 1e-9:
            nav.add_measurement("gnss", tg[j], zg[j], R=Rg[j],
                                t_arrival=ta[j] if arrival else None)
            j += 1
        if block == 1:
            nav.add_imu(stamps[a], prep.gyro[a], prep.accel[a])
        else:
            nav.add_imu(stamps[a:b], prep.gyro[a:b], prep.accel[a:b])
    for k in range(j, len(tg) if upto is None else j):
        nav.add_measurement("gnss", tg[k], zg[k], R=Rg[k],
                            t_arrival=ta[k] if arrival else None)
    return nav


def _rmse(res, ref) -> np.ndarray:
    r = rmse(errors_against(res.forward, ref))
    return np.array([r[k] for k in ("east_m", "north_m", "up_m", "ve_mps", "vn_mps",
                                    "vu_mps", "roll_deg", "pitch_deg", "yaw_deg")])


# ------------------------------------------------------------------- 1. jittered stamps
def _jittered(prep, jitter_s: float, seed: int = 5):
    """The prepared samples with their stamps jittered uniformly by +-``jitter_s`` (the
    first kept: the navigator starts there); the batch's grid and samples from them."""
    u = np.random.default_rng(seed).uniform(-jitter_s, jitter_s, len(prep.t))
    u[0] = 0.0
    s = prep.t + u
    tg, g, a, q = regular_imu("jittered", s, prep.gyro, prep.accel, 0.1)
    assert q["imu_resampled"] == 1 and tg[0] == s[0]
    return s, tg, g, a, float(np.median(np.diff(s)))


def test_jittered_stamps_stream_equals_the_batch_resampling(drive):
    """2 ms of jitter on a 10 ms IMU: streamed sample by sample and in blocks, the result
    is the batch's on the same data (resampled by regular_imu) to rounding."""
    prep = _prep(drive, 60.0)
    s, tg, g, a, dt = _jittered(prep, 0.002)
    meas = prep.rows("gnss")

    def nav():
        return Navigator(prep.system, prep.initial, dt, imu_errors=prep.imu_errors)

    batch = nav()
    batch.add_measurements("gnss", *meas[:2], R=meas[2])
    batch.add_imu(tg, g, a)
    ref = batch.result()
    for block in (1, 37):
        res = _stream(prep, nav(), 0.0, stamps=s, block=block).result()
        K = min(len(res.t), len(ref.t))
        assert K >= len(ref.t) - 1  # (the latest sample waits for its next stamp)
        d = np.abs(res.states[:K] - ref.states[:K]).max(axis=0)
        # (measured on the 240 s drive: 1e-16 rad, 4e-11 m, 1e-11 m/s, 6e-13 quaternion)
        assert d[7:9].max() < 1e-14 and d[9] < 1e-9, d  # lat/lon [rad], h [m]
        assert d[4:7].max() < 1e-9 and d[0:4].max() < 1e-11, d  # vel [m/s], quaternion
        n = (K - 1) * prep.n_per
        np.testing.assert_allclose(res.forward.lla[:n], ref.forward.lla[:n], rtol=0,
                                   atol=1e-9)
        np.testing.assert_allclose(res.forward.euler[:n], ref.forward.euler[:n], rtol=0,
                                   atol=1e-11)


def test_jittered_stamps_integrate_every_increment_once(drive):
    """The grid samples made from jittered stamps hold the integral of the rates over
    their span: their sum is the integral up to the last stamp's grid time."""
    prep = _prep(drive, 10.0)
    s, _, _, _, dt = _jittered(prep, 0.004, seed=2)
    nav = Navigator(prep.system, prep.initial, dt)
    nav.add_imu(s, prep.gyro, prep.accel)
    m = nav._imu_dth.n
    end = prep.t[0] + m * dt
    dur = np.diff(np.r_[s, np.inf])
    cover = np.clip(np.minimum(s + dur, end) - np.maximum(s, prep.t[0]), 0.0, None)
    np.testing.assert_allclose(nav._imu_dth.view.sum(axis=0),
                               (prep.gyro * cover[:, None]).sum(axis=0), rtol=1e-9)
    assert end <= s[-1] < end + dt


def test_bad_imu_stamps_are_one_line(drive):
    prep = _prep(drive, 2.0)
    t, dt = prep.t, prep.dt
    nav = prep.navigator()
    with pytest.raises(ValueError, match=r"^add_imu: the first sample is stamped .*half an"):
        nav.add_imu(t[0] + 0.6 * dt, prep.gyro[0], prep.accel[0])
    nav.add_imu(t[0] + 0.3 * dt, prep.gyro[0], prep.accel[0])  # jittered: accepted
    nav.add_imu(t[1] - 0.2 * dt, prep.gyro[1], prep.accel[1])
    with pytest.raises(ValueError, match=r"^add_imu: sample 2 is stamped .*not after the one "
                                         r"before"):
        nav.add_imu(t[1] - 0.3 * dt, prep.gyro[2], prep.accel[2])
    with pytest.raises(ValueError, match=r"^add_imu: sample 2 is stamped .*a gap"):
        nav.add_imu(t[3], prep.gyro[2], prep.accel[2])
    with pytest.raises(ValueError, match=r"^add_imu: sample 3 is stamped .*not after"):
        nav.add_imu(np.r_[t[2], t[2]], prep.gyro[2:4], prep.accel[2:4])
    nav.add_imu(t[2:10] + 0.1 * dt, prep.gyro[2:10], prep.accel[2:10])
    with pytest.raises(ValueError, match=r"^add_imu: 2 time stamp\(s\) with rotation data of "
                                         r"shape \(3, 3\)"):
        nav.add_imu(t[10:12], prep.gyro[10:13], prep.accel[10:12])
    with pytest.raises(ValueError, match=r"^add_imu: give gyro and accel"):
        nav.add_imu(t[10], prep.gyro[10])
    nav = prep.navigator()
    with pytest.raises(ValueError, match=r"^add_imu: 1 time stamp\(s\) with rotation data of "
                                         r"shape \(2,\)"):
        nav.add_imu(t[0], prep.gyro[0, :2], prep.accel[0])


# --------------------------------------------------------------------- 2. late measurements
def test_declared_latency_sets_the_hold():
    sys_ = load_system({"sensors": {
        "gnss": {"timing": {"latency_range_s": [0.1, 0.4]}},
        "baro": {"sigma_m": 1.0, "timing": {"latency_list_s": [0.2, 0.7],
                                            "delay_compensation": "recompute"}}},
        "aiding": ["gnss", "baro"]})
    assert declared_latency(sys_) == {"gnss": 0.4}  # (recompute bridges its own delays)
    assert declared_latency(_latency(0.3)) == {"gnss": 0.3}
    assert declared_latency(System()) == {}


def test_a_stream_with_declared_latency_is_the_batch(drive):
    """GNSS fixes arriving 0.3 s late (the filter period is 0.2 s): declared
    (sensors.gnss.timing.latency_s), the stream holds each epoch 0.31 s and uses every fix
    at its time of validity — position, velocity and attitude RMSE within 5 % of the
    batch with the fixes on time (the same epochs: equal).  Undeclared, the stream uses
    each fix at the epoch after its arrival, with a warning: several times worse."""
    _, _, ref = drive
    batch_prep = _prep(drive, 120.0)
    batch = batch_prep.feed(batch_prep.navigator()).result()
    rb = _rmse(batch, ref)
    prep = _prep(drive, 120.0, _latency(0.3))
    with warnings.catch_warnings():
        warnings.simplefilter("error", LateMeasurementWarning)
        nav = _stream(prep, prep.navigator(), 0.3)
        res = nav.result()
        late = _stream(prep, prep.navigator(), 0.3, arrival=False).result()
    assert nav.hold_s == pytest.approx(0.3 + prep.dt)
    rs = _rmse(res, ref)
    assert np.all(np.abs(rs / rb - 1.0) < 0.05), (rs, rb)
    np.testing.assert_array_equal(res.states, batch.states)
    np.testing.assert_array_equal(late.states, batch.states)
    assert res.data_quality["late_measurements_dropped"] == 0
    with pytest.warns(LateMeasurementWarning, match="no latency declared") as w:
        before = _stream(_prep(drive, 120.0), batch_prep.navigator(), 0.3).result()
    assert len([x for x in w if x.category is LateMeasurementWarning]) == 1
    rn = _rmse(before, ref)
    assert rn[1] > 3 * rb[1] and rn[8] > 3 * rb[8], (rn, rb)  # north, yaw


def test_the_batch_with_arrival_times_uses_the_declared_latency(drive):
    """prepare/feed with the fixes' arrival times (a file's t_arrival_s) and the latency
    declared: the on-time result."""
    imu, gnss, _ = drive
    late = replace(gnss, t_arrival=gnss.t + 0.3, quality={})
    on_time = _prep(drive, 60.0)
    on_time = on_time.feed(on_time.navigator()).result()
    prep = prepare(imu, {"gnss": late}, _latency(0.3))
    n = len(on_time.t) - 1
    prep.t, prep.gyro, prep.accel = (x[:n * prep.n_per] for x in (prep.t, prep.gyro,
                                                                    prep.accel))
    assert prep.series["gnss"].t_arrival is not None
    with warnings.catch_warnings():
        warnings.simplefilter("error", LateMeasurementWarning)
        res = prep.feed(prep.navigator()).result()
    np.testing.assert_array_equal(res.states, on_time.states)


def test_a_measurement_later_than_declared_is_said_once_and_counted(drive):
    prep = _prep(drive, 30.0, _latency(0.3))
    with pytest.warns(LateMeasurementWarning) as w:
        res = _stream(prep, prep.navigator(), 0.6).result()
    w = [x for x in w if x.category is LateMeasurementWarning]
    assert len(w) == 1
    msg = str(w[0].message)
    assert msg.startswith("gnss: a measurement arrived 0.600 s after its time of validity")
    assert "sensors.gnss.timing.latency_s = 0.3 s declared" in msg
    assert "set sensors.gnss.timing.latency_s" in msg and "\n" not in msg
    n = int(np.count_nonzero(prep.series["gnss"].t < prep.t[-1] - 1.0))
    assert res.data_quality["late_measurements_deferred"] >= n
    # fed late without its arrival time: dropped when its epoch has run, said once
    with pytest.warns(LateMeasurementWarning, match=r"dropped .*latency_s") as w:
        res = _stream(prep, prep.navigator(), 0.6, arrival=False).result()
    assert len([x for x in w if x.category is LateMeasurementWarning]) == 1
    assert res.data_quality["late_measurements_dropped"] >= n


def test_late_measurements_without_a_declared_latency_name_the_key(drive):
    prep = _prep(drive, 20.0)
    with pytest.warns(LateMeasurementWarning) as w:
        res = _stream(prep, prep.navigator(), 0.25, arrival=False).result()
    w = [x for x in w if x.category is LateMeasurementWarning]
    assert len(w) == 1
    assert "no latency declared in sensors.gnss.timing" in str(w[0].message)
    assert "sensors.gnss.timing.latency_s" in str(w[0].message)
    assert res.data_quality["late_measurements_dropped"] > 0
    # an explicit hold_s is a hold too
    with warnings.catch_warnings():
        warnings.simplefilter("error", LateMeasurementWarning)
        _stream(prep, prep.navigator(hold_s=0.3), 0.25).result()


# ---------------------------------------------------------------------- 3. solution_at
def _truth_error(snap, ref):
    """(position error ENU [m], velocity error [m/s], heading error [rad]) of a snapshot
    against the truth at its time."""
    lla = np.array([np.interp(snap.t, ref.t, ref.lla[:, j]) for j in range(3)])
    vel = np.array([np.interp(snap.t, ref.t, ref.vel[:, j]) for j in range(3)])
    hd = np.interp(snap.t, ref.t, np.unwrap(ref.euler[:, 2]))
    d = earth.llh_difference_enu(*snap.lla, *lla)
    return np.asarray(d), snap.vel - vel, float(np.angle(np.exp(1j * (snap.euler[2] - hd))))


def test_solution_at_a_chosen_time(drive):
    """Mid-stream on the drive: within the samples since the last epoch (mechanized),
    beyond the latest sample (extrapolated at its rates, the sigma growing), in the
    recorded history (the forward solution's rows, interpolated), against the truth."""
    _, _, ref = drive
    prep = _prep(drive, 80.0)
    nav = prep.navigator()
    probe = 6000 + 7  # 60.07 s after the start: between epochs
    _stream(prep, nav, 0.0, upto=probe)
    latest = nav.solution()
    tk = nav.t0 + nav.loop.k * nav.T
    assert tk < latest.t
    same = nav.solution_at(latest.t)
    np.testing.assert_allclose(same.lla, latest.lla, rtol=1e-13)
    np.testing.assert_allclose(same.vel, latest.vel, atol=1e-10)
    mid = nav.solution_at(0.5 * (tk + latest.t) + 0.3 * prep.dt)
    sig = [nav.solution_at(latest.t + h).sigma for h in (0.0, 0.5, 2.0, 5.0)]
    for a, b in zip(sig[:-1], sig[1:], strict=True):
        assert np.all(b[3:9] > a[3:9])  # velocity and position sigmas grow
    assert np.all(sig[0][3:9] >= nav.solution_at(tk).sigma[3:9])
    for snap, tol_p, tol_v in ((mid, 1.0, 0.1), (nav.solution_at(latest.t + 0.5), 1.0, 0.1),
                               (nav.solution_at(latest.t + 2.0), 1.5, 0.2)):
        dp, dv, dh = _truth_error(snap, ref)
        assert np.linalg.norm(dp[:2]) < tol_p and np.linalg.norm(dv[:2]) < tol_v, snap.t
        assert abs(dh) < units.deg(1.0)
        assert np.all(np.abs(dp[:2]) < 4 * snap.sigma[6:8])
    # the history: the forward solution at its rows, and between them
    fwd = nav.result().forward
    for i in (1234, 3000, 5000):
        s = nav.solution_at(fwd.t[i])
        np.testing.assert_allclose(s.lla, fwd.lla[i], rtol=1e-13)
        np.testing.assert_allclose(s.euler, fwd.euler[i], atol=1e-12)
        np.testing.assert_allclose(s.sigma, fwd.sigma[i], rtol=1e-9)
    s = nav.solution_at(fwd.t[3000] + 0.25 * prep.dt)
    assert np.all(np.abs(earth.llh_difference_enu(*s.lla, *fwd.lla[3000]))
                  <= np.abs(earth.llh_difference_enu(*fwd.lla[3001], *fwd.lla[3000])) + 1e-9)
    with pytest.raises(ValueError, match=r"^solution_at: .* is before the start"):
        nav.solution_at(prep.t[0] - 1.0)
    nav = prep.navigator(record_rows=False)
    nav.add_imu(prep.t[:500], prep.gyro[:500], prep.accel[:500])
    with pytest.raises(ValueError, match=r"^solution_at: .* before the kept history, which "
                                         r"begins at the last filter epoch"):
        nav.solution_at(prep.t[10])
    with pytest.raises(ValueError, match="finite number"):
        nav.solution_at(float("nan"))


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


# ----------------------------------------------------------------------- 5. bad input
def test_bad_stream_input_is_one_line_naming_it(drive):
    prep = _prep(drive, 5.0)
    tg, zg, Rg = prep.rows("gnss")
    for period in (0.0, -0.01, float("nan"), "fast"):
        with pytest.raises(ValueError, match=r"^Navigator: imu_period must be a positive "
                                             r"number of seconds, got "):
            Navigator(prep.system, prep.initial, period)
    with pytest.raises(ValueError, match=r"^Navigator: hold_s must be a non-negative"):
        prep.navigator(hold_s=-1.0)
    nav = prep.navigator()
    nav.add_measurement("gnss", tg[0], zg[0], R=Rg[0])
    for r in (Rg[1], None):  # the stream's fast path (R given) and the general one
        with pytest.raises(ValueError, match=r"^gnss: a measurement has 5 value\(s\) .*"
                                             r"gnss takes 6 \(lat_deg, lon_deg"):
            nav.add_measurement("gnss", tg[1], zg[1][:5], R=r)
        bad = zg[1].copy()
        bad[4] = np.nan
        with pytest.raises(ValueError, match=r"^gnss: the measurement at t = .* has "
                                             r"NaN/inf in z\[4\] \(vN_mps\), which its "
                                             r"model reads$"):
            nav.add_measurement("gnss", tg[1], bad, R=r)
    with pytest.raises(ValueError, match=r"^gnss: R has shape \(3, 3\) per measurement; "
                                         r"gnss's residual takes \(6, 6\)"):
        nav.add_measurement("gnss", tg[1], zg[1], R=np.eye(3))
    with pytest.raises(ValueError, match=r"^gnss: R is not finite"):
        nav.add_measurement("gnss", tg[1], zg[1], R=np.full((6, 6), np.nan))
    with pytest.raises(ValueError, match=r"^gnss: the measurement valid at .* arrives at .* "
                                         r"before the time it describes$"):
        nav.add_measurement("gnss", tg[1], zg[1], R=Rg[1], t_arrival=tg[1] - 1.0)
    with pytest.raises(ValueError, match=r"^gnss: a time of validity is not a number"):
        nav.add_measurement("gnss", float("nan"), zg[1], R=Rg[1])
    with pytest.raises(ValueError, match=r"^unknown sensor 'lidar'; registered: "):
        nav.add_measurement("lidar", tg[1], zg[1], R=Rg[1])
    with pytest.raises(ValueError, match=r"^gnss: z has shape \(3, 6\) for 2 time\(s\) of "
                                         r"validity \(one row per measurement\)$"):
        nav.add_measurements("gnss", tg[1:3], np.vstack([zg[1:3], zg[3]]), R=Rg[1:3])
    assert len(nav._meas["gnss"]) == 1  # nothing bad was kept
    # GNSS measuring positions only: NaN velocity is what it does not measure
    pos = load_system({"sensors": {"gnss": {"measures": "position"}}})
    prep2 = _prep(drive, 5.0, pos)
    assert prep2.system.sensors.gnss.measures == "position"
    nav = prep2.navigator()
    z = zg[1].copy()
    z[3:] = np.nan
    nav.add_measurement("gnss", tg[1], z, sigma=np.ones(6))
