"""Virtual map: covariance intersection, range-bearing Jacobians, landmark covariances
and the log-det utility, against independent brute-force references."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import minimize_scalar

from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight
from explore_rl.planning.config import PlanningConfig, VirtualMapConfig
from explore_rl.planning.virtual_map import (
    VirtualMap,
    covariance_intersection,
    fuse_in_order,
    landmark_covariance_from_pose,
    measurement_noise,
    range_bearing,
    range_bearing_jacobians,
)

CFG = VirtualMapConfig()


def random_spd(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` random 2x2 SPD matrices with eigenvalues spread over two decades."""
    angles = rng.uniform(0, np.pi, n)
    c, s = np.cos(angles), np.sin(angles)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    eig = 10.0 ** rng.uniform(-3, -1, (n, 2))
    return rot @ (eig[:, :, None] * np.swapaxes(rot, -1, -2))


def fused_info_det(a: np.ndarray, b: np.ndarray, w: float) -> float:
    return float(np.linalg.det(w * np.linalg.inv(a) + (1 - w) * np.linalg.inv(b)))


def reference_ci(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Covariance intersection by numerical 1D optimisation (independent of the closed form)."""
    res = minimize_scalar(
        lambda w: -fused_info_det(a, b, w), bounds=(0, 1), method="bounded",
        options={"xatol": 1e-12},
    )
    candidates = [0.0, 1.0, res.x]
    w = max(candidates, key=lambda w: fused_info_det(a, b, w))
    return np.linalg.inv(w * np.linalg.inv(a) + (1 - w) * np.linalg.inv(b))


# --------------------------------------------------------------------- covariance intersection


def test_ci_never_loses_information_and_is_symmetric():
    rng = np.random.default_rng(0)
    a, b = random_spd(rng, 300), random_spd(rng, 300)
    fused, w = covariance_intersection(a, b)
    info_det = np.linalg.det(np.linalg.inv(fused))
    best_input = np.maximum(np.linalg.det(np.linalg.inv(a)), np.linalg.det(np.linalg.inv(b)))
    assert np.all(info_det >= best_input * (1 - 1e-9))
    assert np.all((w >= 0) & (w <= 1))
    fused_swapped, w_swapped = covariance_intersection(b, a)
    np.testing.assert_allclose(fused_swapped, fused, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(w_swapped, 1 - w, atol=1e-9)


def test_ci_weight_matches_grid_search():
    rng = np.random.default_rng(1)
    a, b = random_spd(rng, 40), random_spd(rng, 40)
    _, w = covariance_intersection(a, b)
    grid = np.linspace(0.0, 1.0, 20001)
    for k in range(len(a)):
        info_a, info_b = np.linalg.inv(a[k]), np.linalg.inv(b[k])
        dets = np.linalg.det(grid[:, None, None] * info_a + (1 - grid[:, None, None]) * info_b)
        best = int(np.argmax(dets))
        assert fused_info_det(a[k], b[k], w[k]) >= dets[best] * (1 - 1e-12)
        # the optimum is unique (sqrt det is strictly concave along the segment)
        assert abs(w[k] - grid[best]) < 1e-3


def test_ci_special_cases():
    a, b = np.diag([1.0, 4.0]), np.diag([4.0, 1.0])
    fused, w = covariance_intersection(a, b)
    assert w == pytest.approx(0.5)
    np.testing.assert_allclose(fused, np.diag([1.6, 1.6]))
    # an input better in every direction wins outright
    fused, w = covariance_intersection(0.5 * b, b)
    assert w == pytest.approx(1.0)
    np.testing.assert_allclose(fused, 0.5 * b)


# ------------------------------------------------------------------------ range-bearing model


def test_jacobians_match_finite_differences():
    rng = np.random.default_rng(2)
    eps = 1e-6
    for _ in range(20):
        pose = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi)]
        angle, dist = rng.uniform(0, 2 * np.pi), rng.uniform(0.5, 3.0)
        landmark = pose[:2] + dist * np.array([np.cos(angle), np.sin(angle)])
        h_x, h_l = range_bearing_jacobians(pose, landmark, CFG.min_range)
        num_x = np.zeros((2, 3))
        for i in range(3):
            d = np.zeros(3)
            d[i] = eps
            diff = range_bearing(pose + d, landmark) - range_bearing(pose - d, landmark)
            num_x[:, i] = diff / (2 * eps)
        num_l = np.zeros((2, 2))
        for i in range(2):
            d = np.zeros(2)
            d[i] = eps
            diff = range_bearing(pose, landmark + d) - range_bearing(pose, landmark - d)
            num_l[:, i] = diff / (2 * eps)
        np.testing.assert_allclose(h_x, num_x, atol=1e-7)
        np.testing.assert_allclose(h_l, num_l, atol=1e-7)


def test_landmark_covariance_matches_pseudo_inverse_formula():
    rng = np.random.default_rng(3)
    pose = np.array([1.0, -2.0, 0.7])
    pose_cov = np.diag([0.01, 0.02, 0.001])
    pose_cov[0, 1] = pose_cov[1, 0] = 0.005
    landmarks = pose[:2] + rng.uniform(-3, 3, (10, 2))
    covs = landmark_covariance_from_pose(landmarks, pose, pose_cov, CFG)
    r = measurement_noise(CFG)
    for lm, cov in zip(landmarks, covs):
        h_x, h_l = range_bearing_jacobians(pose, lm, CFG.min_range)
        pinv = np.linalg.pinv(h_l)
        expected = pinv @ (r + h_x @ pose_cov @ h_x.T) @ pinv.T
        np.testing.assert_allclose(cov, expected, rtol=1e-9, atol=1e-15)
        assert np.all(np.linalg.eigvalsh(cov) > 0)


def test_larger_pose_covariance_gives_larger_landmark_covariance():
    landmarks = np.array([[1.0, 0.5], [2.5, -1.0], [-0.5, 2.0]])
    pose = np.zeros(3)
    small = landmark_covariance_from_pose(landmarks, pose, np.diag([1e-4, 1e-4, 1e-5]), CFG)
    large = landmark_covariance_from_pose(landmarks, pose, np.diag([1e-2, 1e-2, 1e-3]), CFG)
    assert np.all(np.trace(large, axis1=1, axis2=2) > np.trace(small, axis1=1, axis2=2))
    # a perfectly known pose leaves only the sensor noise: radial std = sigma_range
    exact = landmark_covariance_from_pose(np.array([[2.0, 0.0]]), pose, np.zeros((3, 3)), CFG)
    assert np.sqrt(exact[0, 0, 0]) == pytest.approx(CFG.sigma_range)
    assert np.sqrt(exact[0, 1, 1]) == pytest.approx(2.0 * np.deg2rad(CFG.sigma_bearing_deg))


def test_min_range_clamp_prevents_blow_up():
    pose = np.array([0.0, 0.0, 0.3])
    pose_cov = np.diag([1e-3, 1e-3, 1e-3])
    at_clamp = landmark_covariance_from_pose(np.array([[CFG.min_range, 0.0]]), pose, pose_cov, CFG)
    for lm in ([1e-9, 0.0], [0.1, 0.0], [0.0, 0.0]):
        cov = landmark_covariance_from_pose(np.array([lm]), pose, pose_cov, CFG)
        assert np.all(np.isfinite(cov))
        np.testing.assert_allclose(cov, at_clamp, rtol=1e-9)


# ---------------------------------------------------------------------------- walled grid


def wall_grid() -> tuple[GridSpec, np.ndarray]:
    """10 m x 10 m at 0.1 m with a wall x in [4.0, 4.2) along the whole height."""
    grid = GridSpec((0.0, 0.0), 0.1, (100, 100))
    blocked = np.zeros(grid.shape, dtype=bool)
    blocked[:, 40:42] = True
    return grid, blocked


# ----------------------------------------------------------------------------- virtual map


def reference_map(vm: VirtualMap, poses, pose_covs, blocked) -> np.ndarray:
    """Pose-by-pose, landmark-by-landmark loop with pseudo-inverses and numerical CI."""
    covs = vm.prior_covariances()
    r = measurement_noise(vm.config)
    for pose, pose_cov in zip(poses, pose_covs):
        for l, lm in enumerate(vm.landmark_xy):
            if np.linalg.norm(lm - pose[:2]) > vm.config.sensor_range:
                continue
            if not line_of_sight(pose[None, :2], lm[None], blocked, vm.grid, 0.5, 0.5)[0]:
                continue
            h_x, h_l = range_bearing_jacobians(pose, lm, vm.config.min_range)
            pinv = np.linalg.pinv(h_l)
            observed = pinv @ (r + h_x @ pose_cov @ h_x.T) @ pinv.T
            covs[l] = reference_ci(covs[l], observed)
    return covs


def test_predicted_map_matches_reference_loop():
    grid = GridSpec((0.0, 0.0), 0.1, (40, 60))  # 6 m x 4 m
    blocked = np.zeros(grid.shape, dtype=bool)
    blocked[10:30, 30:32] = True
    poses = np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.5], [4.5, 2.0, 1.0], [1.5, 1.2, -0.2]])
    # similar sizes, different shapes: CI results depend on the fusion order
    rng = np.random.default_rng(6)
    factors = rng.normal(0, 0.03, (len(poses), 3, 3)) * [1, 1, 0.1]
    pose_covs = factors @ np.swapaxes(factors, 1, 2) + 1e-5 * np.eye(3)
    vm = VirtualMap(grid, CFG)
    covs = vm.predict_landmark_covariances(poses, pose_covs, blocked)
    np.testing.assert_allclose(covs, reference_map(vm, poses, pose_covs, blocked), rtol=1e-6)
    assert np.array_equal(vm.covariances, vm.prior_covariances())  # pure
    pairs = vm.visible_pairs(poses, blocked)
    np.testing.assert_array_equal(
        vm.predict_landmark_covariances(poses, pose_covs, blocked, pairs=pairs), covs
    )


def test_visible_pairs_by_length_are_the_same_pairs():
    """EM's fast backend tests line of sight by length (segments far from walls unsampled):
    the same pairs as the reference's test, walls near and far."""
    grid, blocked = wall_grid()
    rng = np.random.default_rng(8)
    blocked[rng.integers(0, grid.ny, 40), rng.integers(0, grid.nx, 40)] = True  # scattered cells
    poses = np.column_stack([rng.uniform(0, grid.nx * grid.resolution, 30),
                             rng.uniform(0, grid.ny * grid.resolution, 30), rng.uniform(-3, 3, 30)])
    vm = VirtualMap(grid, CFG)
    expected = vm.visible_pairs(poses, blocked)
    assert 0 < len(expected[0]) < len(vm.in_range_pairs(poses)[0])  # some pairs blocked, some seen
    for got, want in zip(vm.visible_pairs(poses, blocked, by_length=True), expected):
        np.testing.assert_array_equal(got, want)


def test_utility_drops_with_more_and_better_observations():
    grid = GridSpec((0.0, 0.0), 0.1, (200, 200))
    blocked = np.zeros(grid.shape, dtype=bool)
    vm = VirtualMap(grid, CFG)
    prior_u = vm.utility()
    assert prior_u == pytest.approx(vm.num_landmarks * np.log(CFG.prior_std**4))
    good = np.diag([1e-4, 1e-4, 1e-5])
    one = vm.utility(vm.predict_landmark_covariances([[5.0, 5.0, 0.0]], [good], blocked))
    two = vm.utility(
        vm.predict_landmark_covariances([[5.0, 5.0, 0.0], [14.0, 14.0, 0.0]], [good, good], blocked)
    )
    bad = vm.utility(vm.predict_landmark_covariances([[5.0, 5.0, 0.0]], [100 * good], blocked))
    assert two < one < bad < prior_u
    # continuing from a map only adds information
    covs = vm.predict_landmark_covariances([[5.0, 5.0, 0.0]], [good], blocked)
    more = vm.predict_landmark_covariances([[6.0, 5.0, 0.0]], [good], blocked, initial=covs)
    assert vm.utility(more) < vm.utility(covs)


def test_wall_stops_the_update():
    grid, blocked = wall_grid()
    vm = VirtualMap(grid, CFG)
    pose, cov = np.array([[3.0, 5.0, 0.0]]), np.array([np.diag([1e-4, 1e-4, 1e-5])])
    behind = vm.landmark_index(np.array([5.75, 5.25]))  # 2.76 m away, behind the wall
    on_wall = vm.landmark_index(np.array([4.25, 5.25]))  # the cell holding the wall
    with_wall = vm.predict_landmark_covariances(pose, cov, blocked)
    without = vm.predict_landmark_covariances(pose, cov, np.zeros_like(blocked))
    prior = CFG.prior_std**2 * np.eye(2)
    np.testing.assert_array_equal(with_wall[behind], prior)
    assert np.trace(without[behind]) < np.trace(prior)
    assert np.trace(with_wall[on_wall]) < np.trace(prior)


def test_frontier_covariance_trace_map_and_update():
    grid = GridSpec((-1.0, -1.0), 0.1, (50, 60))
    vm = VirtualMap(grid, CFG)
    blocked = np.zeros(grid.shape, dtype=bool)
    vm.update(np.array([[1.0, 1.0, 0.0]]), np.array([np.eye(3) * 1e-4]), blocked)
    assert vm.landmark_grid.shape == (10, 12)
    trace = vm.trace_map()
    assert trace.shape == (10, 12)
    cell = vm.landmark_grid.world_to_cell(np.array([1.3, 1.2]))
    np.testing.assert_allclose(
        np.trace(vm.frontier_landmark_covariance(np.array([1.3, 1.2]))), trace[cell[0], cell[1]]
    )
    assert trace[cell[0], cell[1]] < 2 * CFG.prior_std**2
    outside = vm.frontier_landmark_covariance(np.array([[50.0, 0.0], [1.3, 1.2]]))
    np.testing.assert_allclose(outside[0], CFG.prior_std**2 * np.eye(2))
    assert outside.shape == (2, 2, 2)


def test_rejects_bad_cell_size_and_mask():
    grid = GridSpec((0.0, 0.0), 0.1, (10, 10))
    with pytest.raises(ValueError, match="integer multiple"):
        VirtualMap(grid, VirtualMapConfig(cell_size=0.55))
    with pytest.raises(ValueError, match="blocked mask"):
        VirtualMap(grid, CFG).predict_landmark_covariances(
            np.zeros((1, 3)), np.zeros((1, 3, 3)), np.zeros((5, 5), dtype=bool)
        )


def test_yaml_defaults_match_dataclasses():
    """conf/planning/default.yaml repeats the dataclass defaults (config.py)."""
    path = Path(__file__).parents[2] / "conf" / "planning" / "default.yaml"
    assert yaml.safe_load(path.read_text()) == asdict(PlanningConfig())


def test_fuse_in_order_equals_fusing_one_observation_at_a_time():
    rng = np.random.default_rng(11)
    covs, observed = random_spd(rng, 30), random_spd(rng, 200)
    landmark_idx = rng.integers(0, 25, 200)  # landmarks 25-29 never observed
    expected = covs.copy()
    for lm, obs in zip(landmark_idx, observed):
        expected[lm], _ = covariance_intersection(expected[lm], obs)
    fused = covs.copy()
    fuse_in_order(fused, landmark_idx, observed)
    np.testing.assert_allclose(fused, expected, rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(fused[25:], covs[25:])
    fuse_in_order(fused, np.zeros(0, dtype=int), np.zeros((0, 2, 2)))  # nothing to fuse
    np.testing.assert_allclose(fused, expected, rtol=1e-9, atol=1e-15)
