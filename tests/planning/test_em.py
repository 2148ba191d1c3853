"""EM planner: forward-simulated SLAM on graph copies, the no-loop shortcut, the choice.

States are built by hand around a real iSAM2 ``PoseGraph``: a U-shaped tour (east, north,
west, then south back towards the start) with odometry only, a real ``OccupancyGrid``
known free along the tour, and hand-made candidates.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.linalg import block_diag

from explore_rl.geometry import se2_between, se2_compose
from explore_rl.grid import GridSpec
from explore_rl.mapping.frontiers import Frontier
from explore_rl.mapping.occupancy import OccupancyGrid
from explore_rl.mapping.paths import path_length
from explore_rl.planning.config import ActionSetConfig, PlanningConfig
from explore_rl.planning.em import (
    EMConfig,
    EMPlanner,
    ObservationCache,
    Observations,
    propagate_chain,
    simulate_graph,
    step_covariances,
)
from explore_rl.planning.policies import NearestFrontier, PolicyConfig
from explore_rl.planning.revisits import predict_revisits, sample_path
from explore_rl.planning.virtual_map import VirtualMap
from explore_rl.state import Candidate, ExplorationState
from explore_rl.slam.config import PoseGraphConfig, SlamConfig
from explore_rl.slam.pose_graph import PoseGraph, key

GRID = GridSpec((0.0, 0.0), 0.1, (200, 200))
TOUR = [[2.0, 2.0], [14.0, 2.0], [14.0, 14.0], [2.0, 14.0], [2.0, 8.0]]
SPACING = 0.5
STEPS_PER_KEYFRAME = 3
KNOWN_RADIUS = 1.5  # m of known free space around the tour


def graph_config(scale: float) -> PoseGraphConfig:
    """Odometry sigmas ``scale`` times the defaults."""
    base = PoseGraphConfig()
    return PoseGraphConfig(odom_sigma_xy_per_step=base.odom_sigma_xy_per_step * scale,
                           odom_sigma_yaw_deg_per_step=base.odom_sigma_yaw_deg_per_step * scale)


def chain_graph(waypoints, config: PoseGraphConfig) -> tuple[PoseGraph, np.ndarray]:
    """A pose graph of keyframes every ``SPACING`` along ``waypoints`` (noise-free
    odometry) and the cumulative travel at each keyframe."""
    poses, travel = sample_path(np.asarray(waypoints, float), SPACING, include_start=True)
    poses[0, 2] = poses[1, 2]
    graph = PoseGraph(config, poses[0])
    for a, b in zip(poses[:-1], poses[1:]):
        graph.add_keyframe(se2_between(a, b), STEPS_PER_KEYFRAME)
    return graph, travel


def known_free_near(poses: np.ndarray, radius: float) -> OccupancyGrid:
    occupancy = OccupancyGrid(GRID)
    centres = GRID.cell_centers()[:, :, None, :]
    gap = np.min(np.linalg.norm(centres - poses[None, None, :, :2], axis=-1), axis=-1)
    occupancy.log_odds[gap <= radius] = occupancy.config.free_threshold - 1.0
    return occupancy


def candidate(path) -> Candidate:
    path = np.asarray(path, float)
    cell = GRID.world_to_cell(path[-1])
    return Candidate(Frontier(cell[None], cell, GRID.cell_to_world(cell), 1), path, path_length(path))


def tour_state(scale: float, extra_paths=()) -> ExplorationState:
    """At the tour's end (2, 8), 6 m north of the start: candidate 0 goes 3 m east into
    the unknown interior, candidate 1 goes 6.4 m south past the start keyframes."""
    config = graph_config(scale)
    graph, travel = chain_graph(TOUR, config)
    poses = graph.poses_se2()
    session = SimpleNamespace(graph=graph, occupancy=known_free_near(poses, KNOWN_RADIUS),
                              config=SlamConfig(keyframe_distance=SPACING, pose_graph=config),
                              keyframes=[SimpleNamespace(travel=t) for t in travel])
    here = poses[-1]
    paths = [[here[:2], [5.0, 8.0]], [here[:2], [2.0, 2.8], [0.8, 2.8]], *extra_paths]
    candidates = [candidate(p) for p in paths]
    nearest = int(np.argmin([c.length for c in candidates]))
    return ExplorationState(session, here, float(travel[-1]), candidates, nearest, None, None)


def planner(max_candidates: int = 10, **em) -> EMPlanner:
    """EM over the ``max_candidates`` nearest frontiers (``planning.actions.kind=nearest``);
    the reference backend (graph copies) unless ``backend`` is given (this file tests the
    reference; tests/planning/test_em_fast.py the fast backend against it)."""
    planning = PlanningConfig(actions=ActionSetConfig(kind="nearest", max_frontiers=max_candidates))
    return EMPlanner(PolicyConfig(name="em"), planning, EMConfig(**{"backend": "reference", **em}))


def utility_of(graph: PoseGraph, occupancy: OccupancyGrid) -> float:
    """Virtual-map utility from the graph's own per-pose covariances (public API only)."""
    vmap = VirtualMap(GRID, PlanningConfig().virtual_map)
    covs = np.stack([graph.world_xy_yaw_covariance(i) for i in range(graph.num_poses)])
    return vmap.utility(vmap.predict_landmark_covariances(graph.poses_se2(), covs,
                                                          occupancy.known_occupied))


