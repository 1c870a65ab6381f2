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


@pytest.mark.parametrize("fault", [
    {"sensor": "gnss", "kind": "spoofing", "size_sigma": 40.0},
    {"sensor": "sar", "kind": "false_match", "size_sigma": 15.0},
    {"sensor": "star", "kind": "misidentification", "size_sigma": 30.0},
    {"sensor": "gnss", "kind": "burst", "size_sigma": 6.0},
])
def test_each_fault_model_is_detected_and_isolated(tmp_path, fault):
    """A short campaign (two runs, the fault's start, length and direction drawn per run)
    with each of the sensor failure models: the chi-square FDI isolates the faulty local
    filter's measurements inside the fault and hardly any outside."""
    f = {"start_s": {"between": [150.0, 200.0]}, "duration_s": {"between": [60.0, 90.0]},
         **fault}
    scn = scenario(tmp_path, 0.005, [f])
    scn = scn.model_copy(update={"modes": [scn.modes[0].model_copy(update={
        "aiding": ["gnss", "star", "sar"]})]})
    for seed in (1, 2):
        data = make_run_data(scn, seed, max_time=T_END)
        drawn = scn.faults[0].fault(np.random.default_rng([seed, 0xFA17]))
        res = run_mode(scn, ["gnss", "star", "sar"], data, "faulty", max_time=T_END)
        g = res.fdi[res.fdi["local"] == fault["sensor"]]
        end = T_END if fault["kind"] in ("false_match", "spoofing") else drawn.end  # (held)
        inside = g[(g["t"] >= drawn.start) & (g["t"] <= end)]
        outside = g[(g["t"] < drawn.start - 1.0) | (g["t"] > end + 5.0)]
        assert inside["isolated"].mean() > 0.5, (seed, drawn)
        assert outside["isolated"].mean() < 0.05, (seed, drawn)


def test_drawn_faults_leave_the_runs_noise_as_it_was(tmp_path):
    """The faults' draws come from a stream of their own: a run's IMU errors and sensor
    noise are the same with or without them, outside the faulty sensor's window."""
    f = {"sensor": "sar", "kind": "false_match", "start_s": {"between": [100.0, 200.0]},
         "duration_s": 50.0, "size_sigma": {"between": [5.0, 10.0]}}
    clean = make_run_data(scenario(tmp_path, 0.005, []), 3, max_time=T_END)
    faulty = make_run_data(scenario(tmp_path, 0.005, [f]), 3, max_time=T_END)
    np.testing.assert_array_equal(clean.dtheta, faulty.dtheta)
    for name in ("gnss", "star", "baro"):
        np.testing.assert_array_equal(clean.series[name].z, faulty.series[name].z)
    before = clean.series["sar"].t < 100.0
    np.testing.assert_array_equal(clean.series["sar"].z[before],
                                  faulty.series["sar"].z[before])
    assert not np.array_equal(clean.series["sar"].z, faulty.series["sar"].z)
