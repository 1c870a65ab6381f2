"""Protection levels by solution separation: the equations against a case written by
hand, and on a processed drive — fault-free levels that bound the error, a GNSS height
ramp detected and the GNSS excluded with three sensors, detected and alerted (not
excluded) with two."""

from dataclasses import replace

import numpy as np
import pytest
from test_process import LEVER, make_flight
from test_series_route import _velocity

from fednav import System
from fednav.core import earth
from fednav.io.data import SensorData
from fednav.navigator.integrity import (
    IntegrityConfig,
    protection_level,
    q_function,
    q_inverse,
    separation_threshold,
)
from fednav.navigator.navigator import HealthWarning
from fednav.process import process
from fednav.process.output import solution_columns, summary


def test_two_position_sensors_by_hand():
    """A constant position measured once by two sensors (sigma 1 and 2): the all-sensor
    estimate has variance 1/(1 + 1/4); leaving one out leaves the other's."""
    s1, s2 = 1.0, 2.0
    s0 = np.sqrt(1.0 / (1.0 / s1**2 + 1.0 / s2**2))
    sk = np.array([[s2], [s1]])  # without sensor 1: sensor 2's; without 2: sensor 1's
    k_fa = q_inverse(1e-3 / 4)
    ss, T = separation_threshold(np.array([s0]), sk, k_fa)
    np.testing.assert_allclose(ss[:, 0], [np.sqrt(s2**2 - s0**2), np.sqrt(s1**2 - s0**2)])
    np.testing.assert_allclose(T, k_fa * ss)
    p = np.array([1e-3, 1e-3])
    pl = protection_level(np.array([s0]), sk, T, p, 1e-6)[0]
    lhs = 2 * q_function(pl / s0) + sum(p[k] * q_function((pl - T[k, 0]) / sk[k, 0])
                                        for k in range(2))
    assert lhs == pytest.approx(1e-6, rel=1e-6)
    # the level grows with the prior fault probability and with the threshold
    assert protection_level(np.array([s0]), sk, T, p * 10, 1e-6)[0] > pl
    assert protection_level(np.array([s0]), sk, 2 * T, p, 1e-6)[0] > pl
    # no fault hypotheses: the fault-free term alone, K_ff sigma0
    assert protection_level(np.array([s0]), sk, T, 0 * p, 1e-6)[0] == pytest.approx(
        q_inverse(0.5e-6) * s0, rel=1e-6)


def test_budget_defaults_and_priors():
    c = IntegrityConfig(prior_fault={"gnss": 1e-3})
    assert c.prior("gnss") == 1e-3 and c.prior("baro") == 1e-4
    assert IntegrityConfig().risk_vertical == 1e-7


@pytest.fixture(scope="module")
def drive():
    imu, gnss, ref = make_flight()
    rng = np.random.default_rng(3)
    tb = np.arange(0.1, ref.t[-1], 0.1)
    h = np.interp(tb, ref.t, ref.lla[:, 2]) + 0.3 * rng.standard_normal(len(tb))
    baro = SensorData("baro", "sim-baro", tb, h[:, None])
    return imu, gnss, _velocity(gnss), baro, ref


def _cfg(**integrity):
    return System.model_validate({
        "imu": {"gyro_arw_deg_sqrt_h": 0.2, "accel_vrw_mps_sqrt_s": 0.002,
                "gyro_bias_deg_h": 10, "accel_bias_mps2": 0.01, "gyro_markov_deg_h": 0,
                "accel_markov_mps2": 0},
        "sensors": {"gnss": {"lever_m": list(LEVER)}, "velocity": {"lever_m": list(LEVER)},
                    "baro": {"sigma_m": 0.3, "damping_loop": False}},
        "integrity": integrity})


def _ramp(gnss, rate_mps, start_s=120.0):
    g = replace(gnss, lla=gnss.lla.copy(), quality={})
    k = g.t > start_s
    g.lla[k, 2] += (g.t[k] - start_s) * rate_mps
    return g


def test_fault_free_levels_bound_the_error(drive):
    imu, gnss, vel, baro, ref = drive
    res = process(imu, {"gnss": gnss, "velocity": vel, "baro": baro},
                  _cfg(alert_limit_vertical_m=50.0))
    s = summary(res, ref, {})["integrity"]
    assert s["sensors"] == ["gnss", "velocity", "baro"]
    assert s["exclusions"] == [] and s["alert_fraction"] == 0.0
    assert res.integrity.test_ratio.max() < 1.0
    assert s["vertical_error_above_level"] == 0.0
    assert s["horizontal_error_above_level"] == 0.0
    assert s["availability"] == 1.0
    # the vertical level: a few times the error, not a wall (the baro witnesses the height)
    assert s["vpl_m"]["median"] < 30 * s["vertical_error_median"]
    cols = solution_columns(res.forward)
    assert {"hpl_m", "vpl_m", "heading_pl_deg", "integrity_alert"} <= set(cols)
    assert not [w for w in res.warnings if w.startswith("integrity")]


