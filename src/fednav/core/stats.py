"""Distribution quantiles without importing ``scipy.stats`` (0.6-0.7 s at start-up, most
of a short command's import time): the functions ``scipy.stats`` itself evaluates,
called from ``scipy.special`` (equal to the bit; ``tests/test_stats.py``)."""

from __future__ import annotations

import numpy as np


def chi2_ppf(q, dof):
    """The chi-square quantile: ``x`` with ``P(X <= x) = q`` for ``dof`` degrees of freedom
    (``scipy.stats.chi2.ppf(q, dof)``); arrays broadcast, a scalar for scalars."""
    from scipy.special import gammaincinv

    x = 2.0 * gammaincinv(np.asarray(dof, dtype=float) / 2.0, q)
    return float(x) if np.ndim(x) == 0 else x
