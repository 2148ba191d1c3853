"""The zero-shot target check: common coverage, ratios by hand, intervals and verdicts."""

from __future__ import annotations

import json

import numpy as np
import pytest

from explore_rl import comparison, zero_shot
from explore_rl.zero_shot import ZeroShotTargets


def run(policy: str, trial: int, travel: list[float], explored: list[float], error: list[float],
        ms: float = 10.0, scene: str = "street") -> dict:
    rows = [{"travel_m": t, "explored": x, "map_error_m": e} for t, x, e in zip(travel, explored, error)]
    return {"scene": scene, "policy": policy, "trial": trial, "status": "explored", "rows": rows,
            "travel_m": travel[-1], "ms_decide": ms}


def test_travel_to_reach_interpolates_from_the_start_and_holds_the_end():
    trial = run("em", 0, [10.0, 20.0, 30.0], [0.2, 0.6, 0.5], [0.1, 0.2, 0.3])
    assert comparison.travel_to_reach(trial, 0.1) == pytest.approx(5.0)  # from (0 m, 0 %) to (10 m, 20 %)
    assert comparison.travel_to_reach(trial, 0.4) == pytest.approx(15.0)
    assert comparison.travel_to_reach(trial, 0.6) == pytest.approx(20.0)
    assert comparison.travel_to_reach(trial, 0.9) == pytest.approx(30.0)  # never: the final travel


def test_common_coverage_is_the_stop_coverage_or_the_least_any_trial_explored_floored():
    runs = [run("em", 0, [10.0], [0.9], [0.1]), run("learned", 0, [10.0], [0.95], [0.1])]
    assert zero_shot.common_coverage(runs, 0.85) == 0.85
    runs.append(run("em", 1, [10.0, 20.0], [0.5, 0.697], [0.1, 0.1]))
    assert zero_shot.common_coverage(runs, 0.85) == pytest.approx(0.69)


def test_ratios_at_the_common_coverage_and_at_equal_travel_by_hand():
    # learned reaches 80 % at 100 m (error 0.2) and 120 m (error 0.4); em at 200 m and 250 m
    runs = [run("learned", 0, [50.0, 100.0], [0.4, 0.8], [0.1, 0.2], ms=10.0),
            run("learned", 1, [60.0, 120.0], [0.4, 0.8], [0.3, 0.4], ms=10.0),
            run("em", 0, [100.0, 200.0], [0.4, 0.8], [0.05, 0.1], ms=100.0),
            run("em", 1, [125.0, 250.0], [0.4, 0.8], [0.15, 0.2], ms=300.0)]
    (entry,) = zero_shot.check_targets(runs, resamples=200)
    assert entry["coverage"] == pytest.approx(0.8) and not entry["at_stop_coverage"]
    assert entry["travel_ratio"] == pytest.approx(110.0 / 225.0)
    assert entry["error_ratio"] == pytest.approx(0.3 / 0.15)
    # em's error at learned's mean travel, 110 m: 0.05 + 0.1 * 0.05 = 0.055 (em 0) and 0.15 (em 1, before its first row)
    assert entry["reference_map_error_at_equal_travel_m"] == pytest.approx((0.055 + 0.15) / 2)
    assert entry["equal_travel_error_ratio"] == pytest.approx(0.3 / 0.1025)
    assert entry["speedup"] == pytest.approx(200.0 / 10.0)
    assert np.isnan(entry["closures_ratio"])  # these rows have no loop_closures: no ratio, "n/a" in the table
    for key in set(zero_shot.KEYS) - {"closures_ratio"}:  # each interval holds its point estimate (two trials each)
        low, high = entry[f"{key}_ci95"]
        assert low <= entry[key] + 1e-12 and entry[key] <= high + 1e-12
    assert entry["travel_met"] and not entry["error_met"] and entry["speed_met"]
    text = zero_shot.targets_markdown([entry])
    assert "| street | 80 (below stop) | 110.0 / 225.0 |" in text and "| n/a | 20.00" in text
    assert "travel, speed |" in text
    json.dumps(zero_shot.targets_json([entry]))


