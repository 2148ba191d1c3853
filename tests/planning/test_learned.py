"""The learned policy in the runner: the same graph as the environment's from cheaper
features, the same choice as the environment's actor, and clear errors."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from explore_rl.config import load_config
from explore_rl.planning.em import make_decision_context
from explore_rl.planning.learned import (
    LearnedPolicy,
    actor_logits,
    frontier_covariances,
    graph_features,
    pairs_in_range,
    pairs_in_range_reference,
)
from explore_rl.planning.policies import PolicyConfig, make_policy
from explore_rl.planning.virtual_map import VirtualMap
from explore_rl.runner import Explorer
from explore_rl.models.checkpoint import CheckpointError
from tests.policy_files import TINY_MODEL, actor_file, env_decisions

FAST = ["scene=office", "slam=model", "planning.actions.max_frontiers=4", "explore.progress_bar=false", *TINY_MODEL]


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    config = load_config(FAST)
    path, learner = actor_file(tmp_path_factory.mktemp("learned"), config)
    return config, path, learner


def test_same_graph_and_same_choice_as_the_environment(setup):
    """On every decision of an office episode: ``graph_features`` gives the env's graph
    (built from EM's full decision context) and the policy picks what the env's TorchRL
    actor picks."""
    config, path, learner = setup
    policy = make_policy(PolicyConfig("learned", checkpoint=str(path)), np.random.default_rng(0),
                         planning=config.planning, graph=config.graph)
    assert isinstance(policy, LearnedPolicy)
    sizes = []
    for decision, env_choice in env_decisions(config, learner, steps=7):
        state = decision.state
        graph = graph_features(state, decision.actions, policy.virtual_map(state.session.occupancy.grid))
        expected = decision.graph
        np.testing.assert_allclose(graph.features, expected.features, rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(graph.edges, expected.edges)
        np.testing.assert_allclose(graph.weights, expected.weights, rtol=1e-12)
        np.testing.assert_array_equal(graph.candidate, expected.candidate)
        assert policy.choose(state) == env_choice
        sizes.append((graph.num_nodes, len(decision.actions)))
    assert max(n for n, _ in sizes) > 30 and max(f for _, f in sizes) > 1
    assert set(policy.last_ms) == {"actions", "graph", "forward"}


def test_frontier_covariances_equal_the_full_virtual_map_anywhere(setup):
    """Any points, seen or unseen, inside or outside the map: the cell's covariance in the
    fully fused map of the decision context."""
    config, _, learner = setup
    for decision, _ in env_decisions(config, learner, steps=6):
        pass
    state = decision.state
    vmap = VirtualMap(state.session.occupancy.grid, config.planning.virtual_map)
    context = make_decision_context(state, vmap)
    rng = np.random.default_rng(0)
    near = context.poses[rng.integers(len(context.poses), size=40), :2] + rng.normal(0, 1.5, (40, 2))
    points = np.vstack([near, [[-5.0, -5.0], [100.0, 3.0]]])
    got = frontier_covariances(vmap, context.poses, context.pose_covs, context.blocked, points)
    expected = vmap.frontier_landmark_covariance(points, context.landmark_covs)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-18)
    seen = np.trace(expected, axis1=1, axis2=2) < 0.079
    assert seen.sum() > 10  # the test covers fused cells, not just the prior


def test_the_runner_explores_with_the_learned_policy(setup):
    _, path, _ = setup
    run_config = load_config([*FAST, "policy=learned", f"policy.checkpoint={path}", "explore.max_decisions=2"])
    result = Explorer(run_config).run()
    assert len(result.records) == 2 and result.status.value == "max_decisions"


def test_a_missing_actor_file_fails_with_one_line(tmp_path):
    config = load_config(FAST)
    missing = tmp_path / "policies" / "actor.pt"
    with pytest.raises(CheckpointError) as error:
        make_policy(PolicyConfig("learned", checkpoint=str(missing)), np.random.default_rng(0),
                    planning=config.planning)
    message = str(error.value)
    assert "\n" not in message and str(missing) in message and "explore-rl-train" in message


def test_extended_features_are_the_environments_too(tmp_path):
    """``graph.features=extended``: the runner's cheaper graph (landmarks near the frontiers
    only) equals the env's (the fully fused map), and the policy reads the actor's set."""
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)
    policy = make_policy(PolicyConfig("learned", checkpoint=str(path)), np.random.default_rng(0),
                         planning=config.planning, graph=load_config(FAST).graph)
    assert policy.features == "extended"
    for decision, env_choice in env_decisions(config, learner, steps=4):
        state = decision.state
        graph = graph_features(state, decision.actions, policy.virtual_map(state.session.occupancy.grid),
                               config.planning.em.backend, "extended")
        assert graph.features.shape[1] == 10
        np.testing.assert_allclose(graph.features, decision.graph.features, rtol=1e-9, atol=1e-12)
        assert policy.choose(state) == env_choice


def test_the_fast_path_decides_as_the_reference_on_real_states(tmp_path):
    """The fast decision path (candidates' revisits at once, one landmark fusion, KD-tree
    pairs, the encoding padded only to the graph's nodes) against the first implementation
    on every decision of an office episode, extended features: the same graph, the same
    frontier, the real rows' logits within 1e-5."""
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)
    policy_config = PolicyConfig("learned", checkpoint=str(path))
    fast = LearnedPolicy(policy_config, config.planning, graph=config.graph)
    reference = LearnedPolicy(policy_config, config.planning, graph=config.graph, reference=True)
    nodes = []
    for decision, _ in env_decisions(config, learner, steps=6):
        state = decision.state
        assert fast.choose(state) == reference.choose(state)
        np.testing.assert_allclose(fast.last_graph.features, reference.last_graph.features, rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(fast.last_graph.edges, reference.last_graph.edges)
        n = fast.last_graph.num_nodes
        assert len(fast.last_encoded.x) == n < len(reference.last_encoded.x) == config.graph.max_nodes
        logits = actor_logits(fast.actor, fast.last_encoded)
        torch.testing.assert_close(logits, actor_logits(reference.actor, reference.last_encoded)[:n],
                                   rtol=0.0, atol=1e-5)
        nodes.append(n)
    assert max(nodes) > 30


def test_pairs_in_range_equal_the_full_distance_matrix_at_the_boundary():
    """KD-tree pairs = ``np.nonzero`` of the full matrix, in the same order, including
    landmarks exactly at the radius (kept) and one ulp beyond it (not)."""
    rng = np.random.default_rng(0)
    poses = rng.uniform(0.0, 20.0, (300, 2))
    radius = 3.0
    on_circle = poses[:40] + np.array([radius, 0.0])
    beyond = poses[40:80] + np.array([np.nextafter(radius, np.inf), 0.0])
    landmarks = np.vstack([rng.uniform(0.0, 20.0, (500, 2)), on_circle, beyond])
    got = pairs_in_range(poses, landmarks, radius)
    expected = pairs_in_range_reference(poses, landmarks, radius)
    assert len(expected[0]) > 1000
    for a, b in zip(got, expected):
        np.testing.assert_array_equal(a, b)
    exact = np.linalg.norm(landmarks[expected[1]] - poses[expected[0]], axis=-1) == radius
    assert exact.sum() > 0  # the boundary case is exercised
