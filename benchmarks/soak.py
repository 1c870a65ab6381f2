"""Numerical soak of every filter (run by hand: ``python benchmarks/soak.py [--cycles N]``).

Each registry filter runs ``--cycles`` (default 10^6; the particle filter a hundredth of
that) predict/update cycles on the 18-state INS error model under the hostile conditions
of :mod:`fednav.filters.soak` (P0 = 1e6 I, Q x 1e-12, a 1e-12 measurement variance, a
1e6-sigma outlier every 97 cycles), then again under ordinary conditions. Prints, per
filter: cycles completed, the FilterError that stopped it (if any), the worst covariance
asymmetry, the smallest eigenvalue and the largest condition number seen, and the time
per cycle. A NaN or an indefinite covariance without a FilterError aborts the script.
"""

from __future__ import annotations

import argparse

from fednav.filters import REGISTRY
from fednav.filters.soak import soak


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles", type=int, default=1_000_000)
    ap.add_argument("--conditions", choices=("hostile", "ordinary", "both"), default="both")
    args = ap.parse_args()
    for label, kw in (("hostile", {}), ("ordinary", {"huge_p": 1.0, "tiny_q": 1.0, "small_r": 1.0,
                                                     "outlier_every": 0})):
        if args.conditions not in (label, "both"):
            continue
        print(f"--- {label} conditions, {args.cycles} cycles")
        for name in sorted(REGISTRY):
            opts = {"n_particles": 300} if name == "pf" else {}
            n = max(1, args.cycles // 100) if name == "pf" else args.cycles
            r = soak(name, n, **kw, **opts)
            stop = "ran to the end" if r.error is None else f"stopped: {r.error}"
            per = r.seconds / max(r.cycles, 1) * 1e6
            print(f"{name:8s} {r.cycles:>8d} cycles  asym {r.max_asymmetry:.1e}  min eig "
                  f"{r.min_eig:.2e}  max cond {r.max_cond:.2e}  {per:7.1f} us/cycle  {stop}")


if __name__ == "__main__":
    main()
