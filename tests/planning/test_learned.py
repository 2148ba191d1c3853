"""The learned policy in the runner: the same graph as the environment's from cheaper
features, the same choice as the environment's actor, and clear errors."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.planning.em import make_decision_context
from explore_rl.planning.learned import LearnedPolicy, frontier_covariances, graph_features
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
