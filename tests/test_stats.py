"""fednav.core.stats: quantiles equal to scipy.stats's to the bit."""

import numpy as np
import pytest

from fednav.core.stats import chi2_ppf


@pytest.mark.parametrize("q", [1e-5, 0.05, 0.5, 0.95, 0.99, 1 - 1e-7, 1 - 1e-12])
def test_chi2_ppf_is_scipy_stats(q):
    from scipy.stats import chi2

    dof = np.array([1, 2, 3, 6, 15, 57, 300])
    assert np.array_equal(chi2_ppf(q, dof), chi2.ppf(q, dof))
    assert chi2_ppf(q, 3) == chi2.ppf(q, 3) and isinstance(chi2_ppf(q, 3), float)


def test_process_does_not_import_scipy_stats():
    """A command's start-up does not pay for scipy.stats (0.6 s): nothing on the process
    path imports it."""
    import subprocess
    import sys

    code = ("import sys, fednav.cli, fednav.process.run, fednav.filters.federated, "
            "fednav.navigator.engine, fednav.ins.stops; "
            "print('scipy.stats' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "False"
