"""Evidence behind docs/paper001.md (run by hand: ``python benchmarks/paper001_evidence.py``).

1. The fusion bias: the federated PF with and without the correction of the bias that
   fusing noisy sample covariances introduces, beside the EKF — 3-D position/attitude
   RMS and the share of errors outside the filter's 3 sigma (seeds 1-4).
2. The large-attitude regimes over 12 seeds (more than the reproduction's 5), run by run:
   how often the PF pays and how often a filter loses track.
"""

from __future__ import annotations

import sys

import numpy as np

from fednav.campaign.montecarlo import run_seeds
from fednav.filters import ParticleFilter
from fednav.launch import navigate
from fednav.scenarios import paper001


class _NoFusionCorrection(ParticleFilter):
    covariance_dof = None


def _one(args):
    scn, seed, variant = args
    data = navigate.make_data(scn, seed)
    if variant == "pf, no fusion-bias correction":
        import fednav.launch.navigate as nav

        saved = nav.ParticleFilter
        nav.ParticleFilter = _NoFusionCorrection
        try:
            r = navigate.run(scn, data, "pf")
        finally:
            nav.ParticleFilter = saved
    else:
        r = navigate.run(scn, data, variant)
    e = np.column_stack([r.att, r.pos, r.vel])
    pos, att = paper001.rms3(r)
    return variant, seed, pos, att, float(np.mean(np.abs(e) > 3 * r.sigma)), \
        float(np.linalg.norm(r.pos[-1]))


def main(jobs: int = 2) -> None:
    scn = paper001.load_scenario()
    variants = ("ekf", "pf", "pf, no fusion-bias correction")
    out = run_seeds(_one, [(scn, s, v) for v in variants for s in range(1, 5)], jobs)
    print("1. fusion bias (paper conditions, seeds 1-4): 3-D RMS and share outside 3 sigma")
    for v in variants:
        rows = [o for o in out if o[0] == v]
        print(f"  {v:32s} pos {np.mean([o[2] for o in rows]):6.2f} m   att "
              f"{np.mean([o[3] for o in rows]):6.2f}\"   outside 3 sigma "
              f"{100 * np.mean([o[4] for o in rows]):5.1f} %")
    print("2. large initial attitude error, star sensor from 120 s, 12 seeds: "
          "3-D position RMS [m] run by run")
    for reg in scn.regimes:
        if not reg.name.startswith("attitude"):
            continue
        s = scn.with_regime(reg)
        res = run_seeds(_one, [(s, seed, k) for k in ("pf", "ekf") for seed in range(1, 13)],
                        jobs)
        for k in ("pf", "ekf"):
            rows = [o for o in res if o[0] == k]
            pos = np.array([o[2] for o in rows])
            lost = sum(o[5] > paper001.LOST_M for o in rows)
            print(f"  {reg.name[:16]:16s} {k.upper():3s} median {np.median(pos):8.1f}  "
                  f"lost {lost}/12  runs: {' '.join(f'{p:.0f}' for p in pos)}")
        pf = np.array([o[2] for o in res if o[0] == "pf"])
        ekf = np.array([o[2] for o in res if o[0] == "ekf"])
        print(f"  {'':16s} PF better in {int(np.sum(pf < ekf))}/12 runs")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2)
