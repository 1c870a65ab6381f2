"""Real-data processing pipeline on simulated data with known truth (fednav's generator),
and the ``fednav process`` command line."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fednav import System, load_system
from fednav.cli import app
from fednav.core import earth, units
from fednav.io.csvdata import IMU_COLUMNS, write_csv
from fednav.io.data import GnssData, ImuData, ImuErrors, Reference
from fednav.process import errors_against, process, rmse
from fednav.sensors import ImuErrors as SimImuErrors
from fednav.sensors import corrupt_imu
from fednav.sim.trajectory import Segment, generate

LEVER = np.array([0.6, -1.2, 0.4])  # antenna: right, aft, up of the IMU [m]


def simulated_imu(truth, rng, *initial) -> ImuData:
    """The truth's increments with a MEMS IMU's errors (50 deg/h and 2 mg biases, 0.2
    deg/sqrt(h), 1e-3 m/s/sqrt(s)) and those figures; ``initial``: the file's initial
    attitude and its sigma, if any.  Sample ``k`` covers ``[t_k, t_k+1]``: stamped
    ``t_k``, where its rates start to hold (ImuData's convention)."""
    sim = SimImuErrors(gyro_bias=units.deg_per_h(50.0), accel_bias=units.milli_g(2.0),
                       gyro_arw=units.deg_per_sqrt_h(0.2), accel_vrw=1e-3)
    dth, dv, _ = corrupt_imu(truth.dtheta, truth.dv, truth.dt, sim, rng)
    errs = ImuErrors(*[np.full(3, v) for v in (units.deg_per_sqrt_h(0.2), 1e-3,
                                               units.deg_per_h(50.0), units.milli_g(2.0),
                                               1e-6, 1e-5, 1000.0, 1000.0)])
    return ImuData("sim-imu", truth.t[:-1], dth / truth.dt, dv / truth.dt, errs, *initial)


def make_flight():
    """A 240 s drive with turns, 100 Hz IMU, 5 Hz GNSS at an antenna lever arm."""
    segs = [Segment(20.0), Segment(10.0, accel=1.0), Segment(30.0, heading_rate=units.deg(3)),
            Segment(40.0), Segment(30.0, heading_rate=units.deg(-4)), Segment(10.0, accel=-0.5),
            Segment(50.0, heading_rate=units.deg(2)), Segment(50.0)]
    truth = generate(np.array([units.deg(45.0), units.deg(-75.0), 50.0]), 7.0,
                     [0.0, 0.0, units.deg(45.0)], segs, 0.01)
    rng = np.random.default_rng(7)
    imu = simulated_imu(truth, rng, truth.euler[0] + units.deg(np.array([0.5, -0.5, 2.0])),
                        units.deg(np.array([1.0, 1.0, 3.0])))
    tg = np.arange(0.2, truth.t[-1], 0.2)
    tr = truth.at(tg)
    from fednav.core import attitude as att

    C = att.euler_to_dcm(tr["euler"])
    d = C @ LEVER
    rm, rn = earth.radii(tr["lla"][:, 0])
    ant = tr["lla"] + np.column_stack([d[:, 1] / (rm + tr["lla"][:, 2]),
                                       d[:, 0] / ((rn + tr["lla"][:, 2]) *
                                                  np.cos(tr["lla"][:, 0])), d[:, 2]])
    # antenna velocity v + C (w_ib x l), body rate from the true increments
    k = np.rint(tg / truth.dt).astype(int)
    w = truth.dtheta[k - 1] / truth.dt
    vant = tr["vel"] + np.einsum("kij,kj->ki", C, np.cross(w, LEVER))
    sp, sv = 1.0, 0.05
    noise_p = rng.standard_normal((len(tg), 3)) * sp
    ant[:, 0] += noise_p[:, 0] / (rm + tr["lla"][:, 2])
    ant[:, 1] += noise_p[:, 1] / ((rn + tr["lla"][:, 2]) * np.cos(tr["lla"][:, 0]))
    ant[:, 2] += noise_p[:, 2]
    vant += rng.standard_normal((len(tg), 3)) * sv
    gnss = GnssData("sim-gnss", tg, ant, vant, np.full(3, sp), np.full(3, sv), LEVER)
    ref = Reference("truth", truth.t, truth.lla, truth.vel, truth.euler)
    return imu, gnss, ref


@pytest.fixture(scope="module")
def flight():
    return make_flight()


@pytest.fixture(scope="module")
def result(flight):
    imu, gnss, _ = flight
    return process(imu, {"gnss": gnss}, System(), smooth=True)


def test_forward_filter_tracks_the_truth(flight, result):
    e = errors_against(result.forward, flight[2])
    r = rmse(e)
    assert max(r["east_m"], r["north_m"], r["up_m"]) < 0.3
    assert max(r["ve_mps"], r["vn_mps"], r["vu_mps"]) < 0.03
    assert r["roll_deg"] < 0.15 and r["pitch_deg"] < 0.15
    # heading starts 2 deg off and converges once the vehicle accelerates and turns
    late = rmse({k: v[e["t"] > 60] for k, v in e.items()})
    assert late["yaw_deg"] < 0.4


def test_smoother_improves_position_velocity_and_attitude(flight, result):
    f = rmse(errors_against(result.forward, flight[2]))
    s = rmse(errors_against(result.smoothed, flight[2]))
    for k in ("east_m", "north_m", "up_m", "ve_mps", "vn_mps", "pitch_deg", "roll_deg"):
        assert s[k] < f[k], k


def test_filter_is_consistent(result):
    from fednav.process.output import consistency

    c = consistency(result.forward)["gnss"]
    assert 0.6 < c["nis_per_dof"] < 1.6


def test_ignoring_the_lever_arm_costs_accuracy(flight, result):
    """End-to-end check of the lever-arm sign: zero lever -> clearly worse position."""
    imu, gnss, ref = flight
    wrong = process(imu, {"gnss": gnss}, load_system({"sensors": {"gnss": {"lever_m": [0, 0, 0]}}}))
    good = rmse(errors_against(result.forward, ref))
    bad = rmse(errors_against(wrong.forward, ref))
    assert bad["north_m"] + bad["east_m"] > 1.5 * (good["north_m"] + good["east_m"])


def test_coarse_heading_from_the_gnss_course(flight):
    from fednav.process.run import fix_course as gnss_course

    _, gnss, ref = flight
    assert units.to_deg(gnss_course(gnss, 1.0)) == pytest.approx(45.0, abs=2.0)
    still = GnssData("still", gnss.t, gnss.lla, gnss.vel * 0.0, gnss.sigma_pos_enu,
                     gnss.sigma_vel, gnss.lever)
    assert gnss_course(still, 1.0) is None


def test_cli_process_csv_end_to_end(tmp_path, flight):
    imu, gnss, ref = flight
    cols = {"t_s": imu.t}
    for j, c in enumerate(IMU_COLUMNS[1:4]):
        cols[c] = imu.gyro[:, j]
    for j, c in enumerate(IMU_COLUMNS[4:7]):
        cols[c] = imu.accel[:, j]
    write_csv(tmp_path / "imu.csv", cols)
    write_csv(tmp_path / "gnss.csv", {
        "t_s": gnss.t, "lat_deg": units.to_deg(gnss.lla[:, 0]),
        "lon_deg": units.to_deg(gnss.lla[:, 1]), "h_m": gnss.lla[:, 2],
        "vE_mps": gnss.vel[:, 0], "vN_mps": gnss.vel[:, 1], "vU_mps": gnss.vel[:, 2]})
    write_csv(tmp_path / "ref.csv", {
        "t_s": ref.t, "lat_deg": units.to_deg(ref.lla[:, 0]),
        "lon_deg": units.to_deg(ref.lla[:, 1]), "h_m": ref.lla[:, 2],
        "vE_mps": ref.vel[:, 0], "vN_mps": ref.vel[:, 1], "vU_mps": ref.vel[:, 2],
        "pitch_deg": units.to_deg(ref.euler[:, 0]), "roll_deg": units.to_deg(ref.euler[:, 1]),
        "heading_deg": units.to_deg(ref.euler[:, 2])})
    e = imu.errors
    (tmp_path / "cfg.yaml").write_text(
        f"imu: {{gyro_arw_rad_sqrt_s: {e.gyro_arw[0]}, accel_vrw_mps_sqrt_s: "
        f"{e.accel_vrw[0]}, gyro_bias_radps: {e.gyro_bias[0]}, accel_bias_mps2: "
        f"{e.accel_bias[0]}, gyro_markov_radps: 1.0e-6, accel_markov_mps2: 1.0e-5, "
        f"gyro_tau_s: 1000, accel_tau_s: 1000}}\n"
        f"sensors: {{gnss: {{sigma_pos_enu_m: [1, 1, 1], sigma_vel_mps: [0.05, 0.05, 0.05], "
        f"lever_m: [{LEVER[0]}, {LEVER[1]}, {LEVER[2]}]}}}}\n"
        f"alignment: {{initial_attitude: coarse}}\n")
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["process", "csv", "--imu", str(tmp_path / "imu.csv"),
                                   "--gnss", str(tmp_path / "gnss.csv"), "--ref",
                                   str(tmp_path / "ref.csv"), "--smooth", "--out", str(out),
                                   "--config", str(tmp_path / "cfg.yaml")])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    # in the solution's order: ENU, then [pitch, roll, heading] (docs/conventions.md)
    assert list(s["rmse"]) == ["east_m", "north_m", "up_m", "ve_mps", "vn_mps", "vu_mps",
                               "pitch_deg", "roll_deg", "yaw_deg"]
    assert s["rmse"]["north_m"] < 1.0 and s["run_time_s"] > 0
    assert (out / "solution.csv").is_file() and (out / "solution_smoothed.csv").is_file()
    assert (out / "errors.png").is_file()
    # the terminal's RMSE tables name each column with its unit (issue 29), not by key
    assert "north position [m]" in res.output and "heading [°]" in res.output
    head = next(ln for ln in res.output.splitlines() if "position [m]" in ln)
    assert head.index("east position") < head.index("north position") < head.index(
        "up position")
    assert "RMSE smoothed against the reference" in res.output
    assert "north_m" not in res.output
    # the IMU noise checked against the recording (fednav.process.identify): the true
    # figures are consistent with it, flown as given, and it says so
    n = s["noise"]
    assert n["method"] == "em" and n["identified"] == n["prior"] and not n["accepted"]
    assert "IMU noise: the given figures flown (every NIS/dof inside 0.5..2" in res.output
    bad = CliRunner().invoke(app, ["process", "csv", "--imu", str(tmp_path / "imu.csv"),
                                   "--gnss", str(tmp_path / "gnss.csv"), "--out",
                                   str(tmp_path / "out2"), "--noise", "learn"])
    assert bad.exit_code == 2
    assert "--noise learn: not identify, identify-all or as-given" in bad.output


