"""The drawing process: jobs run in a forked worker come back as they would have run in the
caller — their results in order, their exceptions raised — and a worker that cannot take a
job, or dies, leaves the jobs to the caller."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from fednav.core.drawer import Drawer, can_fork

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="fork: Linux only")


def pid_and(x):
    return os.getpid(), x


def fails(message):
    raise ValueError(message)


def write(path, text):
    Path(path).write_text(text)
    return Path(path)


def test_jobs_run_in_the_worker_in_order_and_raise_what_they_raise(tmp_path):
    with Drawer(workers=1) as d:
        assert d.forked
        a = d.submit(pid_and, 1)
        b = d.submit(fails, "no such axis")
        c = d.submit(write, tmp_path / "f.txt", "drawn")
        pid, x = d.result(a)
        assert pid != os.getpid() and x == 1  # (drawn in the worker)
        with pytest.raises(ValueError, match="no such axis"):
            d.result(b)
        assert d.result(c).read_text() == "drawn"
    assert not d.forked  # (closed)


def test_jobs_go_to_the_worker_holding_the_fewest():
    with Drawer(workers=2) as d:
        ks = [d.submit(pid_and, i) for i in range(4)]
        pids = [d.result(k)[0] for k in ks]
        assert [d.result(k)[1] for k in ks] == [0, 1, 2, 3]
        assert pids[0] == pids[2] != pids[1] == pids[3]


def test_a_job_that_does_not_pickle_is_run_here():
    with Drawer(workers=1) as d:
        k = d.submit(lambda v: (os.getpid(), v), 7)
        assert d.result(k) == (os.getpid(), 7)


def test_a_dead_worker_leaves_its_jobs_to_the_caller():
    with Drawer(workers=1) as d:
        d._workers[0].proc.kill()
        k = d.submit(pid_and, 3)
        assert d.result(k) == (os.getpid(), 3)


def test_without_fork_the_jobs_run_at_once_in_the_caller():
    d = Drawer(workers=0)
    k = d.submit(pid_and, 2)
    assert not d.forked and d.result(k) == (os.getpid(), 2)
    d.close()


def test_an_aborted_drawer_ends_its_worker():
    d = Drawer(workers=2)
    procs = [w.proc for w in d._workers]
    d.abort()
    assert not any(p.is_alive() for p in procs)


def test_no_fork_beside_other_threads(monkeypatch):
    import threading

    monkeypatch.setattr(threading, "active_count", lambda: 2)
    assert can_fork() == 0


def test_process_outputs_drawn_in_the_worker_are_the_callers(tmp_path):
    """``fednav process``'s files written with the plots drawn in the worker: the same
    files, in the same order, byte for byte, as drawn in the caller."""
    from test_process import make_flight

    from fednav.process import output, process

    imu, gnss, ref = make_flight()
    res = process(imu, {"gnss": gnss})
    got = {}
    for workers in (2, 0):
        out = tmp_path / str(workers)
        with Drawer(workers, preload=("fednav.process.output",)) as d:
            assert d.forked == workers
            files = output.write(out, res, ref, {}, None, gnss, drawer=d)
        got[workers] = [(f.name, f.read_bytes()) for f in files]
    assert [n for n, _ in got[2]] == [n for n, _ in got[0]]
    assert {"track.png", "errors.png", "summary.json"} <= {n for n, _ in got[2]}
    for (name, a), (_, b) in zip(got[2], got[0], strict=True):
        assert a == b, name


def sleep_then(x):
    import time

    time.sleep(0.5)
    return os.getpid(), x


def test_ctrl_c_is_the_callers_and_sigterm_ends_the_worker_quietly(capfd):
    """The worker ignores SIGINT (the command's Ctrl-C ends it through abort) and dies of
    SIGTERM without a traceback; its jobs then run in the caller."""
    import signal

    with Drawer(workers=1) as d:
        k = d.submit(sleep_then, 5)
        pid = d._workers[0].proc.pid
        os.kill(pid, signal.SIGINT)  # (at once: the worker is born ignoring it)
        assert d.result(k) == (pid, 5)  # (drawn by the worker, Ctrl-C notwithstanding)
        j = d.submit(pid_and, 6)
        os.kill(pid, signal.SIGTERM)
        got = d.result(j)
        assert got[1] == 6
    assert "Traceback" not in capfd.readouterr().err
