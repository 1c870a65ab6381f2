"""Where issue 42's "protection levels no more than 6x the RMS error" can hold: the levels
of solution separation (``fednav.navigator.integrity.separation``, fednav's own function)
against the error of a consistent filter, in closed form.

    python benchmarks/integrity_levels.py

A consistent filter's horizontal RMS error is ``sqrt(2) sigma0`` (east and north each
``sigma0``) and its vertical one ``sigma0``.  Fault-free, the separations do not move the
levels (only the tests), so the level over the RMS error depends on the budget and on how
much each sub-solution loses against the all-sensor one.  Two geometries:

* ``N equal sensors``: every sensor measures the axis alike, so the sub-solution leaving
  one out has ``sigma_k = sigma0 sqrt(N / (N - 1))`` (information adds);
* ``one strong sensor``: the sub-solution without it has ``sigma_k = r sigma0`` (the
  cruise design of docs/integrity.md: without the GNSS only the SAR's 5 s fixes hold the
  horizontal position; its measured 29x is what r = 3.5 gives here), the others lose
  little (``sigma_k = 1.05 sigma0``).

Budgets: fednav's default (``IntegrityConfig()``: integrity risk 1e-7 per axis, false
alerts 4e-6, prior fault 1e-4 per sensor: an aviation-like allocation) and a looser one
(risk 1e-5, false alerts 1e-3, prior 1e-3: an order of what a road vehicle's or a
robot's safety case may allocate).  The floor, whatever the sensors, is the fault-free
term alone: ``2 Q(PL / sigma0) = risk`` (vertical; ``risk / 2`` for each of east and
north).
"""

from __future__ import annotations

import numpy as np

from fednav.navigator.integrity import IntegrityConfig, q_inverse, separation

BUDGETS = {
    "default (1e-7, 4e-6, 1e-4)": IntegrityConfig(),
    "looser (1e-5, 1e-3, 1e-3)": IntegrityConfig(risk_horizontal=1e-5, risk_vertical=1e-5,
                                                 risk_heading=1e-5, false_alert=1e-3,
                                                 prior_fault={"default": 1e-3}),
}


def ratios(cfg: IntegrityConfig, sigma_k: np.ndarray) -> tuple[float, float]:
    """(HPL over the horizontal RMS error, VPL over the vertical one) of a consistent
    filter with sigma0 = 1 on every axis and sub-solutions of ``sigma_k`` (one per sensor)."""
    n = len(sigma_k)
    s0 = np.ones((1, 4))
    sk = np.broadcast_to(np.asarray(sigma_k, dtype=float)[:, None, None], (n, 1, 4))
    res = separation(np.zeros(1), np.zeros((n, 1, 4)), s0, sk,
                     [f"s{k}" for k in range(n)], cfg)
    return float(res.hpl[0] / np.sqrt(2.0)), float(res.vpl[0])


def main() -> None:
    print(f"{'budget':28s}{'geometry':24s}{'HPL / RMS_h':>12s}{'VPL / RMS_v':>12s}")
    for name, cfg in BUDGETS.items():
        floor_h = q_inverse(cfg.risk_horizontal / 4.0)  # (each of east, north: risk / 2)
        floor_v = q_inverse(cfg.risk_vertical / 2.0)
        print(f"{name:28s}{'floor (fault-free term)':24s}{floor_h:12.1f}{floor_v:12.1f}")
        for n in (2, 3, 4, 6, 10):
            h, v = ratios(cfg, np.full(n, np.sqrt(n / (n - 1.0))))
            print(f"{'':28s}{f'{n} equal sensors':24s}{h:12.1f}{v:12.1f}")
        for r in (2.0, 3.5, 5.0, 7.0):
            h, v = ratios(cfg, np.r_[r, 1.05, 1.05, 1.05])
            print(f"{'':28s}{f'one strong, r = {r:g}':24s}{h:12.1f}{v:12.1f}")


if __name__ == "__main__":
    main()
