"""One route for a measurement: every sensor's recording is a series (``Series``), given to
``prepare``/``process``/``tune`` in one mapping by registered name — the GNSS and the
velocity sensor as ordinary entries — and its noise becomes R in one place (the
navigator's ``residual_covariances``)."""

from dataclasses import replace

import numpy as np
import pytest
from test_process import make_flight

from fednav import System, load_system
from fednav.io import read_gnss_csv, read_sensor_csv, write_sensor_csv
from fednav.io.data import DataError, GnssData, SensorData, Series, VelocityData
from fednav.navigator.navigator import residual_covariances
from fednav.process import prepare, process
from fednav.sensors.base import MeasurementSeries


@pytest.fixture(scope="module")
def flight():
    return make_flight()


def _short(flight, seconds=60.0):
    imu, gnss, ref = flight
    n = int(seconds / imu.period())
    cut = replace(imu, t=imu.t[:n], gyro=imu.gyro[:n], accel=imu.accel[:n], quality={})
    keep = gnss.t < imu.t[n - 1]
    g = replace(gnss, t=gnss.t[keep], lla=gnss.lla[keep], vel=gnss.vel[keep], quality={})
    return cut, g, ref


def _velocity(gnss, seed=0):
    """An ENU velocity sensor (the GNSS velocity with 5 cm/s noise, correlated E-N)."""
    rng = np.random.default_rng(seed)
    c = np.array([[0.05**2, 0.0015, 0.0], [0.0015, 0.05**2, 0.0], [0.0, 0.0, 0.08**2]])
    v = gnss.vel + rng.multivariate_normal(np.zeros(3), c, len(gnss.t))
    return VelocityData("vel", gnss.t, v, np.broadcast_to(c, (len(gnss.t), 3, 3)).copy(),
                        np.zeros(3))


def test_every_reader_gives_a_series(flight):
    imu, gnss, _ = flight
    vel = _velocity(gnss)
    for d in (gnss, vel, SensorData("baro", "b", gnss.t, gnss.lla[:, 2:])):
        assert isinstance(d, Series)
    assert gnss.name == "gnss" and gnss.z.shape == (len(gnss.t), 6) and gnss.absent == ()
    pos = replace(gnss, vel=None, quality={})
    assert pos.absent == (3, 4, 5) and np.isnan(pos.z[:, 3:]).all()
    assert vel.name == "velocity" and vel.z is vel.vel and vel.cov.shape == (len(vel.t), 3, 3)


def test_gnss_read_as_any_sensor_flies_as_the_gnss_reader(flight, tmp_path):
    """The GNSS file read by the generic reader (``read_sensor_csv("gnss", ...)``) and by
    its own reader: the same navigation."""
    imu, gnss, _ = _short(flight)
    sig = np.r_[gnss.sigma_pos_enu[[1, 0, 2]], gnss.sigma_vel]
    path = write_sensor_csv(tmp_path / "gnss.csv", MeasurementSeries(
        "gnss", gnss.t, gnss.z, sig), sigma=True)
    generic = read_sensor_csv("gnss", path)
    own = read_gnss_csv(path, lever=gnss.lever)
    cfg = load_system({"sensors": {"gnss": {"lever_m": list(map(float, gnss.lever))}}})
    a = process(imu, {"gnss": generic}, cfg).forward
    b = process(imu, {"gnss": own}, cfg).forward
    np.testing.assert_array_equal(a.lla, b.lla)
    np.testing.assert_array_equal(a.euler, b.euler)


def test_velocity_sensor_as_a_plain_series_with_its_covariance(flight):
    imu, gnss, _ = _short(flight)
    vel = _velocity(gnss)
    plain = SensorData("velocity", "vel", vel.t, vel.vel, cov=vel.cov)
    a = process(imu, {"gnss": gnss, "velocity": vel}, System()).forward
    b = process(imu, {"gnss": gnss, "velocity": plain}, System()).forward
    np.testing.assert_array_equal(a.lla, b.lla)
    # a series without its noise: one line
    with pytest.raises(DataError, match="velocity data without each row's 1-sigma"):
        process(imu, {"gnss": gnss, "velocity": SensorData("velocity", "v", vel.t,
                                                             vel.vel)}, System())


