"""Smoke test of benchmarks/bench_decision_real.py: it runs (``--smoke``: two office
decisions, model front end) and its JSON last line holds the figures RESULTS.md quotes.
Times are not checked (beyond the policy.em_top_k hybrids' being timed); the fast learned path must have been the reference's decision
(:class:`~explore_rl.planning.learned.Equivalence`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.benchmarks.smoke import run_script

KEYS = ["ms_em", "ms_learned", "ms_learned_reference", "em_over_learned", "em_over_learned_decide",
        "em_over_learned_median", "em_over_shared", "ms_state", "same_choice", "equivalent",
        "equivalence", "feature_rel_diff", "logit_rel_diff", "probability_diff", "max_logit_diff", "ms_part_actions",
        "ms_part_marginals", "ms_part_landmarks", "ms_part_forward", "ms_part_forward_reference", "scenes", "rows",
        "ms_top2", "ms_top3", "em_over_top2", "em_over_top3", "ms_observe", "ms_observe_reference",
        "observe_speedup", "same_observation"]


def test_bench_decision_real_smoke(tmp_path: Path) -> None:
    result = run_script("benchmarks/bench_decision_real.py", "--smoke", cwd=tmp_path)
    assert result["smoke"] is True
    missing = [key for key in KEYS if key not in result]
    assert not missing, f"JSON last line lacks {missing} (has {sorted(result)})"
    assert result["states"] == len(result["rows"]) == 2 and set(result["scenes"]) == {"office"}
    assert result["same_choice"] is True and result["equivalent"] is True
    assert result["same_observation"] is True and result["ms_observe"] > 0 and result["ms_observe_reference"] > 0
    assert result["feature_rel_diff"] <= result["equivalence"]["feature_rtol"]
    assert result["logit_rel_diff"] <= result["equivalence"]["logit_rtol"]
    assert result["probability_diff"] <= result["equivalence"]["probability_atol"]
    assert result["em_over_shared"] >= result["em_over_learned"]  # the bound: the learned-only parts at 0 ms
    assert result["ms_em"] > 0 and result["ms_learned"] > 0 and result["ms_learned_reference"] > 0
    assert result["ms_top2"] > 0 and abs(result["em_over_top2"] - result["ms_em"] / result["ms_top2"]) <= 0.011


@pytest.mark.parametrize(("features", "covariances"), [("loops", True), ("no_covariance", False)])
def test_bench_decision_real_takes_an_actor_of_other_features(tmp_path: Path, features: str, covariances: bool) -> None:
    """``--actor`` of a ``graph.features=loops`` or ``no_covariance`` actor: it drives and decides, its parts are
    timed with its own columns, the JSON names its features, and the fast path is still the reference's decision
    (for ``no_covariance`` one without marginals against one that computes and drops them)."""
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    path, _ = actor_file(tmp_path / features, load_config([*TINY_MODEL, f"graph.features={features}"]))
    result = run_script("benchmarks/bench_decision_real.py", "--smoke", "--actor", str(path), cwd=tmp_path)
    assert result["actor"] == str(path) and result["states"] == 2
    assert result["features"] == features and result["reads_covariances"] is covariances
    assert result["same_choice"] is True and result["equivalent"] is True
