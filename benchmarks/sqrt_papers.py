"""Paper scenarios, standard vs square-root filters (run by hand:
``python benchmarks/sqrt_papers.py [--papers 000,002,003,004]``).

Each paper's one-run tables (the runs of ``tests/golden``: paper 000 seed 2, 250 s;
002 seed 3, 120 s; 003 seed 5, 460 s; 004 seed 6, 300 s) with ``filter.form: standard``
and ``square_root`` (every local filter factored; paper 003's total-state UKF master is
not a registry filter and stays as it is).  Prints per paper the largest relative
difference of any table entry, the entry, and the standard form's own sensitivity to a
one-ulp change of its inputs for that paper (``tests/golden/sensitivity.json``, the
largest over its keys): a difference at or below that is rounding, not a different
filter.  Paper 001 (particle filter locals) has no square-root form.

``--alpha A`` runs both forms with the unscented spread ``filter.alpha = A`` instead of the
scenario's (papers 000 and 002 fly alpha = 1e-3, whose zeroth weight 1 - n/(alpha^2 n)
~ -1e6 amplifies rounding): where the two forms agree to 1e-8 once the spread is wide.
"""

from __future__ import annotations

import argparse
import importlib
import json
import time
from pathlib import Path

SKIP = ("seed", "time_s", "ms_per_cycle", "seconds_per_run")
RUNS = {"000": (2, 250.0), "002": (3, 120.0), "003": (5, 460.0), "004": (6, 300.0)}


def _square_root(scn):
    return scn.model_copy(update={"filter": scn.filter.model_copy(
        update={"form": "square_root"})})


def _tables(out) -> list[dict]:
    return [r for r in out[0]] + ([r for r in out[2]] if len(out) > 2 else [])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--papers", default="000,002,003,004")
    ap.add_argument("--alpha", type=float, default=None,
                    help="unscented spread for both forms (default: the scenario's)")
    args = ap.parse_args()
    sens = json.loads((Path(__file__).parents[1] / "tests" / "golden" /
                       "sensitivity.json").read_text())
    for paper in args.papers.split(","):
        p = importlib.import_module(f"fednav.scenarios.paper{paper}")
        scn = p.load_scenario()
        if args.alpha is not None:
            scn = scn.model_copy(update={"filter": scn.filter.model_copy(
                update={"alpha": args.alpha})})
        seed, T = RUNS[paper]
        if paper == "003":
            scn = scn.model_copy(update={"fault_experiment": scn.fault_experiment.model_copy(
                update={"duration_s": T})})
        t0 = time.perf_counter()
        a = _tables(p.one_run((scn, seed, T)))
        t1 = time.perf_counter()
        b = _tables(p.one_run((_square_root(scn), seed, T)))
        t2 = time.perf_counter()
        worst, where = 0.0, ""
        for ra, rb in zip(a, b, strict=True):
            for k, v in ra.items():
                if (isinstance(v, float) and k not in SKIP and v == v and v != 0.0):
                    rel = abs(v - rb[k]) / abs(v)
                    if rel > worst:
                        worst, where = rel, f"{ra.get('mode', ra.get('filter', ''))}/{k}"
        s = max(sens.get(f"paper{paper}", {}).values(), default=float("nan"))
        print(f"paper {paper}: {len(a)} table rows, largest relative difference "
              f"{worst:.2e} ({where}); the standard form's one-ulp sensitivity up to "
              f"{s:.2e}; standard {t1 - t0:.0f} s, square-root {t2 - t1:.0f} s", flush=True)


if __name__ == "__main__":
    main()
