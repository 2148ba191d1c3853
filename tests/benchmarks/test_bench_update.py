"""Smoke test of benchmarks/bench_update.py: it runs (``--smoke``: one batch of 2 workers x 3
decisions, a tiny model) and its JSON last line holds the figures RESULTS.md quotes; the
learner's value targets and losses equal the reference's. Speeds are not checked."""

from __future__ import annotations

from pathlib import Path

from tests.benchmarks.smoke import run_script


def test_bench_update_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_update.py", "--smoke", cwd=tmp_path, timeout=240)
    assert result["smoke"] is True and result["batch_shape"] == [2, 3]
    for key in ("update_ms", "update_ms_reference", "targets_ms", "targets_ms_reference", "speedup"):
        assert result[key] > 0, key
    assert result["same_targets"] is True and result["same_losses"] is True