@pytest.mark.parametrize(("cfg", "message"), [
    ("imu: {gyro_arw: 1}\n", "key 'imu.gyro_arw': unknown key"),
    ("fdi_alpha: {gps: 0.01}\n", "unknown local filter"),
])
def test_cli_bad_config_is_one_line(tmp_path, flight, cfg, message):
    imu, gnss, _ = flight
    (tmp_path / "cfg.yaml").write_text(cfg)
    cols = {"t_s": imu.t[:500]}
    for j, c in enumerate(IMU_COLUMNS[1:]):
        cols[c] = (imu.gyro if j < 3 else imu.accel)[:500, j % 3]
    write_csv(tmp_path / "imu.csv", cols)
    write_csv(tmp_path / "gnss.csv", {
        "t_s": gnss.t[:20], "lat_deg": units.to_deg(gnss.lla[:20, 0]),
        "lon_deg": units.to_deg(gnss.lla[:20, 1]), "h_m": gnss.lla[:20, 2],
        "vE_mps": gnss.vel[:20, 0], "vN_mps": gnss.vel[:20, 1], "vU_mps": gnss.vel[:20, 2]})
    res = CliRunner().invoke(app, ["process", "csv", "--imu", str(tmp_path / "imu.csv"),
                                   "--gnss", str(tmp_path / "gnss.csv"), "--out",
                                   str(tmp_path / "o"), "--config", str(tmp_path / "cfg.yaml")])
    assert res.exit_code == 2
    assert message in res.output and "Traceback" not in res.output