# ---------------------------------------------------------------------- graph and utility


def test_utility_drops_when_a_loop_closure_is_added():
    graph, _ = chain_graph(TOUR[:4] + [[2.0, 2.5]], graph_config(3.0))
    occupancy = known_free_near(graph.poses_se2(), KNOWN_RADIUS)
    before = utility_of(graph, occupancy)
    last = graph.num_poses - 1
    relative = se2_between(graph.poses_se2()[0], graph.poses_se2()[last])
    cov = np.diag([1e-4] * 3 + [0.05**2] * 3)
    graph.add_loop_closure(0, last, relative, cov, "pose_matching")
    after = utility_of(graph, occupancy)
    assert after < before - 1.0


def test_updating_a_copy_leaves_the_live_graph_unchanged():
    graph, _ = chain_graph(TOUR, graph_config(3.0))
    poses = graph.poses_se2()
    marginals = [graph.marginal_covariance(i) for i in range(graph.num_poses)]
    version, count = graph.version, graph.num_poses

    copy = graph.copy()
    copy.add_keyframe(np.array([0.5, 0.0, 0.0]), STEPS_PER_KEYFRAME)
    wrong = np.array([0.3, -0.2, 0.05])  # inconsistent on purpose: the copy's estimate moves
    copy.add_loop_closure(0, copy.num_poses - 1, wrong, np.diag([1e-4] * 3 + [0.05**2] * 3), "pm")

    assert not np.allclose(copy.poses_se2()[:count], poses, atol=1e-3)
    assert not np.allclose(copy.marginal_covariance(count - 1), marginals[-1])
    assert graph.version == version and graph.num_poses == count
    np.testing.assert_array_equal(graph.poses_se2(), poses)
    fresh = graph.isam  # read iSAM2 itself, not the wrapper's cache
    for i in range(count):
        np.testing.assert_array_equal(fresh.marginalCovariance(key(i)), marginals[i])


def test_simulated_graph_is_a_copy():
    state = tour_state(3.0)
    em = planner()
    context = em.decision_context(state)
    predicted = em.predict_path(context, state.candidates[1].path)
    assert predicted.revisits
    live = state.session.graph
    version, poses = live.version, live.poses_se2()
    simulated = simulate_graph(live, context.poses, predicted, em.em)
    assert simulated.num_poses == live.num_poses + len(predicted)
    assert live.version == version
    np.testing.assert_array_equal(live.poses_se2(), poses)


# ---------------------------------------------------------------------- the no-loop shortcut


def test_chain_propagation_matches_finite_differences():
    """Linearise the composition chain numerically: world-frame error at the start,
    anisotropic factor noise in each step's end frame (gtsam's BetweenFactor)."""
    rng = np.random.default_rng(3)
    start = np.array([1.0, 2.0, 0.4])
    steps = np.column_stack([rng.uniform(0.2, 0.6, 6), rng.uniform(-0.2, 0.2, 6),
                             rng.uniform(-0.8, 0.8, 6)])
    poses = [start]
    for u in steps:
        poses.append(se2_compose(poses[-1], u))
    poses = np.array(poses[1:])
    start_cov = np.diag([0.02, 0.05, 0.01]) + 0.004
    step_covs = np.stack([np.diag(rng.uniform(1e-4, 1e-2, 3)) for _ in steps])

    def chain(e: np.ndarray) -> np.ndarray:
        x = np.r_[start[:2] + e[:2], start[2] + e[2]]
        out = []
        for k, u in enumerate(steps):
            x = se2_compose(x, se2_compose(u, e[3 + 3 * k: 6 + 3 * k]))
            out.append(x)
        return np.concatenate(out)

    h = 1e-7
    jac = np.column_stack([(chain(h * d) - chain(-h * d)) / (2 * h) for d in np.eye(3 + 3 * len(steps))])
    joint = jac @ block_diag(start_cov, *step_covs) @ jac.T
    expected = np.stack([joint[3 * k: 3 * k + 3, 3 * k: 3 * k + 3] for k in range(len(steps))])
    np.testing.assert_allclose(propagate_chain(start_cov, start, poses, step_covs), expected,
                               rtol=1e-6, atol=1e-12)


