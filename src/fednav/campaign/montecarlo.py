"""Monte Carlo driver: run a per-seed function over seeds (see :mod:`fednav.campaign` for
the engines and the resumable result store).

Worker processes limit BLAS/OpenMP to one thread: runs are the unit of parallelism, and a
multi-threaded matrix product in every worker would oversubscribe the cores (a
3000-particle filter run took 2.6x longer with two workers on two cores).
"""

from __future__ import annotations

from collections.abc import Callable


def run_seeds(fn: Callable | list[Callable], args: list, jobs: int = 1,
              progress: Callable | None = None, campaign=None,
              plan: str | None = None) -> list:
    """``[fn(a) for a in args]`` in order, with ``jobs`` worker processes (Dask), reusing
    and filling the ``campaign`` store when one is given; ``progress()`` after each.
    ``fn`` may be a list: one function per unit; ``plan``: the units' kernel plan
    (:func:`fednav.campaign.store.run_units`)."""
    from .store import run_units

    return run_units(fn, args, jobs, progress, campaign, plan)
