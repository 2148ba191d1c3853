"""Smoke test of benchmarks/study_safety.py: its --smoke size runs end to end (a few
seconds) and prints the layer-on vs layer-off figures and targets as its JSON last line."""

from __future__ import annotations

from pathlib import Path

from tests.benchmarks.smoke import run_script


def test_study_safety_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/study_safety.py", "--smoke", "--out", str(tmp_path / "safety"), cwd=tmp_path)
    assert result["smoke"] is True
    for key in ("model", "per_policy", "icp", "targets", "all_targets_met", "table"):
        assert key in result, f"study_safety: JSON last line lacks {key} (has {sorted(result)})"
    assert set(result["model"]) == {"on", "off"}
    for variant in ("on", "off"):
        for key in ("blocked_fraction", "contacts_per_run", "min_clearance_m", "explored", "travel_m",
                    "map_error_m", "ms_per_decision", "ms_safety"):
            assert key in result["model"][variant]
    assert (tmp_path / "safety" / "safety_runs.jsonl").is_file()
