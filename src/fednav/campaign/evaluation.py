"""Error statistics over a flight and Monte Carlo summaries with confidence intervals."""

from __future__ import annotations

import numpy as np


def error_stats(err) -> dict[str, np.ndarray]:
    """Statistics over time (axis 0) of an error series (K, ...).

    ``mean_abs`` (the paper-002 statistic), ``rms``, ``std``, ``max_abs``, ``max``, ``min``.
    """
    e = np.asarray(err, dtype=float)
    if not np.all(np.isfinite(e)):
        raise ValueError("error_stats: error series contains NaN/inf")
    return {
        "mean_abs": np.abs(e).mean(axis=0),
        "rms": np.sqrt((e**2).mean(axis=0)),
        "std": e.std(axis=0),
        "max_abs": np.abs(e).max(axis=0),
        "max": e.max(axis=0),
        "min": e.min(axis=0),
    }


#: Why a campaign table's number is null in summary.json (``write_json(why=...)``).
NULL_REASONS = {
    "ci95": "a 95 % confidence interval needs at least 2 runs with a finite value",
    "ours": "no run gave a finite value (e.g. a window outside a truncated flight)",
}


def mean_ci95(values) -> tuple[float, float]:
    """Monte Carlo mean and half-width of its 95 % confidence interval (Student t)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]  # e.g. a fault window outside a truncated flight
    n = v.size
    if n == 0:
        return float("nan"), float("nan")
    m = float(v.mean())
    if n < 2:
        return m, float("nan")
    # Student-t quantile: scipy.stats.t.ppf is this function (equal to the bit), without
    # importing scipy.stats (0.6 s) in the process that writes the tables.
    from scipy.special import stdtrit

    h = float(stdtrit(n - 1, 0.975) * v.std(ddof=1) / np.sqrt(n))
    return m, h