def test_chain_propagation_matches_the_graph_copy():
    state = tour_state(3.0)
    em = planner()
    context = em.decision_context(state)
    predicted = em.predict_path(context, state.candidates[0].path)
    assert not predicted.revisits and len(predicted) >= 4
    graph = simulate_graph(context.graph, context.poses, predicted, em.em)
    n = context.graph.num_poses
    from_graph = np.stack([graph.world_xy_yaw_covariance(i) for i in range(n, graph.num_poses)])
    chained = propagate_chain(context.pose_covs[-1], context.poses[-1], predicted.poses,
                              step_covariances(context.graph, predicted.steps, em.em))
    np.testing.assert_allclose(chained, from_graph, rtol=2e-3, atol=1e-9)


def test_shortcut_gives_the_same_utility_as_the_graph_copy():
    state = tour_state(0.3)  # certain enough that exploring lowers U
    shortcut = planner().evaluate(state)
    copied = planner(shortcut_without_loops=False).evaluate(state)
    no_loop = shortcut.loops == 0
    assert no_loop.any()
    drop_shortcut = shortcut.u0 - shortcut.u_after[no_loop]
    drop_copied = copied.u0 - copied.u_after[no_loop]
    assert np.all(np.abs(drop_shortcut) > 0.1)
    np.testing.assert_allclose(drop_shortcut, drop_copied, rtol=1e-3)
    # candidates with loops take the copy either way
    np.testing.assert_allclose(shortcut.u_after[~no_loop], copied.u_after[~no_loop], rtol=1e-12)


def test_u0_matches_the_virtual_map_api():
    state = tour_state(3.0)
    context = planner().decision_context(state)
    expected = utility_of(state.session.graph, state.session.occupancy)
    assert context.u0 == pytest.approx(expected, rel=1e-9)


# ---------------------------------------------------------------------- the choice


def test_em_closes_the_loop_when_uncertain_and_nearest_does_not():
    state = tour_state(5.0)
    em = planner()
    assert NearestFrontier().choose(state) == 0
    assert em.choose(state) == 1
    evaluation = em.last_evaluation
    assert evaluation.loops[evaluation.best] >= 1
    # the loop's utility drop, not exploration, pays for the longer path
    drops = evaluation.u0 - evaluation.u_after
    extra_length = evaluation.lengths[1] - evaluation.lengths[0]
    assert drops[1] - drops[0] > PlanningConfig().reward.alpha * extra_length


def test_em_explores_when_certain():
    """Same tour with 10x smaller odometry noise: new space beats the loop."""
    em = planner()
    assert em.choose(tour_state(0.1)) == 0
    assert em.last_evaluation.loops[em.last_evaluation.best] == 0


def test_evaluate_returns_aligned_terms_and_respects_the_cap():
    far = [[2.0, 8.0], [2.0, 13.0], [9.0, 13.5]]  # back along the tour: the longest path
    state = tour_state(3.0, extra_paths=[far])
    lengths = np.array([c.length for c in state.candidates])
    full = planner().evaluate(state)
    np.testing.assert_array_equal(full.indices, np.argsort(lengths))
    np.testing.assert_allclose(full.lengths, lengths[full.indices])
    alpha = PlanningConfig().reward.alpha
    np.testing.assert_allclose(full.raw, full.u0 - full.u_after - alpha * full.lengths)
    assert full.indices[full.nearest] == state.nearest
    assert len(full.u_after) == len(full.loops) == len(full.raw) == len(state.candidates)
    context = planner().decision_context(state)
    for k, index in enumerate(full.indices):
        poses, travel = sample_path(state.candidates[index].path, SPACING)
        revisits = predict_revisits(poses[:, :2], context.poses[:, :2], context.keyframe_travel,
                                    context.travel, context.blocked, GRID,
                                    PlanningConfig().revisits, path_travel=travel)
        assert full.loops[k] == len(revisits)
    rewards = full.rewards(PlanningConfig())
    assert rewards.shape == full.raw.shape and np.all((rewards >= -1) & (rewards <= 1))
    assert rewards[full.best] == pytest.approx(0.0 if full.best == full.nearest else 1.0)

    capped = planner(max_candidates=2).evaluate(state)
    longest = int(np.argmax(lengths))
    assert len(capped.indices) == 2 and longest not in capped.indices
    np.testing.assert_allclose(capped.u_after, full.u_after[:2])
    assert capped.chosen in capped.indices


# ---------------------------------------------------------------------- observations carried over


def fresh_observations(vmap: VirtualMap, poses: np.ndarray, blocked: np.ndarray) -> Observations:
    """What the cache must return: every visible pair's observation in closed form."""
    return Observations.closed_form(vmap, poses, *vmap.visible_pairs(poses, blocked))