def test_gnss_ramp_is_detected_and_excluded(drive):
    imu, gnss, vel, baro, ref = drive
    res = process(imu, {"gnss": _ramp(gnss, 0.1), "velocity": vel, "baro": baro}, _cfg())
    s = summary(res, ref, {})["integrity"]
    assert [e["sensor"] for e in s["exclusions"]] == ["gnss"]
    t_ex = s["exclusions"][0]["t_s"]
    assert 120.0 < t_ex < 150.0  # (before the ramp reaches 3 m)
    assert s["vertical_error_above_level"] == 0.0
    assert summary(res, ref, {})["rmse"]["up_m"] < 0.2  # (the ramp is 12 m at the end)
    assert any("'gnss' excluded" in w for w in res.warnings)


def test_two_sensors_detect_but_do_not_exclude(drive):
    imu, gnss, vel, _, ref = drive
    cfg = _cfg()
    cfg = cfg.model_copy(update={"sensors": cfg.sensors})
    res = process(imu, {"gnss": _ramp(gnss, 0.5), "velocity": vel}, cfg)
    s = summary(res, ref, {})["integrity"]
    assert s["exclusions"] == [] and s["alert_fraction"] > 0.3
    assert any("two sensors cannot say which one is faulty" in w for w in res.warnings)


def test_one_sensor_is_refused_in_one_line(drive):
    from fednav.io.data import DataError

    imu, gnss, _, _, _ = drive
    with pytest.raises(DataError, match="two or more recorded aiding sensors"):
        process(imu, {"gnss": gnss}, _cfg())


def test_stanford_regions_by_hand():
    from fednav.process.stanford import regions

    err = np.array([0.5, 2.0, 12.0, 0.5, 15.0, 2.0])
    pl = np.array([1.0, 1.0, 1.0, 20.0, 12.0, 1.0])
    alert = np.array([False, False, False, False, False, True])
    r = regions(err, pl, alert, limit=10.0)
    assert r == {"epochs": 6, "alerted": 1, "normal": 1, "misleading": 1,
                 "hazardously_misleading": 1, "unavailable": 1, "unavailable_misleading": 1}
    assert regions(err, pl, alert, None) == {"epochs": 6, "alerted": 1, "bounded": 2,
                                             "misleading": 3}


@pytest.mark.slow
def test_outputs_carry_the_levels_and_the_stanford_diagram(drive, tmp_path):
    import json

    from fednav.process import output

    imu, gnss, vel, baro, ref = drive
    res = process(imu, {"gnss": _ramp(gnss, 0.1), "velocity": vel, "baro": baro},
                  _cfg(alert_limit_vertical_m=5.0))
    files = output.write(tmp_path, res, ref, {}, None, gnss)
    assert tmp_path / "stanford.png" in files
    s = json.loads((tmp_path / "summary.json").read_text())["integrity"]
    v = s["stanford"]["vertical"]
    assert v["hazardously_misleading"] == 0 and v["misleading"] == 0
    assert v["epochs"] == sum(v[k] for k in v if k != "epochs")
    head = (tmp_path / "solution.csv").read_text().splitlines()[0].split(",")
    assert {"hpl_m", "vpl_m", "heading_pl_deg", "integrity_alert", "excluded"} <= set(head)


def _stream_levels(prep, block: int = 500):
    """The levels of an :class:`IntegrityNavigator` fed the prepared data: every series
    first, then the IMU samples ``block`` at a time, a snapshot after each block."""
    from fednav.navigator.integrity_stream import IntegrityNavigator

    nav = IntegrityNavigator(prep.system, prep.initial, prep.dt, imu_errors=prep.imu_errors,
                             record_rows=False, record_covariance=False)
    for s in prep.series.values():
        nav.add_series(s)
    snaps = []
    for a in range(0, len(prep.t), block):
        b = min(a + block, len(prep.t))
        nav.add_imu(prep.t[a:b], prep.gyro[a:b], prep.accel[a:b])
        snaps.append(nav.solution())
    return nav, snaps


