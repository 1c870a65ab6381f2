"""Integrity proven by Monte Carlo (fednav.campaign.integrity): a design's protection
levels against the truth, its faults detected and excluded, the Stanford diagram of the
campaign, the counts that add up over runs and survive the campaign store."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from fednav.campaign import integrity as ig
from fednav.campaign.design import one_run
from fednav.cli import app
from fednav.sim.scenario import load_scenario

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "cruise-integrity.yaml"
MODE = "SINS/CNS/SAR/baro/GNSS"


def _design(tmp_path, faults=None, name="d") -> Path:
    """The example design with ``faults`` instead of its own (None: kept; []: none)."""
    d = yaml.safe_load(EXAMPLE.read_text())
    if faults is not None:
        d["faults"] = faults
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(d))
    return p


def test_upper_bound_is_clopper_pearson():
    from scipy.stats import beta

    for n in (1, 10, 1000, 100_000):
        assert ig.upper_bound(0, n) == pytest.approx(1 - 0.05 ** (1 / n), rel=1e-10)
    for k, n in ((1, 10), (3, 1000), (50, 100_000)):
        assert ig.upper_bound(k, n) == pytest.approx(beta.ppf(0.95, k + 1, n - k), rel=1e-9)
    assert ig.upper_bound(5, 5) == 1.0 and np.isnan(ig.upper_bound(0, 0))


def test_a_gnss_spoofing_ramp_is_detected_excluded_and_bounded():
    """One run of the example (a GNSS spoofing ramp of 1 m/s from 100-200 s): the ramp
    trips a test within seconds, GNSS is named and excluded, no epoch's error exceeds
    its level; the run's histogram holds every epoch once."""
    scn = load_scenario(EXAMPLE)
    rows, _, counts = one_run((scn, 3, 260.0))
    r = rows[0]
    assert r["integrity.fault_sensor"] == "gnss"
    assert r["integrity.fault_detected"] == 1 and r["integrity.time_to_detect_s"] < 30.0
    assert r["integrity.candidate"] == r["integrity.excluded"] == "gnss"
    assert r["integrity.fault_excluded"] == 1
    for axis in ("horizontal", "vertical", "heading"):
        assert r[f"integrity.{axis}.misleading"] == 0
        assert r[f"integrity.{axis}.max_error_over_level"] < 1.0
        assert getattr(counts[MODE], axis).sum() == r[f"integrity.{axis}.epochs"] == 260


def test_a_sar_false_match_is_detected(tmp_path):
    """A SAR image-matching false match (10 sigma, held): detected within seconds, the
    levels still bound the error."""
    scn = load_scenario(_design(tmp_path, [{
        "sensor": "sar", "kind": "false_match", "start_s": {"between": [100, 150]},
        "duration_s": 500, "size_sigma": 10}]))
    rows, _, _ = one_run((scn, 1, 220.0))
    r = rows[0]
    assert r["integrity.fault_detected"] == 1 and r["integrity.time_to_detect_s"] < 20.0
    assert r["integrity.fault_excluded"] == 1
    assert all(r[f"integrity.{a}.misleading"] == 0 for a in ("horizontal", "vertical"))


def test_fault_free_runs_raise_no_alert_and_bound_the_error(tmp_path):
    scn = load_scenario(_design(tmp_path, []))
    for seed in (1, 2):
        rows, _, _ = one_run((scn, seed, 200.0))
        r = rows[0]
        assert r["integrity.detected"] == 0 and r["integrity.excluded"] == ""
        assert "integrity.fault_sensor" not in r
        for axis in ("horizontal", "vertical", "heading"):
            assert r[f"integrity.{axis}.misleading"] == 0
            assert r[f"integrity.{axis}.alerted"] == 0
            assert 0 < r[f"integrity.{axis}.median_error"] < r[f"integrity.{axis}.median_level"]


MIXED = [{"sensor": "gnss", "kind": "spoofing", "start_s": {"between": [80, 120]},
          "duration_s": 60, "size_sigma": {"between": [20, 40]}, "share": 0.45},
         {"sensor": "sar", "kind": "false_match", "start_s": {"between": [80, 120]},
          "duration_s": 1000, "size_sigma": {"between": [8, 12]}, "share": 0.45}]


def test_alternative_faults_are_drawn_by_their_shares(tmp_path):
    """Faults with a share are alternatives: each run draws at most one of them, in
    proportion to the shares (the rest fault-free), with the same parameters as when
    drawn alone; a design without shares draws as before."""
    from fednav.sim.runs import FAULT_STREAM

    scn = load_scenario(_design(tmp_path, MIXED))
    got = [scn.draw_faults(np.random.default_rng([s, FAULT_STREAM])) for s in range(600)]
    assert all(len(f) <= 1 for f in got)
    kinds = [f[0].kind if f else "" for f in got]
    for k in ("spoofing", "false_match"):
        assert abs(kinds.count(k) / 600 - 0.45) < 0.06
    assert abs(kinds.count("") / 600 - 0.10) < 0.04
    alone = load_scenario(_design(tmp_path, [dict(MIXED[0], share=None)], "alone"))
    for s, f in enumerate(got[:50]):
        if f and f[0].kind == "spoofing":  # its parameters do not depend on the choice
            g = alone.draw_faults(np.random.default_rng([s, FAULT_STREAM]))[0]
            assert (g.start, g.size_sigma, g.bearing) == (f[0].start, f[0].size_sigma,
                                                          f[0].bearing)
    from fednav.sim.scenario import FaultExperimentConfig

    with pytest.raises(ValueError, match="fault_experiment.fault: share"):
        FaultExperimentConfig(duration_s=100, mode="m", fault=dict(
            sensor="gnss", start_s=10, end_s=20, size_sigma=5, share=0.5))
    with pytest.raises(ValueError, match="add up to 1.2"):
        load_scenario(_design(tmp_path, [dict(MIXED[0], share=0.6), dict(MIXED[1],
                                                                        share=0.6)], "bad"))


