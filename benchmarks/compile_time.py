"""The compile part of a first run (issue 39): ``fednav reproduce 002`` cold and warm.

    python benchmarks/compile_time.py [--pairs 2] [--baseline SRC] [--events]

Each pair runs the README main command twice in fresh processes with an empty
``NUMBA_CACHE_DIR`` (cold: every kernel compiled) and then the same folder (warm: every
kernel loaded), each into a fresh output folder; the compile part is cold - warm.  With
``--baseline SRC`` (another checkout's ``src`` folder, e.g. a ``git worktree``) the pairs
alternate between this checkout and that one.  ``--events``: one process flying
``reproduce 002 --runs 2 --jobs 1`` with numba's compile events, each function's own
compile time (its callees' taken out), the largest first.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"

EVENTS = """
import collections, time
from numba.core import event
import fednav  # (its numba settings)
own, stack = collections.defaultdict(float), []
class Listener(event.Listener):
    def on_start(self, e):
        d = e.data.get("dispatcher")
        stack.append((d.py_func.__qualname__ if d is not None else "?", time.perf_counter(), []))
    def on_end(self, e):
        name, t0, kids = stack.pop()
        dt = time.perf_counter() - t0
        own[name] += dt - sum(kids)
        if stack:
            stack[-1][2].append(dt)
event.register("numba:compile", Listener())
from typer.testing import CliRunner
from fednav.cli import app
r = CliRunner().invoke(app, ["reproduce", "002", "--runs", "2", "--jobs", "1", "--fresh",
                             "--out", OUT])
assert r.exit_code == 0, r.output
print(f"compiling (own times) {sum(own.values()):.1f} s")
for k, v in sorted(own.items(), key=lambda x: -x[1])[:20]:
    print(f"{v:7.1f} s  {k}")
"""


def _run(src: Path, cache: Path, out: Path) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(src))
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "fednav", "reproduce", "002", "--fresh", "--out",
                    str(out)], env=env, check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=2)
    ap.add_argument("--baseline", type=Path, default=None)
    ap.add_argument("--events", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.events:
            env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "events-cache"),
                       PYTHONPATH=str(SRC))
            subprocess.run([sys.executable, "-c",
                            f"OUT = {str(tmp / 'events-out')!r}\n" + EVENTS],
                           env=env, check=True)
            return
        codes = [("this", SRC)] + ([("baseline", args.baseline.resolve())]
                                   if args.baseline else [])
        print(f"{'code':>9} {'cold [s]':>9} {'warm [s]':>9} {'compile part [s]':>17}")
        for i in range(args.pairs):
            for name, src in codes:
                cache, out = tmp / f"cache-{name}-{i}", tmp / f"out-{name}-{i}"
                cold, warm = _run(src, cache, out), _run(src, cache, out)
                print(f"{name:>9} {cold:9.1f} {warm:9.1f} {cold - warm:17.1f}")


if __name__ == "__main__":
    main()
