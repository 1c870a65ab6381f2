"""Short reproduction smoke runs (seconds); the full reproduction stays out of CI."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fednav.cli import app
from fednav.scenarios import paper002
from fednav.sim.runs import make_run_data, run_mode


def test_modes_behave_as_the_paper_says_on_a_short_flight():
    scn = paper002.load_scenario()
    data = make_run_data(scn, 3, max_time=300.0)
    res = {m.name: run_mode(scn, list(m.aiding), data, m.name, 300.0) for m in scn.modes}
    stats = {k: paper002.run_statistics(r) for k, r in res.items()}
    # SAR fixes bound the position; CNS bounds the attitude; together at least as good.
    assert stats["SINS/SAR"]["dlambda_m"] < 0.1 * stats["SINS"]["dlambda_m"]
    assert stats["SINS/CNS"]["phiU_arcsec"] < 2.0
    assert stats["SINS/CNS/SAR"]["dlambda_m"] < 2.0
    assert stats["SINS/CNS/SAR"]["phiU_arcsec"] < 2.0
    # Filter 1-sigma is reported and finite for aided modes.
    assert np.all(np.isfinite(res["SINS/CNS/SAR"].sigma))
    b = res["SINS/CNS/SAR"].beta
    np.testing.assert_allclose(sum(b.values()), 1.0)


def test_cli_reproduce_smoke(tmp_path, report_complete):
    r = CliRunner().invoke(app, ["reproduce", "cruise-missile", "--runs", "2", "--jobs", "1",
                                 "--max-time", "60", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    report_complete(tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["paper"] == "002" and s["runs"] == 2 and s["seed"] == 1
    row = s["tables"]["T2"]["rows"]["SINS/CNS/SAR"]["dlambda_m"]
    assert set(row) == {"ours", "ci95", "paper"} and row["paper"] == 0.79
    assert set(s["tables"]["T3"]["rows"]["SINS"]) == {"phiE_arcsec", "phiN_arcsec",
                                                      "phiU_arcsec"}
    assert (tmp_path / "errors.png").exists() and (tmp_path / "runs.csv").exists()
    # Table 1: every state, the paper's 16 keys plus the two vertical-channel extras.
    t1 = s["tables"]["T1"]["rows"]
    assert set(t1) == set(paper002.PAPER_T1) | {"dVU", "dh"}
    assert t1["phiE"]["degree"]["paper"] == 8.67 and t1["dh"]["degree"]["paper"] is None
    assert set(t1["phiE"]["degree"]) == {"ours", "paper"}
    assert {"degree", "degree_filter_units", "sigma_shrink"} == set(t1["phiU"])
    phases = set(s["observability_phases"]["si"])   # the phases inside the 60 s flight
    assert {"climb pitch-up", "climb"} <= phases <= {g.name for g in
                                                     paper002.load_scenario().segments}
    # Table 4: three filters on the same runs (default min(runs, 3) = 2 runs).
    t4 = s["tables"]["T4"]
    assert set(t4["rows"]) == {"SGHQF", "AASGHQF", "UKF"} and t4["runs"] == 2
    assert set(t4["rows"]["UKF"]) == {"att_arcsec", "vel_mps", "pos_m", "ms_per_cycle"}
    assert t4["rows"]["SGHQF"]["ms_per_cycle"]["paper"] == 8.7
    # The sparse grid and the UKF agree on this nearly linear error model.
    assert np.isclose(t4["rows"]["SGHQF"]["pos_m"]["ours"], t4["rows"]["UKF"]["pos_m"]["ours"],
                      rtol=1e-3)


def test_t4_runs_option(tmp_path):
    r = CliRunner().invoke(app, ["reproduce", "002", "--runs", "1", "--t4-runs", "1",
                                 "--jobs", "1", "--max-time", "20", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "summary.json").read_text())["tables"]["T4"]["runs"] == 1
    bad = CliRunner().invoke(app, ["reproduce", "001", "--t4-runs", "2"])
    assert bad.exit_code == 2 and "applies to paper 002 only" in bad.output
    bad = CliRunner().invoke(app, ["reproduce", "002", "--t4-runs", "0"])
    assert bad.exit_code == 2 and "at least 1" in bad.output


def test_cli_rejects_unknown_paper():
    r = CliRunner().invoke(app, ["reproduce", "999"])
    assert r.exit_code != 0
    assert "unknown paper '999'" in r.output


def test_qualitative_claims_full_flight():
    """Paper 002's claims on full 1200 s flights (2 Monte Carlo runs, seeds 1-2)."""
    scn = paper002.load_scenario()
    rows, _ = paper002.run_monte_carlo(scn, runs=2, seed=1)
    mean = {}
    for r in rows:
        for k, v in r.items():
            if k not in ("seed", "mode"):
                mean.setdefault(r["mode"], {}).setdefault(k, []).append(v)
    m = {mode: {k: np.mean(v) for k, v in cols.items()} for mode, cols in mean.items()}
    sar, cns, fed = m["SINS/SAR"], m["SINS/CNS"], m["SINS/CNS/SAR"]
    # SAR corrects position and velocity but not heading.
    assert sar["dlambda_m"] < 0.01 * m["SINS"]["dlambda_m"]
    assert sar["phiU_arcsec"] > 5 * cns["phiU_arcsec"]
    # CNS corrects attitude but the position drifts.
    assert cns["phiU_arcsec"] < 1.0 and cns["dlambda_m"] > 10 * sar["dlambda_m"]
    # The federated system is at least as good as the better sub-system on every column
    # (2 runs only: allow 15 % of Monte Carlo noise).
    for col in fed:
        assert fed[col] <= 1.15 * min(sar[col], cns[col]), col