def test_loop_closures_per_metre_ratio_at_the_common_coverage_by_hand():
    """(closures + 1) per metre up to the coverage both reach (80 %): learned 2 closures in 100 m,
    EM 9 in 200 m and 0 in 100 m -> (3/100) / mean(10/200, 1/100) = 0.03 / 0.03 = 1."""
    def with_closures(trial: dict, closures: list[int]) -> dict:
        for row, count in zip(trial["rows"], closures):
            row["loop_closures"] = count
        return trial

    runs = [with_closures(run("learned", 0, [50.0, 100.0], [0.4, 0.8], [0.1, 0.2]), [0, 2]),
            with_closures(run("em", 0, [100.0, 200.0], [0.4, 0.8], [0.1, 0.1]), [3, 9]),
            with_closures(run("em", 1, [50.0, 100.0], [0.4, 0.8], [0.1, 0.1]), [0, 0])]
    (entry,) = zero_shot.check_targets(runs, resamples=50)
    assert entry["closures_ratio"] == pytest.approx((3 / 100) / ((10 / 200 + 1 / 100) / 2))


def test_a_target_is_met_only_when_the_whole_interval_is_within_it():
    # travel ratios 0.9 on average but spread: one learned trial at 2x em's travel
    runs = [run("learned", t, [travel], [0.85], [0.1]) for t, travel in enumerate([40.0, 140.0])]
    runs += [run("em", t, [100.0], [0.85], [0.1], ms=10.0) for t in range(2)]
    (entry,) = zero_shot.check_targets(runs, resamples=500)
    assert entry["travel_ratio"] == pytest.approx(0.9) and entry["travel_ratio_ci95"][1] > 1.1
    assert not entry["travel_met"]
    assert entry["error_ratio_ci95"] == pytest.approx([1.0, 1.0]) and entry["error_met"]
    assert not entry["speed_met"]  # 1x


def test_one_trial_per_scene_gives_no_interval_and_no_verdict_but_the_pool_does():
    runs = []
    for k, ratio in enumerate([0.5, 2.0, 1.0]):
        scene = f"building_{k}"
        runs += [run("learned", 0, [100.0 * ratio], [0.6], [0.1 * ratio], scene=scene),
                 run("em", 0, [100.0], [0.6], [0.1], scene=scene)]
    *scenes, pooled = zero_shot.check_targets(runs, resamples=300)
    assert all(np.isnan(e["travel_ratio_ci95"]).all() and not e["travel_met"] for e in scenes)
    assert "one trial: no interval" in zero_shot.targets_markdown(scenes) and "| n/a |" in zero_shot.targets_markdown(
        scenes)
    assert pooled["scenes"] == 3
    assert pooled["travel_ratio"] == pytest.approx(1.0)  # the geometric mean of 0.5, 2, 1
    low, high = pooled["travel_ratio_ci95"]
    assert low < 1.0 < high and not pooled["travel_met"]  # resampled scenes spread it
    assert pooled["error_ratio"] == pytest.approx(1.0) and pooled["speedup"] == pytest.approx(1.0)


def test_the_report_without_learned_or_em_has_no_target_table():
    runs = [run("nearest", 0, [10.0], [0.9], [0.1]), run("em", 0, [10.0], [0.9], [0.1])]
    assert zero_shot.check_targets(runs) == []
    assert zero_shot.targets_markdown([]) == ""


def test_write_summary_adds_the_target_table_and_json(tmp_path):
    runs = [run("learned", t, [50.0, 100.0], [0.5, 0.9], [0.1, 0.2]) for t in range(2)]
    runs += [run("em", t, [100.0, 200.0], [0.5, 0.9], [0.1, 0.1], ms=100.0) for t in range(2)]
    for r in runs:  # the summary's other tables read these final figures
        r.update({"map_error_m": r["rows"][-1]["map_error_m"], "explored": 0.9, "volume_m3": 1.0, "loop_closures": 0,
                  "explored_per_m": 0.01, "contacts": 0, "blocked_decisions": 0, "min_clearance_m": 0.1})
        for row in r["rows"]:
            row["volume_m3"] = 1.0
    comparison.write_summary(runs, tmp_path)
    saved = json.loads((tmp_path / "targets.json").read_text())
    assert saved["targets"] == {"coverage": 0.85, "max_travel_ratio": 1.1, "max_error_ratio": 1.1, "min_speedup": 5.0}
    assert saved["entries"][0]["coverage"] == 0.85 and "Zero-shot targets" in (tmp_path / "summary.md").read_text()
    assert ZeroShotTargets().coverage == saved["entries"][0]["coverage"]


