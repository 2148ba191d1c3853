"""The learned policy in the runner: the same graph as the environment's from cheaper
features, the same choice as the environment's actor, and clear errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from explore_rl.config import load_config
from explore_rl.graph.encode import loop_length_rows
from explore_rl.graph.features import feature_names
from explore_rl.planning.em import EMPlanner, make_decision_context, pose_covariances
from explore_rl.planning.learned import (
    Equivalence,
    LearnedPolicy,
    actor_logits,
    closure_gains,
    decision_difference,
    frontier_covariances,
    graph_features,
    landmark_covariances,
    landmarks_near,
    landmarks_near_reference,
    pairs_in_range,
    pairs_in_range_reference,
    pose_marginals,
    revisit_counts,
    top_probability,
    visible_pairs_of,
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


@pytest.mark.parametrize("features, width", [("extended", 10), ("loops", 11), ("no_covariance", 7)])
def test_extended_features_are_the_environments_too(tmp_path, features, width):
    """``graph.features=extended`` (and ``loops``, its ``loop_length`` too): the runner's cheaper
    graph (landmarks near the frontiers only) equals the env's (the fully fused map), and the
    policy reads the actor's set."""
    config = load_config([*FAST, f"graph.features={features}"])
    path, learner = actor_file(tmp_path, config)
    policy = make_policy(PolicyConfig("learned", checkpoint=str(path)), np.random.default_rng(0),
                         planning=config.planning, graph=load_config(FAST).graph)
    assert policy.features == features
    for decision, env_choice in env_decisions(config, learner, steps=4):
        state = decision.state
        graph = graph_features(state, decision.actions, policy.virtual_map(state.session.occupancy.grid),
                               config.planning.em.backend, features)
        assert graph.features.shape[1] == width
        np.testing.assert_allclose(graph.features, decision.graph.features, rtol=1e-9, atol=1e-12)
        assert policy.choose(state) == env_choice


PRIORS = {  # policy key: (its per-row values, the node feature they equal and the feature set that has it)
    "revisit_bias": (lambda graph, encoded, actions: revisit_counts(graph, encoded, actions), "revisits", "extended"),
    "loop_bias": (lambda graph, encoded, actions: loop_length_rows(graph, encoded), "loop_length", "loops"),
}


@pytest.mark.parametrize("key", sorted(PRIORS))
def test_a_prior_adds_its_node_feature_to_the_logits(tmp_path, key):
    """``policy.revisit_bias`` / ``policy.loop_bias`` on an actor of the extended set: each frontier row's value is
    the ``revisits`` / ``loop_length`` column of the same state's graph of a set that has it (pose rows 0); with 0
    the choice is the actor's greedy one; with a bias far above the logits' spread it is a frontier of the largest
    value; the actor's own logits are kept either way. A negative bias is refused in one line naming the key."""
    values_of, column, feature_set = PRIORS[key]
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)
    alone = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path)), config.planning, graph=config.graph)
    biased = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path), **{key: 1e6}), config.planning,
                           graph=config.graph)
    informative = 0  # decisions whose frontiers differ in the prior's value
    for decision, env_choice in env_decisions(config, learner, steps=6):
        state = decision.state
        assert alone.choose(state) == env_choice
        graph, encoded = alone.last_graph, alone.last_encoded
        values = values_of(graph, encoded, decision.actions)
        reference = graph_features(state, decision.actions, alone.virtual_map(state.session.occupancy.grid),
                                   config.planning.em.backend, feature_set)
        rows = np.flatnonzero(encoded.action_mask)
        np.testing.assert_allclose(values[rows], reference.features[encoded.nodes[rows],
                                                                    feature_names(feature_set).index(column)],
                                   rtol=1e-6)
        assert not values[~encoded.action_mask].any()
        choice = biased.choose(state)
        np.testing.assert_array_equal(biased.last_logits, alone.last_logits)
        chosen_row = rows[graph.candidate[encoded.nodes[rows]] == choice][0]
        assert values[chosen_row] == values[rows].max()
        informative += values[rows].max() > values[rows].min()
    assert informative > 0
    with pytest.raises(ValueError, match=f"policy.{key}") as error:
        load_config([*FAST, f"policy.{key}=-0.5"])
    assert "\n" not in str(error.value)


