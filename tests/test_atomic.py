import json

import pytest
from typer.testing import CliRunner

from fednav.cli import app
from fednav.core.atomic import clear_results, replacing, save_figure, write_text


def test_replacing_keeps_the_old_file_when_writing_fails(tmp_path):
    p = write_text(tmp_path / "summary.json", "old")
    with pytest.raises(RuntimeError), replacing(p) as tmp:
        tmp.write_text("half")
        raise RuntimeError("killed")
    assert p.read_text() == "old" and list(tmp_path.iterdir()) == [p]
    write_text(p, "new")
    assert p.read_text() == "new" and list(tmp_path.iterdir()) == [p]


def test_figure_written_under_a_tmp_name_keeps_its_format(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure()
    p = save_figure(fig, tmp_path / "errors.png")
    plt.close(fig)
    assert p.read_bytes()[:4] == b"\x89PNG" and len(list(tmp_path.iterdir())) == 1


def test_clear_results(tmp_path):
    for n in ("summary.json", "report.html", "runs.csv"):
        (tmp_path / n).write_text("x")
    clear_results(tmp_path)
    assert [p.name for p in tmp_path.iterdir()] == ["runs.csv"]


def _stale(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text(json.dumps({"paper": "old"}))
    (out / "report.html").write_text("old")
    return out


def test_a_run_that_fails_does_not_leave_the_previous_summary(tmp_path, monkeypatch):
    from fednav.filters.base import FilterError
    from fednav.scenarios import paper002

    def boom(*a, **k):
        raise FilterError("ukf 'star': step 17 (update): innovation covariance not PD")

    monkeypatch.setattr(paper002.EXPERIMENT, "reproduce", boom)
    out = _stale(tmp_path)
    r = CliRunner().invoke(app, ["reproduce", "002", "--out", str(out)])
    assert r.exit_code == 2 and "Traceback" not in r.output
    assert "error: ukf 'star': step 17" in r.output
    assert not (out / "summary.json").exists() and not (out / "report.html").exists()


@pytest.mark.parametrize("argv", [
    ["reproduce", "002", "--scenario", "missing.yaml"],
    ["process", "csv", "--imu", "missing-imu.csv", "--gnss", "missing-gnss.csv"],
])
def test_refused_input_leaves_the_previous_result_alone(tmp_path, argv):
    out = _stale(tmp_path)
    r = CliRunner().invoke(app, [*argv, "--out", str(out)])
    assert r.exit_code == 2 and "Traceback" not in r.output and "missing" in r.output
    assert (out / "summary.json").read_text() == json.dumps({"paper": "old"})


@pytest.mark.parametrize("argv", [["reproduce", "002"],
                                  ["process", "csv", "--imu", "a.csv", "--gnss", "b.csv"]])
def test_output_path_that_is_a_file_is_one_line(tmp_path, argv):
    f = tmp_path / "results"
    f.write_text("not a folder")
    r = CliRunner().invoke(app, [*argv, "--out", str(f)])
    assert r.exit_code == 2 and r.output.strip().count("\n") == 0
    assert "a file of that name exists" in r.output and str(f) in r.output


@pytest.mark.slow
def test_process_killed_at_random_moments_leaves_only_complete_files(tmp_path):
    """kill -9 `fednav process` at random moments: every visible file is complete (the
    CSVs parse, summary.json is valid JSON), a summary.json is only there when the run
    finished, and a later run succeeds in the same folder."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    import numpy as np
    import pandas as pd

    good = Path(__file__).parent / "data" / "bad" / "good"
    out = tmp_path / "out"
    cmd = [str(Path(sys.executable).parent / "fednav"), "process", "csv", "--imu",
           str(good / "imu.csv"), "--gnss", str(good / "gnss.csv"), "--ref",
           str(good / "ref.csv"), "--config", str(good / "cfg.yaml"), "--smooth",
           "--out", str(out)]
    rng = np.random.default_rng(1)
    for _ in range(6):
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
        time.sleep(rng.uniform(0.5, 4.0))
        killed = p.poll() is None
        if killed:
            os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        for f in out.glob("*"):
            if f.name.startswith("."):
                continue                          # a temporary file, never read as a result
            if f.suffix == ".csv":
                assert len(pd.read_csv(f)) > 0
            elif f.suffix == ".json":
                json.loads(f.read_text())
        if killed and not (out / "summary.json").exists():
            assert not (out / "report.html").exists()
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert s["rmse"]["north_m"] < 50


def test_debug_shows_the_traceback(tmp_path):
    r = CliRunner().invoke(app, ["--debug", "process", "csv", "--imu", "missing.csv",
                                 "--gnss", "missing.csv", "--out", str(tmp_path)])
    assert r.exit_code != 0 and r.exception is not None
    assert "not found" in str(r.exception)


def test_json_outputs_never_hold_nan_or_infinity(tmp_path):
    """Issue 27: with --runs 1 a confidence interval is NaN; JSON has no NaN (a strict
    reader refuses it): it is written as null."""
    import json
    import math

    import numpy as np

    from fednav.core.atomic import write_json

    p = write_json(tmp_path / "s.json", {"ci": float("nan"), "x": np.float64(1.5),
                                         "inf": [np.inf, -math.inf], "a": np.array([1, 2])})

    def refuse(c):
        raise ValueError(c)

    s = json.loads(p.read_text(), parse_constant=refuse)
    assert s.pop("null_values")                     # (why: test_json_nulls_say_why)
    assert s == {"ci": None, "x": 1.5, "inf": [None, None], "a": [1, 2]}


def test_json_nulls_say_why(tmp_path):
    """Issue 27: a non-finite number is null *with the reason*: the file's key
    ``null_values`` lists, per reason, the JSON Pointers of the numbers it replaced."""
    from fednav.core.atomic import NULLS_KEY, write_json

    p = write_json(tmp_path / "s.json", {"rows": {"a/b": {"ci95": float("nan"), "x": 1.0}},
                                         "t": [float("inf"), float("nan")]},
                   why={"ci95": "needs 2 runs"})
    s = json.loads(p.read_text())
    assert s["rows"]["a/b"] == {"ci95": None, "x": 1.0} and s["t"] == [None, None]
    assert s[NULLS_KEY] == [
        {"why": "needs 2 runs", "was": "NaN", "paths": ["/rows/a~1b/ci95"]},
        {"why": "infinite: a division by zero or an overflow", "was": "Infinity",
         "paths": ["/t/0"]},
        {"why": "not a number: nothing to compute it from (no finite data)", "was": "NaN",
         "paths": ["/t/1"]}]
    write_json(p, {"x": 1.0})
    assert NULLS_KEY not in json.loads(p.read_text())     # only when a number was replaced


def _pointer_get(doc, pointer: str):
    for part in pointer.split("/")[1:]:
        part = part.replace("~1", "/").replace("~0", "~")
        doc = doc[int(part)] if isinstance(doc, list) else doc[part]
    return doc


def test_a_one_run_campaign_says_why_its_intervals_are_null(tmp_path):
    """`--runs 1`: every confidence interval is null, and summary.json says why (strict
    JSON, each pointer of null_values is a null of the file); campaign.json is strict."""
    out = tmp_path / "c"
    r = CliRunner().invoke(app, ["reproduce", "000", "--runs", "1", "--max-time", "5",
                                 "--jobs", "1", "--out", str(out)])
    assert r.exit_code == 0, r.output

    def refuse(c):
        raise ValueError(c)

    s = json.loads((out / "summary.json").read_text(), parse_constant=refuse)
    json.loads((out / "campaign.json").read_text(), parse_constant=refuse)
    (block,) = [b for b in s["null_values"] if b["paths"][0].endswith("/ci95")]
    assert block["why"].startswith("a 95 % confidence interval needs at least 2 runs")
    assert all(_pointer_get(s, p) is None for p in block["paths"])
    cis = [v for row in s["tables"]["T1"]["rows"].values() for v in row.values()]
    assert len(block["paths"]) >= len(cis) and all(c["ci95"] is None for c in cis)
