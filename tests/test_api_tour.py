"""examples/api_tour.py, the Python API's tour, and the snippets of docs/api.md run as
documented: on data the tour simulates itself, into a folder it is given, never over a
user's files."""

import re
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).parents[1]
TOUR = ROOT / "examples" / "api_tour.py"
API_MD = ROOT / "docs" / "api.md"


def _run_tour(out: Path, monkeypatch) -> dict:
    """The tour run as ``python examples/api_tour.py --out OUT``; its variables."""
    monkeypatch.setattr(sys, "argv", [str(TOUR), "--out", str(out)])
    return runpy.run_path(str(TOUR), run_name="__main__")


@pytest.fixture(scope="module")
def toured(tmp_path_factory):
    out = tmp_path_factory.mktemp("tour") / "out"
    with pytest.MonkeyPatch.context() as mp:
        return out, _run_tour(out, mp)


def test_the_tour_runs_and_its_figures_hold(toured):
    out, v = toured
    assert v["out"] == out
    for name in v["WRITES"]:
        assert (out / name).stat().st_size > 0, name
    # a 100 s drive with 5 Hz GNSS (1.5 m): decimetres, the smoother no worse
    assert v["rms"]["north_m"] < 0.5 and v["rms"]["east_m"] < 0.5
    assert v["rms_smoothed"]["east_m"] <= v["rms"]["east_m"] * 1.05
    assert v["same"] and v["result"].health(v["imu"], v["gnss"]) == []


def test_the_tour_never_overwrites(toured, monkeypatch):
    out, _ = toured
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(SystemExit, match="does not overwrite"):
        _run_tour(out, monkeypatch)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_the_tour_uses_the_top_level_api():
    """Every name the tour calls on ``fednav`` is exported (``fednav.__all__``)."""
    import fednav

    used = set(re.findall(r"\bfednav\.([A-Za-z_]\w*)\(", TOUR.read_text()))
    assert used and used <= set(fednav.__all__), used - set(fednav.__all__)


def test_the_api_page_snippets_run(toured, tmp_path):
    """docs/api.md's code, in the order of its sections, on the tour's drive (the page's
    configuration example on its own: it changes the system the others use)."""
    out, _ = toured
    blocks = re.findall(r"```python\n(.*?)```", API_MD.read_text(), re.S)
    data, configure, batch, stream, flight, evaluate, plot = blocks[1:8]
    assert "load_system({" in configure and "prepare(" in stream
    assert "solution_at(" in flight and "from_sigmas(" in flight
    exec(compile(configure, "docs/api.md (configure)", "exec"), {"fednav": __import__("fednav")})
    code = "\n".join((data, batch, stream, flight, evaluate, plot))
    code = code.replace('Path("results/car-drive")', f"Path({str(out)!r})")
    code = code.replace('"errors.png"', repr(str(tmp_path / "errors.png")))
    code = code.replace('"track.png"', repr(str(tmp_path / "track.png")))
    scope: dict = {}
    exec(compile(code, "docs/api.md", "exec"), scope)
    assert scope["result"].forward.t[-1] == scope["res"].forward.t[-1]
    ahead, now = scope["ahead"], scope["now"]  # (the stream of flight software)
    assert np.hypot(*ahead.sigma[6:8]) > np.hypot(*now.sigma[6:8])
    assert scope["nav"].result().data_quality["late_measurements_dropped"] == 0
    assert (tmp_path / "errors.png").exists() and (tmp_path / "track.png").exists()