def test_the_old_layout_is_read_with_a_warning(flight):
    imu, gnss, _ = _short(flight, 30.0)
    new = process(imu, {"gnss": gnss}, System()).forward
    with pytest.warns(FutureWarning, match=r"process\(imu, \{'gnss': gnss"):
        old = process(imu, gnss, None, System()).forward
    np.testing.assert_array_equal(new.lla, old.lla)
    with pytest.warns(FutureWarning, match=r"prepare\(imu, gnss, velocity"):
        prepare(imu, gnss=gnss, cfg=System())


def test_a_bad_mapping_is_one_line(flight):
    imu, gnss, _ = _short(flight, 30.0)
    with pytest.raises(DataError, match=r"unknown sensor 'gps'; registered: .*gnss"):
        process(imu, {"gps": gnss}, System())
    with pytest.raises(DataError, match=r"gnss data given as sensor 'baro'"):
        process(imu, {"gnss": gnss, "baro": gnss}, System())
    with pytest.raises(DataError, match=r"sensors\['gnss'\]: a ndarray, not a sensor's "
                                        r"series"):
        process(imu, {"gnss": gnss.lla}, System())
    # a sensor given None is left out
    a = process(imu, {"gnss": gnss, "velocity": None}, System()).forward
    b = process(imu, {"gnss": gnss}, System()).forward
    np.testing.assert_array_equal(a.lla, b.lla)


def test_noise_becomes_R_in_one_place(flight):
    """``Prepared.series`` holds each row's 1-sigma or covariance, not R; ``rows`` gives
    the R the navigator builds of it (one for all rows when they are the same)."""
    imu, gnss, _ = _short(flight, 30.0)
    vel = _velocity(gnss)
    rows = np.column_stack([np.full((len(gnss.t), 3), 2.0), np.full((len(gnss.t), 3), 0.2)])
    rows[::3] *= 1.5
    mixed = replace(gnss, sigma_rows=rows, quality={})
    prep = prepare(imu, {"gnss": mixed, "velocity": vel}, System())
    assert set(prep.series) == {"gnss", "velocity"}
    t, z, R = prep.rows("gnss")
    model = prep.system.sensors.gnss.measurement_model()
    np.testing.assert_array_equal(R[1], model.R(rows[1]))
    np.testing.assert_array_equal(R[0], model.R(rows[0]))
    assert not np.array_equal(R[0], R[1])
    _, _, Rv = prep.rows("velocity")
    np.testing.assert_allclose(Rv[0], vel.cov[0])  # (no Gauss-Markov part: R is cov)
    same = residual_covariances(model, np.broadcast_to(rows[1], (5, 6)))
    assert same.strides[0] == 0  # one R broadcast
    # fed with R per call, the stream equals the batch's series fed with their noise
    batch = prep.feed(prep.navigator()).result()
    nav = prep.navigator()
    for name in prep.series:
        tn, zn, Rn = prep.rows(name)
        nav.add_measurements(name, tn, zn, R=Rn)
    nav.add_imu(prep.t, prep.gyro, prep.accel)
    np.testing.assert_array_equal(nav.result().states, batch.states)



def test_a_section_takes_what_it_leaves_to_the_recording(flight):
    """``SensorConfig.for_recording``: one method per sensor, the same path for all."""
    from fednav.sensors import GnssConfig, VelocityConfig, registry

    _, gnss, _ = flight
    g = GnssConfig(sigma_vel_mps=0.3).for_recording(gnss)
    assert g.sigma_pos_enu_m == tuple(gnss.sigma_pos_enu) and g.sigma_vel_mps == (0.3,) * 3
    assert g.lever_m == tuple(gnss.lever) and g.measures == "position_velocity"
    assert g.period_s is None  # (the filter's epochs follow the fixes)
    baro = SensorData("baro", "b", gnss.t[::5], gnss.lla[::5, 2:])
    assert registry.spec("baro").config(sigma_m=1.0).for_recording(baro).period_s == \
        pytest.approx(1.0)
    pos = replace(gnss, vel=None, quality={})
    assert GnssConfig().for_recording(pos).measures == "position"
    with pytest.raises(DataError, match="sensors.gnss.measures is velocity, the file has "
                                        "position only"):
        GnssConfig(measures="velocity").for_recording(pos)
    vel = _velocity(gnss)
    vel.lever = np.array([0.1, 0.2, 0.3])
    assert VelocityConfig().for_recording(vel).lever_m == (0.1, 0.2, 0.3)
    assert VelocityConfig(lever_m=(0, 0, 1)).for_recording(vel).lever_m == (0, 0, 1)
    baro = registry.spec("baro").config(sigma_m=1.0)
    air = registry.spec("airdata").config(sigma_airspeed_mps=0.5)
    assert baro.roles(System()) == {"damping": "sensors.baro.damping_loop"}
    assert baro.model_copy(update={"damping_loop": False}).roles(System()) == {}
    assert air.roles(System()) == {}
    assert air.roles(System.model_construct(constraint="wind")) == {
        "constraint": "constraint: wind"}


