"""Where a whole ``fednav process`` command's time goes: start-up, reading, processing,
writing, plots — and the same command's wall time against KF-GINS's on the same folder.

    python benchmarks/process_breakdown.py FOLDER_OR_ARGS... [--repeat 3] [--kfgins BIN]

``FOLDER_OR_ARGS``: the arguments after ``fednav process`` (e.g. ``kfgins DIR``, or
``csv --imu imu.csv --gnss gnss.csv``), run whole as a user runs them (a fresh
interpreter each time, ``--out`` a temporary folder).  Each run is timed by a harness
that wraps the command's stages in the same process (imports until the command starts;
the reader; :func:`fednav.process.run.process`; the solution files; the plots; the rest
of the writing) and by the wall clock around the process.  With ``--kfgins`` (and a
``kfgins DIR`` command) KF-GINS runs on the same folder, alternated, best of each.

Issue 39's target: the whole process at most KF-GINS's wall time.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

#: The harness run in the timed interpreter: stage timers around the command's parts,
#: then fednav's own entry point; the stages written as JSON to $FEDNAV_BREAKDOWN.
HARNESS = r"""
import json, os, sys, time, atexit
T0 = time.perf_counter()
stages = {}
def timed(mod, name, key):
    f = getattr(mod, name)
    def wrapper(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            stages[key] = stages.get(key, 0.0) + time.perf_counter() - t
    setattr(mod, name, wrapper)
import fednav.cli as cli
import fednav.process.run as run
import fednav.process.output as output
first = {}
orig_run_process = cli._run_process
def run_process(read, *a, **k):
    first.setdefault("start", time.perf_counter() - T0)
    def timed_read(cfg):
        t = time.perf_counter()
        try:
            return read(cfg)
        finally:
            stages["read"] = time.perf_counter() - t
    return orig_run_process(timed_read, *a, **k)
cli._run_process = run_process
timed(run, "process", "process")
timed(output, "write", "write (all)")
timed(output, "write_solution", "solution files")
for name in ("plot_track", "plot_errors", "plot_stanford"):
    if hasattr(output, name):
        timed(output, name, "plots")
def report():
    stages["start-up (imports)"] = first.get("start", float("nan"))
    stages["total in-process"] = time.perf_counter() - T0
    Path = __import__("pathlib").Path
    Path(os.environ["FEDNAV_BREAKDOWN"]).write_text(json.dumps(stages))
atexit.register(report)
sys.argv = ["fednav"] + sys.argv[1:]
from fednav.__main__ import main
main()
"""

ORDER = ("start-up (imports)", "read", "process", "solution files", "plots", "write (all)",
         "total in-process")


def fednav_once(args: list[str], work: Path) -> dict:
    out = work / f"out-{time.monotonic_ns()}"
    rec = work / "stages.json"
    env = {**os.environ, "FEDNAV_BREAKDOWN": str(rec)}
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", HARNESS, "process", *args, "--out", str(out)],
                       capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"fednav process {' '.join(args)} failed: {r.stderr[-2000:]}")
    stages = json.loads(rec.read_text())
    stages["wall"] = wall
    return stages


def kfgins_once(binary: str, folder: Path, work: Path) -> float:
    cfg = yaml.safe_load((folder / "kf-gins.yaml").read_text())
    Path(cfg["outputpath"]).mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    subprocess.run([binary, "kf-gins.yaml"], cwd=folder, capture_output=True, check=True)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--kfgins", default=os.environ.get("KFGINS_BIN"))
    a, args = ap.parse_known_args()  # (the rest: fednav process's arguments)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        fednav_once(args, work)  # (warm: kernels compiled and cached)
        runs, kf = [], []
        for _ in range(a.repeat):
            if a.kfgins and args[0] == "kfgins":
                kf.append(kfgins_once(a.kfgins, Path(args[1]), work))
            runs.append(fednav_once(args, work))
    best = min(runs, key=lambda s: s["wall"])
    print(f"fednav process {' '.join(args)}: best of {a.repeat} (by wall)")
    for k in (*ORDER, "wall"):
        print(f"  {k:22s} {best.get(k, float('nan')):6.2f} s")
    if kf:
        print(f"  KF-GINS wall           {min(kf):6.2f} s   ratio fednav/KF-GINS "
              f"{best['wall'] / min(kf):.2f}")


if __name__ == "__main__":
    main()
