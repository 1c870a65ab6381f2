"""The GNSS is an ordinary registry entry: what a recording's start, alignment, timing
checks, epoch period and health checks take from the GNSS they take from whichever
registered sensor declares ``fixes`` (``fednav.sensors.registry.fix_sensor``), so a
second such sensor under another name flies the same run to the last digit."""

from dataclasses import replace

import numpy as np
import pytest
from test_process import make_flight
from test_series_route import _short, _velocity

from fednav import load_system
from fednav.io.data import DataError
from fednav.process import process
from fednav.sensors import registry
from fednav.sensors.gnss import SPEC as GNSS


@pytest.fixture
def rtk():
    """The GNSS's spec under another name ('rtk'), registered for the test."""
    registry.register(replace(GNSS, name="rtk", label="RTK"))
    yield "rtk"
    registry.unregister("rtk")


def test_the_registry_names_the_sensor_whose_fixes_start_a_run(rtk):
    assert registry.fix_sensor(["baro", "gnss"]) == "gnss"
    assert registry.fix_sensor(["baro", rtk]) == rtk
    assert registry.fix_sensor(["baro", "star"]) is None
    assert registry.label("gnss") == "GNSS" and registry.label("baro") == "baro"
    assert set(registry.total_models()) == {"gnss", "star", rtk}


def test_a_fix_sensor_under_another_name_flies_the_same_run(rtk):
    imu, gnss, _ = _short(make_flight(), 60.0)
    vel = _velocity(gnss)
    section = {"sigma_pos_enu_m": [0.5, 0.5, 1.0], "sigma_vel_mps": 0.05,
               "lever_m": [0.0, 0.0, 0.0], "time_offset_s": 0.02}
    a = process(imu, {"gnss": gnss, "velocity": vel},
                load_system({"sensors": {"gnss": section}}))
    b = process(imu, {rtk: replace(gnss, name=rtk, quality={}), "velocity": vel},
                load_system({"sensors": {rtk: section}}))
    np.testing.assert_array_equal(a.forward.lla, b.forward.lla)
    np.testing.assert_array_equal(a.forward.euler, b.forward.euler)
    assert a.alignment == b.alignment
    assert b.fixes_flown.name == rtk and len(b.fixes_flown.t) == len(a.fixes_flown.t)
    said = [w.replace("GNSS", "RTK").replace("sensors.gnss", f"sensors.{rtk}")
             .replace("'gnss'", f"'{rtk}'")
            for w in a.warnings]
    assert said == b.warnings and any("RTK" in w for w in b.warnings)
    assert {k.replace("gnss", rtk): v for k, v in a.data_quality.items()} == b.data_quality
    assert set(b.consistency) == {rtk, "velocity"}


def test_without_fixes_the_refusal_names_the_registered_fix_sensor():
    imu, gnss, _ = _short(make_flight(), 30.0)
    with pytest.raises(DataError, match="no GNSS positions to start from"):
        process(imu, {"velocity": _velocity(gnss)}, load_system({}))
