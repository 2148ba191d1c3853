"""Smoke test of benchmarks/study_learning.py: a tiny run trained, then evaluated under the
protocol (the same episodes for every policy) both as a run and as a policy file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.benchmarks.smoke import load_script, run_main, run_script


def test_study_learning_smoke(tmp_path):
    result = run_script("benchmarks/study_learning.py", "--smoke", "--out", str(tmp_path), cwd=tmp_path,
                        timeout=240)
    assert result["smoke"] is True and result["held_out"] is True and result["layouts"] == [1000]
    assert set(result["policies"]) == {"learned", "em", "nearest", "random"}
    em, nearest = result["policies"]["em"], result["policies"]["nearest"]
    assert np.isnan(em["ci95"]).all()  # one episode per policy has no spread: no interval (unit tests cover it)
    assert nearest["mean_reward"] <= 0.0 <= em["mean_reward"]  # Algorithm 1's ranges
    assert "gap_closed" in result and set(result["per_layout"]) == {"1000"}
    run = result["runs"]["smoke_run"]["last"]
    # the run and the policy file are the same actor on the same episodes: the same figures
    assert run["policies"]["learned"]["mean_reward"] == result["policies"]["learned"]["mean_reward"]
    lines = (tmp_path / "episodes.jsonl").read_text().splitlines()
    assert len(lines) == 4  # one episode per policy: the second evaluation came from the cache
    assert {json.loads(line)["policy"] for line in lines} == {"learned", "em", "nearest", "random"}
    assert (tmp_path / "learning_curves.png").is_file() and (tmp_path / "protocol.json").is_file()


@pytest.mark.parametrize("script, required", [("benchmarks/study_learning.py", ["--policy", "actor.pt"]),
                                              ("benchmarks/collect_decisions.py", ["--out", "data"]),
                                              ("benchmarks/study_data.py", ["--dataset", "data"])])
def test_repeated_set_flags_add_up(script, required):
    """``--set A --set B`` keeps both overrides (a second flag once silently dropped the first)."""
    args = load_script(script).parse_args([*required, "--set", "graph.features=extended",
                                           "--set", "scene.building.lot_probability=1", "x.y=2"])
    assert args.set == ["graph.features=extended", "scene.building.lot_probability=1", "x.y=2"]


def episode(policy: str, layout: int, start: int, reward: float):
    from explore_rl.trainer.evaluate import EpisodeResult

    return EpisodeResult(policy, layout, start, 0, [reward], [True], 0.5, 10.0, 0.1)


def test_policy_difference_is_paired_on_the_same_episodes():
    difference = load_script("benchmarks/study_learning.py").policy_difference
    rng = np.random.default_rng(0)
    hardness = rng.normal(0.0, 0.3, 12)  # shared by every policy: pairing cancels it
    results = {name: [episode(name, 1000, k, level + h) for k, h in enumerate(hardness)]
               for name, level in (("learned", 0.6), ("em", 0.8), ("random", 0.0))}
    other = [episode("learned", 1000, k, 0.4 + h) for k, h in enumerate(hardness)]
    figures = difference(results, other)
    assert figures["gap_closed"] == pytest.approx(0.5) and figures["difference"] == pytest.approx(0.25)
    low, high = figures["difference_ci95"]  # every resample gives the same difference: a point
    assert low == pytest.approx(0.25) and high == pytest.approx(0.25)
    low, high = figures["gap_closed_ci95"]
    assert low <= 0.5 <= high
    with pytest.raises(ValueError, match="same episodes"):
        difference(results, other[::-1])


@pytest.mark.parametrize("flag", ["--policy", "--compare"])
def test_an_actor_that_names_no_training_layouts_is_refused_before_any_episode(tmp_path, capsys, flag):
    """The protocol cannot refuse the layouts of a file that names none: one line, before any episode (an
    offline-distilled file once crashed with a TypeError, and --compare was checked only after the first policy
    played)."""
    from explore_rl.models.actor_file import read_actor_file, save_actor_file

    actor_file = read_actor_file("policies/office_paper/actor.pt")
    actor_file.meta = {"kind": "offline distillation (em_choice)", "scene": "office", "train_layouts": None}
    nameless = save_actor_file(tmp_path / "nameless.pt", actor_file)
    other = {"--policy": ["--compare", "policies/office_paper/actor.pt"], "--compare": ["--policy",
             "policies/office_paper/actor.pt"]}[flag]
    code, _, err = run_main("benchmarks/study_learning.py", [flag, str(nameless), *other, "--layouts", "2000",
                                                             "--starts", "1", "--max-decisions", "1", "--out",
                                                             str(tmp_path)], capsys)
    assert code != 0
    assert err.strip().splitlines() == [err.strip()]  # one line, no traceback
    assert "meta['train_layouts']" in err
    assert not (tmp_path / "episodes.jsonl").exists()  # not one episode played