def test_csv_without_noise_figures_takes_a_preset_or_names_the_key(tmp_path, flight):
    """No figure anywhere: the consumer MEMS preset, said; some figures but not all: the
    missing one named (a grade fills them)."""
    imu, gnss, ref = flight
    bare = ImuData("bare.csv", imu.t, imu.gyro, imu.accel)
    from fednav.io import DataError

    res = process(bare, {"gnss": gnss})
    assert any("bare.csv: no IMU error figures in the file or the config: the 'consumer' "
               "MEMS preset is assumed" in w for w in res.warnings)
    r = rmse(errors_against(res.forward, ref))
    assert np.hypot(r["north_m"], r["east_m"]) < 1.0
    with pytest.raises(DataError, match=r"bare.csv: no IMU error figures.*imu\.accel_vrw"
                                        r".*imu\.grade"):
        process(bare, {"gnss": gnss}, load_system({"imu": {"gyro_arw_rad_sqrt_s": 1e-4}}))
    res = process(bare, {"gnss": gnss}, load_system({"imu": {"gyro_arw_rad_sqrt_s": 1e-4,
                                                         "grade": "industrial"}}))
    assert not any("preset is assumed" in w for w in res.warnings)


@pytest.mark.parametrize("shift", [-0.002, 0.0, 0.002, -0.0099])
def test_each_fix_meets_the_first_epoch_at_or_after_it(flight, shift):
    """IMU stamps on another phase than the GNSS's (an IMU clock 2 ms ahead of the
    fixes): the epoch grid starts at the first IMU sample at or after the first fix, so
    every fix is used at the epoch right after it — less than one IMU period later.  It
    started at the nearest sample, which could lie just before the fix: every fix then
    waited a whole filter period (0.198 s), and an independent car drive's north error
    was 19 % larger."""
    from dataclasses import replace

    from fednav.navigator.navigator import epochs_at
    from fednav.process import prepare

    imu, gnss, _ = flight
    imu = replace(imu, t=imu.t + shift)
    prep = prepare(imu, {"gnss": gnss}, System())
    t0, T = prep.initial.t, prep.system.filter.period_s
    k = epochs_at(np.ascontiguousarray(gnss.t), t0, T)
    late = (t0 + T * k - gnss.t)[k > 0]
    assert late.min() >= -1e-9
    assert late.max() < prep.dt


