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


POOL = "benchmarks/results/decide_time/collect_pool_s81.py"


def collect_log(path, ratios: list[float], dps_1: list[float]) -> None:
    last = {"speedup_async_rounds": ratios, "dps_1_rounds": dps_1, "dps_async_rounds": [r * d for r, d in zip(ratios, dps_1)]}
    path.write_text("1 worker: ...\n" + json.dumps({"benchmark": "collect"}) + "\n" + json.dumps(last) + "\nuptime\n")


def test_collect_pool_pools_the_rounds_of_each_side(tmp_path, capsys):
    collect_log(tmp_path / "bench_collect_rounds4_before_s81_r1.log", [1.8, 2.0], [3.0, 4.0])
    collect_log(tmp_path / "bench_collect_rounds4_before_s81_r2.log", [1.9, 1.7], [3.5, 3.5])
    collect_log(tmp_path / "bench_collect_rounds4_s81_r1.log", [1.5, 1.7], [4.0, 5.0])
    code, out, err = run_main(POOL, ["--logs", str(tmp_path)], capsys)
    assert code == 0, err
    summary = json_lines(out)[-1]
    assert summary["session80"]["rounds"] == 4 and summary["session80"]["speedup_async"] == pytest.approx(1.85)
    assert summary["session80"]["speedup_async_ci95"][0] < 1.85 < summary["session80"]["speedup_async_ci95"][1]
    assert summary["session81"]["rounds"] == 2 and summary["session81"]["speedup_async"] == pytest.approx(1.6)
    assert summary["session81"]["dps_1"] == [4.0, 5.0] and summary["session81"]["dps_async"] == [6.0, 8.5]


def test_collect_pool_pools_named_sides_and_their_ceilings(tmp_path, capsys):
    collect_log(tmp_path / "a_r1.log", [1.8, 2.0], [3.0, 4.0])
    ceiling = {"ceiling_rounds": [2.0, 1.9, 2.1], "speedup_async_of_ceiling_rounds": [0.9, 0.8, 1.0]}
    (tmp_path / "b_r1.log").write_text(json.dumps({"speedup_async_rounds": [1.5, 1.7, 1.6], "dps_1_rounds": [4.0] * 3,
                                                   "dps_async_rounds": [6.0] * 3, **ceiling}) + "\n")
    code, out, err = run_main(POOL, ["--logs", str(tmp_path), "--side", "old=a_r*.log", "--side", "new=b_r*.log"], capsys)
    assert code == 0, err
    summary = json_lines(out)[-1]
    assert summary["old"]["speedup_async"] == pytest.approx(1.9) and "ceiling" not in summary["old"]
    assert summary["new"]["ceiling"]["rounds"] == 3 and summary["new"]["ceiling"]["mean"] == pytest.approx(2.0)
    assert summary["new"]["speedup_async_of_ceiling"]["mean"] == pytest.approx(0.9)
    low, high = summary["new"]["speedup_async_of_ceiling"]["ci95"]
    assert low < 0.9 < high


def test_collect_pool_refuses_a_side_without_a_pattern(tmp_path, capsys):
    code, _, err = run_main(POOL, ["--logs", str(tmp_path), "--side", "session82"], capsys)
    assert code != 0 and "give NAME=GLOB" in err.strip().splitlines()[-1]


def test_collect_pool_refuses_a_folder_without_logs(tmp_path, capsys):
    code, _, err = run_main(POOL, ["--logs", str(tmp_path)], capsys)
    assert code != 0 and "no logs match" in err.strip().splitlines()[-1]
