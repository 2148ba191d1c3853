"""The extended node features: checked against what they are defined from."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.envs import make_env
from explore_rl.envs.keys import NEAREST_ACTION
from explore_rl.graph.exploration_graph import graph_from_state
from explore_rl.graph.features import (
    FRONTIER_EXTRAS,
    PAPER,
    built_names,
    disc_fraction,
    feature_names,
    feature_set_of,
    kept_columns,
    reads_covariances,
    scales_for,
)

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


def test_the_no_covariance_set_is_the_extended_one_without_its_covariance_columns():
    """``no_covariance``: the extended columns that need no covariance, in the extended order, selected from the
    extended graph the builder makes; every other set reads covariances and is built as it is."""
    names = feature_names("no_covariance")
    assert names == ("distance", "bearing", "identity", "path_length", "frontier_size", "unknown_nearby", "revisits")
    assert feature_set_of(list(names)) == "no_covariance" and len(scales_for(7)) == 7
    assert built_names("no_covariance") == PAPER + FRONTIER_EXTRAS
    assert [built_names("no_covariance")[i] for i in kept_columns("no_covariance")] == list(names)
    assert not reads_covariances("no_covariance")
    for feature_set in ("paper", "extended", "loops"):
        assert reads_covariances(feature_set) and kept_columns(feature_set) is None
        assert built_names(feature_set) == feature_names(feature_set)
    config = load_config(FAST)
    env = make_env(config)
    td = env.reset()
    td = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    decision = env.decision
    context = env.em.decision_context(decision.state)
    extended = graph_from_state(decision.state, context, decision.actions, "extended")
    selected = graph_from_state(decision.state, context, decision.actions, "no_covariance")
    assert selected.features.shape == (extended.num_nodes, 7)
    np.testing.assert_array_equal(selected.features, extended.features[:, [1, 2, 3, 4, 5, 6, 7]])
    np.testing.assert_array_equal(selected.edges, extended.edges)


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


def shortest_paths_reference(n: int, edges: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """All-pairs shortest paths by Floyd-Warshall on a dense matrix (independent of scipy's Dijkstra)."""
    distance = np.full((n, n), np.inf)
    np.fill_diagonal(distance, 0.0)
    for (i, j), w in zip(edges, weights):
        distance[i, j] = distance[j, i] = min(distance[i, j], w)
    for k in range(n):
        distance = np.minimum(distance, distance[:, k:k + 1] + distance[k:k + 1, :])
    return distance


def test_loop_lengths_are_the_longest_pose_graph_distance_to_a_joined_keyframe():
    """On random pose graphs (an odometry chain, some of it of length 0, plus loop edges), with frontiers joined
    to random keyframes: each frontier's value is the largest Floyd-Warshall distance from the current keyframe
    through the pose edges alone, 0 for a frontier joined to none or only to the current pose."""
    from explore_rl.graph.features import loop_lengths

    rng = np.random.default_rng(3)
    for trial in range(20):
        n_poses, n_frontiers = int(rng.integers(5, 40)), int(rng.integers(1, 6))
        chain = np.column_stack([np.arange(n_poses - 1), np.arange(1, n_poses)])
        loops = rng.integers(0, n_poses, size=(int(rng.integers(0, 6)), 2))
        loops = loops[loops[:, 0] != loops[:, 1]]
        pose_edges = np.vstack([chain, loops])
        pose_weights = rng.uniform(0.0, 2.0, len(pose_edges)) * (rng.random(len(pose_edges)) > 0.2)
        frontier_nodes = n_poses + np.arange(n_frontiers)
        current = int(rng.integers(0, n_poses))
        joined = [rng.choice(n_poses, size=int(rng.integers(0, 4)), replace=False) for _ in range(n_frontiers)]
        joined[0] = np.r_[joined[0], current]  # the nearest frontier's edge to the current pose
        frontier_edges = np.array([[k, node] for node, keys in zip(frontier_nodes, joined) for k in keys]).reshape(-1, 2)
        # a frontier edge would be a shortcut between the keyframes it joins: it must not be used
        edges = np.vstack([pose_edges, frontier_edges])
        weights = np.r_[pose_weights, np.full(len(frontier_edges), 1e-3)]
        expected_distance = shortest_paths_reference(n_poses, pose_edges, pose_weights)[current]
        expected = [expected_distance[keys].max() if len(keys) else 0.0 for keys in joined]
        got = loop_lengths(n_poses, edges, weights, current, frontier_nodes)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12, err_msg=f"trial {trial}")


def test_a_revisited_keyframe_out_of_reach_is_a_one_line_error():
    from explore_rl.graph.features import loop_lengths

    # the first decision: one keyframe, no pose edge, the nearest frontier joined to it
    assert loop_lengths(1, np.array([[0, 1]]), np.array([0.5]), 0, np.array([1])).tolist() == [0.0]

    edges = np.array([[0, 1], [2, 3], [3, 4]])  # keyframes 0-1 and 2-3 not joined
    with pytest.raises(ValueError, match="keyframes \\[3\\] are not reachable from keyframe 1"):
        loop_lengths(4, edges, np.ones(3), 1, np.array([4]))


def test_the_loops_graph_appends_loop_length_from_the_graphs_pose_edges():
    """``graph.features=loops``: the extended columns unchanged, then ``loop_length``: 0 on poses, on a frontier
    the largest pose-graph (Floyd-Warshall) distance from the current keyframe to a keyframe it is joined to."""
    config = load_config(FAST)
    env = make_env(config)
    td = env.reset()
    for _ in range(3):
        td = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
    state, actions = env.decision.state, env.decision.actions
    context = env.em.decision_context(state)
    extended = graph_from_state(state, context, actions, "extended", sensor_range=3.0)
    loops = graph_from_state(state, context, actions, "loops", sensor_range=3.0)
    assert loops.features.shape == (extended.num_nodes, 11) and feature_set_of(PAPER + FRONTIER_EXTRAS + ("loop_length",)) == "loops"
    np.testing.assert_array_equal(loops.features[:, :10], extended.features)
    n_poses = int((loops.candidate < 0).sum())
    assert not loops.features[:n_poses, 10].any()
    pose_edges = loops.edges[(loops.edges < n_poses).all(axis=1)]
    distance = shortest_paths_reference(n_poses, pose_edges, loops.weights[(loops.edges < n_poses).all(axis=1)])
    for node in loops.frontier_nodes:
        joined = loops.edges[(loops.edges == node).any(axis=1)].ravel()
        joined = joined[joined < n_poses]
        expected = distance[loops.current, joined].max() if len(joined) else 0.0
        assert loops.features[node, 10] == pytest.approx(expected, abs=1e-9)
    revisiting = [k for k, a in enumerate(actions) if a.prediction.revisits]
    assert revisiting and loops.features[loops.frontier_nodes[revisiting], 10].max() > 0.0  # a loop is measured
    assert len(scales_for(11)) == 11
