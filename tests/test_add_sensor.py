"""docs/architecture.md's worked example, followed: a toy sensor (the radar altimeter of
the page, its code taken from the page itself) is registered and runs end to end — in a
paper's simulation, in both engines, and from its CSV file through ``process``; the
registries drive the validation and the docs table."""

import re
import types
from pathlib import Path

import numpy as np
import pytest

from fednav import System, load_system
from fednav.core.config import ConfigError
from fednav.io import read_sensor_csv, write_sensor_csv
from fednav.process import errors_against, process, rmse
from fednav.sensors import registry

DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"


def _doc_block(marker: str) -> str:
    m = re.search(rf"<!-- {marker} -->\s*```python\n(.*?)```", DOC.read_text(), re.S)
    assert m, f"docs/architecture.md lost its '{marker}' block"
    return m.group(1)


@pytest.fixture
def radalt():
    """The page's sensor module, registered for the test."""
    mod = types.ModuleType("radalt_example")
    exec(compile(_doc_block("add-a-sensor"), str(DOC), "exec"), mod.__dict__)
    registry.register(mod.SPEC)
    yield mod
    registry.unregister("radalt")


def test_the_docs_table_is_the_registry():
    text = DOC.read_text()
    table = text.split("<!-- sensor-table -->\n")[1].split("\n<!-- /sensor-table -->")[0]
    assert table == registry.markdown_table()


def test_unknown_names_are_one_line_errors_naming_the_registered_ones():
    with pytest.raises(ConfigError) as e:
        load_system({"sensors": {"lidar": {"sigma_m": 1.0}}})
    msg = str(e.value)
    assert "\n" not in msg and "lidar" in msg
    assert all(n in msg for n in registry.names())
    with pytest.raises(ConfigError) as e:
        load_system({"filter": {"type": "kalmanish"}})
    msg = str(e.value)
    assert "\n" not in msg and "kalmanish" in msg and "sghqf" in msg and "raukf" in msg
    with pytest.raises(ConfigError, match="unknown aiding sensor 'radalt'"):
        load_system({"aiding": ["radalt"]})


def test_a_registered_sensor_is_accepted_everywhere(radalt):
    s = load_system({"sensors": {"radalt": {"sigma_m": 0.5, "sigma_mps": 0.05}},
                     "aiding": ["radalt"], "filter": {"locals": {"radalt": {"type": "ukf"}}}})
    assert isinstance(s.sensors.radalt, radalt.RadarAltimeterConfig)
    assert s.aiding_sensors() == ["radalt"]
    assert "`radalt`" in registry.markdown_table()
    with pytest.raises(ConfigError, match="sigma_mps"):
        load_system({"sensors": {"radalt": {"sigma_m": 0.5}}})


def test_the_toy_sensor_flies_in_a_simulation_in_both_engines(radalt, monkeypatch):
    from fednav.scenarios import paper002
    from fednav.sim.runs import make_run_data, run_mode

    scn = paper002.load_scenario()
    scn = scn.model_copy(update={"sensors": scn.sensors.replace(
        baro=scn.sensors.baro.model_copy(update={"damping_loop": False}),
        radalt=radalt.RadarAltimeterConfig(sigma_m=0.5, sigma_mps=0.05, period_s=1.0))})
    data = make_run_data(scn, 3, 200.0)
    assert data.series["radalt"].z.shape == (200, 2)
    out = {}
    for engine in ("compiled", "python"):
        monkeypatch.setenv("FEDNAV_ENGINE", engine)
        out[engine] = run_mode(scn, ["star", "radalt"], data, "SINS/CNS/RA", 200.0)
    without = run_mode(scn, ["star"], data, "SINS/CNS", 200.0)
    a, b = out["compiled"], out["python"]
    np.testing.assert_allclose(a.pos, b.pos, rtol=1e-9, atol=1e-9)
    assert {"star", "radalt", "master"} == set(a.beta)  # compiled: FEDNAV_ENGINE held
    up_with = np.sqrt(np.mean(a.pos[:, 2] ** 2))
    up_without = np.sqrt(np.mean(without.pos[:, 2] ** 2))
    assert up_with < 1.0 < up_without  # the altimeter holds the vertical channel
    nis = a.fdi[a.fdi.local == "radalt"]
    assert 0.5 < float((nis.statistic / nis.dof).mean()) < 2.0


