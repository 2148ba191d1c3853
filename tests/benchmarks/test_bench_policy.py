"""Smoke test of benchmarks/bench_policy.py: it runs (``--smoke``: tiny batch, hidden 16)
and its JSON last line holds the figures RESULTS.md quotes. Figures are not checked,
except that the dense and PyG networks agreed."""

from __future__ import annotations

from pathlib import Path

from tests.benchmarks.smoke import run_script

KEYS = ["ms_train_step_dense", "ms_train_step_pyg", "speedup_train", "ms_train_step_dense_1000",
        "ms_train_step_pyg_1000", "speedup_train_1000", "ms_decision_300", "ms_decision_800",
        "ms_decision_300_pyg", "ms_decision_800_pyg", "max_abs_diff_vs_pyg"]


def test_bench_policy_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_policy.py", "--smoke", cwd=tmp_path)
    assert result["smoke"] is True
    missing = [key for key in KEYS if key not in result]
    assert not missing, f"JSON last line lacks {missing} (has {sorted(result)})"
    assert set(result["ms_train_step_dense"]) == set(result["ms_train_step_pyg"]) == {"16"}
    assert result["ms_decision_300"] > 0 and result["ms_decision_800"] > 0
    assert result["max_abs_diff_vs_pyg"] < 1e-4  # same weights, same outputs