def test_solution_is_at_imu_rate_with_the_epochs_after_feedback(flight, result):
    imu, gnss, _ = flight
    f = result.forward
    n_per = 20  # 5 Hz GNSS, 100 Hz IMU
    assert len(f.t) == result.epochs * n_per + 1
    np.testing.assert_array_equal(f.epoch_rows, np.arange(0, len(f.t), n_per))
    np.testing.assert_allclose(np.diff(f.t), 0.01, atol=1e-9)
    # between epochs the sigmas grow from the corrected to the predicted covariance
    k = f.epoch_rows[100]
    assert np.all(np.diff(f.sigma[k:k + n_per, 6]) > 0)
    assert f.sigma[k + n_per, 6] < f.sigma[k + n_per - 1, 6]
    assert f.sigma_euler.shape == (len(f.t), 3) and np.all(f.sigma_euler > 0)


def test_accelerometer_bias_keeps_its_constant_part():
    """Turn-on bias + Gauss-Markov: one state, a random constant driven by the Markov
    process's random walk (a Markov state alone would forget the turn-on bias)."""
    from fednav.process.run import _noise

    errs = ImuErrors(*[np.full(3, v) for v in (1e-4, 1e-3, 1e-4, 0.02, 1e-5, 2e-3, 1e5,
                                               100.0)])
    imu = ImuData("x", np.arange(10) * 0.01, np.zeros((10, 3)), np.zeros((10, 3)), errs)
    n, gb, ab = _noise(imu, System(), 0.01)
    assert ab == pytest.approx(np.hypot(0.02, 2e-3))
    assert np.isinf(n.accel_markov_tau) and n.accel_bias_rw == pytest.approx(2e-3 * np.sqrt(0.02))


