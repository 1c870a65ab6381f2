"""Campaign store and engines: resumable, atomic, identical tables whatever the engine."""

import json
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fednav.campaign.store import (
    Campaign,
    CampaignError,
    _read_unit,
    decode,
    encode,
    open_runs,
    run_units,
)
from fednav.cli import app
from fednav.scenarios import paper000, paper003

ARGS = ["--runs", "2", "--max-time", "30", "--jobs", "1"]


def _reproduce(out, *extra):
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--out", str(out), *extra])
    assert r.exit_code == 0, r.output
    return json.loads((out / "summary.json").read_text())


def _tables(s):
    t = json.loads(json.dumps(s["tables"]))
    for row in t["T4"]["rows"].values():   # wall-clock timings differ between runs
        row.pop("ms_per_cycle")
    return t


def test_codec_round_trip_with_frames_and_dicts():
    scn = paper003.load_scenario()
    res = paper003.one_run((scn, 3, 40.0))
    back = decode(encode(res))
    assert pd.DataFrame(back[0]).equals(pd.DataFrame(res[0]))
    assert pd.DataFrame(back[2]).equals(pd.DataFrame(res[2]))     # NaN-aware
    for k, r in res[1].items():
        b = back[1][k]
        assert np.array_equal(b.pos, r.pos) and np.array_equal(b.sigma, r.sigma, equal_nan=True)
        assert b.mode == r.mode and set(b.beta) == set(r.beta)
    for k, r in res[3].items():   # the fault-detection logs: same values and dtypes
        pd.testing.assert_frame_equal(back[3][k].fdi, r.fdi)
    assert back[3]["isolated"].fdi["isolated"].dtype == bool


@dataclass
class Holder:
    """A result object holding a frame (a field the codec stores column by column)."""

    log: pd.DataFrame


def test_codec_round_trip_of_frames_with_missing_values_and_no_rows():
    frame = pd.DataFrame({"t": [1.0, np.nan], "name": ["a", "b"], "n": [1, 2],
                          "x": [None, 2.5], "ok": [True, False]})
    back = decode(encode({"m": Holder(frame)}))["m"].log
    pd.testing.assert_frame_equal(back, pd.DataFrame(frame.to_dict("records")))
    empty = decode(encode({"m": Holder(frame.iloc[:0])}))["m"].log
    assert list(empty.columns) == list(frame.columns) and len(empty) == 0


def test_codec_round_trip_of_an_analysis_dict():
    """Paper 002's Table-1 unit returns nested numbers and names (kept as JSON)."""
    obs = {"rows": {"phiE": {"degree": {"ours": 8.123456789012345, "paper": None}}},
           "phases": {"si": {"climb": {"phiE": 1e-300}}}}
    assert decode(encode(obs)) == obs
    assert decode(encode((obs, [{"seed": 1, "x": 0.5}]))) == (obs, [{"seed": 1, "x": 0.5}])


@pytest.mark.slow
def test_resume_computes_only_missing_runs_and_gives_identical_tables(tmp_path):
    whole = _reproduce(tmp_path / "whole")
    part = tmp_path / "part"
    _reproduce(part)
    runs = sorted((part / "runs").glob("*.nc"))
    runs[0].unlink()                                          # a run lost ...
    (part / "runs" / f".{runs[1].stem}.123.tmp").write_text("half-written")  # ... a kill
    s = _reproduce(part)
    assert s["campaign"]["runs_computed"] == 1 and s["campaign"]["runs_reused"] == 4
    assert _tables(s) == _tables(whole)
    ds = open_runs(part)
    assert set(ds.dims) == {"run", "mode", "time", "axis"} and list(ds.run.values) == [1, 2]
    assert "SINS/CNS/SAR" in list(ds.mode.values) and np.isfinite(ds.pos).any()


@pytest.mark.slow
def test_other_seed_or_scenario_refused_in_one_line_and_fresh(tmp_path):
    out = tmp_path / "c"
    _reproduce(out)
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--seed", "5", "--out", str(out)])
    assert r.exit_code == 2 and "made with seed 1, not 5" in r.output
    assert len(r.output.strip().splitlines()) == 1
    s = _reproduce(out, "--seed", "5", "--fresh")
    assert s["campaign"]["runs_reused"] == 0
    with pytest.raises(CampaignError, match="scenario_hash"):
        Campaign(out, "002", paper000.load_scenario(), 5)
    f = tmp_path / "file"
    f.write_text("x")
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--out", str(f)])
    assert r.exit_code == 2 and "a file of that name exists" in r.output
    assert (out / "summary.json").exists()  # refused input leaves the result alone


