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