def test_the_loop_prior_keeps_to_its_travel_window(tmp_path):
    """``policy.loop_bias_until_m`` and ``loop_bias_from_m``: on a state where the loop prior changes the choice,
    an end above the robot's travel so far gives the prior's choice, an end at it the actor's (its logits kept
    either way); a start at it the prior's, a start above it the actor's, a window around it the prior's. A
    negative value, or a start at or after the end, is refused in one line naming the key."""
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)

    def policy(**priors) -> LearnedPolicy:
        return LearnedPolicy(PolicyConfig("learned", checkpoint=str(path), **priors), config.planning,
                             graph=config.graph)

    alone, always = policy(), policy(loop_bias=1e6)
    informative = 0  # states where the prior changes the choice
    for decision, _ in env_decisions(config, learner, steps=6):
        state = decision.state
        if state.travel <= 0 or always.choose(state) == alone.choose(state):  # a gate of 0 m means no gate
            continue
        informative += 1
        before = policy(loop_bias=1e6, loop_bias_until_m=state.travel + 0.5)
        after = policy(loop_bias=1e6, loop_bias_until_m=state.travel)
        assert before.choose(state) == always.last_choice
        assert after.choose(state) == alone.last_choice
        np.testing.assert_array_equal(before.last_logits, alone.last_logits)
        started = policy(loop_bias=1e6, loop_bias_from_m=state.travel)  # the late-phase gate
        not_yet = policy(loop_bias=1e6, loop_bias_from_m=state.travel + 0.5)
        window = policy(loop_bias=1e6, loop_bias_from_m=state.travel - 0.25, loop_bias_until_m=state.travel + 0.25)
        assert started.choose(state) == always.last_choice
        assert not_yet.choose(state) == alone.last_choice
        assert window.choose(state) == always.last_choice
        np.testing.assert_array_equal(not_yet.last_logits, alone.last_logits)
    assert informative > 0
    for bad, key in (("policy.loop_bias_until_m=-1", "policy.loop_bias_until_m"),
                     ("policy.loop_bias_from_m=-1", "policy.loop_bias_from_m"),
                     ("policy.loop_bias_from_m=200 policy.loop_bias_until_m=150", "policy.loop_bias_from_m")):
        with pytest.raises(ValueError, match=key) as error:
            load_config([*FAST, *bad.split()])
        assert "\n" not in str(error.value)


def dense_closure_gain(information: np.ndarray, poses: np.ndarray, current: int, keyframe: int,
                       loop_sigma: float) -> float:
    """The relative position std a loop factor removes, from the dense inverse of the whole 6-dof
    system and the posterior covariance ``(S^-1 + R^-1)^-1`` (a route independent of ``closure_gains``)."""
    covariance = np.linalg.inv(information)
    translation = [3, 4]  # Pose3 tangent (rx, ry, rz, tx, ty, tz)

    def world(i: int, j: int) -> np.ndarray:
        def rotation(k: int) -> np.ndarray:
            c, s = np.cos(poses[k, 2]), np.sin(poses[k, 2])
            return np.array([[c, -s], [s, c]])
        block = covariance[np.ix_(6 * i + np.array(translation), 6 * j + np.array(translation))]
        return rotation(i) @ block @ rotation(j).T

    relative = world(keyframe, keyframe) + world(current, current) - world(keyframe, current) - world(current, keyframe)
    after = np.linalg.inv(np.linalg.inv(relative) + np.eye(2) / loop_sigma ** 2)
    return float(np.sqrt(np.trace(relative - after)))


