"""explore_rl/intervals.py: the expanded percentile levels, against Student's t and by the
coverage of a simulated bootstrap."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.intervals import percentile_levels


def test_levels_match_the_t_quantile_scaled_by_the_variance_correction() -> None:
    # n = 10: sqrt(10/9) * t(0.975, 9) = 1.0541 * 2.262157 (tables) = 2.38452; Phi(-2.38452) = 0.008551
    low, high = percentile_levels(10)
    assert low == pytest.approx(0.8551, abs=2e-3) and high == pytest.approx(100 - 0.8551, abs=2e-3)
    assert percentile_levels(100_000)[0] == pytest.approx(2.5, abs=1e-3)  # the plain levels for many units
    assert percentile_levels(2)[0] < percentile_levels(5)[0] < percentile_levels(20)[0] < 2.5


def test_one_unit_has_no_interval() -> None:
    with pytest.raises(ValueError, match="units=1"):
        percentile_levels(1)


def coverage(units: int, levels: tuple[float, float], sims: int = 600, resamples: int = 600) -> float:
    """How often the bootstrap interval of a mean of ``units`` normal values holds the true mean."""
    rng = np.random.default_rng(units)
    hits = 0
    for _ in range(sims):
        values = rng.normal(0.0, 1.0, units)
        means = values[rng.integers(0, units, (resamples, units))].mean(axis=1)
        low, high = np.percentile(means, levels)
        hits += low <= 0.0 <= high
    return hits / sims


def test_expanded_levels_restore_the_coverage_the_plain_percentiles_lose() -> None:
    plain, expanded = coverage(10, (2.5, 97.5)), coverage(10, percentile_levels(10))
    assert plain < 0.91  # ~0.88: the plain bootstrap interval of 10 units is too narrow
    assert expanded > 0.93  # ~0.95
