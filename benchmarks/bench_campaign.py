"""Campaign speed (run by hand: ``python benchmarks/bench_campaign.py [--runs N]``).

Prints, for paper 002 (1200 s flight, four modes: SINS, SINS/SAR, SINS/CNS,
SINS/CNS/SAR with federated UKF local filters):

* seconds per Monte Carlo run of fednav, one core, warm;
* the seconds FilterPy's UKF needs for **the same filter steps** of that run — every
  predict and update fednav's local filters made, replayed through
  ``filterpy.kalman.UnscentedKalmanFilter`` with the same sigma-point settings, the same
  process (fednav's compiled error transition, called per sigma point as FilterPy does)
  and the same measurement functions — measured in this invocation; and the ratio;
* FilterPy's 14 400 bare 16-state UKF steps (a linear process, three position-like
  measurements), and the campaign's wall time as a ratio to them (issue 39's yardstick);
* the wall time of an N-run campaign with the default local Dask workers, the CPU seconds
  of its parent process and of its workers, its serial parts (before the workers start,
  after the last unit), and the import time of the command line.

Ratios only: nothing here is asserted in tests.
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

import numpy as np


def record_steps(scn, seed):
    """Run one Monte Carlo run of paper 002 through the navigator's Python loop (the
    compiled engine makes the same steps without calling the filter classes) and record
    every UKF step it made; returns (seconds of that run, steps)."""
    import os

    from fednav.filters.ukf import UnscentedKalmanFilter as UKF
    from fednav.scenarios import paper002

    steps = []
    predict, update = UKF.predict, UKF.update

    def rec_predict(self, process, q_scale=1.0):
        steps.append(("p", id(self), self.x.copy(), self.P.copy(), process, q_scale))
        return predict(self, process, q_scale)

    def rec_update(self, y, model, nav=None, R=None, gate=None):
        steps.append(("u", id(self), self.x.copy(), self.P.copy(), (y, model, nav, R)))
        return update(self, y, model, nav, R, gate)

    UKF.predict, UKF.update = rec_predict, rec_update
    os.environ["FEDNAV_ENGINE"] = "python"
    try:
        t0 = time.perf_counter()
        paper002.one_run((scn, seed, None))
        t = time.perf_counter() - t0
    finally:
        UKF.predict, UKF.update = predict, update
        del os.environ["FEDNAV_ENGINE"]
    return t, steps


def filterpy_replay(steps, alpha=1e-3, beta=2.0, kappa=0.0):
    """Seconds FilterPy's UKF takes for the recorded steps (state set before each step,
    so every step sees the covariance fednav's filter saw)."""
    from filterpy.kalman import MerweScaledSigmaPoints
    from filterpy.kalman import UnscentedKalmanFilter as FPUKF

    n = steps[0][2].size
    filters = {}
    total = 0.0
    for s in steps:
        key = s[1]
        if key not in filters:
            pts = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
            filters[key] = {}
            filters[key]["pts"] = pts
        pts = filters[key]["pts"]
        x, P = s[2], s[3]
        if s[0] == "p":
            process, q_scale = s[4], s[5]
            f = FPUKF(dim_x=n, dim_z=1, dt=process.T, points=pts,
                      fx=lambda v, dt, pr=process: pr.transition(v[None])[0],
                      hx=lambda v: v[:1])
            f.x, f.P, f.Q = x.copy(), P.copy(), q_scale * process.Qd
            t0 = time.perf_counter()
            f.predict()
            total += time.perf_counter() - t0
        else:
            y, model, nav, R = s[4]
            m = np.atleast_1d(y).size
            f = FPUKF(dim_x=n, dim_z=m, dt=1.0, points=pts, fx=lambda v, dt: v,
                      hx=lambda v, mo=model, na=nav: mo.h(v[None], na)[0])
            f.x, f.P, f.R = x.copy(), P.copy(), np.asarray(R, float)
            # FilterPy's update uses the sigma points of its last predict: draw them.
            f.sigmas_f = pts.sigma_points(x, P)
            t0 = time.perf_counter()
            f.update(np.asarray(y, float))
            total += time.perf_counter() - t0
    return total