def test_damaged_manifest_or_stored_run_refused_in_one_line(tmp_path):
    scn = paper000.load_scenario()
    out = tmp_path / "c"
    args = [(scn, s, 20.0) for s in (1, 2)]
    with Campaign(out, "000", scn, 1) as camp:
        run_units(paper000.one_run, args, campaign=camp)
    bad = sorted((out / "runs").glob("*.nc"))[0]
    bad.write_bytes(bad.read_bytes()[:500])          # damaged outside fednav
    msg = f"stored run {bad.name} cannot be read .*; delete it to compute that run again"
    with Campaign(out, "000", scn, 1) as camp, pytest.raises(CampaignError, match=msg):
        run_units(paper000.one_run, args, campaign=camp)
    with pytest.raises(CampaignError, match=msg):
        open_runs(out)
    bad.unlink()
    with Campaign(out, "000", scn, 1) as camp:
        run_units(paper000.one_run, args, campaign=camp)
        assert (camp.computed, camp.reused) == (1, 1)
    for text in ("{not json", "[1, 2]"):
        (out / "campaign.json").write_text(text)
        with pytest.raises(CampaignError, match="campaign.json is not a fednav campaign "
                                                "manifest .*--fresh"):
            Campaign(out, "000", scn, 1)
        with pytest.raises(CampaignError, match="campaign.json is not a fednav campaign "):
            open_runs(out)
    assert Campaign(out, "000", scn, 1, fresh=True).manifest["seed"] == 1


def test_scheduler_address_nobody_listens_on_is_refused_at_once(monkeypatch):
    """Dask would retry a refused or unresolvable address for its whole 30 s timeout."""
    import socket

    from fednav.campaign.store import _start_client

    t0 = time.perf_counter()
    with pytest.raises(CampaignError, match="tcp://127.0.0.1:1: cannot connect .nothing "
                                            "listens on 127.0.0.1 port 1; start one"):
        _start_client("tcp://127.0.0.1:1", 1)
    assert time.perf_counter() - t0 < 20.0

    def no_host(*_, **__):
        raise socket.gaierror(socket.EAI_NONAME, "Name or service not known")

    monkeypatch.setattr(socket, "create_connection", no_host)
    with pytest.raises(CampaignError, match="cannot connect .host 'nohost': Name or service"):
        _start_client("tcp://nohost:8786", 1)


def _units(jobs=1, campaign=None):
    scn = paper000.load_scenario()
    return run_units(paper000.one_run, [(scn, s, 20.0) for s in (1, 2, 3)], jobs,
                     campaign=campaign)


@pytest.mark.slow
def test_local_dask_cluster_gives_identical_results(tmp_path):
    scn = paper000.load_scenario()
    a = _units(1)
    with Campaign(tmp_path, "000", scn, 1) as camp:
        b = _units(2, camp)
    assert camp.engine.startswith("dask local") and camp.computed == 3
    assert [r[0] for r in a] == [r[0] for r in b]