def test_a_mixed_campaign_reports_each_fault_type_and_size(tmp_path):
    """A design that draws a GNSS spoofing ramp or a SAR false match per run: each run's
    row names its fault's kind and size, and the summary gives detection and exclusion
    per fault type, per size bin, and the fault-free runs' false alerts."""
    scn = load_scenario(_design(tmp_path, MIXED))
    rows = []
    for seed in range(6):
        r, _, _ = one_run((scn, seed, 200.0))
        rows += r
    kinds = {r.get("integrity.fault_kind", "") for r in rows}
    assert {"spoofing", "false_match"} <= kinds
    for r in rows:
        if r.get("integrity.fault_kind"):
            assert r["integrity.faults_drawn"] == 1
            lo, hi = (20, 40) if r["integrity.fault_kind"] == "spoofing" else (8, 12)
            assert lo <= r["integrity.fault_size_sigma"] <= hi
    s = ig.summarize(rows, [], [MODE], scn.integrity)[MODE]
    by = s["faults"]["by_type"]
    assert set(by) <= {"gnss spoofing", "sar false_match"} and len(by) == 2
    for t in by.values():
        assert sum(b["runs"] for b in t["by_size"]) == t["runs"] > 0
        assert t["detected"] == t["runs"]  # every one of these faults is found
    n_free = sum(1 for r in rows if not r.get("integrity.fault_kind"))
    assert s.get("fault_free", {"runs": 0})["runs"] == n_free
    text = "\n".join(ig.integrity_lines({MODE: s}))
    assert "faults (gnss spoofing)" in text and "faults (sar false_match)" in text


def test_a_mode_with_one_tested_sensor_has_no_levels(tmp_path):
    d = yaml.safe_load(EXAMPLE.read_text())
    d["modes"] = [{"name": "SINS/GNSS", "aiding": ["gnss"]}, d["modes"][0]]
    p = tmp_path / "two.yaml"
    p.write_text(yaml.safe_dump(d))
    rows, _, counts = one_run((load_scenario(p), 1, 120.0))
    assert "integrity.detected" not in rows[0] and "integrity.detected" in rows[1]
    assert list(counts) == [MODE]


@pytest.mark.slow
def test_the_campaign_writes_and_resumes_its_integrity(tmp_path):
    """``fednav run`` of the example: summary.json's integrity (per axis the epochs, rates
    and bounds, the faults' detection and exclusion), the Stanford diagram in
    stanford.png and in report.html, the integrity lines in tables.md and on screen; a
    second run reads the stored runs back to the same integrity (the histograms through
    the campaign store)."""
    out = tmp_path / "out"
    args = ["run", str(EXAMPLE), "--runs", "2", "--max-time", "220", "--jobs", "1",
            "--out", str(out)]
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    assert "Integrity: protection levels against the truth" in r.output
    s = json.loads((out / "summary.json").read_text())
    m = s["integrity"][MODE]
    assert m["runs"] == 2 and "_counts" not in m and "IMU" in m["not_protected"]
    for axis in ("horizontal", "vertical", "heading"):
        a = m["axes"][axis]
        assert a["epochs"] == 440 and a["misleading_epochs"] == 0
        assert a["mi_rate_upper95"] == pytest.approx(1 - 0.05 ** (1 / 440))
        assert sum(v for k, v in a["regions"].items() if k != "epochs") == 440
        assert 0.0 <= a["availability"] <= 1.0
    assert m["faults"]["runs"] == 2 and m["faults"]["detected"] == 2
    assert (out / "stanford.png").stat().st_size > 20_000
    assert "alt='stanford.png'" in (out / "report.html").read_text()
    assert "## Integrity" in (out / "tables.md").read_text()
    r = CliRunner().invoke(app, args)
    assert r.exit_code == 0, r.output
    s2 = json.loads((out / "summary.json").read_text())
    assert s2["campaign"]["runs_reused"] == 2 and s2["integrity"] == s["integrity"]


def test_a_modes_system_carries_the_integrity_section():
    """``fednav simulate`` writes each mode's system description (``system_for``): the
    design's integrity budget goes with it, so ``fednav process`` of the files gives
    the levels the design asked for."""
    scn = load_scenario(EXAMPLE)
    assert scn.system_for(scn.modes[0]).integrity == scn.integrity is not None
