"""A first run's kernels compiled by two processes: the plan of what a command compiles.

numba compiles a kernel's callees while it types the kernel, one after the other: the
navigator's engine (``run_epochs``) compiles some ninety functions in one process, and
the two workers of a campaign each compile all of them at the same time.  A *plan* is
the list of fednav kernels, with their argument types, that a command compiled on a
fresh kernel cache, in the order numba started them (:func:`record`).  On a first run
one worker flies its unit (numba going down from the top kernel) while another compiles
the plan from its end (:func:`compile_plan`, from the leaves up), each saving what it
compiled in the shared kernel cache and loading what the other saved there; the two meet
in the middle, and the first worker then compiles the top kernel alone.

A plan is a pickle of numba types kept beside this module (``kernel_plans/NAME.pkl``),
recorded by ``python tests/make_kernel_plan.py NAME`` (on an empty kernel cache) and
checked by the test suite (``tests/test_kernel_plan.py``: a plan that no longer matches
what its command compiles is reported stale).  A plan recorded with another version of
numba is not used (:func:`load`); an entry that cannot be read or compiled is skipped;
an entry whose argument types the command no longer uses compiles a specialisation
nobody calls — time lost on the plan's worker, never a result changed (the command
compiles what it calls itself).
"""

from __future__ import annotations

import importlib
import os
import pickle
from contextlib import contextmanager
from pathlib import Path

#: Where the plans are kept.
PLANS = Path(__file__).resolve().parent / "kernel_plans"
#: Kernels a plan does not compile: the top ones (each command's own, compiled by the
#: worker that flies it: they hold every callee, and the plan's worker would only compile
#: them a second time).
TOPS = {("fednav.navigator.engine", "run_epochs")}
#: True while :func:`record` runs (no plan compiled beside the command it records: the
#: command would load what the plan compiled, and the record would miss it).
_recording = False


def record(run) -> list[tuple]:
    """Call ``run()`` (e.g. a command, in this process) and return the fednav kernels
    numba compiled for it, as (module, the module's name for the kernel, argument types),
    in the order numba started them (kernels no module names — numba overloads — left
    out: their callers compile them).  Meant for a process whose kernel cache is
    empty."""
    import sys

    from numba.core import event

    order: list[tuple] = []

    class Listener(event.Listener):
        def on_start(self, ev):
            d = ev.data.get("dispatcher")
            module = getattr(getattr(d, "py_func", None), "__module__", "")
            if not module.startswith("fednav."):
                return
            # (the compiled form of a Python function has a name of its own: radii_nb)
            name = next((k for k, v in vars(sys.modules[module]).items() if v is d), None)
            if name is not None:
                order.append((module, name, tuple(ev.data["args"])))

        def on_end(self, ev):
            pass

    global _recording
    listener = Listener()
    event.register("numba:compile", listener)
    _recording = True
    try:
        run()
    finally:
        _recording = False
        event.unregister("numba:compile", listener)
    return list(dict.fromkeys(order))  # (each kernel once, in order)


def _kept(name: str) -> dict | None:
    try:
        with open(PLANS / f"{name}.pkl", "rb") as fh:
            kept = pickle.load(fh)
        return {"numba": kept["numba"], "kernels": kept["kernels"]}
    except Exception:  # (none, or written by a numba that cannot be read here)
        return None


def recorded_with(name: str) -> str | None:
    """The version of numba that recorded plan ``name`` (None: no readable plan)."""
    kept = _kept(name)
    return None if kept is None else kept["numba"]


def load(name: str) -> list[tuple] | None:
    """The plan ``name``'s kernels; None when there is none, or it was recorded with
    another version of numba (which may compile other helpers, or type arguments
    otherwise: a worker would compile kernels that nobody calls)."""
    import numba

    kept = _kept(name)
    if kept is None or kept["numba"] != numba.__version__:
        return None
    return kept["kernels"]


def _index_of(module: str, name: str) -> Path | None:
    """Where numba keeps the index of kernel ``module.name``'s cached machine code (None:
    this numba does not say)."""
    try:
        kernel = getattr(importlib.import_module(module), name)
        return Path(kernel._cache._cache_file._index_path)
    except Exception:
        return None


def needed() -> bool:
    """Whether a plan would help now: none of the top kernels (:data:`TOPS`) is in
    numba's kernel cache yet (a first run of this source tree); False when numba does not
    say where its cache is, or while a plan is recorded."""
    if _recording:
        return False
    paths = [_index_of(*top) for top in TOPS]
    return all(p is not None and not p.exists() for p in paths)


def compile_plan(name: str, stop=None) -> int:
    """Compile plan ``name`` from its end (the leaves first), each kernel saved in the
    kernel cache or loaded from it where another process saved it first; the top kernels
    (:data:`TOPS`) left to the process that flies the command.  ``stop()`` (optional),
    asked before each kernel: True gives up (the command is done).  Returns how many
    entries were compiled or loaded (0: no plan)."""
    plan = load(name) or []
    done = 0
    for module, qualname, types in reversed(plan):
        if (module, qualname) in TOPS:
            continue
        if stop is not None and stop():
            break
        try:
            kernel = getattr(importlib.import_module(module), qualname)
            kernel.compile(types)
        except Exception:  # (a plan older than the code: that entry is of no use)
            continue
        done += 1
    return done


@contextmanager
def beside(name: str):
    """While the block runs, a second process compiles plan ``name`` (on a first run:
    :func:`needed`; and only where this process may use more than one CPU): for a command
    that flies in one process.  The process is stopped when the block ends (numba writes
    each cached kernel whole, under a temporary name first)."""
    import subprocess
    import sys

    proc = None
    cpus = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
            else os.cpu_count() or 1)
    if cpus > 1 and load(name) and needed():
        proc = subprocess.Popen(
            [sys.executable, "-c", "from fednav.campaign.kernel_plan import compile_plan; "
                                   f"compile_plan({name!r})"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        yield proc
    finally:
        if proc is not None and proc.poll() is None:
            proc.terminate()
            proc.wait()


def write(name: str, plan: list[tuple]) -> Path:
    """Keep ``plan`` (:func:`record`) as plan ``name``, with numba's version."""
    import numba

    PLANS.mkdir(exist_ok=True)
    path = PLANS / f"{name}.pkl"
    path.write_bytes(pickle.dumps({"numba": numba.__version__, "kernels": plan},
                                  protocol=4))
    return path