def test_the_stream_gives_levels_that_bound_the_error(drive):
    """IntegrityNavigator: the batch bank run as a stream — fault-free, every snapshot
    has finite levels above the error against the reference, no test trips and no
    alert; its levels are the batch's at the same time."""
    from fednav.process.run import prepare

    imu, gnss, vel, baro, ref = drive
    cfg = _cfg(alert_limit_vertical_m=50.0)
    nav, snaps = _stream_levels(prepare(imu, {"gnss": gnss, "velocity": vel, "baro": baro},
                                        cfg))
    assert nav.sensors == ["gnss", "velocity", "baro"] and len(snaps) > 20
    for s in snaps[2:]:
        lv = s.levels
        assert lv["alert"] is False and lv["tripped_s"] is None and lv["test_ratio"] < 1
        assert lv["excluded"] is None
        k = np.searchsorted(ref.t, s.t)
        e = np.asarray(earth.llh_difference_enu(*s.lla, *ref.lla[k]))
        assert np.hypot(e[0], e[1]) < lv["hpl_m"] and abs(e[2]) < lv["vpl_m"]
    batch = process(imu, {"gnss": gnss, "velocity": vel, "baro": baro}, cfg).integrity
    s = snaps[-2]
    i = batch.rows_at(s.t)
    assert s.levels["vpl_m"] == pytest.approx(batch.vpl[i], rel=0.05)
    assert s.levels["hpl_m"] == pytest.approx(batch.hpl[i], rel=0.05)


def test_the_stream_alerts_on_a_gnss_ramp(drive):
    from fednav.process.run import prepare

    imu, gnss, vel, baro, _ = drive
    with pytest.warns(HealthWarning, match="'gnss' excluded"):  # (then excluded)
        _, snaps = _stream_levels(prepare(imu, {"gnss": _ramp(gnss, 0.5), "velocity": vel,
                                                "baro": baro}, _cfg()))
    tripped = [s for s in snaps if s.levels["tripped_s"] is not None]
    assert tripped and 120.0 < tripped[0].levels["tripped_s"] < 150.0
    assert all(s.levels["alert"] or s.levels["excluded"] == "gnss" for s in tripped)
    # (the sub-solution that separates most: here the one without the barometer, which
    # then follows the ramped GNSS height fully — a candidate, not an identification;
    # the velocity sensor sees no height)
    assert tripped[0].levels["candidate"] in ("gnss", "baro")
    assert all(s.levels["alert"] is False for s in snaps if s.t < 120.0)


def test_the_stream_excludes_the_faulty_sensor(drive):
    """Exclusion in the stream: a 0.1 m/s GNSS height ramp from 120 s trips a test; the
    GNSS is excluded once the solution without it is the only one its own bank (the
    pair navigators) agrees with; from then on the output is that solution, near the
    truth and inside its levels — the sensor the batch excludes, tens of seconds
    after the ramp began, as the batch."""
    from fednav.process.run import prepare

    imu, gnss, vel, baro, ref = drive
    sensors = {"gnss": _ramp(gnss, 0.1), "velocity": vel, "baro": baro}
    with pytest.warns(HealthWarning, match="'gnss' excluded at"):
        nav, snaps = _stream_levels(prepare(imu, sensors, _cfg()))
    assert len(nav.bank) == 3 and len(nav.pairs) == 3
    out = [s for s in snaps if s.levels["excluded"] is not None]
    assert out and {s.levels["excluded"] for s in out} == {"gnss"} == {nav.excluded}
    t_ex = out[0].levels["excluded_s"]
    batch = summary(process(imu, sensors, _cfg()), ref, {})["integrity"]["exclusions"]
    assert [e["sensor"] for e in batch] == ["gnss"]
    assert 120.0 < t_ex < 180.0 and abs(t_ex - batch[0]["t_s"]) < 30.0
    assert all(s.levels["excluded"] is None for s in snaps if s.t < 120.0)
    for s in out:
        e = np.asarray(earth.llh_difference_enu(*s.lla, *ref.lla[np.searchsorted(ref.t,
                                                                                  s.t)]))
        assert abs(e[2]) < min(1.0, s.levels["vpl_m"]) and not s.levels["alert"]


def test_the_stream_refuses_one_sensor(drive):
    from fednav.navigator.integrity_stream import IntegrityNavigator
    from fednav.process.run import prepare

    imu, gnss, *_ = drive
    prep = prepare(imu, {"gnss": gnss}, _cfg())
    with pytest.raises(ValueError, match="two or more aiding sensors"):
        IntegrityNavigator(prep.system, prep.initial, prep.dt)
