"""Smoke test of benchmarks/bench_sorting.py: it runs (``--smoke``: the office, two states), records
real decision keys, and the radix passes give numpy's permutations on every one of them."""

from __future__ import annotations

from pathlib import Path

from tests.benchmarks.smoke import run_script


def test_bench_sorting_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_sorting.py", "--smoke", cwd=tmp_path)
    assert result["smoke"] is True and result["states"] == len(result["rows"]) == 2
    assert result["same_order"] is True
    assert all(row["sorts"] > 0 for row in result["rows"])  # keys were recorded: the comparison is not vacuous
    assert result["ms_radix_per_decision"] > 0 and result["ms_numpy_per_decision"] > 0
    assert result["largest_keys"] > 0
