"""zero_shot_buildings_100/association.py on synthetic paired reports whose ratios are known by construction."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tests.benchmarks.smoke import run_script, script_runner

SCRIPT = "benchmarks/results/zero_shot_buildings_100/association.py"
CLOSURE_RATES = (2.0, 1.6, 1.2, 0.8, 0.5, 0.3)  # the policy's loop closures per decision; EM closes 1
ERROR_RATIOS = (0.8, 0.9, 1.0, 1.2, 1.4, 1.6)   # fewer closures, higher map error: rank correlation -1
TRAVEL_RATIOS = (1.0, 0.9, 1.1, 0.95, 1.05, 0.85)


def trial(scene: str, policy: str, metres_per_decision: float, error: float, closures_per_decision: float) -> dict:
    """10 decisions of 10 % explored each, a constant map error, closures growing linearly."""
    rows = [{"decision": i, "travel_m": metres_per_decision * (i + 1), "explored": 0.1 * (i + 1),
             "map_error_m": error, "loop_closures": closures_per_decision * (i + 1)} for i in range(10)]
    return {"scene": scene, "policy": policy, "trial": 0, "seed": 0, "status": "explored", "rows": rows,
            "ms_decide": 10.0}


def write_report(folder: Path) -> Path:
    """One ``N_scene/trials.jsonl`` per scene, with the learned trial and EM's."""
    for k, (rate, error, travel) in enumerate(zip(CLOSURE_RATES, ERROR_RATIOS, TRAVEL_RATIOS)):
        scene = f"building_{k}"
        sub = folder / f"{k}_{scene}"
        sub.mkdir(parents=True)
        runs = [trial(scene, "learned", 10.0 * travel, 0.1 * error, rate), trial(scene, "em", 10.0, 0.1, 1.0)]
        (sub / "trials.jsonl").write_text("".join(json.dumps(run) + "\n" for run in runs))
    return folder


def test_ratios_rank_correlation_and_split_by_closures(tmp_path: Path) -> None:
    report = write_report(tmp_path / "report")
    result = run_script(SCRIPT, str(report), "--resamples", "200", cwd=tmp_path)
    assert result["scenes"] == 6
    geometric_mean = lambda values: math.exp(sum(map(math.log, values)) / len(values))  # noqa: E731
    assert math.isclose(result["error_ratio"], geometric_mean(ERROR_RATIOS), rel_tol=1e-9)
    assert math.isclose(result["travel_ratio"], geometric_mean(TRAVEL_RATIOS), rel_tol=1e-9)
    assert result["closures_ratio"] < 1.0  # three scenes with far fewer closures per metre, three with more
    assert result["rho_error_closures"] == pytest.approx(-1.0, abs=1e-12)
    assert result["rho_error_closures_ci95"] == pytest.approx([-1.0, -1.0], abs=1e-12)  # every resample: same order
    assert -1.0 < result["rho_error_travel"] < 1.0
    split = result["by_closures"]
    assert split["closes_as_many"]["scenes"] == 3 and split["closes_fewer"]["scenes"] == 3
    assert math.isclose(split["closes_as_many"]["error_ratio"], geometric_mean(ERROR_RATIOS[:3]), rel_tol=1e-9)
    assert math.isclose(split["closes_fewer"]["error_ratio"], geometric_mean(ERROR_RATIOS[3:]), rel_tol=1e-9)


def test_bad_reports_fail_in_one_line(tmp_path: Path, capsys) -> None:
    association = script_runner(SCRIPT, capsys)

    def refusal(*args: str) -> str:
        proc = association(*args)
        assert proc.returncode != 0
        return proc.stderr.strip().splitlines()[-1]

    assert "is not a folder" in refusal(str(tmp_path / "missing"))
    (tmp_path / "empty").mkdir()
    assert "no trials.jsonl in it or its sub-folders" in refusal(str(tmp_path / "empty"))
    report = write_report(tmp_path / "report")
    assert "0 scenes with a trial of both 'learned' and 'nearest'" in refusal(str(report), "--reference", "nearest")