def test_velocity_sensor_axes_and_clock_corrections():
    from fednav.io.data import VelocityData
    from fednav.process.run import adjust_sensors

    t = np.arange(5.0)
    v = VelocityData("v", t, np.tile([1.0, 2.0, 3.0], (5, 1)),
                     np.tile(np.diag([1.0, 4.0, 9.0]), (5, 1, 1)), np.zeros(3))
    g = GnssData("g", t, np.tile([0.7, 0.1, 5.0], (5, 1)), np.zeros((5, 3)), np.ones(3),
                 np.ones(3), np.zeros(3))
    cfg = load_system({"sensors": {"velocity": {"axes": ["N", "-E", "U"], "time_offset_s": 7.5},
                                   "gnss": {"time_offset_s": -1.0}}})
    g2, v2 = adjust_sensors(g, v, cfg)
    np.testing.assert_allclose(v2.vel[0], [-2.0, 1.0, 3.0])  # E = -col 2, N = col 1
    np.testing.assert_allclose(np.diag(v2.cov[0]), [4.0, 1.0, 9.0])
    np.testing.assert_allclose(v2.t, t + 7.5)
    np.testing.assert_allclose(g2.t, t - 1.0)
    np.testing.assert_allclose(v.vel[0], [1.0, 2.0, 3.0])  # the input is left alone
    _, v3 = adjust_sensors(g, v, load_system({"sensors": {"velocity": {
        "sigma_mps": [0.1, 0.1, 0.2]}}}))
    np.testing.assert_allclose(np.diag(v3.cov[3]), [0.01, 0.01, 0.04])
    with pytest.raises(ValueError, match="must name E, N and U once each"):
        load_system({"sensors": {"velocity": {"axes": ["N", "N", "U"]}}})


