"""The extended node features: checked against what they are defined from."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.envs import make_env
from explore_rl.envs.keys import NEAREST_ACTION
from explore_rl.graph.exploration_graph import graph_from_state
from explore_rl.graph.features import FRONTIER_EXTRAS, PAPER, disc_fraction, feature_set_of, scales_for

FAST = ["scene=street", "slam=model", "planning.actions.max_frontiers=4", "explore.travel_budget=40"]


def test_disc_fraction_matches_brute_force():
    rng = np.random.default_rng(0)
    mask = rng.random((40, 50)) < 0.3
    for cell, radius in (((20, 25), 6), ((1, 2), 5), ((39, 49), 3)):
        yy, xx = np.mgrid[0:40, 0:50]
        inside = (yy - cell[0]) ** 2 + (xx - cell[1]) ** 2 <= radius ** 2
        assert disc_fraction(mask, np.array(cell), radius) == pytest.approx(mask[inside].mean())


def test_feature_sets_and_scales_are_consistent():
    assert feature_set_of(PAPER) == "paper" and feature_set_of(PAPER + FRONTIER_EXTRAS) == "extended"
    assert len(scales_for(4)) == 4 and len(scales_for(10)) == 10
    with pytest.raises(ValueError, match="no feature set"):
        scales_for(5)
    with pytest.raises(ValueError, match="graph.features='huge'"):
        load_config(["graph.features=huge"])
    with pytest.raises(ValueError, match="model.feature_scale has 4 entries"):
        load_config(["graph.features=extended", "model.feature_scale=[1,1,1,1]"])


def test_extended_graph_adds_frontier_columns_from_the_state():
    config = load_config(FAST)
    env = make_env(config)
    td = env.reset()
    for _ in range(2):  # a state with some history
        td = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    decision = env.decision
    state, actions = decision.state, decision.actions
    context = env.em.decision_context(state)
    paper = graph_from_state(state, context, actions, "paper")
    extended = graph_from_state(state, context, actions, "extended", sensor_range=3.0)
    assert extended.features.shape == (paper.num_nodes, 10)
    np.testing.assert_array_equal(extended.features[:, :4], paper.features)
    poses = paper.candidate < 0
    assert not extended.features[poses, 4:].any()
    rows = extended.features[paper.frontier_nodes, 4:]
    for k, action in enumerate(actions):
        candidate = state.candidates[action.candidate]
        assert rows[k, 0] == pytest.approx(candidate.length)
        assert rows[k, 1] == pytest.approx(candidate.frontier.size * state.session.occupancy.grid.resolution)
        assert 0.0 < rows[k, 2] < 1.0  # a frontier borders unknown and known space
        assert rows[k, 3] == len(action.prediction.revisits)
        assert (rows[k, 4] > 0) == (len(action.prediction.revisits) > 0)
        assert 0.0 < rows[k, 5] <= 2 * config.planning.virtual_map.prior_std ** 2 + 1e-12


def test_the_env_and_the_learner_take_the_extended_set():
    from explore_rl.trainer.a2c import Learner

    config = load_config([*FAST, "graph.features=extended", "model.hidden=16", "model.mlp_hidden=16"])
    env = make_env(config)
    td = env.reset()
    assert td["x"].shape == (config.graph.max_nodes, 10)
    learner = Learner(config, env.action_spec)
    assert learner.actor(td.clone())["action"].shape == ()


def test_disc_fraction_at_and_beyond_every_border():
    """The disc built once per radius, cut at the grid's borders: the brute-force fraction
    for cells inside, on and outside every border (0 where the disc misses the grid)."""
    rng = np.random.default_rng(1)
    mask = rng.random((30, 45)) < 0.4
    yy, xx = np.mgrid[0:30, 0:45]
    for iy in range(-12, 43, 2):
        for ix in range(-12, 58, 3):
            for radius in (1, 4, 9):
                inside = (yy - iy) ** 2 + (xx - ix) ** 2 <= radius ** 2
                expected = float(mask[inside].mean()) if inside.any() else 0.0
                assert disc_fraction(mask, np.array([iy, ix]), radius) == expected
