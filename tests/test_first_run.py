"""A first run as a new user meets it: ``fednav --version``, the one-line notice before
numba compiles the kernels (a cold cache) and timing lines that leave the compile out."""

import json
from pathlib import Path

import numba
import pytest
from typer.testing import CliRunner

from fednav import __version__, _kernel_cache
from fednav.cli import app

EXAMPLE = Path(__file__).parents[1] / "examples" / "car-drive.yaml"


def test_version_option_and_command():
    r = CliRunner().invoke(app, ["--version"])
    assert r.exit_code == 0 and r.output.strip() == f"fednav {__version__}"
    r = CliRunner().invoke(app, ["version"])
    assert r.exit_code == 0 and r.output.strip() == __version__


def test_the_notice_comes_once_before_an_actual_compilation(monkeypatch):
    monkeypatch.setattr(_kernel_cache, "_watch", None)  # (a fresh process's state)
    said = []
    _kernel_cache.watch_compiles(said.append)
    _kernel_cache.watch_compiles(said.append)  # idempotent: one listener, one notice
    assert _kernel_cache.compile_seconds() == 0.0 and said == []

    @numba.njit  # (no cache: compiled here)
    def inner(x):
        return x + 1.0

    @numba.njit
    def outer(x):
        return inner(x) * 2.0

    assert outer(1.0) == 4.0
    assert said == [_kernel_cache.NOTICE] == ["compiling fast kernels once (a minute or two)"]
    first = _kernel_cache.compile_seconds()
    assert first > 0.0
    assert outer(2.0) == 6.0  # compiled already: no event, no time
    assert _kernel_cache.compile_seconds() == first

    @numba.njit
    def other(x):
        return x - 1.0

    other(1.0)  # a later compilation is timed but not announced again
    assert said == [_kernel_cache.NOTICE] and _kernel_cache.compile_seconds() > first


def test_a_cold_cache_folder_is_one_without_kernels(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert _kernel_cache.cold()
    (tmp_path / "core_abc").mkdir()
    (tmp_path / "core_abc" / "kernels.f-1.py311.nbi").write_bytes(b"")
    assert not _kernel_cache.cold()
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "missing"))
    assert not _kernel_cache.cold()


@pytest.fixture(scope="module")
def short_drive(tmp_path_factory):
    from fednav.sim.dataset import load_dataset_config, simulate_dataset, write_csv_dataset

    d = tmp_path_factory.mktemp("first-run")
    cfg = load_dataset_config(EXAMPLE)
    write_csv_dataset(simulate_dataset(cfg.model_copy(update={"segments": cfg.segments[:5]})),
                      d)
    return d


def test_the_timing_line_leaves_the_compile_time_out(short_drive, tmp_path, monkeypatch):
    """``process`` says how long the filter ran without the kernels' compilation (here a
    pretend 30 s of it) and says the compile time apart; summary.json's run_time_s too."""
    clock = iter([0.0, 30.0])
    monkeypatch.setattr(_kernel_cache, "compile_seconds", lambda: next(clock))
    d = short_drive
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(d / "imu.csv"),
                                 "--gnss", str(d / "gnss.csv"), "--ref",
                                 str(d / "reference.csv"), "--config",
                                 str(d / "process.yaml"), "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    line = next(ln for ln in r.output.splitlines() if "filter epochs in" in ln)
    s = json.loads((tmp_path / "summary.json").read_text())
    assert line == (f"{s['epochs']} filter epochs in {s['run_time_s']:.2f} s "
                    f"(+ 30.0 s compiling fast kernels, once)")


def test_no_compile_no_note():
    from fednav.cli import _compiled_note

    assert _compiled_note(0.0) == ""
    assert _compiled_note(21.04) == " (+ 21.0 s compiling fast kernels, once)"


README = Path(__file__).parents[1] / "README.md"


def test_the_readme_needs_nothing_but_a_clone():
    """Every file the README names is in the repository, except the optional real-data
    section's (NaveGo's LGPL files, not bundled), which says where they come from; its
    first screen keeps the two commands for a fresh machine."""
    import re

    text = README.read_text()
    root = README.parent
    first = text[:text.index("## The navigator")].split("\n\n")[:6]
    assert any('pip install -e . && fednav reproduce 002' in p for p in first)
    assert any('pip install -e ".[test]" && python -m pytest -q' in p for p in first)
    optional = text.index("*Optional: a real rover.*")
    end = text.index("```\n", text.index("```bash", optional) + 7)
    assert "NaveGo" in text[optional:end] and "LGPL" in text[optional:end]
    assert "../shared" not in text[:optional] + text[end:]
    named = set(re.findall(r"\b((?:examples|docs|benchmarks)/[\w./-]+\.(?:yaml|md|py))", text))
    named |= {m for m in re.findall(r"\]\(([\w./-]+)\)", text) if not m.startswith("http")}
    missing = sorted(n for n in named if not (root / n.split("#")[0]).exists())
    assert not missing and len(named) > 10, missing