@pytest.mark.slow
def test_cli_output_rate_defaults_to_10_hz_keeps_the_figures_and_refuses_a_rate_above_the_imu(
        tmp_path, flight):
    """Issue 29: the solution files come at 10 Hz unless asked (every IMU sample made a
    10-minute drive 25 MB); `imu` (or 0) gives every sample, `filter` the filter epochs;
    summary.json's figures come from the full-rate solution whatever the rate."""
    imu, gnss, ref = flight
    cols = {"t_s": imu.t[:3000]}
    for j, c in enumerate(IMU_COLUMNS[1:]):
        cols[c] = (imu.gyro if j < 3 else imu.accel)[:3000, j % 3]
    write_csv(tmp_path / "imu.csv", cols)
    write_csv(tmp_path / "gnss.csv", {
        "t_s": gnss.t, "lat_deg": units.to_deg(gnss.lla[:, 0]),
        "lon_deg": units.to_deg(gnss.lla[:, 1]), "h_m": gnss.lla[:, 2],
        "vE_mps": gnss.vel[:, 0], "vN_mps": gnss.vel[:, 1], "vU_mps": gnss.vel[:, 2]})
    write_csv(tmp_path / "ref.csv", {
        "t_s": ref.t, "lat_deg": units.to_deg(ref.lla[:, 0]),
        "lon_deg": units.to_deg(ref.lla[:, 1]), "h_m": ref.lla[:, 2],
        "vE_mps": ref.vel[:, 0], "vN_mps": ref.vel[:, 1], "vU_mps": ref.vel[:, 2]})
    e = imu.errors
    (tmp_path / "cfg.yaml").write_text(
        f"imu: {{gyro_arw_rad_sqrt_s: {e.gyro_arw[0]}, accel_vrw_mps_sqrt_s: "
        f"{e.accel_vrw[0]}, gyro_bias_radps: {e.gyro_bias[0]}, accel_bias_mps2: "
        f"{e.accel_bias[0]}, gyro_markov_radps: 1.0e-6, accel_markov_mps2: 1.0e-5, "
        f"gyro_tau_s: 1000, accel_tau_s: 1000}}\n")
    args = ["process", "csv", "--imu", str(tmp_path / "imu.csv"), "--gnss",
            str(tmp_path / "gnss.csv"), "--ref", str(tmp_path / "ref.csv"), "--config",
            str(tmp_path / "cfg.yaml"), "--out"]

    def run(name, *more):
        r = CliRunner().invoke(app, [*args, str(tmp_path / name), *more])
        assert r.exit_code == 0, r.output
        return (np.loadtxt(tmp_path / name / "solution.csv", delimiter=",", skiprows=1),
                json.loads((tmp_path / name / "summary.json").read_text()))

    full, s_full = run("full", "--output-rate", "imu")
    default, s_default = run("default")
    ten, _ = run("ten", "--output-rate", "10")
    zero, _ = run("zero", "--output-rate", "0")
    epochs, _ = run("epochs", "--output-rate", "filter")
    np.testing.assert_allclose(np.diff(full[:, 0]), 0.01, atol=1e-6)
    np.testing.assert_allclose(default, full[::10], rtol=1e-9)
    np.testing.assert_allclose(ten, default, rtol=1e-9)
    np.testing.assert_allclose(zero, full, rtol=1e-9)
    np.testing.assert_allclose(np.diff(epochs[:, 0]), 0.2, atol=1e-6)  # (GNSS at 5 Hz)
    assert set(epochs[:, 0].round(6)) <= set(full[:, 0].round(6))
    assert s_default["rmse"] == s_full["rmse"]
    assert s_default["consistency"] == s_full["consistency"]
    assert s_default["inputs"]["output_rate_hz"] == 10.0
    assert s_full["inputs"]["output_rate_hz"] == "imu"
    # errors.csv thinned alike (the reference here has every IMU sample)
    err_full = np.loadtxt(tmp_path / "full" / "errors.csv", delimiter=",", skiprows=1)
    err = np.loadtxt(tmp_path / "default" / "errors.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(err, err_full[::10], rtol=1e-9)
    assert (tmp_path / "ten" / "track.png").is_file()
    # the config's output_rate_hz may say 'imu' or 'filter' too (the option wins)
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(cfg.read_text() + "output_rate_hz: imu\n")
    by_config, s_config = run("by-config")
    np.testing.assert_allclose(by_config, full, rtol=1e-9)
    assert s_config["inputs"]["output_rate_hz"] == "imu"
    np.testing.assert_allclose(run("option-wins", "--output-rate", "10")[0], default, rtol=1e-9)
    r = CliRunner().invoke(app, [*args, str(tmp_path / "bad"), "--output-rate", "500"])
    assert r.exit_code == 2
    assert "--output-rate 500 Hz: must be positive and at most the IMU rate (100 Hz)" in r.output
    r = CliRunner().invoke(app, [*args, str(tmp_path / "bad"), "--output-rate", "fast"])
    assert r.exit_code == 2 and "error: --output-rate fast: a rate in Hz, 'imu'" in r.output


def test_output_rate_and_format_parsing():
    from fednav.process.output import check_format, parse_rate

    assert parse_rate(None) is None and parse_rate("IMU") == "imu" and parse_rate(0) == "imu"
    assert parse_rate("0") == "imu" and parse_rate("filter") == "filter"
    assert parse_rate("25") == 25.0 and parse_rate(2.5) == 2.5
    for bad in ("-1", "nan", "ten"):
        with pytest.raises(ValueError, match="--output-rate"):
            parse_rate(bad)
    assert check_format(None) == "csv" and check_format("CSV") == "csv"
    with pytest.raises(ValueError, match="--format xlsx: must be csv or parquet"):
        check_format("xlsx")


def test_parquet_solution_needs_its_extra_and_holds_the_csv_columns(tmp_path, result,
                                                                     monkeypatch):
    import builtins

    from fednav.process import output

    sol = output.decimate(result.forward, 10.0)
    csv = output.write_solution(tmp_path / "solution.csv", sol)
    real_import = builtins.__import__

    def no_pyarrow(name, *a, **k):
        if name == "pyarrow" or name.startswith("pyarrow."):
            raise ImportError(name)
        return real_import(name, *a, **k)

    with monkeypatch.context() as m:
        m.setattr(builtins, "__import__", no_pyarrow)
        with pytest.raises(ValueError) as e:
            output.check_format("parquet")
    assert str(e.value) == "--format parquet needs pyarrow: pip install 'fednav[parquet]'"
    pytest.importorskip("pyarrow")
    import pandas as pd

    pq = output.write_solution(tmp_path / "solution.parquet", sol)
    a, b = pd.read_parquet(pq), pd.read_csv(csv)
    assert list(a.columns) == list(b.columns) and len(a) == len(b)
    np.testing.assert_allclose(a.to_numpy(), b.to_numpy(), rtol=0, atol=1e-4)  # (CSV decimals)
    # (unrounded: the float64 values themselves)
    np.testing.assert_array_equal(a["lat_deg"], units.to_deg(sol.lla[:, 0]))
    np.testing.assert_array_equal(a["sigma_N_m"], sol.sigma[:, 7])


def test_an_output_folder_that_would_overwrite_an_input_is_refused(tmp_path, flight):
    """Issue 27: `--ref D/solution.csv --out D` replaced the user's reference with
    fednav's solution, exit 0; `tune --out` naming its own base config likewise."""
    imu, gnss, ref = flight
    write_csv(tmp_path / "imu.csv", {"t_s": imu.t, **{c: imu.gyro[:, i] for i, c in
                                                      enumerate(IMU_COLUMNS[1:4])},
                                     **{c: imu.accel[:, i] for i, c in
                                        enumerate(IMU_COLUMNS[4:7])}})
    deg = units.to_deg
    write_csv(tmp_path / "gnss.csv", {"t_s": gnss.t, "lat_deg": deg(gnss.lla[:, 0]),
                                      "lon_deg": deg(gnss.lla[:, 1]), "h_m": gnss.lla[:, 2],
                                      "vE_mps": gnss.vel[:, 0], "vN_mps": gnss.vel[:, 1],
                                      "vU_mps": gnss.vel[:, 2]})
    mine = tmp_path / "solution.csv"
    mine.write_text("t_s,lat_deg,lon_deg,h_m\n0,45,-75,50\n")
    before = mine.read_bytes()
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(tmp_path / "imu.csv"),
                                 "--gnss", str(tmp_path / "gnss.csv"), "--ref", str(mine),
                                 "--out", str(tmp_path)])
    assert r.exit_code == 2 and "would overwrite the reference file" in r.output
    assert mine.read_bytes() == before
    base = tmp_path / "base.yaml"
    base.write_text("sensors: {gnss: {lever_m: [0.6, -1.2, 0.4]}}\n")
    r = CliRunner().invoke(app, ["tune", "csv", "--imu", str(tmp_path / "imu.csv"),
                                 "--gnss", str(tmp_path / "gnss.csv"), "--config", str(base),
                                 "--out", str(base)])
    assert r.exit_code == 2 and "is one of the inputs" in r.output
    assert "lever_m: [0.6" in base.read_text()


