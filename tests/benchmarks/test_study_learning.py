"""Smoke test of benchmarks/study_learning.py: a tiny run trained and evaluated end to end."""

from __future__ import annotations

from tests.benchmarks.smoke import run_script


def test_study_learning_smoke(tmp_path):
    result = run_script("benchmarks/study_learning.py", "--smoke", "--out", str(tmp_path), cwd=tmp_path,
                        timeout=180)
    assert result["smoke"] is True
    assert set(result["baselines"]) == {"nearest", "em", "random"}
    em, nearest = result["baselines"]["em"], result["baselines"]["nearest"]
    assert em["em_agreement"] == 1.0 and em["mean_reward"] >= nearest["mean_reward"]
    assert result["runs"]["smoke_run"]["last"]["decisions"] >= 1
    assert (tmp_path / "learning_curves.png").is_file() and (tmp_path / "learning_eval.json").is_file()
