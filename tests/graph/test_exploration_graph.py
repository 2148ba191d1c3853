"""The exploration graph and its padded encoding, on hand-made states with known values."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.graph.encode import encode, nodes_to_keep
from explore_rl.graph.exploration_graph import (
    CURRENT,
    FRONTIER,
    POSE,
    build_graph,
    factor_edges,
    graph_from_state,
    unique_edges,
)
from explore_rl.planning.actions import select_actions
from explore_rl.planning.config import ActionSetConfig, PlanningConfig
from explore_rl.planning.em import EMConfig, EMPlanner
from explore_rl.planning.policies import PolicyConfig
from explore_rl.planning.revisits import predict_revisits, sample_path
from explore_rl.planning.virtual_map import VirtualMap
from explore_rl.geometry import se2_between
from tests.planning.test_em import GRID, SPACING, tour_state

SOUTH = [[2.0, 8.0], [2.0, 6.0]]  # 2 m into the unknown: the nearest frontier, no revisit


# ---------------------------------------------------------------------- build_graph from arrays


def small_graph():
    """Three poses in a row, a loop factor 0-2, two frontiers: f0 (nearest) and f1
    revisiting pose 0."""
    pose_xy = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    pose_edges = np.array([[0, 1], [1, 2], [2, 1], [0, 2]])  # a duplicate in reverse order
    frontier_xy = np.array([[2.0, 3.0], [-1.0, 0.0]])
    return build_graph(pose_xy, [0.01, 0.02, 0.03], pose_edges, frontier_xy, [0.04, 0.05],
                       frontier_revisits=[[], [0]])


def test_build_graph_nodes_edges_weights_and_features_by_value():
    graph = small_graph()
    assert graph.num_nodes == 5 and graph.current == 2
    np.testing.assert_array_equal(graph.frontier_nodes, [3, 4])
    assert graph.nearest_node == 3
    # pose-pose factors (deduplicated), current-nearest, loop frontier-revisited pose
    assert {tuple(e) for e in graph.edges} == {(0, 1), (1, 2), (0, 2), (2, 3), (0, 4)}
    weights = dict(zip(map(tuple, graph.edges), graph.weights))
    assert weights == {(0, 1): 1.0, (1, 2): 1.0, (0, 2): 2.0, (2, 3): 3.0, (0, 4): 1.0}
    expected = np.array([
        [0.01, 2.0, np.pi, POSE],
        [0.02, 1.0, np.pi, POSE],
        [0.03, 0.0, 0.0, CURRENT],
        [0.04, 3.0, np.pi / 2, FRONTIER],
        [0.05, 3.0, np.pi, FRONTIER],
    ])
    np.testing.assert_allclose(graph.features, expected, atol=1e-12)
    adj = graph.adjacency()
    np.testing.assert_array_equal(adj, adj.T)
    assert adj[2, 3] == 3.0 and adj[3, 4] == 0.0 and np.all(np.diag(adj) == 0)


def test_build_graph_rejects_an_empty_action_set():
    with pytest.raises(ValueError, match="needs a pose and a frontier"):
        build_graph([[0.0, 0.0]], [0.1], np.zeros((0, 2)), np.zeros((0, 2)), [], [])


# ---------------------------------------------------------------------- from a SLAM state


def test_graph_from_a_hand_made_slam_state():
    state = tour_state(3.0, extra_paths=[SOUTH])
    graph_ = state.session.graph
    last = graph_.num_poses - 1
    graph_.add_loop_closure(0, last - 2, se2_between(graph_.poses_se2()[0], graph_.poses_se2()[last - 2]),
                            np.diag([1e-4] * 3 + [0.05**2] * 3), "pose_matching")
    planning = PlanningConfig()
    em = EMPlanner(PolicyConfig(name="em"), planning, EMConfig())
    actions = select_actions(state, planning.actions, planning.revisits)
    graph = graph_from_state(state, em.decision_context(state), actions)

    # the action set, computed independently: the nearest + every path that revisits
    poses = graph_.poses_se2()
    travel = np.array([k.travel for k in state.session.keyframes])
    revisits = []
    for c in state.candidates:
        samples, s = sample_path(c.path, SPACING)
        revisits.append(predict_revisits(samples[:, :2], poses[:, :2], travel, state.travel,
                                         state.session.occupancy.known_occupied, GRID,
                                         planning.revisits, path_travel=s))
    expected = [state.nearest] + [i for i in np.argsort([c.length for c in state.candidates])
                                  if i != state.nearest and revisits[i]]
    assert len(expected) < len(state.candidates), "the test needs a frontier left out"
    np.testing.assert_array_equal(graph.candidate[graph.frontier_nodes], expected)
    assert state.candidates[state.nearest].path[-1].tolist() == SOUTH[-1]

    n_poses = graph_.num_poses
    assert graph.num_nodes == n_poses + len(expected) and graph.current == n_poses - 1
    edges = {tuple(e) for e in graph.edges}
    chain = {(i, i + 1) for i in range(n_poses - 1)}
    loops = {(k.keyframe_index, n_poses + f) for f, c in enumerate(expected) for k in revisits[c]}
    assert edges == chain | {(0, last - 2)} | {(n_poses - 1, n_poses)} | loops
    xy = np.vstack([poses[:, :2], [state.candidates[c].frontier.waypoint_xy for c in expected]])
    for (i, j), w in zip(graph.edges, graph.weights):
        assert w == pytest.approx(np.linalg.norm(xy[i] - xy[j]))

    # features: per-pose public marginals, the virtual map rebuilt from them, geometry by hand
    pose_covs = np.stack([graph_.world_xy_yaw_covariance(i) for i in range(n_poses)])
    vmap = VirtualMap(GRID, planning.virtual_map)
    landmarks = vmap.predict_landmark_covariances(poses, pose_covs, state.session.occupancy.known_occupied)
    frontier_cov = vmap.frontier_landmark_covariance(xy[n_poses:], landmarks)
    uncertainty = np.r_[np.trace(pose_covs[:, :2, :2], axis1=1, axis2=2), np.trace(frontier_cov, axis1=1, axis2=2)]
    np.testing.assert_allclose(graph.features[:, 0], uncertainty, rtol=1e-6)
    offset = xy - poses[-1, :2]
    np.testing.assert_allclose(graph.features[:, 1], np.hypot(offset[:, 0], offset[:, 1]), atol=1e-12)
    np.testing.assert_allclose(graph.features[:, 2], np.arctan2(offset[:, 1], offset[:, 0]), atol=1e-12)
    identity = np.r_[np.full(n_poses - 1, -1.0), 0.0, np.ones(len(expected))]
    np.testing.assert_array_equal(graph.features[:, 3], identity)


def test_extra_nearest_frontiers_widen_the_action_set():
    state = tour_state(3.0, extra_paths=[SOUTH])
    revisits = PlanningConfig().revisits
    paper = select_actions(state, ActionSetConfig(), revisits)
    wider = select_actions(state, ActionSetConfig(extra_nearest=len(state.candidates)), revisits)
    assert len(wider) == len(state.candidates) > len(paper)
    assert paper[0].candidate == wider[0].candidate == state.nearest
    capped = select_actions(state, ActionSetConfig(extra_nearest=len(state.candidates), max_frontiers=2), revisits)
    assert [a.candidate for a in capped] == [a.candidate for a in wider[:2]]


# ---------------------------------------------------------------------- encoding


def long_graph(n_poses: int = 30):
    """A corridor of poses 1 m apart (current = the last), two frontiers: the nearest at
    the current pose's end and one revisiting pose 3 (far from the current pose)."""
    pose_xy = np.column_stack([np.arange(n_poses, dtype=float), np.zeros(n_poses)])
    chain = np.column_stack([np.arange(n_poses - 1), np.arange(1, n_poses)])
    frontiers = np.array([[n_poses, 0.5], [3.0, 1.0]])
    return build_graph(pose_xy, np.full(n_poses, 0.01), chain, frontiers, [0.04, 0.04], [[], [3]])