def test_closure_gains_equal_a_dense_inverse_and_steer_the_prior(tmp_path):
    """``closure_gains`` on real env states: each action's value is the largest, over the keyframes its path
    revisits, of the relative position std a loop factor removes, computed independently from the dense inverse of
    the 6-dof system (0 for an action that revisits none). ``policy.closure_bias`` far above the logits' spread picks
    a frontier of the largest gain and keeps the actor's logits; a negative value is refused in one line."""
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)
    sigma = config.planning.em.loop_sigma_translation
    alone = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path)), config.planning, graph=config.graph)
    biased = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path), closure_bias=1e6), config.planning,
                           graph=config.graph)
    informative = 0  # decisions whose frontiers differ in their gain
    for decision, _ in env_decisions(config, learner, steps=6):
        state, actions = decision.state, decision.actions
        graph = state.session.graph
        poses, current = graph.poses_se2(), graph.num_poses - 1
        gains = closure_gains(graph, poses, actions, sigma)
        information = graph.information_matrix().toarray()
        for action, gain in zip(actions, gains):
            expected = max((dense_closure_gain(information, poses, current, r.keyframe_index, sigma)
                            for r in action.prediction.revisits), default=0.0)
            assert gain == pytest.approx(expected, rel=1e-6, abs=1e-12)
        choice = biased.choose(state)
        alone.choose(state)
        np.testing.assert_array_equal(biased.last_logits, alone.last_logits)
        assert gains[[a.candidate for a in actions].index(choice)] == pytest.approx(gains.max(), rel=1e-9)
        informative += gains.max() > gains.min() + 1e-6
    assert informative > 0
    with pytest.raises(ValueError, match="policy.closure_bias") as error:
        load_config([*FAST, "policy.closure_bias=-1"])
    assert "\n" not in str(error.value)


def test_em_decides_among_the_actors_shortlist(tmp_path):
    """``policy.em_top_k``: the shortlist is the actor's k most probable frontiers; EM's utilities
    of it equal EM's own evaluation of those frontiers (all of them, on the same state) and the
    choice is the best of them; k = 1 is the actor's greedy choice, k >= the action set EM's.
    A negative k is refused in one line naming the key."""
    config = load_config([*FAST, "graph.features=extended"])  # at most 4 frontiers per decision
    path, learner = actor_file(tmp_path, config)

    def hybrid(k: int) -> LearnedPolicy:
        return LearnedPolicy(PolicyConfig("learned", checkpoint=str(path), em_top_k=k), config.planning,
                             graph=config.graph, robot=config.robot)

    alone, one, two, every = hybrid(0), hybrid(1), hybrid(2), hybrid(4)
    em = EMPlanner(PolicyConfig("em"), config.planning, robot=config.robot)
    shortened = 0  # decisions where the shortlist left frontiers out
    for decision, env_choice in env_decisions(config, learner, steps=6):
        state = decision.state
        full = em.evaluate(state)
        assert alone.choose(state) == one.choose(state) == env_choice
        assert list(one.last_evaluation.indices) == [env_choice]
        assert every.choose(state) == full.chosen
        choice = two.choose(state)
        graph, encoded, logits = alone.last_graph, alone.last_encoded, alone.last_logits.numpy()
        rows = np.flatnonzero(encoded.action_mask)
        most_probable = rows[np.argsort(-logits[rows], kind="stable")][:2]
        evaluation = two.last_evaluation
        assert set(evaluation.indices) == set(graph.candidate[encoded.nodes[most_probable]])
        position = [int(np.flatnonzero(full.indices == candidate)[0]) for candidate in evaluation.indices]
        np.testing.assert_allclose(evaluation.raw, full.raw[position], rtol=1e-9, atol=1e-9)
        assert choice == evaluation.indices[np.argmax(full.raw[position])]
        assert set(two.last_ms) == {"actions", "graph", "forward", "em"}
        shortened += len(full.indices) > 2
    assert shortened > 0
    with pytest.raises(ValueError, match="policy.em_top_k") as error:
        load_config([*FAST, "policy.em_top_k=-1"])
    assert "\n" not in str(error.value)


