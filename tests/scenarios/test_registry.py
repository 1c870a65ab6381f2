"""The paper registry: names the command line accepts, one module imported per paper."""

import subprocess
import sys

from fednav.scenarios import ALIASES, paper_module, papers


def test_registry_matches_each_paper_module():
    mods = papers()
    assert [m.PAPER for m in mods] == list(ALIASES)
    for m in mods:
        assert m.ALIASES == ALIASES[m.PAPER]
        for name in m.ALIASES:
            assert paper_module(name.upper()) is m


def test_unknown_paper_is_none():
    assert paper_module("005") is None


def test_finding_a_paper_imports_only_its_module():
    code = ("import sys; from fednav.scenarios import paper_module; paper_module('002');"
            "print(sorted(m for m in sys.modules if m.startswith('fednav.scenarios.paper')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "['fednav.scenarios.paper002']"


def test_every_paper_implements_the_campaign_interface():
    from fednav.campaign.paper import Paper, Unit

    for m in papers():
        e = m.EXPERIMENT
        assert isinstance(e, Paper) and e.number == m.PAPER
        scn = e.load_scenario()
        units = e.units(scn, 2, 1, 10.0)
        assert units and all(isinstance(u, Unit) for u in units)
        # workers import each unit's function by name: it must be module-level
        assert all(u.fn.__qualname__ == u.fn.__name__ for u in units), m.PAPER
        for opt in e.options:
            assert opt in ("particles", "t4_runs")


def test_outputs_end_with_the_summary(tmp_path):
    """summary.json is written last (its presence means the run finished)."""
    from fednav.scenarios import paper004

    e = paper004.EXPERIMENT
    scn = e.load_scenario()
    rep = e.reproduce(scn, 1, 3, 1, 40.0)
    assert len(e.units(scn, 1, 3, 40.0)) == 1 + 4  # a run, and four sweep points
    files = e.write_outputs(tmp_path, rep)
    assert files[0].name == "summary.json"
    names = {f.name for f in files}
    assert {"runs.csv", "sweep_runs.csv", "errors.png", "latency_sweep.png"} <= names
    last = max(files, key=lambda f: f.stat().st_mtime_ns)
    assert last.name == "summary.json"