def test_encoding_pads_with_zeros_and_masks_frontiers():
    graph = long_graph(10)
    encoded = encode(graph, 16)
    n = graph.num_nodes
    assert encoded.x.shape == (16, 4) and encoded.adj.shape == (16, 16)
    assert encoded.x.dtype == np.float32 and encoded.adj.dtype == np.float32
    np.testing.assert_array_equal(encoded.node_mask, np.arange(16) < n)
    np.testing.assert_array_equal(np.flatnonzero(encoded.action_mask), graph.frontier_nodes)
    np.testing.assert_allclose(encoded.x[:n], graph.features, rtol=1e-6)
    np.testing.assert_allclose(encoded.adj[:n, :n], graph.adjacency(), rtol=1e-6)
    assert not encoded.x[n:].any() and not encoded.adj[n:].any() and not encoded.adj[:, n:].any()
    assert encoded.dropped == 0


def test_truncation_drops_far_poses_without_frontier_edges_first(caplog):
    graph = long_graph(30)  # 32 nodes
    encoded = encode(graph, 20)
    kept = set(encoded.nodes.tolist())
    assert encoded.dropped == 12 and len(kept) == 20
    # frontiers, the current pose and pose 3 (the loop frontier's) stay; then the nearest poses
    assert {30, 31, 29, 3} <= kept
    distance = graph.features[:, 1]
    dropped = sorted(set(range(32)) - kept)
    unlinked_kept = [i for i in kept if i < 29 and i != 3]
    assert min(distance[dropped]) > max(distance[unlinked_kept])
    # rows follow node order; the adjacency is the kept nodes' sub-matrix
    np.testing.assert_array_equal(encoded.nodes, sorted(kept))
    np.testing.assert_allclose(encoded.adj[:20, :20], graph.adjacency()[np.ix_(encoded.nodes, encoded.nodes)])
    np.testing.assert_array_equal(encoded.x[encoded.action_mask, 3], [1.0, 1.0])


