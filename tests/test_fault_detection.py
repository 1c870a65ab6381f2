"""Fault detection and isolation in a full closed-loop run (paper-002 flight + GNSS)."""

from dataclasses import replace

import numpy as np
import pytest
import yaml

from fednav.campaign.report import plot_fdi
from fednav.scenarios import scenario_path
from fednav.sim.runs import make_run_data, run_mode
from fednav.sim.scenario import load_scenario

T_END = 400.0


def scenario(tmp_path, fdi_alpha, faults):
    d = yaml.safe_load(scenario_path("paper002").read_text())
    d["sensors"]["gnss"] = {"sigma_pos_enu_m": 8.0, "sigma_vel_mps": 0.2, "period_s": 1.0}
    d["filter"]["fdi_alpha"] = fdi_alpha
    d["faults"] = faults
    d["modes"] = [{"name": "GNSS+CNS", "aiding": ["gnss", "star"]}]
    p = tmp_path / f"s{len(list(tmp_path.iterdir()))}.yaml"
    p.write_text(yaml.safe_dump(d))
    return load_scenario(p)


FAULT = [{"sensor": "gnss", "start_s": 151.0, "end_s": 250.0, "size_sigma": 5.0}]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fdi")
    out = {}
    for name, alpha, faults in [("clean", 0.005, []), ("isolated", 0.005, FAULT),
                                ("not_isolated", None, FAULT), ("outage", None, [])]:
        scn = scenario(tmp, alpha, faults)
        data = make_run_data(scn, 2, max_time=T_END)
        if name == "outage":  # the same data with the GNSS silent during the fault window
            g = data.series["gnss"]
            keep = (g.t < 151.0) | (g.t > 250.0)
            data.series["gnss"] = replace(g, t=g.t[keep], z=g.z[keep], t_avail=g.t_avail[keep])
        out[name] = run_mode(scn, ["gnss", "star"], data, name, max_time=T_END)
    return out


def test_fault_detected_at_onset_and_isolated_throughout(runs):
    g = runs["isolated"].fdi
    g = g[g["local"] == "gnss"].set_index("t")
    assert g.loc[151.0, "isolated"]  # detected in the first cycle of the fault
    assert g.loc[151.0:250.0, "isolated"].all()
    assert g.loc[151.0, "threshold"] == pytest.approx(18.55, abs=0.01)
    outside = g[(g.index < 151.0) | (g.index > 252.0)]
    assert outside["isolated"].mean() < 0.03  # false alarms near alpha = 0.005


def test_isolation_equals_an_outage_and_beats_no_isolation(runs):
    """Isolated, the faulty GNSS does no harm: the run matches one where the GNSS was
    silent during the window (SINS + CNS drift), far below the run that used the fault."""
    win = lambda r: (r.t >= 151) & (r.t <= 250)  # noqa: E731
    rms = {k: np.sqrt((r.pos[win(r), :2] ** 2).mean()) for k, r in runs.items()}
    assert rms["isolated"] == pytest.approx(rms["outage"], rel=0.02)
    assert rms["not_isolated"] > 3 * rms["isolated"]
    after = lambda r: r.t > 300  # noqa: E731  (recovered once the fault is over)
    rms_after = {k: np.sqrt((r.pos[after(r), :2] ** 2).mean()) for k, r in runs.items()}
    assert rms_after["isolated"] < 1.5 * rms_after["clean"]


def test_fdi_plot(runs, tmp_path):
    p = plot_fdi(runs["isolated"].fdi, tmp_path / "fdi.png")
    assert p.stat().st_size > 10_000