def test_two_scenes_with_many_trials_pool_with_their_trials_spread():
    """Two named scenes with the same ratio but widely spread trials: resampling scenes alone
    would give a zero-width interval at that ratio; the trials' spread must widen it."""
    runs = []
    for scene in ("street", "garage"):
        runs += [run("learned", t, [travel], [0.85], [0.1], scene=scene) for t, travel in enumerate([40.0, 160.0] * 3)]
        runs += [run("em", t, [100.0], [0.85], [0.1], scene=scene) for t in range(6)]
    *scenes, pooled = zero_shot.check_targets(runs, resamples=500)
    assert [e["travel_ratio"] for e in scenes] == pytest.approx([1.0, 1.0]) and pooled["scenes"] == 2
    assert pooled["travel_ratio"] == pytest.approx(1.0)
    low, high = pooled["travel_ratio_ci95"]
    assert low < 0.8 and high > 1.2 and not pooled["travel_met"]
    assert pooled["error_ratio_ci95"] == pytest.approx([1.0, 1.0])  # no spread anywhere: none in the pool


def test_trials_to_resolve_by_hand():
    resolve = zero_shot.trials_to_resolve
    # log half-width ln 1.21 = 2 x the margin ln 1.1: four times the trials
    assert resolve(1.0, [0.8, 1.21], 10, 1.1, upper=True) == 40
    assert resolve(1.0, [0.95, 1.05], 10, 1.1, upper=True) <= 10  # met already: no more trials needed
    assert resolve(1.12, [0.9, 1.4], 20, 1.1, upper=True) == float("inf")  # the ratio itself misses
    # speed-up (a lower bound): ln(10 / 4) over ln(10 / 5), squared, x 10 = 17.5 -> 18
    assert resolve(10.0, [4.0, 20.0], 10, 5.0, upper=False) == 18
    assert resolve(2.4, [1.9, 3.0], 20, 5.0, upper=False) == float("inf")
    assert np.isnan(resolve(1.0, [float("nan"), float("nan")], 1, 1.1, upper=True))


def test_the_markdown_lists_the_trials_to_resolve_each_target():
    runs = [run("learned", t, [travel], [0.85], [0.1]) for t, travel in enumerate([90.0, 110.0])]
    runs += [run("em", t, [100.0], [0.85], [0.1], ms=100.0) for t in range(2)]
    (entry,) = zero_shot.check_targets(runs, resamples=300)
    assert entry["trials_to_resolve"]["speed"] <= 2  # 10x faster, no spread: met
    assert entry["trials_to_resolve"]["error"] <= 2  # equal errors, no spread
    text = zero_shot.targets_markdown([entry])
    assert "| scene | trials now | travel | map error | speedup |" in text and "| street | 2 |" in text


def test_decision_times_of_several_machines_never_meet_the_speed_target():
    """Trials record their processor: a speedup divides one machine's decision times by another's only as a
    flagged figure, never a met target (nor new trials' times by stored ones that record none); one machine's is a
    verdict as before, and so are reports none of whose trials record it (old reports read again)."""
    def timed(policy, trial, ms, cpu):
        return {**run(policy, trial, [50.0, 100.0], [0.4, 0.9], [0.1, 0.1], ms=ms), "cpu": cpu}

    mixed = [timed("learned", 0, 10.0, "A"), timed("learned", 1, 11.0, "A"),
             timed("em", 0, 100.0, "B"), timed("em", 1, 110.0, "B")]
    (entry,) = zero_shot.check_targets(mixed, resamples=200)
    assert entry["speedup"] == pytest.approx(10.0) and entry["speedup_ci95"][0] >= 5.0
    assert entry["decision_times"] == "several machines" and not entry["speed_met"]
    assert "(several machines)" in zero_shot.targets_markdown([entry])
    (entry,) = zero_shot.check_targets([{**t, "cpu": "A"} for t in mixed], resamples=200)
    assert entry["decision_times"] == "one machine" and entry["speed_met"]
    (entry,) = zero_shot.check_targets([{k: v for k, v in t.items() if k != "cpu"} for t in mixed], resamples=200)
    assert entry["decision_times"] == "unrecorded" and entry["speed_met"]
    new_against_stored = [{**t, "cpu": "A"} if t["policy"] == "learned" else {k: v for k, v in t.items() if k != "cpu"}
                          for t in mixed]  # new trials paired with stored ones that record no processor
    (entry,) = zero_shot.check_targets(new_against_stored, resamples=200)
    assert entry["decision_times"] == "several machines" and not entry["speed_met"]
    assert comparison.cpu_model()  # this machine's name, recorded in every trial