@pytest.mark.slow
def test_dask_scheduler_and_worker_subprocesses(tmp_path):
    bindir = Path(sys.executable).parent
    sfile = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([str(bindir / "dask"), "scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file",
                               str(sfile)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        for _ in range(100):
            if sfile.exists() and sfile.stat().st_size:
                break
            time.sleep(0.2)
        address = json.loads(sfile.read_text())["address"]
        procs.append(subprocess.Popen([str(bindir / "dask"), "worker", address,
                                       "--nthreads", "1", "--nworkers", "2",
                                       "--no-dashboard"], stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL))
        with Campaign(tmp_path / "c", "000", paper000.load_scenario(), 1,
                      address=address) as camp:
            b = _units(campaign=camp)
        assert camp.engine == f"dask {address}" and camp.computed == 3
        assert [r[0] for r in _units(1)] == [r[0] for r in b]
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(timeout=30)


@pytest.mark.slow
def test_kill_9_at_random_moments_then_resume_gives_identical_tables(tmp_path):
    """kill -9 a real `fednav reproduce` (and its process group) at several moments; every
    run file left behind is complete, and resuming gives the uninterrupted tables."""
    import os
    import signal

    whole = _reproduce(tmp_path / "whole")
    out = tmp_path / "killed"
    cmd = [str(Path(sys.executable).parent / "fednav"), "reproduce", "002", *ARGS,
           "--out", str(out)]
    rng = np.random.default_rng(0)
    kills = 0
    for _ in range(4):
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)
        n0 = len(list(out.glob("runs/*.nc")))
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(list(out.glob("runs/*.nc"))) == n0 \
                and p.poll() is None:
            time.sleep(0.02)
        # somewhere inside the next units or the writing of the outputs (after the first
        # file the units take 0.02-0.05 s each and the outputs about 1 s: a wait of up to
        # 1.5 s let the whole command finish first in 4 of 6 tries)
        time.sleep(rng.uniform(0.0, 0.3))
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            kills += 1
        p.wait()
        for f in out.glob("runs/*.nc"):       # whatever is there opens as a whole run
            _read_unit(f, out)                # (open_runs needs one with error series:
            assert f.stat().st_size > 0       # which are stored depends on the moment)
    assert kills >= 1
    s = _reproduce(out)
    assert s["campaign"]["runs_computed"] + s["campaign"]["runs_reused"] == 5
    assert _tables(s) == _tables(whole)


@pytest.mark.slow
def test_same_seed_bit_identical_outputs_with_one_or_two_workers(tmp_path):
    """Determinism: --jobs 1 (in-process) and --jobs 2 (Dask worker processes) write the
    same runs.csv digit for digit and the same summary tables (the wall-clock timing
    column ms_per_cycle aside).  Dask on a scheduler: test_dask_scheduler_and_worker_..."""
    a = _reproduce(tmp_path / "j1")
    r = CliRunner().invoke(app, ["reproduce", "002", "--runs", "2", "--max-time", "30",
                                 "--jobs", "2", "--out", str(tmp_path / "j2")])
    assert r.exit_code == 0, r.output
    b = json.loads((tmp_path / "j2" / "summary.json").read_text())
    assert b["campaign"]["engine"].startswith("dask local")
    assert _tables(a) == _tables(b)
    ra, rb = (pd.read_csv(tmp_path / d / "runs.csv", dtype=str).drop(columns="ms_per_cycle")
              for d in ("j1", "j2"))   # as text: every digit written must agree
    assert ra.equals(rb)


@pytest.mark.slow
def test_ctrl_c_ends_in_one_line_and_resume_computes_the_rest(tmp_path):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) during a run on
    local Dask workers: exit status 130, one line saying what is stored, no traceback from
    any worker, no process left; the same command then finishes the campaign."""
    import os
    import signal

    out = tmp_path / "c"
    # enough units of work that a warm kernel cache cannot finish them all between the
    # first stored run and the interrupt (8 units sometimes did)
    from fednav.scenarios import paper_module

    runs = 16
    exp = paper_module("002").EXPERIMENT
    units = len(exp.units(exp.load_scenario(), runs, 1, 60.0))
    cmd = [str(Path(sys.executable).parent / "fednav"), "reproduce", "002", "--runs",
           str(runs), "--max-time", "60", "--jobs", "2", "--out", str(out)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not list(out.glob("runs/*.nc")) \
            and p.poll() is None:
        time.sleep(0.02)
    assert p.poll() is None, "the campaign ended before it could be interrupted"
    os.killpg(p.pid, signal.SIGINT)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 130, stdout + stderr
    assert "Traceback" not in stdout + stderr
    assert stderr.strip().startswith("interrupted: ") and len(stderr.strip().splitlines()) == 1
    stored = len(list(out.glob("runs/*.nc")))
    told = int(stderr.split()[1])             # an interrupt between a file's rename and
    assert told in (stored, stored - 1)       # its count leaves one more file than told
    with pytest.raises(ProcessLookupError):
        os.killpg(p.pid, 0)                   # no worker outlived the interrupt
    r = CliRunner().invoke(app, ["reproduce", "002", "--runs", str(runs), "--max-time", "60",
                                 "--jobs", "1", "--out", str(out)])
    assert r.exit_code == 0, r.output
    s = json.loads((out / "summary.json").read_text())["campaign"]
    assert (s["runs_reused"], s["runs_computed"]) == (stored, units - stored)


def test_a_flight_too_short_for_a_table_ends_in_one_line(tmp_path):
    """Issue 27: `--max-time 0.5` ended in tracebacks (001, 003, 004: empty arrays),
    paper 002's observability table in a ValueError below its first 10 s segment, and
    `--seed -1` in numpy's ValueError."""
    for paper, max_time, why in (("003", "0.5", "--max-time must be at least 1 s"),
                                 ("002", "5", "observability table needs at least its "
                                              "first flight segment")):
        r = CliRunner().invoke(app, ["reproduce", paper, "--runs", "1", "--max-time",
                                     max_time, "--jobs", "1", "--out", str(tmp_path / paper)])
        assert r.exit_code == 2 and why in r.output, r.output
    # seeds outside 0 .. 2^63-1 (numpy's own ValueError surfaced for -1)
    for seed, runs in (("-1", "1"), (str(2**63 - 1), "2"), (str(2**64), "1")):
        r = CliRunner().invoke(app, ["reproduce", "002", "--seed", seed, "--runs", runs,
                                     "--out", str(tmp_path / "s")])
        assert r.exit_code == 2 and "--seed must be 0 .. 2^63-1" in r.output, r.output


