"""Smoke test of benchmarks/bench_kernels.py: it runs (``--smoke``: two office decisions), records real
calls of every kernel, and each compiled kernel gives its numpy baseline's arrays on every call."""

from __future__ import annotations

from pathlib import Path

from tests.benchmarks.smoke import run_script

KERNELS = ("fusion", "layout", "line_of_sight", "in_range")


def test_bench_kernels_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_kernels.py", "--smoke", cwd=tmp_path)
    assert result["smoke"] is True and result["decisions"] == 2
    assert result["same"] is True
    for name in KERNELS:
        kernel = result[name]
        assert kernel["same"] is True
        assert kernel["calls"] > 0 and kernel["size_max"] > 0  # real calls recorded: the comparison is not vacuous
        assert kernel["ms_per_decision"] > 0 and kernel["ms_per_decision_numpy"] > 0
    assert "ms_saved_per_decision" in result