@pytest.mark.parametrize("max_nodes", [40, 20])
def test_compact_encoding_is_the_padded_one_without_its_padding_rows(max_nodes):
    """``compact=True``: the padded encoding's real rows (the same kept nodes when the
    graph is truncated too), and nothing else."""
    graph = long_graph(30)  # 32 nodes
    padded, compact = encode(graph, max_nodes), encode(graph, max_nodes, compact=True)
    k = len(padded.nodes)
    assert len(compact.x) == k == min(32, max_nodes) and compact.adj.shape == (k, k)
    np.testing.assert_array_equal(compact.nodes, padded.nodes)
    assert compact.dropped == padded.dropped
    np.testing.assert_array_equal(compact.x, padded.x[:k])
    np.testing.assert_array_equal(compact.adj, padded.adj[:k, :k])
    np.testing.assert_array_equal(compact.node_mask, padded.node_mask[:k])
    np.testing.assert_array_equal(compact.action_mask, padded.action_mask[:k])
    assert compact.node_mask.all() and compact.x.dtype == compact.adj.dtype == np.float32
    for encoded in (padded, compact):  # the nonzero entries from the edges: those a scan finds
        np.testing.assert_array_equal(encoded.entries, np.argwhere(encoded.adj))
    assert len(compact.entries) > 0


def test_truncation_logs_and_drops_linked_poses_only_when_it_must(caplog):
    graph = long_graph(30)
    with caplog.at_level("WARNING", logger="explore_rl.graph.encode"):
        keep = nodes_to_keep(graph, 3)
    assert set(keep.tolist()) == {29, 30, 31}
    assert any("linked to frontiers" in r.getMessage() for r in caplog.records)
    with pytest.raises(ValueError, match="raise graph.max_nodes"):
        nodes_to_keep(graph, 2)


def test_unique_edges_and_factor_edges_by_value():
    """One integer key per pair gives ``np.unique(..., axis=0)`` of the sorted pairs (both
    orders, duplicates, self-loops, empty); factor pairs keep the edges' order."""
    rng = np.random.default_rng(2)
    for size in (0, 1, 7, 300):
        pairs = rng.integers(0, 40, (size, 2))
        ordered = np.sort(pairs, axis=1)
        ordered = ordered[ordered[:, 0] != ordered[:, 1]]
        expected = np.unique(ordered, axis=0) if len(ordered) else ordered.reshape(0, 2)
        got = unique_edges(pairs)
        assert got.dtype == np.int64 and got.shape == expected.shape
        np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(factor_edges([(3, 4, "odometry"), (0, 9, "loop")]), [[3, 4], [0, 9]])
    assert factor_edges([]).shape == (0, 2)