@pytest.mark.slow
def test_dask_pointing_at_a_non_dask_server_fails_in_one_line(tmp_path):
    """Issue 27: `--dask tcp://HOST:PORT` at an HTTP server (the dashboard's port, say)
    waited forever: Dask's connect timeout does not cover its handshake."""
    import http.server
    import threading
    import time

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                             http.server.SimpleHTTPRequestHandler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        t0 = time.monotonic()
        r = CliRunner().invoke(app, ["reproduce", "002", "--runs", "1", "--max-time", "30",
                                     "--dask", f"tcp://127.0.0.1:{server.server_port}",
                                     "--out", str(tmp_path / "d")])
        assert time.monotonic() - t0 < 15.0
        assert r.exit_code == 2 and "is not a Dask scheduler (it sent nothing" in r.output
    finally:
        server.shutdown()


@pytest.mark.slow
def test_a_stored_run_of_another_campaign_is_refused_not_used(tmp_path):
    """Issue 27: a stored run file replaced by one from another seed's campaign was used
    silently (the tables changed); each run file now carries its work key."""
    a, b = tmp_path / "a", tmp_path / "b"
    for out, seed in ((a, "1"), (b, "5")):
        r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--seed", seed,
                                     "--out", str(out)])
        assert r.exit_code == 0, r.output
    runs_a = sorted((a / "runs").iterdir())
    runs_b = sorted((b / "runs").iterdir())
    victim = next(f for f in runs_a if f.name not in {g.name for g in runs_b})
    victim.write_bytes(runs_b[0].read_bytes())
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--seed", "1", "--out", str(a)])
    assert r.exit_code == 2 and f"stored run {victim.name} is another run's" in r.output


def test_a_stored_run_of_another_fednav_version_is_refused_not_used(tmp_path):
    """Issue 27: each stored run carries its scenario hash and fednav version, verified
    when it is reused (a run made by another version is refused in one line naming the
    file, and so is a campaign folder made by another version)."""
    import json

    import xarray as xr

    out = tmp_path / "a"
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--out", str(out)])
    assert r.exit_code == 0, r.output
    victim = sorted((out / "runs").glob("*.nc"))[0]
    with xr.open_dataset(victim, engine="scipy") as ds:
        ds = ds.load()
    assert {"fednav_work_key", "fednav_scenario_hash", "fednav_version"} <= set(ds.attrs)
    ds.attrs["fednav_version"] = "0.0.1"
    victim.write_bytes(bytes(ds.to_netcdf(engine="scipy")))
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert f"stored run {victim.name} was made with version 0.0.1" in r.output
    assert "Traceback" not in r.output
    victim.unlink()
    manifest = json.loads((out / "campaign.json").read_text())
    (out / "campaign.json").write_text(json.dumps({**manifest, "fednav_version": "0.0.1"}))
    r = CliRunner().invoke(app, ["reproduce", "002", *ARGS, "--out", str(out)])
    assert r.exit_code == 2 and "made with fednav_version 0.0.1" in r.output


