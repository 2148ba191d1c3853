"""decide_time/compare_s59.py on made-up trials: a re-run equal to its stored trial is the same run, one whose travel
moved is not, a trial without a stored one is counted apart, and EM's pooled decision time over the learned policy's is
the ratio of the per-decision means. Bad arguments are refused in one line."""

from __future__ import annotations

import json

import pytest

from tests.benchmarks.smoke import json_lines, run_main

SCRIPT = "benchmarks/results/decide_time/compare_s59.py"


def trial(policy: str, seed: int, travel: float, ms: list[float]) -> dict:
    return {"scene": f"building_{seed}", "policy": policy, "seed": 0, "decisions": len(ms), "travel_m": travel,
            "explored": 0.86, "map_error_m": 0.05, "ms_decide": sum(ms) / len(ms),
            "rows": [{"ms_decide": m} for m in ms]}


def write(folder, trials: list[dict]) -> None:
    for t in trials:
        path = folder / t["scene"]
        path.mkdir(parents=True, exist_ok=True)
        with (path / "trials.jsonl").open("a") as out:
            out.write(json.dumps(t) + "\n")


def test_compare_finds_moved_trajectories_and_pools_decision_times(tmp_path, capsys):
    runs, em_then, learned_then = tmp_path / "runs", tmp_path / "em", tmp_path / "learned"
    write(runs, [trial("em", 1, 100.0, [60.0, 100.0]), trial("learned", 1, 90.0, [20.0, 30.0, 40.0]),
                 trial("em", 2, 50.0, [80.0]), trial("learned", 2, 70.0, [30.0])])
    write(em_then, [trial("em", 1, 100.0, [300.0, 300.0]), trial("em", 2, 50.0, [90.0])])
    write(learned_then, [trial("learned", 1, 90.0 + 1e-3, [20.0, 30.0, 40.0])])  # moved; building 2 not stored
    code, out, err = run_main(SCRIPT, [str(runs), "--stored", f"em={em_then}", f"learned={learned_then}"], capsys)
    assert code == 0, err
    summary = json_lines(out)[-1]
    assert summary["compared"] == 3 and summary["all_same_run"] is False
    assert summary["policies"]["em"] == {"trials": 2, "decisions": 3, "ms_decide": 80.0}
    assert summary["policies"]["learned"] == {"trials": 2, "decisions": 4, "ms_decide": 30.0}
    assert summary["em_over_learned_decide"] == pytest.approx(80.0 / 30.0, abs=0.01)
    assert "| building_1 | em | 2 | 100.0 | 0.05 | True | 80.0 | 300.0 |" in out
    assert "| building_1 | learned | 3 | 90.0 | 0.05 | False |" in out
    assert "| building_2 | learned | 1 | 70.0 | 0.05 | None | 30.0 | None |" in out
    code, out, _ = run_main(SCRIPT, [str(runs), "--stored", f"em={em_then}"], capsys)
    assert code == 0 and json_lines(out)[-1]["all_same_run"] is True  # the EM re-runs are the stored runs


def test_compare_refuses_bad_arguments_in_one_line(tmp_path, capsys):
    code, _, err = run_main(SCRIPT, [str(tmp_path)], capsys)
    assert code == 2 and "no */trials.jsonl" in err.strip().splitlines()[-1]
    write(tmp_path / "runs", [trial("em", 1, 1.0, [1.0])])
    code, _, err = run_main(SCRIPT, [str(tmp_path / "runs"), "--stored", f"em={tmp_path / 'missing'}"], capsys)
    assert code == 2 and "--stored em=" in err.strip().splitlines()[-1]