def filterpy_bare(steps: int = 14_400, n: int = 16, m: int = 3) -> float:
    """Seconds FilterPy's UKF takes for ``steps`` bare steps (a predict and an update
    each) of an ``n``-state filter with a linear process and ``m`` position-like
    measurements: issue 39's yardstick for campaign throughput (a 1000-run
    ``fednav reproduce 002`` at most 17.6 times these 14 400 steps)."""
    from filterpy.kalman import MerweScaledSigmaPoints
    from filterpy.kalman import UnscentedKalmanFilter as FPUKF

    rng = np.random.default_rng(0)
    F = np.eye(n) + 0.01 * np.diag(np.ones(n - 1), 1)
    f = FPUKF(dim_x=n, dim_z=m, dt=1.0,
              points=MerweScaledSigmaPoints(n, alpha=1e-3, beta=2.0, kappa=0.0),
              fx=lambda x, dt: F @ x, hx=lambda x: x[:m])
    f.Q, f.R = 1e-4 * np.eye(n), np.eye(m)
    z = rng.standard_normal((steps, m))
    t0 = time.perf_counter()
    for k in range(steps):
        f.predict()
        f.update(z[k])
    return time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=20, help="runs of the campaign timing")
    args = ap.parse_args()
    from fednav.scenarios import paper002

    scn = paper002.load_scenario()
    paper002.one_run((scn, 1, None))  # warm (numba cache, trajectory cache)
    times = []
    for seed in (2, 3, 4):
        t0 = time.perf_counter()
        paper002.one_run((scn, seed, None))
        times.append(time.perf_counter() - t0)
    t_run = min(times)
    t_py, steps = record_steps(scn, 2)
    n_p = sum(s[0] == "p" for s in steps)
    n_u = len(steps) - n_p
    t_fp = filterpy_replay(steps)
    print(f"paper 002, one run (1200 s, 4 modes), one core: fednav {t_run:.2f} s "
          f"(best of 3); FilterPy UKF for the same {n_p} predicts + {n_u} updates "
          f"{t_fp:.2f} s -> fednav whole run / FilterPy filter steps = x{t_run / t_fp:.2f}; "
          f"fednav's Python filter loop (recording the steps) {t_py:.2f} s")
    imp = min(float(subprocess.run(
        [sys.executable, "-c", "import time; t=time.perf_counter(); import fednav.cli; "
                               "print(time.perf_counter()-t)"],
        capture_output=True, text=True, check=True).stdout) for _ in range(3))
    print(f"import fednav.cli: {imp:.3f} s (best of 3)")
    with tempfile.TemporaryDirectory() as d:
        jobs = min(2, os.cpu_count() or 1)
        cpu = Path(d) / "cpu.json"
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", _CLI_WITH_CPU, str(cpu), "reproduce", "002",
                        "--runs", str(args.runs), "--jobs", str(jobs), "--out",
                        str(Path(d) / "out")], check=True, capture_output=True)
        t = time.perf_counter() - t0
        got = json.loads(cpu.read_text())
    (parent, workers), m = got["cpu"], got["marks"]
    t_bare = min(filterpy_bare() for _ in range(2))
    print(f"FilterPy, 14 400 bare 16-state UKF steps: {t_bare:.2f} s (best of 2); the "
          f"campaign below / these = x{t / t_bare:.1f} (issue 39: at most x17.6 for "
          f"--runs 1000)")
    print(f"fednav reproduce 002 --runs {args.runs} --jobs {jobs}: {t:.1f} s wall "
          f"(Tables 1-4, includes start-up and the 3 Table-4 runs); CPU: parent "
          f"{parent:.1f} s (imports, dispatch, storing runs, tables, plot), workers "
          f"{workers:.1f} s; serial parts: {m['asked']:.2f} s before the cluster is asked "
          f"for, {m['ready'] - m['asked']:.2f} s to start it, {m['end'] - m['last']:.2f} s "
          f"after the last unit (tables, plot, report)")


#: The command line run in-process, then written as JSON to argv[1]: the CPU seconds of
#: that process (all its threads: the Dask scheduler and nannies of a local cluster live
#: there) and of its children (the worker processes), and when (s from the start of the
#: script) the cluster was asked for, when it was ready, when the last unit of work came
#: back, and the end.
_CLI_WITH_CPU = """
import json, resource, sys, time
t0 = time.perf_counter()
out = sys.argv[1]
sys.argv = ["fednav", *sys.argv[2:]]
marks = {}
from fednav.campaign import paper
from fednav.campaign import store as campaign
start_client, run_seeds = campaign._start_client, paper.run_seeds
def timed_start_client(*a, **k):
    marks.setdefault("asked", time.perf_counter() - t0)
    r = start_client(*a, **k)
    marks.setdefault("ready", time.perf_counter() - t0)
    return r
def timed_run_seeds(*a, **k):
    r = run_seeds(*a, **k)
    marks["last"] = time.perf_counter() - t0
    return r
campaign._start_client, paper.run_seeds = timed_start_client, timed_run_seeds
from fednav.cli import main
try:
    main()
except SystemExit as e:
    if e.code:
        raise
marks["end"] = time.perf_counter() - t0
cpu = [r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                         resource.getrusage(resource.RUSAGE_CHILDREN))]
with open(out, "w") as f:
    json.dump({"cpu": cpu, "marks": marks}, f)
"""


if __name__ == "__main__":
    main()
