"""The binomial thresholds of the seed-counting tests (test/binomial.py)."""

from binomial import FALSE_FAILURE, max_failures, min_successes
from scipy.stats import binom


def test_min_successes_is_the_tightest_count_a_correct_method_reaches():
    for n, rate in ((50, 0.95), (50, 0.90), (20, 0.95), (5, 0.95), (100, 0.99)):
        k = min_successes(n, rate)
        assert binom.sf(k - 1, n, rate) >= 1.0 - FALSE_FAILURE  # reached with probability >= 1 - 1e-3 ...
        assert k == n or binom.sf(k, n, rate) < 1.0 - FALSE_FAILURE  # ... and one more would not be
    assert min_successes(50, 0.95) == 42 and min_successes(50, 1.0) == 50


def test_max_failures_mirrors_min_successes():
    assert max_failures(50, 0.05) == 8
    assert binom.cdf(8, 50, 0.05) >= 1.0 - FALSE_FAILURE > binom.cdf(7, 50, 0.05)
