"""Monte Carlo driver: run a per-seed function over seeds, in parallel worker processes."""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor


def run_seeds(fn: Callable, args: list, jobs: int = 1, progress: Callable | None = None) -> list:
    """``[fn(a) for a in args]`` in order, with ``jobs`` processes; ``progress()`` after each."""
    out = []
    if jobs > 1 and len(args) > 1:
        with ProcessPoolExecutor(max_workers=jobs) as ex:
            for r in ex.map(fn, args):
                out.append(r)
                if progress:
                    progress()
    else:
        for a in args:
            out.append(fn(a))
            if progress:
                progress()
    return out