def test_closed_form_observations_equal_the_jacobian_products():
    """``Observations.closed_form`` (the fast backend's) = ``of_pairs`` (the reference's
    inverse and products) to round-off, the gains exactly ``[-I | lever]``; near the pose
    the range clamp holds in both."""
    rng = np.random.default_rng(5)
    vmap = VirtualMap(GRID)
    poses = np.column_stack([rng.uniform(2, 18, 30), rng.uniform(2, 18, 30), rng.uniform(-3, 3, 30)])
    poses[0, :2] = vmap.landmark_xy[vmap.landmark_index(poses[0, :2])]  # exactly on a landmark
    pose_idx, landmark_idx = vmap.in_range_pairs(poses)
    closed = Observations.closed_form(vmap, poses, pose_idx, landmark_idx)
    products = Observations.of_pairs(vmap, poses, pose_idx, landmark_idx)
    np.testing.assert_array_equal(closed.gain[:, :, :2], np.broadcast_to(-np.eye(2), (len(pose_idx), 2, 2)))
    np.testing.assert_allclose(closed.gain, products.gain, rtol=0, atol=1e-14)
    scale = np.abs(products.noise).max()
    np.testing.assert_allclose(closed.noise / scale, products.noise / scale, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(closed.noise, np.swapaxes(closed.noise, 1, 2))


def assert_same_observations(actual: Observations, expected: Observations) -> None:
    np.testing.assert_array_equal(actual.pose_idx, expected.pose_idx)
    np.testing.assert_array_equal(actual.landmark_idx, expected.landmark_idx)
    np.testing.assert_array_equal(actual.gain, expected.gain)
    np.testing.assert_array_equal(actual.noise, expected.noise)


def test_observation_cache_equals_fresh_observations_as_keyframes_move_and_walls_change():
    """Carried-over observations are exactly the fresh ones: unmoved keyframes, moved ones
    (a loop closure), walls that appear and disappear near some segments, new keyframes."""
    rng = np.random.default_rng(3)
    vmap = VirtualMap(GRID)
    blocked = np.zeros(GRID.shape, dtype=bool)
    blocked[rng.integers(0, 200, 300), rng.integers(0, 200, 300)] = True  # scattered wall cells
    poses = np.column_stack([rng.uniform(2, 18, 40), rng.uniform(2, 18, 40), rng.uniform(-3, 3, 40)])
    cache = ObservationCache()
    steps = []
    for step in range(5):
        if step == 1:  # nothing changed but the yaw of a few (visibility and Jacobians ignore it)
            poses[:5, 2] += 0.3
        if step == 2:  # a wall appears next to a few keyframes, another cell is cleared
            blocked[95:105, 100] = True
            blocked[np.flatnonzero(blocked.ravel())[:3] // 200, np.flatnonzero(blocked.ravel())[:3] % 200] = False
        if step == 3:  # a loop closure moves half of them; three new keyframes
            poses[::2, :2] += rng.normal(0, 0.02, (20, 2))
            poses = np.vstack([poses, [[10.0, 10.0, 0.0], [10.5, 10.0, 0.0], [11.0, 10.0, 0.0]]])
        if step == 4:  # keyframes land next to the new wall cells
            poses[:3, :2] = [[10.2, 10.0], [9.8, 9.7], [10.0, 10.4]]
        expected = fresh_observations(vmap, poses, blocked)
        assert_same_observations(cache.observations_of(vmap, poses, blocked), expected)
        steps.append(len(expected.pose_idx))
    assert min(steps) > 1000  # the keyframes see many landmarks


def test_observation_cache_keeps_what_it_can():
    """An unmoved keyframe far from any change is not tested again (the saving)."""
    vmap = VirtualMap(GRID)
    blocked = np.zeros(GRID.shape, dtype=bool)
    blocked[:, 100] = True  # a wall at x = 10 m
    poses = np.array([[3.0, 3.0, 0.0], [17.0, 17.0, 0.0]])
    cache = ObservationCache()
    cache.observations_of(vmap, poses, blocked)
    blocked[150:, 190] = True  # a change within reach of the second keyframe only
    expected = fresh_observations(vmap, poses, blocked)
    tested = []
    original = vmap.line_of_sight

    def counting(xy, landmark_idx, grid_blocked, by_length=False):
        tested.append(np.asarray(xy)[:, :2].copy())
        return original(xy, landmark_idx, grid_blocked, by_length)

    vmap.line_of_sight = counting
    assert_same_observations(cache.observations_of(vmap, poses, blocked), expected)
    retested = np.vstack(tested)
    assert len(retested) and np.all(retested == poses[1, :2])  # only segments of the keyframe near the change