def test_em_decides_where_the_actor_is_unsure(tmp_path):
    """``policy.em_below_confidence=c``: EM's own choice over the whole action set on the decisions
    whose top probability is below ``c``, the actor's greedy choice on the others (counted);
    c = 1 is EM wherever there is a choice, a tiny c the actor. Out-of-range values and both
    hybrids at once are refused in one line naming the keys."""
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)

    def gated(c: float) -> LearnedPolicy:
        return LearnedPolicy(PolicyConfig("learned", checkpoint=str(path), em_below_confidence=c), config.planning,
                             graph=config.graph, robot=config.robot)

    em = EMPlanner(PolicyConfig("em"), config.planning, robot=config.robot)
    confidences = []
    decisions = list(env_decisions(config, learner, steps=6))
    for decision, env_choice in decisions:
        alone = gated(1e-9)
        assert alone.choose(decision.state) == env_choice and alone.em_decisions == 0
        mask = torch.from_numpy(alone.last_encoded.action_mask)
        confidences.append(top_probability(alone.last_logits, mask))
    middle = float(np.median(confidences))
    for c in (1.0, middle):
        policy = gated(c)
        for (decision, env_choice), confidence in zip(decisions, confidences):
            unsure = confidence < c
            expected = em.evaluate(decision.state).chosen if unsure else env_choice
            assert policy.choose(decision.state) == expected
            assert (policy.last_evaluation is not None) == unsure
        assert policy.em_decisions == sum(confidence < c for confidence in confidences)
        assert policy.decisions == len(decisions)
    assert 0 < sum(confidence < middle for confidence in confidences) < len(decisions)
    with pytest.raises(ValueError, match="policy.em_below_confidence") as error:
        load_config([*FAST, "policy.em_below_confidence=1.5"])
    assert len(str(error.value).splitlines()) == 1
    with pytest.raises(ValueError, match="two hybrids") as error:
        load_config([*FAST, "policy.em_below_confidence=0.3", "policy.em_top_k=2"])
    assert len(str(error.value).splitlines()) == 1


@pytest.mark.parametrize("features", ["extended", "no_covariance"])
def test_the_fast_path_decides_as_the_reference_on_real_states(tmp_path, features):
    """The fast decision path (candidates' revisits at once, one landmark fusion by EM's
    fast rounds, KD-tree pairs, the encoding padded only to the graph's nodes; for
    ``no_covariance`` no marginals and no fusion at all) against the first implementation
    (which computes both and drops their columns) on every decision of an office episode:
    the same graph and frontier, within :class:`Equivalence` (round-off only)."""
    config = load_config([*FAST, f"graph.features={features}"])
    path, learner = actor_file(tmp_path, config)
    policy_config = PolicyConfig("learned", checkpoint=str(path))
    fast = LearnedPolicy(policy_config, config.planning, graph=config.graph)
    reference = LearnedPolicy(policy_config, config.planning, graph=config.graph, reference=True)
    nodes = []
    for decision, _ in env_decisions(config, learner, steps=6):
        state = decision.state
        assert fast.choose(state) == reference.choose(state)
        difference = decision_difference(fast, reference)
        assert difference.within(Equivalence()), difference
        np.testing.assert_allclose(fast.last_graph.features, reference.last_graph.features, rtol=1e-9, atol=0)
        np.testing.assert_array_equal(fast.last_graph.edges, reference.last_graph.edges)
        n = fast.last_graph.num_nodes
        assert len(fast.last_encoded.x) == n < len(reference.last_encoded.x) == config.graph.max_nodes
        np.testing.assert_array_equal(fast.last_logits, actor_logits(fast.actor, fast.last_encoded))
        nodes.append(n)
    assert max(nodes) > 30


