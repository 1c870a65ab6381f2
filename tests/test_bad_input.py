"""Replay the bad-input corpus (``tests/data/bad/cases.yaml``, made by its
``make_corpus.py``): every case ends with its exit status and its one line, no traceback,
and no NaN in any output; plus generated malformed CSV and YAML (hypothesis)."""

import math
import shlex
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from fednav.cli import app

BAD = Path(__file__).parent / "data" / "bad"
CASES = yaml.safe_load((BAD / "cases.yaml").read_text())


def _run(argv, out: Path):
    argv = [a.replace("{out}", str(out)) for a in argv]
    if "--out" not in argv and argv[0] in ("process", "reproduce"):
        argv += ["--out", str(out / "out")]
    return CliRunner().invoke(app, argv)


def _numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _numbers(v)
    elif isinstance(obj, float):
        yield obj


def _no_nan_in_outputs(folder: Path) -> None:
    import json

    import numpy as np
    import pandas as pd

    for f in folder.rglob("*"):
        if f.suffix == ".json":
            assert all(math.isfinite(x) for x in _numbers(json.loads(f.read_text()))), f
        elif f.suffix == ".csv":
            v = pd.read_csv(f).select_dtypes("number").to_numpy()
            assert np.isfinite(v).all(), f


def test_corpus_is_large_and_covers_four_families():
    fam = {c["family"] for c in CASES}
    assert len(CASES) >= 60 and fam == {"csv", "navego", "yaml", "cli"}
    assert len({c["id"] for c in CASES}) == len(CASES)


@pytest.mark.parametrize("case", CASES, ids=[c["id"] for c in CASES])
def test_bad_input_case(case, tmp_path, monkeypatch):
    """The case's exit status and line, no traceback; an error is one stderr line, a
    success leaves no NaN in its outputs."""
    monkeypatch.chdir(BAD)
    r = _run(case["argv"], tmp_path)
    assert r.exception is None or isinstance(r.exception, SystemExit), \
        f"exception {type(r.exception).__name__}: {r.exception}"
    assert "Traceback" not in r.output
    assert r.exit_code == case["exit"], r.output
    assert " ".join(case["message"].split()) in " ".join(r.output.split()), r.output
    if case["exit"] != 0:
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    else:
        _no_nan_in_outputs(tmp_path)


# ---------------------------------------------------------------- generated inputs
_CELL = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32).map(repr),
                  st.sampled_from(["", "nan", "inf", "-inf", "abc", "1e30", "0x10", " ", "1,5",
                                   '"', "1;2", "\ufeff"]))


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(header=st.lists(st.sampled_from(["t_s", "lat_deg", "lon_deg", "h_m", "vE_mps",
                                        "vN_mps", "vU_mps", "x", ""]), max_size=8),
       rows=st.lists(st.lists(_CELL, min_size=0, max_size=8), max_size=6),
       sep=st.sampled_from([",", ";", "\t"]))
def test_random_malformed_gnss_csv(tmp_path, header, rows, sep):
    p = tmp_path / "gnss.csv"
    p.write_text("\n".join([sep.join(header)] + [sep.join(r) for r in rows]) + "\n")
    r = CliRunner().invoke(app, ["process", "csv", "--imu", str(BAD / "good" / "imu.csv"),
                                 "--gnss", str(p), "--config", str(BAD / "good" / "cfg.yaml"),
                                 "--out", str(tmp_path / "out")])
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    assert "Traceback" not in r.output
    if r.exit_code != 0:
        assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1, r.output
    else:
        _no_nan_in_outputs(tmp_path / "out")


_SCALAR = st.one_of(st.none(), st.booleans(), st.integers(-10, 10), st.text(max_size=5),
                    st.floats(allow_nan=True, allow_infinity=True))
_YAML = st.recursive(_SCALAR, lambda c: st.one_of(
    st.lists(c, max_size=3),
    st.dictionaries(st.sampled_from(["imu", "period_s", "gnss_sigma_pos_m", "fdi_alpha",
                                     "gyro_arw_rad_sqrt_s", "initial_attitude", "substeps",
                                     "coarse_seconds", "x", "filter", "sensors", "gnss",
                                     "alignment", "type", "aiding"]), c, max_size=4)),
    max_leaves=8)


@settings(max_examples=60, deadline=None)
@given(doc=_YAML)
def test_random_malformed_process_config(doc):
    import tempfile

    from fednav import load_system
    from fednav.core.config import ConfigError

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "cfg.yaml"
        p.write_text(yaml.safe_dump(doc))
        try:
            cfg = load_system(p)
        except ConfigError as e:
            msg = str(e)
            assert "\n" not in msg and str(p) in msg, msg
            return
    for v in cfg.model_dump().values():      # accepted: nothing NaN slipped through
        if isinstance(v, float):
            assert math.isfinite(v)


def test_corpus_commands_are_printable():
    """Each case's command as a user would type it (documentation aid)."""
    for c in CASES:
        assert shlex.join(["fednav", *c["argv"]])