def test_the_toy_sensor_runs_from_its_file(radalt, tmp_path):
    from test_process import make_flight

    imu, gnss, ref = make_flight()

    def at(t):  # the reference's height and climb rate (the simulator reads no more)
        idx = np.rint((t - ref.t[0]) / (ref.t[1] - ref.t[0])).astype(int)
        return {"lla": ref.lla[idx], "vel": ref.vel[idx]}

    truth = types.SimpleNamespace(t=ref.t, at=at)
    series = radalt.RadarAltimeter(0.05, 0.02, 0.5).simulate(truth, np.random.default_rng(5))
    path = write_sensor_csv(tmp_path / "radalt.csv", series)
    assert path.read_text().splitlines()[0] == "t_s,h_m,vU_mps"
    data = read_sensor_csv("radalt", path)
    np.testing.assert_allclose(data.z, series.z, rtol=1e-15)
    cfg = load_system({"sensors": {"radalt": {"sigma_m": 0.05, "sigma_mps": 0.02}}})
    base = process(imu, {"gnss": gnss}, System())
    res = process(imu, {"gnss": gnss, "radalt": data}, cfg)
    from fednav.navigator.solution import consistency

    c = consistency(res.forward.fdi)
    assert set(c) == {"gnss", "radalt"} and 0.5 < c["radalt"]["nis_per_dof"] < 2.0
    r0, r1 = rmse(errors_against(base.forward, ref)), rmse(errors_against(res.forward, ref))
    assert r1["up_m"] < 0.5 * r0["up_m"]
    assert r1["vu_mps"] < r0["vu_mps"]


def test_the_cli_has_a_file_option_per_registered_sensor(tmp_path):
    import json

    from test_process import LEVER
    from typer.testing import CliRunner

    from fednav.cli import app
    from fednav.core import units
    from fednav.io.csvdata import IMU_COLUMNS, write_csv
    from fednav.sensors.base import MeasurementSeries

    r = CliRunner().invoke(app, ["process", "csv", "--help"], env={"COLUMNS": "200"})
    for name in registry.names():
        if name not in ("gnss",):
            assert f"--{name}" in r.output, name
    imu, gnss, ref = make_flight_cached()
    cols = {"t_s": imu.t}
    for j, c in enumerate(IMU_COLUMNS[1:]):
        cols[c] = (imu.gyro if j < 3 else imu.accel)[:, j % 3]
    write_csv(tmp_path / "imu.csv", cols)
    write_csv(tmp_path / "gnss.csv", {
        "t_s": gnss.t, "lat_deg": units.to_deg(gnss.lla[:, 0]),
        "lon_deg": units.to_deg(gnss.lla[:, 1]), "h_m": gnss.lla[:, 2],
        "vE_mps": gnss.vel[:, 0], "vN_mps": gnss.vel[:, 1], "vU_mps": gnss.vel[:, 2]})
    tb = ref.t[100::100]
    h = np.interp(tb, ref.t, ref.lla[:, 2]) + np.random.default_rng(1).normal(0, 0.3, len(tb))
    write_sensor_csv(tmp_path / "baro.csv", MeasurementSeries("baro", tb, h[:, None], [0.3]))
    e = imu.errors
    (tmp_path / "cfg.yaml").write_text(
        f"imu: {{gyro_arw_rad_sqrt_s: {e.gyro_arw[0]}, accel_vrw_mps_sqrt_s: "
        f"{e.accel_vrw[0]}, gyro_bias_radps: {e.gyro_bias[0]}, accel_bias_mps2: "
        f"{e.accel_bias[0]}, gyro_markov_radps: 1.0e-6, accel_markov_mps2: 1.0e-5, "
        f"gyro_tau_s: 1000, accel_tau_s: 1000}}\n"
        f"sensors: {{gnss: {{sigma_pos_enu_m: 1, sigma_vel_mps: 0.05, lever_m: "
        f"[{LEVER[0]}, {LEVER[1]}, {LEVER[2]}]}}, baro: {{sigma_m: 0.3, "
        f"damping_loop: false}}}}\n")
    out = tmp_path / "out"
    args = ["process", "csv", "--imu", str(tmp_path / "imu.csv"), "--gnss",
            str(tmp_path / "gnss.csv"), "--baro", str(tmp_path / "baro.csv"), "--out",
            str(out)]
    r = CliRunner().invoke(app, [*args, "--config", str(tmp_path / "cfg.yaml")])
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())
    assert set(s["consistency"]) == {"gnss", "baro"}
    assert s["inputs"]["baro"].endswith("baro.csv")
    # without its section the sensor's noise is unknown: one line naming the key
    (tmp_path / "bare.yaml").write_text((tmp_path / "cfg.yaml").read_text().replace(
        ", baro: {sigma_m: 0.3, damping_loop: false}", ""))
    r = CliRunner().invoke(app, [*args, "--config", str(tmp_path / "bare.yaml")])
    assert r.exit_code == 2 and "sensors.baro" in r.output and "Traceback" not in r.output