def test_kf_in_the_navigation_loop_matches_ukf(tmp_path):
    """The linear KF (error state, Joseph form) runs the same federated system; with small
    errors it should do as well as the UKF."""
    import yaml

    from fednav.scenarios import scenario_path
    from fednav.sim.scenario import load_scenario

    data_yaml = yaml.safe_load(scenario_path("paper002").read_text())
    data_yaml["filter"]["type"] = "kf"
    p = tmp_path / "kf.yaml"
    p.write_text(yaml.safe_dump(data_yaml))
    scn_kf, scn_ukf = load_scenario(p), paper002.load_scenario()
    d = make_run_data(scn_ukf, 5, max_time=300.0)
    kf = paper002.run_statistics(run_mode(scn_kf, ["star", "sar"], d, max_time=300.0))
    ukf = paper002.run_statistics(run_mode(scn_ukf, ["star", "sar"], d, max_time=300.0))
    for col in kf:
        assert kf[col] == pytest.approx(ukf[col], rel=0.05), col


def test_cli_reports_bad_scenario_in_one_line(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("paper: '002'\nname: x\nbogus: 1\n")
    r = CliRunner().invoke(app, ["reproduce", "002", "--scenario", str(p)])
    assert r.exit_code == 2
    assert "bad.yaml" in r.output and "key 'bogus': unknown key" in r.output


def test_cli_refuses_an_integrity_section_in_one_line(tmp_path):
    """``integrity:`` acts in designs (fednav run) and fednav process; a paper's
    reproduction computes no levels, so the key is refused there, not ignored."""
    from fednav.scenarios import scenario_path

    p = tmp_path / "with-integrity.yaml"
    p.write_text(scenario_path("paper002").read_text()
                 + "integrity: {alert_limit_horizontal_m: 50.0}\n")
    r = CliRunner().invoke(app, ["reproduce", "002", "--scenario", str(p), "--out",
                                 str(tmp_path / "out")])
    assert r.exit_code == 2, r.output
    assert "with-integrity.yaml" in r.output and "key 'integrity'" in r.output
    assert not (tmp_path / "out" / "summary.json").exists()