def test_misleading_messages_are_gone(tmp_path, flight, result):
    """Issue 27: a tab-separated file names its separator; a filter period longer than the
    data says so; a reference with longitudes in -180..180 against a solution in 0..360
    (or a track across the antimeridian) is compared across the wrap."""
    from dataclasses import replace

    from fednav.io.csvdata import read_imu_csv
    from fednav.io.data import DataError

    f = tmp_path / "imu.csv"
    f.write_text("t_s\tgyro_x_radps\n0\t1\n")
    with pytest.raises(DataError, match="separated by tabs"):
        read_imu_csv(f)
    imu, gnss, ref = flight
    with pytest.raises(DataError, match=r"filter.period_s = 1e\+300 s is longer than the IMU"):
        process(imu, {"gnss": gnss}, load_system({"filter": {"period_s": 1e300}}))
    shifted = replace(ref, lla=ref.lla + np.array([0.0, 2 * np.pi, 0.0]), quality={})
    e0 = rmse(errors_against(result.forward, ref))
    e1 = rmse(errors_against(result.forward, shifted))
    assert e1["east_m"] == pytest.approx(e0["east_m"], rel=1e-6)


def test_a_long_isolation_is_said(flight):
    """Issue 27: a receiver that comes back from an outage 200 m off and stays there is
    isolated by fault detection to the end — the solution drifts on the IMU alone — and
    that ended with exit 0 and no word. Now a warning names the filter and the span."""
    from dataclasses import replace

    from fednav.core import earth

    imu, gnss, _ = flight
    off = gnss.t > 100.0
    lla = gnss.lla.copy()
    lla[off] = earth.move_enu(lla[off], np.array([200.0, 0.0, 0.0]))
    bad = replace(gnss, lla=lla, quality={})
    res = process(imu, {"gnss": bad}, load_system({"filter": {"fdi_alpha": 0.001}}))
    said = [w for w in res.warnings if "fault detection isolated the 'gnss'" in w]
    assert len(said) == 1 and "from 100." in said[0], res.warnings
    clean = process(imu, {"gnss": gnss}, load_system({"filter": {"fdi_alpha": 0.001}}))
    assert not any("fault detection isolated" in w for w in clean.warnings)