_FLIGHT = {}


def make_flight_cached():
    from test_process import make_flight

    if not _FLIGHT:
        _FLIGHT["f"] = make_flight()
    return _FLIGHT["f"]


def test_bad_sensor_files_are_one_line_errors_naming_the_file_and_row(tmp_path):
    from fednav.io import DataError

    p = tmp_path / "baro.csv"
    p.write_text("t_s,h_m,t_arrival_s\n1,100,1.1\n2,101,x\n")
    with pytest.raises(DataError, match=r"baro.csv: column 't_arrival_s' has a non-numeric"):
        read_sensor_csv("baro", p)
    p.write_text("t_s,h_m\n1,100\n2,nan\n3,101\n2.5,102\n")
    with pytest.raises(DataError, match=r"baro.csv: column 't_s' is not increasing at data "
                                       r"row 4 "):
        read_sensor_csv("baro", p)
    p.write_text("t_s,h_m,t_arrival_s\n1,100,1.1\n2,101,1.5\n")
    with pytest.raises(DataError, match="data row 2 arrives at 1.500000 s, before"):
        read_sensor_csv("baro", p)
    p.write_text("t_s,h_m\n1,100\n2,nan\n3,101\n")
    d = read_sensor_csv("baro", p)
    assert d.quality["baro_rows_dropped"] == 1 and len(d.t) == 2


def test_process_refuses_or_warns_about_what_it_cannot_use():
    from fednav.io import DataError, SensorData
    from fednav.process.run import prepare

    imu, gnss, _ = make_flight_cached()
    with pytest.raises(DataError, match="filter.state: total — the total-state navigator's "
                                        "solution is at its filter epochs"):
        prepare(imu, {"gnss": gnss}, load_system({"filter": {"state": "total"}, "smoother": True}))
    air = SensorData("airdata", "air.csv", np.arange(1.0, 50.0), np.ones((49, 3)))
    cfg = load_system({"sensors": {"airdata": {"sigma_airspeed_mps": 0.1,
                                               "wind_sigma_mps": 0.1}}})
    prep = prepare(imu, {"gnss": gnss, "airdata": air}, cfg)
    assert any("air.csv: not used (air data: true airspeed and the wind estimate (the wind "
               "constraint; no local filter of its own); the system gives it no role" in w
               for w in prep.warnings)
    with pytest.raises(DataError, match="airdata data given as sensor 'baro'"):
        prepare(imu, {"gnss": gnss, "baro": air}, cfg)


def test_a_scenario_states_its_filter_period(tmp_path):
    import yaml

    from fednav.scenarios import scenario_path
    from fednav.sim.scenario import load_scenario

    d = yaml.safe_load(scenario_path("paper002").read_text())
    del d["filter"]["period_s"]
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="filter.period_s: a scenario states"):
        load_scenario(tmp_path / "s.yaml")


def test_a_launch_scenario_with_both_gps_and_gnss_is_refused(tmp_path):
    import yaml

    from fednav.launch.scenario import load_launch_scenario
    from fednav.scenarios import scenario_path

    d = yaml.safe_load(scenario_path("paper001").read_text())
    d["gps"] = dict(d["gnss"])
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="'gps' and 'gnss' are the same setting"):
        load_launch_scenario(tmp_path / "s.yaml")