@pytest.mark.slow
def test_dask_pointing_at_a_silent_server_fails_in_one_line_within_10_s(tmp_path):
    """A TCP server that accepts and never sends (Dask would wait for its handshake
    forever): one line, exit 2, within 10 s."""
    import socket
    import threading

    srv = socket.create_server(("127.0.0.1", 0))
    conns = []

    def accept():
        while True:
            try:
                conns.append(srv.accept()[0])     # accepted, never answered
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    try:
        t0 = time.monotonic()
        r = CliRunner().invoke(app, ["reproduce", "002", "--runs", "1", "--max-time", "30",
                                     "--dask", f"tcp://127.0.0.1:{srv.getsockname()[1]}",
                                     "--out", str(tmp_path / "d")])
        assert time.monotonic() - t0 < 10.0
        assert r.exit_code == 2, r.output
        (line,) = r.output.strip().splitlines()
        assert line.startswith("error: Dask scheduler tcp://127.0.0.1:") and \
            "is not a Dask scheduler (it sent nothing within 5 s" in line
    finally:
        srv.close()
        for c in conns:
            c.close()


def test_fresh_removes_only_the_run_files(tmp_path):
    """`--fresh` empties runs/ of run files (and temporary ones), not of a user's file."""
    scn = paper000.load_scenario()
    out = tmp_path / "c"
    with Campaign(out, "000", scn, 1) as camp:
        run_units(paper000.one_run, [(scn, 1, 5.0)], campaign=camp)
    (out / "runs" / "notes.txt").write_text("mine")
    (out / "runs" / ".x.nc.123.tmp").write_text("half")
    Campaign(out, "000", scn, 1, fresh=True)
    assert [f.name for f in (out / "runs").iterdir()] == ["notes.txt"]


@pytest.mark.slow
def test_a_folder_holding_more_runs_than_asked_says_so_and_reports_on_all(tmp_path):
    """Issue 29: re-running into a 3-run folder with --runs 2 used to replace the 3-run
    tables with 2-run tables without a word; it now says so and reports on all 3 stored
    runs (reusing them), unless --fresh starts over."""
    out = tmp_path / "c"
    args = ["reproduce", "003", "--max-time", "10", "--jobs", "1", "--out", str(out)]
    r = CliRunner().invoke(app, [*args, "--runs", "3"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, [*args, "--runs", "2"])
    assert r.exit_code == 0, r.output
    assert "holds 3 Monte Carlo runs, more than --runs 2" in r.output
    s = json.loads((out / "summary.json").read_text())
    assert s["runs"] == 3 and s["campaign"]["runs_reused"] == 3
    assert s["campaign"]["runs_computed"] == 0
    r = CliRunner().invoke(app, [*args, "--runs", "4"])  # more than stored: computes one
    assert r.exit_code == 0 and "more than --runs" not in r.output
    assert json.loads((out / "summary.json").read_text())["campaign"]["runs_computed"] == 1
    r = CliRunner().invoke(app, [*args, "--runs", "2", "--fresh"])
    assert r.exit_code == 0 and "more than --runs" not in r.output
    assert json.loads((out / "summary.json").read_text())["runs"] == 2


def test_a_stop_inside_a_gc_callback_or_finalizer_is_sent_again():
    """A signal whose handler runs inside a garbage-collector callback (Dask's GC
    diagnostics) or a ``__del__``: Python would print and drop the exception the stop
    raises there, so the stop is sent again once the stack is out of it."""
    import gc
    import sys

    from fednav.cli import _in_c_callback

    seen = []

    def callback(phase, info):
        if phase == "start":
            seen.append(sys._getframe())

    class Finalized:
        def __del__(self):
            seen.append(sys._getframe())

    gc.callbacks.append(callback)
    try:
        gc.collect()
        assert seen and _in_c_callback(seen[-1])
    finally:
        gc.callbacks.remove(callback)
    Finalized()
    assert _in_c_callback(seen[-1]) and seen[-1].f_code.co_name == "__del__"
    assert not _in_c_callback(sys._getframe())