def test_innovations_far_beyond_their_sigma_end_the_run_unless_forced(flight):
    """Issue 27: GNSS velocity written N, E, U under E, N, U headers ran to exit 0 with a
    run NIS/dof in the hundreds and no word. Beyond 100 the run ends with one line naming
    the likely causes; --force (force=True) writes it with a warning; a clean run says
    nothing."""
    from dataclasses import replace

    from fednav.io.data import DataError

    imu, gnss, _ = flight
    swapped = replace(gnss, vel=gnss.vel[:, [1, 0, 2]], quality={})
    with pytest.raises(DataError, match=r"'gnss' local filter's innovations are .* times "
                                        r"their expected size.*axis order"):
        process(imu, {"gnss": swapped}, System())
    res = process(imu, {"gnss": swapped}, System(), force=True)
    assert any("innovations are" in w and "too optimistic" in w for w in res.warnings)
    clean = process(imu, {"gnss": gnss}, System())
    assert not any("innovations are" in w for w in clean.warnings)


def test_the_navigators_result_reports_its_health(flight):
    """The checks `process` runs live in the navigator: NavResult.health() gives the same
    warnings to streaming and batch users (never a refusal)."""
    from dataclasses import replace

    from fednav.process.run import prepare

    imu, gnss, _ = flight
    swapped = replace(gnss, vel=gnss.vel[:, [1, 0, 2]], quality={})
    prep = prepare(imu, {"gnss": swapped}, System())
    nav = prep.feed(prep.navigator(record_rows=False, record_covariance=False,
                                   innovations=False))
    said = nav.result().health()
    assert any("'gnss' local filter's innovations are" in w for w in said)
    prep = prepare(imu, {"gnss": gnss}, System())
    clean = prep.feed(prep.navigator(record_rows=False, record_covariance=False,
                                     innovations=False))
    assert clean.result().health() == []