def test_the_equivalence_rejects_real_changes(setup):
    """:class:`Equivalence` admits the same decision and rejects what is more than
    round-off: a pose marginal 1e-7 relative off (what the planar approximation under icp
    does), a logit moved by 1e-5 of the largest, a frontier's logit moved by 1e-3 of it
    (its probability with it), another frontier."""
    config, path, learner = setup
    policy = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path)), config.planning, graph=config.graph)
    other = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path)), config.planning, graph=config.graph)
    for decision, _ in env_decisions(config, learner, steps=4):
        pass
    policy.choose(decision.state), other.choose(decision.state)
    equivalence = Equivalence()
    same = decision_difference(policy, other)
    assert same.within(equivalence) and same.feature_rel == same.logit_rel == same.probability == 0.0
    features = other.last_graph.features.copy()
    features[0, 0] *= 1 + 1e-7
    other.last_graph = dataclasses.replace(other.last_graph, features=features)
    assert not decision_difference(policy, other).within(equivalence)
    other.choose(decision.state)
    logits = other.last_logits.clone()
    scale = float(logits.abs().max())
    logits[0] += 1e-5 * scale
    other.last_logits = logits
    assert decision_difference(policy, other).logit_rel > equivalence.logit_rtol
    other.choose(decision.state)
    frontier = torch.from_numpy(other.last_encoded.action_mask).nonzero()[0, 0]
    logits = other.last_logits.double()
    logits[frontier] += 1e-3 * scale  # a real change: logits moved, probabilities too
    other.last_logits = logits.float()
    moved = decision_difference(policy, other)
    assert not moved.within(equivalence) and moved.logit_rel > equivalence.logit_rtol
    other.choose(decision.state)
    other.last_choice = -1
    assert not decision_difference(policy, other).within(equivalence)


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


def test_fast_parts_equal_their_references_on_real_states(setup):
    """Each part the fast path replaced, on every decision of an office episode: the pose
    marginals (:func:`pose_marginals`, another elimination order: round-off) against EM's,
    the landmarks near the frontiers and the fused landmarks (the segments' line of sight
    by length, the observations in closed form fused by EM's fast rounds) against the
    first code (Jacobian products fused in order)."""
    config, _, learner = setup
    planning = config.planning
    checked = 0
    for decision, _ in env_decisions(config, learner, steps=6):
        state = decision.state
        graph, vmap = state.session.graph, VirtualMap(state.session.occupancy.grid, planning.virtual_map)
        poses = graph.poses_se2()
        expected, _ = pose_covariances(graph, poses, "fast")
        pose_covs = pose_marginals(graph, poses, "fast")
        scale = np.abs(expected).max(axis=(1, 2), keepdims=True)
        np.testing.assert_allclose(pose_covs / scale, expected / scale, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(pose_marginals(graph, poses, "reference"), pose_covariances(
            graph, poses, "reference")[0])
        blocked = state.session.occupancy.known_occupied
        frontier_xy = np.array([c.frontier.waypoint_xy for c in state.candidates])
        for radius in (0.25, 3.0):
            np.testing.assert_array_equal(landmarks_near(vmap, frontier_xy, radius),
                                          landmarks_near_reference(vmap, frontier_xy, radius))
        landmarks = landmarks_near(vmap, frontier_xy, planning.virtual_map.sensor_range)
        pose_idx, landmark_idx = visible_pairs_of(vmap, poses, blocked, landmarks)
        reference_pairs = visible_pairs_of(vmap, poses, blocked, landmarks, reference=True)
        np.testing.assert_array_equal(pose_idx, reference_pairs[0])
        np.testing.assert_array_equal(landmark_idx, reference_pairs[1])
        fused = landmark_covariances(vmap, poses, pose_covs, blocked, landmarks)
        np.testing.assert_allclose(fused, landmark_covariances(vmap, poses, pose_covs, blocked, landmarks,
                                                               reference=True), rtol=1e-10, atol=1e-18)
        checked += len(pose_idx)
    assert checked > 1000


def test_a_policy_without_covariance_columns_computes_no_marginals(tmp_path, monkeypatch):
    """``graph.features=no_covariance``: the runner's learned policy decides without the pose marginals and the
    virtual map's fusion (both made to fail here), as the environment's actor does on the same states."""
    import explore_rl.planning.learned as learned

    config = load_config([*FAST, "graph.features=no_covariance"])
    path, learner = actor_file(tmp_path, config)
    policy = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path)), config.planning, graph=config.graph)

    def fails(*args, **kwargs):
        raise AssertionError("a covariance was computed")

    choices = []
    for decision, env_choice in env_decisions(config, learner, steps=3):
        with monkeypatch.context() as patch:
            for name in ("pose_marginals", "decision_estimates", "landmark_covariances"):
                patch.setattr(learned, name, fails)
            choices.append((policy.choose(decision.state), env_choice))
        assert policy.last_graph.features.shape[1] == 7
    assert all(mine == env for mine, env in choices) and len(choices) == 3
