import pytest
import yaml

from fednav.core.config import ConfigError
from fednav.scenarios import scenario_path
from fednav.sim.scenario import load_scenario


def write(tmp_path, mutate):
    data = yaml.safe_load(scenario_path("paper002").read_text())
    mutate(data)
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


def test_packaged_scenario_loads():
    s = load_scenario(scenario_path("paper002"))
    assert s.duration == pytest.approx(1200.0)
    assert [m.name for m in s.modes] == ["SINS", "SINS/SAR", "SINS/CNS", "SINS/CNS/SAR"]


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda d: d["sensors"]["sar"].update(sigma_pos=3),
     r"s\.yaml: key 'sensors\.sar\.sigma_pos': unknown key"),
    (lambda d: d["start"].update(lat_deg="north"), r"key 'start\.lat_deg'"),
    (lambda d: d.pop("imu_period_s"), r"key 'imu_period_s': missing value"),
    (lambda d: d["filter"].update(type="pf9"), r"key 'filter\.type'"),
], ids=["unknown key", "wrong type", "missing value", "unknown filter name"])
def test_bad_scenario_is_one_line(tmp_path, mutate, message):
    with pytest.raises(ConfigError, match=message):
        load_scenario(write(tmp_path, mutate))


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load_scenario(tmp_path / "nope.yaml")


def test_error_is_one_line(tmp_path):
    p = write(tmp_path, lambda d: d["start"].update(bogus=1, lat_deg="x"))
    with pytest.raises(ConfigError) as e:
        load_scenario(p)
    assert "\n" not in str(e.value) and "more" in str(e.value)


def test_fault_experiment_requires_detection_level(tmp_path):
    d = yaml.safe_load(scenario_path("paper003").read_text())
    d["filter"].pop("fdi_alpha")
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="fdi_alpha"):
        load_scenario(p)


def test_the_documented_processing_config_validates():
    """docs/data-formats.md's example is a valid system description, without warnings."""
    import warnings
    from pathlib import Path

    import yaml

    from fednav import load_system

    doc = (Path(__file__).resolve().parents[1] / "docs" / "data-formats.md").read_text()
    block = doc.split("## Processing config")[1].split("```yaml\n")[1].split("```")[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = load_system(yaml.safe_load(block))
    assert s.sensors.gnss.lever_m == (0.51, -0.16, 0.0) and s.filter.period_s == 0.05


def test_a_key_given_twice_in_a_yaml_is_refused_naming_it(tmp_path):
    """Issue 27: PyYAML keeps the last of two equal keys silently."""
    from fednav.core.config import ConfigError, read_mapping

    p = tmp_path / "c.yaml"
    p.write_text("sensors:\n  gnss:\n    sigma_pos_enu_m: 1.0\n    sigma_pos_enu_m: 5.0\n")
    with pytest.raises(ConfigError,
                       match=r"key 'sigma_pos_enu_m' given twice \(lines 3 and 4\)"):
        read_mapping(p, "processing config")
