"""The evaluation protocol: same episodes for every policy, paired bootstrap intervals,
gap_closed, held-out checks and a cache keyed on what changes an episode."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.envs.keys import EM_ACTION, NEAREST_ACTION
from explore_rl.trainer.evaluate import (
    EpisodeResult,
    EpisodeSpec,
    check_actor_features,
    check_held_out,
    episode_key,
    episode_specs,
    gap_closed,
    paired_bootstrap,
    play,
    run_protocol,
    summarize,
    training_layouts,
)

FAST = ["scene=street", "slam=model", "planning.actions.max_frontiers=3", "explore.travel_budget=30"]


def test_episode_seeds_depend_on_layout_and_start_only():
    specs = episode_specs([5, 7], 3)
    assert [(s.layout, s.start) for s in specs] == [(5, 0), (5, 1), (5, 2), (7, 0), (7, 1), (7, 2)]
    assert len({s.seed for s in specs}) == 6
    assert episode_specs([7], 2) == specs[3:5]  # another layout list gives layout 7 the same episodes


def test_every_policy_sees_the_same_first_observation():
    config = load_config(FAST)
    spec = episode_specs([4], 1)[0]
    firsts = {}

    def recorder(name, pick):
        def choose(td):
            firsts.setdefault(name, td["x"].clone())
            return int(td[pick])
        return choose

    em = play(config, spec, "em", recorder("em", EM_ACTION), 1)
    nearest = play(config, spec, "nearest", recorder("nearest", NEAREST_ACTION), 1)
    assert (em.layout, em.start, em.seed) == (nearest.layout, nearest.start, nearest.seed) == (4, 0, spec.seed)
    np.testing.assert_allclose(firsts["em"].numpy(), firsts["nearest"].numpy(), rtol=0, atol=0)


def test_the_bootstrap_interval_matches_the_normal_approximation():
    values = np.random.default_rng(0).normal(0.3, 1.0, 400)
    low, high = paired_bootstrap({"p": values}, lambda v: float(np.mean(v["p"])), resamples=3000)
    half = 1.96 * values.std(ddof=1) / np.sqrt(len(values))
    assert low == pytest.approx(values.mean() - half, abs=0.2 * half)
    assert high == pytest.approx(values.mean() + half, abs=0.2 * half)


def test_the_paired_interval_of_gap_closed_is_tight_when_learned_tracks_em():
    """Episodes vary a lot, but learned sits exactly halfway between random and EM on each:
    a paired bootstrap keeps gap_closed at 0.5 in every resample, an unpaired one would not."""
    rng = np.random.default_rng(1)
    random = rng.normal(0.0, 0.5, 30)
    em = random + 0.6 + rng.uniform(0, 0.01, 30)
    values = {"random": random, "em": em, "learned": (random + em) / 2}
    assert gap_closed({k: float(np.mean(v)) for k, v in values.items()}) == pytest.approx(0.5)
    low, high = paired_bootstrap(values, lambda v: gap_closed({k: float(np.mean(c)) for k, c in v.items()}))
    assert 0.49 < low <= high < 0.51


def _result(policy, layout, start, rewards):
    return EpisodeResult(policy, layout, start, 0, rewards, [True], 0.5, 10.0, 0.1)


def test_summary_per_layout_and_pooled():
    results = {
        "em": [_result("em", 1, 0, [1.0]), _result("em", 2, 0, [0.5])],
        "random": [_result("random", 1, 0, [0.0]), _result("random", 2, 0, [0.1])],
        "learned": [_result("learned", 1, 0, [0.5]), _result("learned", 2, 0, [0.1])],
    }
    summary = summarize(results, resamples=200)
    assert summary["layouts"] == [1, 2]
    assert summary["policies"]["em"]["mean_reward"] == pytest.approx(0.75)
    assert summary["gap_closed"] == pytest.approx((0.3 - 0.05) / (0.75 - 0.05))
    assert summary["per_layout"]["1"]["gap_closed"] == pytest.approx(0.5)
    assert summary["per_layout"]["2"]["gap_closed"] == pytest.approx(0.0)


def test_training_layouts_are_refused():
    trained_scene, trained = training_layouts({"scene": {"name": "office", "seed": 0}, "seed": 0, "env": {}})
    assert trained == range(0, 1)
    with pytest.raises(ValueError, match="training layouts"):
        check_held_out("office", [3, 0], trained_scene, trained)
    check_held_out("office", [3, 4], trained_scene, trained)
    check_held_out("street", [0], trained_scene, trained)  # another scene is held out
    scene, ranged = training_layouts({"scene": {"name": "building"}, "env": {"train_layouts": [0, 500]}})
    with pytest.raises(ValueError, match="0..499"):
        check_held_out("building", [499], scene, ranged)
    with pytest.raises(ValueError, match=r"meta\['train_layouts'\]") as error:  # nothing says what it trained on
        training_layouts({"scene": {"name": "building", "seed": None}, "seed": None, "env": {"train_layouts": None}})
    assert "\n" not in str(error.value)


def test_the_cache_key_follows_what_changes_an_episode():
    config = load_config(FAST)
    spec = EpisodeSpec(1, 0, 99)
    key = episode_key(config, spec, "em", 5, "src")
    other_budget = dataclasses.replace(config, explore=dataclasses.replace(config.explore, travel_budget=31.0))
    other_trainer = dataclasses.replace(config, train=dataclasses.replace(config.train, frames=7))
    assert episode_key(other_budget, spec, "em", 5, "src") != key
    assert episode_key(other_trainer, spec, "em", 5, "src") == key
    assert episode_key(config, EpisodeSpec(1, 0, 98), "em", 5, "src") != key
    assert episode_key(config, spec, "em", 6, "src") != key
    assert episode_key(config, spec, "em", 5, "other source") != key


def test_an_actor_of_other_features_is_refused_before_any_episode(tmp_path):
    """The shipped actor reads the extended features: under graph.features=paper the protocol
    fails at once, naming the fix, instead of in the learned policy's first decision."""
    shipped = "policies/buildings_sparse_em_choice/actor.pt"
    cache = tmp_path / "episodes.jsonl"
    with pytest.raises(ValueError, match="set graph.features=extended"):
        run_protocol(load_config(FAST), episode_specs([4], 1), ["em", "learned"], 1, actor_path=shipped, cache=cache)
    assert not cache.exists()  # not even EM played
    check_actor_features(load_config([*FAST, "graph.features=extended"]), shipped)  # the matching set passes
