"""Paper 000 (airship): summary shape (smoke) and the claims on short flights."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fednav.cli import app
from fednav.scenarios import paper000
from fednav.sim.runs import make_run_data, run_configured_mode


@pytest.mark.slow
def test_cli_reproduce_000_smoke(tmp_path, report_complete):
    r = CliRunner().invoke(app, ["reproduce", "airship", "--runs", "1", "--jobs", "1",
                                 "--max-time", "40", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    report_complete(tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    t1 = s["tables"]["T1"]["rows"]
    assert set(t1) == {"AEKF/none", "AEKF/wind", "RAUKF/none", "RAUKF/wind", "CUKF/none",
                       "CUKF/wind"}
    assert set(t1["CUKF/wind"]) == {"pos_mean_m", "vel_mean_mps", "pos_std_m",
                                    "vel_std_mps"}
    assert t1["AEKF/none"]["pos_mean_m"]["paper"] == 2.37
    assert "CUKF/wind, wind estimate +2 m/s east" in s["tables"]["limitation"]["rows"]
    assert (tmp_path / "wind_window.png").exists()


def test_constraint_helps_only_with_the_right_wind():
    scn = paper000.load_scenario()
    T = 300.0
    data = make_run_data(scn, 2, T)
    st = {m.name: paper000.run_statistics(run_configured_mode(scn, m, data, T))
          for m in scn.modes}
    assert st["CUKF"]["vel_mean_mps"] < 0.5 * st["AEKF"]["vel_mean_mps"]
    assert st["CUKF"]["pos_mean_m"] < st["AEKF"]["pos_mean_m"]
    biased = paper000.with_air_data(scn, wind_bias_mps=(2.0, 0.0))
    cukf = next(m for m in scn.modes if m.name == "CUKF")
    b = paper000.run_statistics(run_configured_mode(biased, cukf,
                                                    make_run_data(biased, 2, T), T))
    assert b["vel_mean_mps"] > 1.5  # pinned to the wrong wind
    assert b["pos_mean_m"] > 10 * st["CUKF"]["pos_mean_m"]
    assert np.isfinite(b["pos_std_m"])