def test_simulated_and_recorded_series_take_one_route(flight):
    """A simulated sensor's series is a Series too, and the navigator's add_series takes
    either: the same data as a recorded file and as the simulator's give the same run."""
    from fednav.sensors.base import MeasurementSeries

    imu, gnss, _ = _short(flight, 30.0)
    prep = prepare(imu, {"gnss": gnss}, System())
    d = prep.series["gnss"]
    sim = MeasurementSeries("gnss", d.t, d.z, prep.system.sensors.gnss.sigma())
    assert isinstance(sim, Series) and sim.name == "gnss" and sim.t_arrival is sim.t_avail
    a = prep.feed(prep.navigator()).result()
    nav = prep.navigator()
    nav.add_series(sim)
    nav.add_imu(prep.t, prep.gyro, prep.accel)
    np.testing.assert_array_equal(nav.result().states, a.states)


def test_process_csv_reads_an_rtklib_solution_as_the_gnss_file(flight, tmp_path):
    """``fednav process csv --gnss FILE.pos``: the RTKLIB solution of the same fixes (its
    own layout: date and time on the GPS clock, degrees, N/E/U sigmas, vn/ve/vu) gives the
    run the fednav CSV gives."""
    import json
    import time as _time

    from typer.testing import CliRunner

    from fednav.cli import app
    from fednav.core import units
    from fednav.io.csvdata import write_csv

    imu, gnss, _ = _short(flight, 60.0)
    write_csv(tmp_path / "imu.csv", {"t_s": imu.t, **{
        f"{k}_{a}_{u}": v[:, i] for k, v, u in (("gyro", imu.gyro, "radps"),
                                                ("accel", imu.accel, "mps2"))
        for i, a in enumerate("xyz")}}, significant=17)
    lat, lon = units.to_deg(gnss.lla[:, 0]), units.to_deg(gnss.lla[:, 1])
    write_csv(tmp_path / "gnss.csv", {"t_s": gnss.t, "lat_deg": lat, "lon_deg": lon,
                                      "h_m": gnss.lla[:, 2], "vE_mps": gnss.vel[:, 0],
                                      "vN_mps": gnss.vel[:, 1], "vU_mps": gnss.vel[:, 2]},
              significant=17)
    lines = ["%  GPST  latitude(deg) longitude(deg) height(m) Q ns sdn(m) sde(m) sdu(m) "
             "sdne(m) sdeu(m) sdun(m) age(s) ratio vn(m/s) ve(m/s) vu(m/s) sdvn sdve sdvu "
             "sdvne sdveu sdvun"]
    for i, t in enumerate(gnss.t):  # (times since 1970-01-01: the IMU file's 0)
        day = _time.strftime("%Y/%m/%d %H:%M:", _time.gmtime(int(t // 60) * 60))
        lines.append(f"{day}{t % 60:06.3f} {lat[i]:.12f} {lon[i]:.12f} {gnss.lla[i, 2]:.6f} "
                     f"1 12 0 0 0 0 0 0 0 0 {gnss.vel[i, 1]:.9f} {gnss.vel[i, 0]:.9f} "
                     f"{gnss.vel[i, 2]:.9f} 0 0 0 0 0 0")
    (tmp_path / "gnss.pos").write_text("\n".join(lines) + "\n")
    (tmp_path / "cfg.yaml").write_text(
        "imu: {grade: tactical}\nsensors: {gnss: {sigma_pos_enu_m: 1, sigma_vel_mps: 0.05, "
        f"lever_m: {list(map(float, gnss.lever))}}}}}\n")
    out = {}
    for name in ("gnss.csv", "gnss.pos"):
        r = CliRunner().invoke(app, ["process", "csv", "--imu", str(tmp_path / "imu.csv"),
                                     "--gnss", str(tmp_path / name), "--config",
                                     str(tmp_path / "cfg.yaml"), "--out",
                                     str(tmp_path / name.replace(".", "_"))])
        assert r.exit_code == 0, r.output
        out[name] = json.loads((tmp_path / name.replace(".", "_") / "summary.json")
                               .read_text())
    a, b = out["gnss.csv"]["consistency"]["gnss"], out["gnss.pos"]["consistency"]["gnss"]
    assert a["measurements"] == b["measurements"] >= len(gnss.t) - 1
    assert b["nis_per_dof"] == pytest.approx(a["nis_per_dof"], rel=1e-3)
    assert out["gnss.pos"]["data_quality"]["gnss_rtklib_q"] == {"fixed": len(gnss.t)}


def test_edges_of_the_route(flight):
    """A file's three figures are not rows (a 3-fix GNSS through an outage), a simulated
    series flies as any other (GNSS, velocity, baro through an outage), a sensor whose
    every measurement an outage withholds is said and left out, an old call with
    placeholders is read, a sensor given twice is refused."""
    from fednav.process.outages import withhold
    from fednav.sensors.base import MeasurementSeries

    imu, gnss, _ = _short(flight, 40.0)
    three = GnssData("g", np.array([0.0, 1.0, 2.0]), gnss.lla[:3], gnss.vel[:3],
                     np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 0.3]),
                     np.array([0.5, 0.0, 1.0]))
    w = withhold(three, [(0.5, 1.5)])
    assert len(w.t) == 2 and list(w.sigma_pos_enu) == [1.0, 2.0, 3.0]
    assert list(w.lever) == [0.5, 0.0, 1.0]
    cfg = load_system({"sensors": {"gnss": {"lever_m": list(map(float, gnss.lever))},
                                   "baro": {"sigma_m": 1.0, "damping_loop": False,
                                            "outages_s": [[10.0, 20.0]]}}})
    sig = np.r_[gnss.sigma_pos_enu[[1, 0, 2]], gnss.sigma_vel]
    sims = {"gnss": MeasurementSeries("gnss", gnss.t, gnss.z, sig),
            "velocity": MeasurementSeries("velocity", gnss.t, gnss.vel, np.full(3, 0.05)),
            "baro": MeasurementSeries("baro", gnss.t, gnss.lla[:, 2:], np.array([1.0]))}
    a = process(imu, sims, cfg)
    b = process(imu, {"gnss": SensorData("gnss", "g", gnss.t, gnss.z,
                                         sigma=np.tile(sig, (len(gnss.t), 1))),
                      "velocity": SensorData("velocity", "v", gnss.t, gnss.vel,
                                             sigma=np.full((len(gnss.t), 3), 0.05)),
        "baro": SensorData("baro", "b", gnss.t, gnss.lla[:, 2:])}, cfg)
    np.testing.assert_array_equal(a.forward.lla, b.forward.lla)
    gone = load_system({"sensors": {"baro": {"sigma_m": 1.0, "damping_loop": False,
                                             "outages_s": [[0.0, 100.0]]}}})
    res = process(imu, {"gnss": gnss, "baro": sims["baro"]}, gone)
    assert any("every baro measurement lies inside sensors.baro.outages_s" in w
               for w in res.warnings)
    with pytest.warns(FutureWarning):
        with pytest.raises(DataError, match="no GNSS positions to start from"):
            process(imu, None, None, cfg=System())  # (the old layout's placeholders)
    with pytest.warns(FutureWarning), pytest.raises(DataError, match="gnss data given twice"):
        process(imu, gnss, None, System(), sensors={"gnss": gnss})


def test_prepareds_old_names_are_read_for_a_release(flight):
    imu, gnss, _ = _short(flight, 30.0)
    prep = prepare(imu, {"gnss": gnss, "baro": SensorData("baro", "b", gnss.t,
                                                         gnss.lla[:, 2:])},
                   load_system({"sensors": {"baro": {"sigma_m": 1.0}}}))
    with pytest.warns(FutureWarning, match=r"Prepared.measurements is now Prepared.series"):
        t, z, R = prep.measurements["gnss"]
    np.testing.assert_array_equal(R, prep.rows("gnss")[2])
    with pytest.warns(FutureWarning, match="Prepared.others"):
        assert set(prep.others) == {"baro"}
    with pytest.warns(FutureWarning, match="Prepared.arrivals"):
        assert prep.arrivals == {}
