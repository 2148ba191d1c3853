"""The percentile levels of a 95 % bootstrap interval from ``n`` independent units.

The plain 2.5 / 97.5 percentiles of a bootstrapped mean are too narrow for few units:
resampling ``n`` values has the spread of the ``1/n`` (not ``1/(n-1)``) variance and uses
the normal, not Student's t, quantile. With 10 units they cover the truth ~88 % of the time,
with 20 ~92 % (tests/test_intervals.py simulates it); that let EM differ "significantly" from
another run of itself over 10 validation scenes (benchmarks/RESULTS.md, session 34). The
expanded percentile interval (Hesterberg, "What teachers should know about the bootstrap",
2015) reads the percentiles at the normal level whose quantile is
``sqrt(n / (n - 1)) * t(0.975, n - 1)``: ~95 % coverage from n = 10, the plain levels as n grows.
"""

from __future__ import annotations

import math

from scipy import stats

LEVEL = 0.95


def percentile_levels(units: int, level: float = LEVEL) -> tuple[float, float]:
    """Lower and upper percentiles (0-100) of a ``level`` interval from ``units`` independent
    resampled units (episodes, trials, scenes); ``units`` must be at least 2."""
    if units < 2:
        raise ValueError(f"units={units}: an interval needs at least 2 independent units")
    tail = (1.0 - level) / 2.0
    z = math.sqrt(units / (units - 1)) * stats.t.ppf(1.0 - tail, units - 1)
    low = 100.0 * float(stats.norm.cdf(-z))
    return low, 100.0 - low
