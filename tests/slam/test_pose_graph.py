"""iSAM2 pose graph: marginals, frames, loop closures, robustness, copies, pickling."""

from __future__ import annotations

import dataclasses
import pickle

import gtsam
import numpy as np
import pytest

from explore_rl.geometry import se2_between, se2_compose, se2_to_matrix
from explore_rl.slam.config import PoseGraphConfig
from explore_rl.slam.frontend import ScanMatch
from explore_rl.slam.pose_graph import PoseGraph, key, odometry_covariance

LOOP_SIGMAS = np.array([0.01, 0.01, np.deg2rad(1.0), 0.05, 0.05, 0.01])  # rx ry rz tx ty tz
LOOP_COV = np.diag(LOOP_SIGMAS**2)


def square_path(side: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """True planar poses around a square (turning 90 deg on the step into each corner)
    and the number of motion steps of each keyframe delta."""
    per_side = int(round(side / step))
    deltas, steps = [], []
    for _ in range(4):
        for k in range(per_side):
            turn = np.pi / 2 if k == per_side - 1 else 0.0
            deltas.append([step, 0.0, turn])
            steps.append(9 if turn else 3)
    poses = [np.array([1.0, 1.0, 0.0])]
    for d in deltas[:-1]:  # stop one step short of the start: the closure joins them
        poses.append(se2_compose(poses[-1], d))
    return np.array(poses), np.array(steps[: len(poses) - 1])


def noisy_odometry(truth: np.ndarray, steps: np.ndarray, config: PoseGraphConfig, seed: int):
    rng = np.random.default_rng(seed)
    out = []
    for a, b, k in zip(truth[:-1], truth[1:], steps):
        sigma = np.sqrt(k) * np.array(
            [config.odom_sigma_xy_per_step, config.odom_sigma_xy_per_step,
             np.deg2rad(config.odom_sigma_yaw_deg_per_step)]
        )
        out.append(se2_between(a, b) + rng.normal(0.0, sigma))
    return out


def build(truth, steps, config, seed=0) -> PoseGraph:
    graph = PoseGraph(config, truth[0])
    for delta, k in zip(noisy_odometry(truth, steps, config, seed), steps):
        graph.add_keyframe(delta, int(k))
    return graph


def true_relative(truth, i, j) -> np.ndarray:
    return se2_to_matrix(se2_between(truth[i], truth[j]))


def position_errors(graph: PoseGraph, truth: np.ndarray) -> np.ndarray:
    return np.linalg.norm(graph.poses_se2()[:, :2] - truth[:, :2], axis=1)


def dense_covariance(graph: PoseGraph) -> np.ndarray:
    """Inverse of the dense information of all factors, linearised where iSAM2 is."""
    isam = graph.isam
    ordering = gtsam.Ordering([key(i) for i in range(graph.num_poses)])
    linear = isam.getFactorsUnsafe().linearize(isam.getLinearizationPoint())
    information, _ = linear.hessian(ordering)
    return np.linalg.inv(information)


def rel_diff(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_key_is_gtsams_symbol():
    for i in (0, 1, 7, 12345, 2**40):
        assert key(i) == gtsam.symbol("x", i)
        assert gtsam.Symbol(key(i)).chr() == ord("x") and gtsam.Symbol(key(i)).index() == i
    with pytest.raises(IndexError, match=">= 0"):
        key(-1)


def test_marginals_match_dense_information_inverse():
    config = PoseGraphConfig(loop_robust_kernel="none")
    truth, steps = square_path(side=2.0, step=1.0)  # 8 poses
    graph = build(truth, steps, config, seed=1)
    # One scan-matching factor with a full (correlated) covariance.
    rng = np.random.default_rng(0)
    A = rng.normal(size=(6, 6)) * 0.01
    cov = A @ A.T + 1e-4 * np.eye(6)
    ssm = ScanMatch(se2_to_matrix([1.0, 0.02, 0.01]), cov, False, 0, 100, 0.0)
    graph.add_keyframe([1.0, 0.0, 0.0], 3, ssm)
    graph.add_loop_closure(len(truth), 0, true_relative(truth, 0, 1), LOOP_COV, "pose_matching")
    assert graph.factor_counts == {"odometry": 8, "scan_matching": 1, "pose_matching": 1}

    dense = dense_covariance(graph)
    for i in range(graph.num_poses):
        block = dense[6 * i : 6 * i + 6, 6 * i : 6 * i + 6]
        assert rel_diff(graph.marginal_covariance(i), block) < 1e-6, i
    i, j = 2, 6
    idx = np.r_[6 * i : 6 * i + 6, 6 * j : 6 * j + 6]
    assert rel_diff(graph.joint_marginal_covariance(i, j), dense[np.ix_(idx, idx)]) < 1e-6


@pytest.mark.parametrize("yaw_deg", [90.0, 60.0])  # at 90 deg, R and R^T give the same
def test_world_xy_covariance_rotates_body_frame_translation_block(yaw_deg):
    config = PoseGraphConfig()
    yaw = np.deg2rad(yaw_deg)
    graph = PoseGraph(config, [2.0, 3.0, yaw])
    # A scan match that pins the body direction 30 deg left of forward, loose across it.
    u = np.array([np.cos(np.pi / 6), np.sin(np.pi / 6)])
    w = np.array([-u[1], u[0]])
    cov = np.diag([1e-6, 1e-6, 1e-6, 0.0, 0.0, 1e-6])
    cov[3:5, 3:5] = 0.001**2 * np.outer(u, u) + 0.1**2 * np.outer(w, w)
    ssm = ScanMatch(se2_to_matrix([1.0, 0, 0]), cov, False, 0, 100, 0.0)
    graph.add_keyframe([1.0, 0.0, 0.0], 1, ssm)
    body = graph.marginal_covariance(1)[3:5, 3:5]
    R = graph.pose(1)[:2, :2]
    world = graph.world_xy_covariance(1)
    assert abs(np.arctan2(R[1, 0], R[0, 0]) - yaw) < 1e-6
    np.testing.assert_allclose(world, R @ body @ R.T, rtol=1e-9, atol=1e-15)
    # The pinned body direction (30 deg) points at yaw + 30 deg in the world.
    tight_world = np.linalg.eigh(world)[1][:, 0]
    expected = np.array([np.cos(yaw + np.pi / 6), np.sin(yaw + np.pi / 6)])
    assert abs(abs(tight_world @ expected) - 1.0) < 1e-3, tight_world
    assert np.linalg.eigvalsh(world)[0] < 0.1 * np.linalg.eigvalsh(world)[1]
    xy_yaw = graph.world_xy_yaw_covariance(1)
    np.testing.assert_allclose(xy_yaw[:2, :2], world)
    np.testing.assert_allclose(xy_yaw[2, 2], graph.marginal_covariance(1)[2, 2])
    stacked = graph.all_world_xy_covariances()
    assert stacked.shape == (2, 2, 2)
    np.testing.assert_allclose(stacked[1], world)


def test_loop_closure_shrinks_current_covariance():
    config = PoseGraphConfig()
    truth, steps = square_path(side=2.0, step=0.5)
    graph = build(truth, steps, config)
    last = graph.num_poses - 1
    before = np.trace(graph.world_xy_covariance(last))
    version = graph.version
    graph.add_loop_closure(0, last, true_relative(truth, 0, last), LOOP_COV, "pose_matching")
    assert graph.version > version
    after = np.trace(graph.world_xy_covariance(last))
    assert after < 0.5 * before, (before, after)


def _square_with_closures(kernel: str, wrong: bool, seed: int):
    """3 m square, noisy odometry, a correct closure end -> start, maybe a 2 m-wrong one."""
    config = PoseGraphConfig(loop_robust_kernel=kernel)
    truth, steps = square_path(side=3.0, step=0.5)
    graph = build(truth, steps, config, seed=seed)
    last = graph.num_poses - 1
    graph.add_loop_closure(0, last, true_relative(truth, 0, last), LOOP_COV, "pose_matching")
    if wrong:
        bad = true_relative(truth, 3, 15) @ se2_to_matrix([2.0, 0.0, 0.0])
        graph.add_loop_closure(3, 15, bad, LOOP_COV, "segment_matching")
    return graph, truth


def test_robust_kernel_absorbs_a_wrong_loop_closure():
    for seed in range(3):
        clean, truth = _square_with_closures("cauchy", wrong=False, seed=seed)
        robust, _ = _square_with_closures("cauchy", wrong=True, seed=seed)
        plain, _ = _square_with_closures("none", wrong=True, seed=seed)
        assert robust.factor_counts["segment_matching"] == 1
        # Odometry drift alone leaves ~5-12 cm after the correct closure on this square;
        # the wrong closure moves no pose by more than 2 cm on top of it.
        assert np.abs(robust.poses_se2()[:, :2] - clean.poses_se2()[:, :2]).max() < 0.02
        assert position_errors(robust, truth).max() < 0.15
        # Without the kernel the same closure drags the map far off.
        assert position_errors(plain, truth).max() > 0.5


def test_copy_is_independent():
    config = PoseGraphConfig()
    truth, steps = square_path(side=2.0, step=0.5)
    live = build(truth, steps, config)
    last = live.num_poses - 1
    poses = live.poses_matrix()
    marginal = live.marginal_covariance(last)
    sibling = live.copy()
    sibling.add_keyframe([0.5, 0.0, 0.0], 3)
    sibling.add_loop_closure(0, last + 1, true_relative(truth, 0, 1), LOOP_COV, "pose_matching")
    assert sibling.num_poses == live.num_poses + 1
    assert not np.allclose(sibling.marginal_covariance(last), marginal)
    # The live graph: same size, estimates and marginals (fresh from iSAM2, not cache).
    assert live.isam.getFactorsUnsafe().size() < sibling.isam.getFactorsUnsafe().size()
    assert live.num_poses == last + 1 and "pose_matching" not in live.factor_counts
    np.testing.assert_array_equal(live.isam.marginalCovariance(key(last)), marginal)
    fresh = live.isam.calculateEstimate()
    np.testing.assert_array_equal(
        np.stack([fresh.atPose3(key(i)).matrix() for i in range(live.num_poses)]), poses
    )


def test_pickle_round_trip_reproduces_estimates():
    config = PoseGraphConfig()
    truth, steps = square_path(side=2.0, step=0.5)
    graph = build(truth, steps, config)
    last = graph.num_poses - 1
    graph.add_loop_closure(0, last, true_relative(truth, 0, last), LOOP_COV, "pose_matching")
    restored = pickle.loads(pickle.dumps(graph))
    np.testing.assert_allclose(restored.poses_matrix(), graph.poses_matrix(), atol=1e-12)
    np.testing.assert_allclose(
        restored.marginal_covariance(last), graph.marginal_covariance(last), rtol=1e-10
    )
    assert restored.factor_counts == graph.factor_counts
    assert restored.edges == graph.edges and restored.version == graph.version
    # Both keep working identically.
    for g in (graph, restored):
        g.add_keyframe([0.5, 0.0, 0.1], 3)
    np.testing.assert_allclose(restored.poses_se2(), graph.poses_se2(), atol=1e-12)


def test_odometry_noise_scales_with_sqrt_of_motion_steps():
    config = dataclasses.replace(PoseGraphConfig(), odom_sigma_xy_per_step=0.02)
    one, four = odometry_covariance(config, 1), odometry_covariance(config, 4)
    np.testing.assert_allclose(np.sqrt(four[3, 3]), 2 * 0.02)
    np.testing.assert_allclose(np.sqrt(four[2, 2]), 2 * np.sqrt(one[2, 2]))
    np.testing.assert_allclose(four[5, 5], one[5, 5])  # z stays tight, unscaled


def test_scan_match_factor_joins_its_anchor_and_unusable_ones_are_skipped():
    graph = PoseGraph(PoseGraphConfig(), [0.0, 0.0, 0.0])
    cov = np.diag([1.0, 1.0, 1e-4, 1e-4, 1e-4, 1.0])
    step = se2_to_matrix([0.5, 0.0, 0.0])
    degenerate = ScanMatch(step, np.eye(6) * 1e4, True, 3, 0, 0.0)
    graph.add_keyframe([0.5, 0.0, 0.0], 3, degenerate)
    assert graph.factor_counts["scan_matching"] == 0
    spanning = ScanMatch(step, cov, False, 0, 100, 0.0, span=2, span_relative=step @ step)
    j = graph.add_keyframe([0.5, 0.0, 0.0], 3, spanning)
    assert graph.edges[-1] == (0, j, "scan_matching")
    assert graph.factor_counts == {"odometry": 2, "scan_matching": 1}
    with pytest.raises(ValueError):
        graph.add_keyframe([0.5, 0.0, 0.0], 3, ScanMatch(step, cov, False, 0, 100, 0.0, span=9))


def test_poses_se2_are_cached_copies_renewed_by_each_update():
    config = PoseGraphConfig()
    truth, steps = square_path(2.0, 0.5)
    graph = build(truth[:6], steps[:5], config)
    first = graph.poses_se2()
    T = graph.poses_matrix()
    np.testing.assert_array_equal(first, np.stack([T[:, 0, 3], T[:, 1, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])], -1))
    first[:] = 0.0  # a copy: the cache is untouched
    assert np.abs(graph.poses_se2()).max() > 0.5
    graph.add_keyframe([0.5, 0.0, 0.0], 3)
    assert len(graph.poses_se2()) == 7
    np.testing.assert_allclose(graph.poses_se2()[-1, :2], se2_compose(graph.poses_se2()[-2], [0.5, 0.0, 0.0])[:2])


class CountingIsam:
    """Delegates to a live ``gtsam.ISAM2`` and counts the estimate reads (pybind objects
    cannot be patched)."""

    def __init__(self, isam: gtsam.ISAM2):
        self.isam, self.single, self.full = isam, 0, 0

    def calculateEstimatePose3(self, k):  # noqa: N802 (gtsam's name)
        self.single += 1
        return self.isam.calculateEstimatePose3(k)

    def calculateEstimate(self):  # noqa: N802
        self.full += 1
        return self.isam.calculateEstimate()

    def __getattr__(self, name):
        return getattr(self.isam, name)


def full_estimates(graph: PoseGraph) -> np.ndarray:
    """Every estimate fresh from ``calculateEstimate``, as ``(N, 4, 4)``."""
    isam = graph.isam.isam if isinstance(graph.isam, CountingIsam) else graph.isam
    values = isam.calculateEstimate()
    return np.stack([values.atPose3(key(i)).matrix() for i in range(graph.num_poses)])


@pytest.mark.parametrize("read_every", [1, 3])
def test_estimates_are_recomputed_only_where_they_changed_and_equal_a_full_read(read_every):
    """A long chain, then loop closures (relinearising much of it), then the chain goes on;
    the estimates read after every (or every third) update equal ``calculateEstimate``'s
    bit for bit, and between closures only a few keyframes are computed again."""
    config = PoseGraphConfig()
    truth, steps = square_path(side=8.0, step=0.5)  # 64 keyframes
    deltas = noisy_odometry(truth, steps, config, seed=4)
    graph = PoseGraph(config, truth[0])
    counting = graph._isam = CountingIsam(graph._isam)
    per_read, updates = [], 0

    def update(action) -> None:
        nonlocal updates
        action()
        updates += 1
        if updates % read_every == 0:
            single, full = counting.single, counting.full
            poses = graph.poses_matrix()
            per_read.append((graph.num_poses, counting.single - single, counting.full - full))
            np.testing.assert_array_equal(poses, full_estimates(graph))

    for delta, k in zip(deltas[:48], steps[:48]):
        update(lambda: graph.add_keyframe(delta, int(k)))
    chain = list(per_read)
    for i in (0, 2):
        update(lambda: graph.add_loop_closure(i, 47 - i, true_relative(truth, i, 47 - i), LOOP_COV, "pose_matching"))
    for delta, k in zip(deltas[48:], steps[48:]):
        update(lambda: graph.add_keyframe(delta, int(k)))
    np.testing.assert_array_equal(graph.poses_se2(), graph.poses_se2())  # cached, stable
    late_chain = [r for r in chain if r[0] > 35]
    assert late_chain and all(full == 0 and single < 0.2 * n for n, single, full in late_chain)
    assert any(full or single >= 10 for _, single, full in per_read[len(chain):])  # the closures moved many


def test_copies_share_read_estimates_but_not_their_updates():
    config = PoseGraphConfig()
    truth, steps = square_path(side=2.0, step=0.5)
    live = build(truth, steps, config)
    before = live.poses_matrix()
    sibling = live.copy()
    sibling.add_loop_closure(0, live.num_poses - 1, true_relative(truth, 0, live.num_poses - 1), LOOP_COV,
                             "pose_matching")
    np.testing.assert_array_equal(sibling.poses_matrix(), full_estimates(sibling))
    assert not np.array_equal(sibling.poses_matrix(), before)
    np.testing.assert_array_equal(live.poses_matrix(), before)
    live.add_keyframe([0.5, 0.0, 0.0], 3)
    np.testing.assert_array_equal(live.poses_matrix(), full_estimates(live))
