"""benchmarks/common.py: the t interval the paired-round benchmarks report, and the bootstrap over layouts the
offline probes report."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from common import cluster_bootstrap, layout_clusters, mean_ci95, seed_list  # noqa: E402


def test_mean_ci95_matches_the_textbook_t_interval() -> None:
    # three values 1, 2, 3: mean 2, sample sd 1, t(0.975, 2 dof) = 4.302653 (tables)
    mean, (low, high) = mean_ci95([1.0, 2.0, 3.0])
    half = 4.302653 / 3 ** 0.5
    assert mean == pytest.approx(2.0)
    assert low == pytest.approx(2.0 - half, abs=1e-5) and high == pytest.approx(2.0 + half, abs=1e-5)


def test_mean_ci95_has_no_interval_for_one_value() -> None:
    assert mean_ci95([1.7]) == (1.7, None)


def test_layout_clusters_are_the_rows_of_each_layout() -> None:
    groups = layout_clusters(np.array([3, 1, 3, 2, 1]))
    assert [group.tolist() for group in groups] == [[1, 4], [3], [0, 2]]


def test_the_bootstrap_resamples_whole_layouts_not_rows() -> None:
    """One layout of 1 decision scoring 0, one of 99 scoring 1: drawing layouts, both draws are the first one a
    quarter of the time, so the interval reaches 0; drawing rows it would stay near 0.99."""
    values = np.r_[0.0, np.ones(99)]
    groups = layout_clusters(np.r_[0, np.ones(99, dtype=int)])
    low, high = cluster_bootstrap(lambda rows: float(values[rows].mean()), groups, seed=1)
    assert low == 0.0 and high == 1.0
    assert cluster_bootstrap(lambda rows: float(values[rows].mean()), groups, seed=1) == [low, high]


def test_seed_list_reads_ranges_and_lists():
    assert seed_list("0-7") == list(range(8))
    assert seed_list("0,3,5-6") == [0, 3, 5, 6] and seed_list("4") == [4]


def test_named_paths_keep_their_order_and_refuse_a_malformed_one():
    from common import named_paths

    assert named_paths(["b=x/1.json", "a=y.json"]) == {"b": Path("x/1.json"), "a": Path("y.json")}
    for bad in ("nameless", "=path", "name="):
        with pytest.raises(ValueError, match="--point") as error:
            named_paths([bad], "--point ")
        assert "\n" not in str(error.value)
