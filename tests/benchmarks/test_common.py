"""benchmarks/common.py: the t interval the paired-round benchmarks report."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from common import mean_ci95  # noqa: E402


def test_mean_ci95_matches_the_textbook_t_interval() -> None:
    # three values 1, 2, 3: mean 2, sample sd 1, t(0.975, 2 dof) = 4.302653 (tables)
    mean, (low, high) = mean_ci95([1.0, 2.0, 3.0])
    half = 4.302653 / 3 ** 0.5
    assert mean == pytest.approx(2.0)
    assert low == pytest.approx(2.0 - half, abs=1e-5) and high == pytest.approx(2.0 + half, abs=1e-5)


def test_mean_ci95_has_no_interval_for_one_value() -> None:
    assert mean_ci95([1.7]) == (1.7, None)
