"""Figures drawn beside the work: processes forked before a command reads its data, which
load matplotlib and draw once while the command reads and filters, then draw the
command's figures (one each, side by side) while it writes its other files.

A ``fednav process`` spent about a third of its wall time on its plots, most of it
before the first line was drawn: importing matplotlib (0.3 s) and its first figure's fonts
and renderer (0.3 s).  Beside the work these cost nothing where a second processor is
free.  Where none is, where ``fork`` is not the platform's way to start a process
(Windows; macOS, where it is unsafe), or where the caller already runs threads (a fork
copies no thread but the caller's, and a lock another one held would never be freed), the
figures are drawn in the caller as before: the files are the same either way.

A job is a picklable function and its arguments (a module's function, data arrays); its
result (the path written) or its exception comes back to :meth:`Drawer.result`.  A worker
that died (killed, out of memory) leaves its jobs to the caller.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable


def warm_up(preload: tuple[str, ...] = ()) -> None:
    """Import matplotlib and render one small figure with text, a legend and a PNG: what a
    process's first figure pays once (fonts, the Agg renderer, the PNG writer); then
    import the modules named in ``preload`` (those of the jobs to come)."""
    import importlib
    import io

    from .plots import new_figure

    fig, ax = new_figure(figsize=(2, 2))
    ax[0, 0].plot([0.0, 1.0], [0.0, 1.0], label="a")
    ax[0, 0].set_xlabel("east [m]")
    ax[0, 0].legend()
    fig.savefig(io.BytesIO(), format="png", dpi=40)
    for name in preload:
        importlib.import_module(name)


def _serve(conn, preload: tuple[str, ...]) -> None:
    """The worker's loop: warm up, then run each job received until None or the end of
    the pipe; send back ``(True, result)`` or ``(False, exception)``.  Ctrl-C is the
    caller's to handle (it ends the worker); SIGTERM and SIGHUP end it at once, not
    through the handlers it inherited."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    try:
        warm_up(preload)
    except Exception:  # (a job will meet the same problem and report it)
        pass
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        fn, args = job
        try:
            out = (True, fn(*args))
        except BaseException as e:  # noqa: BLE001 (every failure goes back to the caller)
            out = (False, e)
        try:
            conn.send(out)
        except Exception:  # (an exception that does not pickle: its text does)
            conn.send((False, RuntimeError(f"{type(out[1]).__name__}: {out[1]}")))


def can_fork() -> int:
    """How many drawing processes to fork here: none unless ``fork`` is this platform's
    start method (Linux), a second processor is ours and the caller runs no other thread;
    else one per processor beside the caller's, at most :data:`MOST_WORKERS` (on two
    processors a second worker's start slowed the caller's work more than its drawing
    saved: ``fednav process`` 0.99x against 0.87x the serial wall time with one)."""
    if sys.platform != "linux" or threading.active_count() > 1:
        return 0
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    return min(cpus - 1, MOST_WORKERS)


#: the most drawing processes (``fednav process`` draws two plots, three or four with
#: integrity or a second reference)
MOST_WORKERS = 2


class _Worker:
    """One forked drawing process: its pipe, the jobs it holds (numbers, in order) and
    the thread sending the last one."""

    def __init__(self, preload: tuple[str, ...]):
        import multiprocessing as mp
        import signal

        ctx = mp.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_serve, args=(child, preload), daemon=True,
                                name="fednav-drawer")
        try:  # (born ignoring Ctrl-C: one in its first instant would otherwise kill it)
            old = signal.signal(signal.SIGINT, signal.SIG_IGN)
        except ValueError:  # (not the main thread)
            old = None
        try:
            self.proc.start()
        finally:
            if old is not None:
                signal.signal(signal.SIGINT, old)
        child.close()
        self.held: list[int] = []
        self.sender: threading.Thread | None = None

    def send(self, k: int, job: tuple) -> None:
        self.held.append(k)
        prev, proc, conn = self.sender, self.proc, self.conn

        def send():
            if prev is not None:
                prev.join()
            try:
                conn.send(job)
            except Exception:  # (gone, or a job that does not pickle: its jobs are then
                proc.kill()    # drawn in the caller, the worker's end read as its death)

        self.sender = threading.Thread(target=send, daemon=True)
        self.sender.start()

    def receive(self) -> tuple | None:
        """The next job's ``(ok, value)``; None when the worker is gone."""
        try:
            while not self.conn.poll(0.2):
                if not self.proc.is_alive():
                    return None
            return self.conn.recv()
        except (EOFError, OSError):
            return None

    def stop(self, kill: bool) -> None:
        if self.sender is not None:
            self.sender.join(timeout=0.0 if kill else None)
        if kill:
            self.proc.kill()
        else:
            try:
                self.conn.send(None)
            except (OSError, ValueError):
                pass
        self.proc.join()
        self.conn.close()


class Drawer:
    """Draws figures in processes forked now (:func:`can_fork` of them, or ``workers``),
    else in the caller; each imports the modules named in ``preload`` while it waits (the
    jobs' own).

    ``submit(fn, *args)`` hands a job to the worker holding the fewest and returns at once
    (a thread sends it); ``result(job)`` waits for what it gave and raises what it raised.
    ``close()`` ends the workers (after their jobs), ``abort()`` kills them.
    """

    def __init__(self, workers: int | None = None, preload: tuple[str, ...] = ()):
        self._jobs: list = []
        self._done: dict[int, tuple] = {}
        self._owner: dict[int, _Worker] = {}
        n = can_fork() if workers is None else workers
        self._workers = [_Worker(tuple(preload)) for _ in range(n)]

    @property
    def forked(self) -> int:
        """How many worker processes draw the figures (0: the caller)."""
        return len(self._workers)

    def submit(self, fn: Callable, *args) -> int:
        """Hand ``fn(*args)`` over; its number for :meth:`result`."""
        self._jobs.append((fn, args))
        k = len(self._jobs) - 1
        if not self._workers:
            self._done[k] = self._run_here(fn, args)
            return k
        w = min(self._workers, key=lambda w: len(w.held))
        self._owner[k] = w
        w.send(k, (fn, args))
        return k

    @staticmethod
    def _run_here(fn, args) -> tuple:
        try:
            return True, fn(*args)
        except Exception as e:  # noqa: BLE001 (raised again by result())
            return False, e

    def result(self, k: int):
        """What job ``k`` returned (raising what it raised); waits for it."""
        w = self._owner.get(k)
        while k not in self._done:
            got = w.receive()
            if got is None:  # (it died: the jobs it held and did not give are drawn here)
                self._workers.remove(w)
                w.stop(kill=True)
                for j in w.held:
                    self._done[j] = self._run_here(*self._jobs[j])
                w.held.clear()
                break
            self._done[w.held.pop(0)] = got
        ok, value = self._done[k]
        if not ok:
            raise value
        return value

    def close(self) -> None:
        """End the workers once their jobs are done."""
        self._stop(kill=False)

    def abort(self) -> None:
        """End the workers now (the command failed)."""
        self._stop(kill=True)

    def _stop(self, kill: bool) -> None:
        workers, self._workers = self._workers, []
        for w in workers:
            w.stop(kill)

    def __enter__(self) -> Drawer:
        return self

    def __exit__(self, kind, value, tb) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()
