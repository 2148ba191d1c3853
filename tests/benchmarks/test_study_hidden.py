"""Smoke test of benchmarks/study_hidden.py: a tiny run's replay buffer, two sizes, end to end."""

from __future__ import annotations

from tests.benchmarks.smoke import run_script


def test_study_hidden_smoke(tmp_path):
    result = run_script("benchmarks/study_hidden.py", "--smoke", cwd=tmp_path, timeout=300)
    assert result["smoke"] is True and set(result["results"]) == {"8", "16"}
    assert result["train_decisions"] >= 1
    assert result["reference"]["best"] >= result["reference"]["random"]
    for size in result["results"].values():
        assert len(size["curve"]) >= 2 and size["ms_step"] > 0
