"""Where a whole ``fednav process`` command's wall time goes: start-up, read, filter,
write (files and plots).

    python benchmarks/process_phases.py [--repeat 3] -- csv --imu imu.csv --gnss gnss.csv \\
        [--ref reference.csv] [--config process.yaml] --out OUT
    python benchmarks/process_phases.py -- kfgins FOLDER --out OUT

Each repetition is a fresh process (start-up is one of the phases) that runs the command
as ``fednav process ...`` does, with the time stamped where a phase begins and ends:

* **start-up** — from the interpreter's start to the first file read (imports, the
  command line, the system description);
* **read** — the reader of the first file to the last one's end;
* **filter** — ``fednav.process.run.process`` (checks, alignment, the noise
  identification's passes, the filter, the IMU-rate solution, the health monitor; the
  numba kernels are loaded here);
* **write** — ``fednav.process.output.write``: the solution, errors and summary files, and
  the plots (drawn beside the work where ``fednav.core.drawer`` forks its worker: then
  this is the waiting for them);
* **total** — to the command's end, as the user waits for it.

The median of each phase over ``--repeat`` runs is printed, every run's line before it.
(The stamps import the modules they wrap before the command starts, as the command
imports them before its first read; its drawing worker, forked first, finds them
imported.)
Run ``PYTHONPATH=OTHER/src python benchmarks/process_phases.py ...`` for another
checkout's figures (a worktree of an earlier commit: before and after on one machine).
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

#: what the child runs: the command with its phases stamped
CHILD = r"""
import json, sys, time
T0 = time.perf_counter()
marks = {}
import importlib

def stamp(modname, fname, key):
    m = importlib.import_module(modname)
    f = getattr(m, fname)

    def g(*a, **k):
        marks.setdefault(key + "_start", time.perf_counter() - T0)
        try:
            return f(*a, **k)
        finally:
            marks[key + "_end"] = time.perf_counter() - T0
    setattr(m, fname, g)

stamp("fednav.io.csvdata", "_read", "read")
stamp("fednav.io.kfgins", "read_table", "read")
stamp("fednav.process.run", "process", "filter")
stamp("fednav.process.output", "write", "write")
from fednav.cli import app
sys.argv = ["fednav", "process"] + json.loads(sys.argv[1])
try:
    app(prog_name="fednav")
except SystemExit as e:
    if e.code:
        raise
marks["total"] = time.perf_counter() - T0
print("PHASES " + json.dumps(marks))
"""

PHASES = ("start-up", "read", "filter", "write", "total")


def phases(m: dict) -> dict[str, float]:
    return {"start-up": m["read_start"], "read": m["read_end"] - m["read_start"],
            "filter": m["filter_end"] - m["filter_start"],
            "write": m["write_end"] - m["write_start"], "total": m["total"]}


def run_once(args: list[str]) -> dict[str, float]:
    r = subprocess.run([sys.executable, "-c", CHILD, json.dumps(args)], capture_output=True,
                       text=True)
    line = [s for s in r.stdout.splitlines() if s.startswith("PHASES ")]
    if r.returncode or not line:
        raise SystemExit(f"fednav process {' '.join(args)} failed (exit {r.returncode}): "
                         f"{(r.stderr or r.stdout).strip()[-2000:]}")
    return phases(json.loads(line[-1][len("PHASES "):]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("command", nargs=argparse.REMAINDER,
                    help="-- then the arguments of `fednav process`")
    a = ap.parse_args()
    args = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not args:
        ap.error("give the arguments of `fednav process` after --")
    run_once(args)  # (warm: a first run may compile the kernels)
    runs = [run_once(args) for _ in range(a.repeat)]
    for r in runs:
        print("  " + "  ".join(f"{k} {r[k]:.2f}" for k in PHASES))
    med = {k: statistics.median(r[k] for r in runs) for k in PHASES}
    print("median " + "  ".join(f"{k} {med[k]:.2f} s" for k in PHASES))


if __name__ == "__main__":
    main()
