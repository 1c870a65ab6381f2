"""Numerical soak of every filter (run by hand: ``python benchmarks/soak.py [--cycles N]``).

Each registry filter runs ``--cycles`` (default 10^6; the particle filter a hundredth of
that) predict/update cycles on the 18-state INS error model under the hostile conditions
of :mod:`fednav.filters.soak` (P0 = 1e6 I, Q x 1e-12, a 1e-12 measurement variance, a
1e6-sigma outlier every 97 cycles), then again under ordinary conditions.  ``--form``:
the filters' covariance form (``standard`` or ``square_root``: every Gaussian filter's
Cholesky-factor form; the particle filter has none and is skipped); ``--gate``: the
chi-square gating level of the measurement (default 1e-9 with ``square_root``, none with
``standard`` — the figures of the standard form in docs/reliability.md were taken
without; ``--gate 0``: none; after 3 rejections in a row the measurement is re-admitted
with an inflated covariance, as the federated filter does); ``--linear``: the state
propagates by ``Phi x`` instead of the nonlinear error model.

Prints one line per filter, ``NAME: completed N cycles`` or ``NAME: FilterError at step K:
reason``, each followed by the worst covariance asymmetry, the smallest eigenvalue and the
largest condition number seen and the time per cycle; and a last line ``K of M filters
completed``.  A NaN or an indefinite covariance without a FilterError is printed as
``NAME: SILENT FAILURE: ...`` (the filter counts as not completed).
"""

from __future__ import annotations

import argparse

from fednav.filters import REGISTRY
from fednav.filters.soak import soak
from fednav.filters.square_root import SQUARE_ROOT


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cycles", type=int, default=1_000_000)
    ap.add_argument("--conditions", choices=("hostile", "ordinary", "both"), default="both")
    ap.add_argument("--form", choices=("standard", "square_root"), default="standard")
    ap.add_argument("--gate", type=float, default=None,
                    help="chi-square gating level (default 1e-9 with --form square_root, "
                         "none with standard; 0: none)")
    ap.add_argument("--filters", default=None, help="comma-separated names (default: all)")
    ap.add_argument("--linear", action="store_true",
                    help="the state propagates by Phi x, not the nonlinear error model")
    args = ap.parse_args()
    gate = args.gate if args.gate is not None else (
        1e-9 if args.form == "square_root" else None)
    gate = gate or None
    names = args.filters.split(",") if args.filters else sorted(REGISTRY)
    for label, kw in (("hostile", {}), ("ordinary", {"huge_p": 1.0, "tiny_q": 1.0, "small_r": 1.0,
                                                     "outlier_every": 0})):
        if args.conditions not in (label, "both"):
            continue
        print(f"--- {label} conditions, {args.cycles} cycles, form {args.form}, "
              f"gate {gate if gate else 'none'}"
              f"{', linear process' if args.linear else ''}", flush=True)
        done = ran = 0
        for name in names:
            if args.form == "square_root" and name not in SQUARE_ROOT:
                print(f"{name}: no square-root form (not a Gaussian filter), skipped")
                continue
            opts = {"n_particles": 300} if name == "pf" else {}
            n = max(1, args.cycles // 100) if name == "pf" else args.cycles
            ran += 1
            try:
                r = soak(name, n, form=args.form, gate_alpha=gate, linear=args.linear, **kw,
                         **opts)
            except AssertionError as e:  # a silent failure: the soak's finding
                print(f"{name}: SILENT FAILURE: {e}", flush=True)
                continue
            per = r.seconds / max(r.cycles, 1) * 1e6
            figures = (f"(asym {r.max_asymmetry:.1e}, min eig {r.min_eig:.2e}, max cond "
                       f"{r.max_cond:.2e}, {per:.1f} us/cycle, {r.readmissions} "
                       f"re-admissions)")
            if r.error is None:
                done += 1
                print(f"{name}: completed {r.cycles} cycles {figures}", flush=True)
            else:
                print(f"{name}: FilterError at step {r.cycles + 1}: {r.error} {figures}",
                      flush=True)
        print(f"{done} of {ran} filters completed", flush=True)


if __name__ == "__main__":
    main()
