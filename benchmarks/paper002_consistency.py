"""Filter consistency on paper 002: RMS of (error / filter sigma) per navigation state.

Values near 1 mean the filter's covariance describes its real errors.
Run by hand: ``python benchmarks/paper002_consistency.py [runs]``.
"""

import sys

import numpy as np

from fednav.scenarios import paper002
from fednav.sim.runs import make_run_data, run_mode

NAMES = "phiE phiN phiU vE vN vU pE pN pU".split()


def main(runs: int = 6) -> None:
    scn = paper002.load_scenario()
    acc: dict[str, list] = {}
    for seed in range(1, runs + 1):
        data = make_run_data(scn, seed)
        for m in scn.modes:
            if not m.aiding:
                continue
            r = run_mode(scn, list(m.aiding), data, m.name)
            acc.setdefault(m.name, []).append(np.c_[r.att, r.vel, r.pos] / r.sigma[:, :9])
    for name, zs in acc.items():
        z = np.sqrt((np.concatenate(zs) ** 2).mean(axis=0))
        print(f"{name:14s} " + " ".join(f"{n}={v:.2f}" for n, v in zip(NAMES, z, strict=True)))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 6)
