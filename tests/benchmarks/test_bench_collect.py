"""Smoke test of benchmarks/bench_collect.py: it runs (``--smoke``: 1 batch of 2 decisions
per worker, tiny model; 1 paired round with the ceiling: each round spawns two collectors and two
independent processes, and the rounds' mean and interval are
``common.mean_ci95``'s, tested on its own) and its JSON last line holds the figures RESULTS.md quotes. Speeds
are not checked; the same-work checks and the async policy-lag bound are."""

from __future__ import annotations

from pathlib import Path

from tests.benchmarks.smoke import run_script

KEYS = ["same_actions", "sync_bound", "async_bound", "ms_update_per_batch", "dps_1", "dps_2", "scaling",
        "same_actions_async", "dps_async", "dps_async_per_worker", "speedup_async", "cpu_async",
        "max_policy_lag", "policy_lag_max_async", "cpu_1", "speedup_async_per_cpu",
        "gated_bounds", "rounds", "speedup_async_rounds", "speedup_async_ci95", "ceiling", "ceiling_rounds",
        "speedup_async_of_ceiling", "dps_independent_rounds", "same_actions_independent"]


def test_bench_collect_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_collect.py", "--smoke", "--rounds", "1", "--ceiling", cwd=tmp_path,
                        timeout=300)
    assert result["smoke"] is True
    missing = [key for key in KEYS if key not in result]
    assert not missing, f"JSON last line lacks {missing} (has {sorted(result)})"
    # the same decisions in the 1-worker, sync and async runs (per-worker seeds, fixed weights)
    assert result["same_actions"] is True and result["same_actions_async"] is True
    assert result["same_actions_independent"] is True  # the two independent processes took them too
    assert 0 <= result["policy_lag_max_async"] <= result["max_policy_lag"]
    assert len(result["dps_async_per_worker"]) == 2 and result["speedup_async"] > 0
    # the headline speedup is the paired round's ratio; one round has no interval
    assert result["rounds"] == len(result["speedup_async_rounds"]) == 1
    assert abs(result["speedup_async"] - result["speedup_async_rounds"][0]) < 1e-3
    assert result["speedup_async_ci95"] is None
    # the ceiling: the independent processes' rate over the 1-worker run's; async's share of it
    ceiling, share = result["ceiling"], result["speedup_async_of_ceiling"]
    assert ceiling > 0 and abs(share - result["speedup_async"] / ceiling) < 1e-2
