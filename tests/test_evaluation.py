import numpy as np
import pytest
from scipy import stats

from fednav.campaign.evaluation import error_stats, mean_ci95


def test_error_stats_values():
    e = np.array([[1.0, -2.0], [-3.0, 2.0], [2.0, 0.0]])
    s = error_stats(e)
    np.testing.assert_allclose(s["mean_abs"], [2.0, 4 / 3])
    np.testing.assert_allclose(s["rms"], np.sqrt([14 / 3, 8 / 3]))
    np.testing.assert_allclose(s["std"], e.std(axis=0))
    np.testing.assert_allclose(s["max_abs"], [3.0, 2.0])
    np.testing.assert_allclose(s["max"], [2.0, 2.0])
    np.testing.assert_allclose(s["min"], [-3.0, -2.0])
    with pytest.raises(ValueError, match="NaN"):
        error_stats([1.0, np.nan])


def test_mean_ci95_matches_student_t():
    v = np.array([1.0, 2.0, 4.0, 3.5, 2.5])
    m, h = mean_ci95(v)
    lo, hi = stats.t.interval(0.95, len(v) - 1, loc=v.mean(), scale=stats.sem(v))
    assert m == pytest.approx(v.mean())
    assert h == pytest.approx((hi - lo) / 2)
    m1, h1 = mean_ci95([5.0])
    assert m1 == 5.0 and np.isnan(h1)


def test_mean_ci95_is_the_scipy_stats_t_interval_to_the_bit():
    rng = np.random.default_rng(5)
    for n in (2, 3, 10, 101, 1000):
        v = rng.normal(size=n)
        h = float(stats.t.ppf(0.975, n - 1) * v.std(ddof=1) / np.sqrt(n))
        assert mean_ci95(v)[1] == h


def test_ci_covers_true_mean_at_95_percent():
    rng = np.random.default_rng(11)
    hits = 0
    for _ in range(2000):
        m, h = mean_ci95(rng.normal(3.0, 2.0, 8))
        hits += abs(m - 3.0) <= h
    assert hits / 2000 == pytest.approx(0.95, abs=0.015)
