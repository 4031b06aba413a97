"""Thresholds for tests that count successes over seeds, from the binomial distribution.

A statistical property (a 95 % interval covers the truth, a verdict is right
in 95 % of runs) is checked by counting, over n seeds, the runs that have it.
Seeds give independent noise streams and PRBS phases, so a method that meets
its rate exactly gives a Binomial(n, rate) count.  A threshold at the rate
itself (``count >= 0.95 n``) fails such a method about half of the time;
these helpers instead return the count it misses with probability at most
:data:`FALSE_FAILURE`, so an assertion fails when the rate is really worse,
not by chance.
"""

from __future__ import annotations

from scipy.stats import binom

FALSE_FAILURE = 1e-3
"""Chance that one assertion fails for a method that meets its nominal rate exactly."""


def min_successes(n: int, rate: float, false_failure: float = FALSE_FAILURE) -> int:
    """The largest count ``k`` that n trials at success probability ``rate`` reach w.p. >= 1 - ``false_failure``.

    Parameters
    ----------
    n : int
        Trials (seeds).
    rate : float
        Nominal success probability [-], e.g. the confidence level of an interval.
    false_failure : float
        Largest accepted chance that ``count >= k`` fails at exactly the nominal rate [-].

    Returns
    -------
    int
        ``max {k : P(X >= k) >= 1 - false_failure}`` for ``X ~ Binomial(n, rate)``;
        e.g. 42 for n = 50 and rate = 0.95 (P(X >= 42) = 0.99924, P(X >= 43) = 0.9968).
    """
    # P(X >= k) = sf(k - 1) falls as k grows: take the last k that still clears the bound.
    return max(k for k in range(n + 1) if binom.sf(k - 1, n, rate) >= 1.0 - false_failure)


def max_failures(n: int, rate: float, false_failure: float = FALSE_FAILURE) -> int:
    """The smallest count ``m`` that n trials at failure probability ``rate`` stay within w.p. >= 1 - ``false_failure``.

    ``n - min_successes(n, 1 - rate)``: at most ``rate`` false alarms is at least ``1 - rate`` right verdicts.
    E.g. 8 for n = 50 and rate = 0.05.
    """
    return n - min_successes(n, 1.0 - rate, false_failure)
