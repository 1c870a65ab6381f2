"""examples/api_tour.py, the Python API's tour (docs/api.md), runs as documented: on data
it simulates itself, into a folder it is given, never over a user's files."""

import importlib.util
from pathlib import Path

import pytest

TOUR = Path(__file__).parents[1] / "examples" / "api_tour.py"


def _tour():
    spec = importlib.util.spec_from_file_location("api_tour", TOUR)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_tour_runs_and_its_figures_hold(tmp_path, capsys):
    tour = _tour()
    out = tmp_path / "tour"
    r = tour.main(["--out", str(out)])
    assert r["out"] == out
    for name in tour.WRITES:
        assert (out / name).stat().st_size > 0, name
    # a 100 s drive with 5 Hz GNSS (1.5 m): decimetres, the smoother no worse
    assert r["rmse"]["north_m"] < 0.5 and r["rmse"]["east_m"] < 0.5
    assert r["rmse_smoothed"]["east_m"] <= r["rmse"]["east_m"] * 1.05
    assert r["stream_equals_batch"] and r["health"] == []
    text = capsys.readouterr().out
    assert "equal to the batch run's" in text and "RMSE north_m" in text

    # the same folder again: the tour refuses to overwrite what is there
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    with pytest.raises(SystemExit, match="does not overwrite"):
        tour.main(["--out", str(out)])
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_the_tour_uses_the_top_level_api():
    """Every name the tour calls on ``fednav`` is exported (``fednav.__all__``)."""
    import re

    import fednav

    used = set(re.findall(r"\bfednav\.([A-Za-z_]\w*)\(", TOUR.read_text()))
    assert used and used <= set(fednav.__all__), used - set(fednav.__all__)
