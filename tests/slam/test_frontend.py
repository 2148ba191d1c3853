"""Sequential scan matcher on synthetic clouds (points sampled on surfaces, 3 m range)."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import numpy as np
import yaml

from explore_rl.geometry import matrix_to_se2, se2_between, se2_to_matrix, transform_points
from explore_rl.slam.config import PoseGraphConfig, ScanMatcherConfig
from explore_rl.slam.frontend import ScanMatch, ScanMatcher

SENSOR_HEIGHT = 0.4
RANGE = 3.0
DENSITY = 250.0  # points per square metre of surface (~10k points per 3 m scan)
NOISE = 0.003


def sample_rect(rng, corner, u, v, density=DENSITY):
    """Uniform points on the parallelogram ``corner + a u + b v``, a, b in [0, 1]."""
    corner, u, v = (np.asarray(x, dtype=float) for x in (corner, u, v))
    n = rng.poisson(np.linalg.norm(np.cross(u, v)) * density)
    a, b = rng.random((2, n, 1))
    return corner + a * u + b * v


def sample_box(rng, lo, hi):
    """Four sides and the top of an axis-aligned box standing on the floor."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    dx, dy, dz = [x1 - x0, 0, 0], [0, y1 - y0, 0], [0, 0, z1 - z0]
    return np.vstack(
        [
            sample_rect(rng, lo, dx, dz),
            sample_rect(rng, lo, dy, dz),
            sample_rect(rng, [x0, y1, z0], dx, dz),
            sample_rect(rng, [x1, y0, z0], dy, dz),
            sample_rect(rng, [x0, y0, z1], dx, dy),
        ]
    )


def room_points(rng, floor=True):
    """A 6 m x 5 m room, walls 2.5 m high, three boxes."""
    w, d, h = 6.0, 5.0, 2.5
    parts = [
        sample_rect(rng, [0, 0, 0], [w, 0, 0], [0, 0, h]),
        sample_rect(rng, [0, d, 0], [w, 0, 0], [0, 0, h]),
        sample_rect(rng, [0, 0, 0], [0, d, 0], [0, 0, h]),
        sample_rect(rng, [w, 0, 0], [0, d, 0], [0, 0, h]),
        sample_box(rng, (1.0, 1.0, 0.0), (1.8, 1.5, 0.8)),
        sample_box(rng, (4.0, 3.2, 0.0), (4.5, 4.2, 1.2)),
        sample_box(rng, (2.5, 3.8, 0.0), (3.0, 4.3, 0.5)),
    ]
    if floor:
        parts.append(sample_rect(rng, [0, 0, 0], [w, 0, 0], [0, d, 0]))
    return np.vstack(parts)


def corridor_points(rng):
    """Two parallel 20 m walls 2 m apart along x, plus the floor: nothing fixes x."""
    length, half_width, h = 20.0, 1.0, 2.5
    return np.vstack(
        [
            sample_rect(rng, [-10, -half_width, 0], [length, 0, 0], [0, 0, h]),
            sample_rect(rng, [-10, half_width, 0], [length, 0, 0], [0, 0, h]),
            sample_rect(rng, [-10, -half_width, 0], [length, 0, 0], [0, 2 * half_width, 0]),
        ]
    )


def thin_wall_points(rng, face_y):
    """A 0.2 m thick wall (faces y = 0 and 0.2) with a 1.2 m door at x = 0, jambs,
    side walls and the floor; only the face at ``face_y`` (the one the sensor sees)."""
    h = 2.5
    parts = [sample_rect(rng, [-5, -5, 0], [10, 0, 0], [0, 10, 0])]
    for xa, xb in [(-5.0, -0.6), (0.6, 5.0)]:
        parts.append(sample_rect(rng, [xa, face_y, 0], [xb - xa, 0, 0], [0, 0, h]))
    for x in (-0.6, 0.6):
        parts.append(sample_rect(rng, [x, 0, 0], [0, 0.2, 0], [0, 0, h]))
    for x in (-2.0, 2.0):
        parts.append(sample_rect(rng, [x, -3, 0], [0, 6, 0], [0, 0, h]))
    return np.vstack(parts)


def floor_points(rng):
    return sample_rect(rng, [-5, -5, 0], [10, 0, 0], [0, 10, 0])


def scan(world_points, pose_se2, rng):
    """World points seen from a planar base pose: sensor frame, within range, noisy."""
    T = se2_to_matrix(pose_se2, z=SENSOR_HEIGHT)
    pts = transform_points(np.linalg.inv(T), world_points)
    pts = pts[np.linalg.norm(pts, axis=1) <= RANGE]
    return pts + rng.normal(0.0, NOISE, pts.shape)


def sensor_delta(a_se2, b_se2):
    return se2_to_matrix(se2_between(a_se2, b_se2))


def register_pair(make_world, a, b, prior_error=(0.0, 0.0, 0.0), seed=0, config=None):
    """First scan at ``a`` then at ``b`` with a wheel prior off by ``prior_error``."""
    rng = np.random.default_rng(seed)
    matcher = ScanMatcher(config or ScanMatcherConfig())
    first = matcher.register(scan(make_world(rng), a, rng), np.eye(4))
    prior = se2_to_matrix(se2_between(a, b) + np.asarray(prior_error))
    second = matcher.register(scan(make_world(rng), b, rng), prior)
    return first, second


def test_room_registration_recovers_motion_despite_bad_prior():
    a, b = np.array([2.5, 2.0, 0.3]), np.array([2.9, 2.25, 0.55])
    first, match = register_pair(room_points, a, b, prior_error=(0.1, -0.06, 0.0))
    assert first.degenerate and not first.usable
    assert match.usable and match.weak_directions == 0
    error = se2_between(se2_between(a, b), matrix_to_se2(match.relative))
    assert np.hypot(error[0], error[1]) < 0.01, error
    assert abs(np.rad2deg(error[2])) < 0.2, error
    # Covariance: symmetric positive definite; yaw, x, y within a few cm / deg here;
    # z, roll, pitch left to the odometry factors.
    assert np.allclose(match.covariance, match.covariance.T)
    assert np.all(np.linalg.eigvalsh(match.covariance) > 0)
    sigmas = np.sqrt(np.diag(match.covariance))
    assert np.all(sigmas[3:5] < 0.03) and sigmas[2] < np.deg2rad(1.0), sigmas
    assert np.all(sigmas[[0, 1, 5]] >= 1.0), sigmas


def test_first_frame_returns_wheel_delta():
    rng = np.random.default_rng(1)
    delta = se2_to_matrix([0.3, 0.1, 0.2])
    match = ScanMatcher(ScanMatcherConfig()).register(scan(room_points(rng), [2, 2, 0], rng), delta)
    assert match.degenerate
    assert np.allclose(match.relative, delta)


def test_floor_only_and_empty_clouds_are_degenerate():
    a, b = np.array([0.0, 0.0, 0.0]), np.array([0.4, 0.1, 0.2])
    _, floor = register_pair(floor_points, a, b)
    assert floor.degenerate and not floor.usable
    assert floor.weak_directions >= 3
    # Falls back to the wheel delta.
    assert np.allclose(floor.relative, sensor_delta(a, b), atol=1e-9)

    matcher = ScanMatcher(ScanMatcherConfig())
    rng = np.random.default_rng(2)
    matcher.register(scan(room_points(rng), [2, 2, 0], rng), np.eye(4))
    for cloud in (np.empty((0, 3)), np.full((5, 3), np.nan), np.zeros((3, 3))):
        delta = se2_to_matrix([0.5, 0.0, 0.1])
        match = matcher.register(cloud, delta)
        assert match.degenerate and np.allclose(match.relative, delta)
        assert np.all(np.diag(match.covariance) >= 1.0)


def test_dropping_ground_makes_floor_only_scan_empty():
    config = ScanMatcherConfig(drop_ground_below_z=-SENSOR_HEIGHT + 0.1)
    _, match = register_pair(floor_points, [0, 0, 0], [0.4, 0, 0], config=config)
    assert match.degenerate and match.n_points == 0


def test_corridor_is_weak_along_its_axis():
    a, b = np.array([0.0, 0.0, 0.0]), np.array([0.4, 0.05, 0.05])
    _, match = register_pair(corridor_points, a, b, prior_error=(0.07, 0.0, 0.0))
    assert match.usable
    assert match.weak_directions >= 1
    # The tangent translation is in the body frame of b: the corridor axis there is
    # world x rotated by -yaw_b.
    along = se2_to_matrix(b)[:3, :3].T @ np.array([1.0, 0.0, 0.0])
    across = se2_to_matrix(b)[:3, :3].T @ np.array([0.0, 1.0, 0.0])
    cov_t = match.covariance[3:, 3:]
    assert np.sqrt(along @ cov_t @ along) > 0.5
    assert np.sqrt(across @ cov_t @ across) < 0.02
    assert np.sqrt(match.covariance[2, 2]) < np.deg2rad(0.5)
    # Along the weak axis the estimate keeps the (7 cm off) wheel prior.
    rel = matrix_to_se2(match.relative)
    assert abs(rel[0] - (se2_between(a, b)[0] + 0.07)) < 0.02, rel
    # Across the corridor the scan still corrects the pose.
    assert abs(rel[1] - se2_between(a, b)[1]) < 0.02, rel


def test_pickle_restarts_with_empty_map():
    rng = np.random.default_rng(3)
    matcher = ScanMatcher(ScanMatcherConfig(voxel_size=0.2))
    matcher.register(scan(room_points(rng), [2, 2, 0], rng), np.eye(4))
    assert len(matcher.local_map_points) > 0
    restored = pickle.loads(pickle.dumps(matcher))
    assert restored.config == matcher.config
    assert len(restored.local_map_points) == 0
    match = restored.register(scan(room_points(rng), [2.3, 2, 0], rng), np.eye(4))
    assert isinstance(match, ScanMatch) and match.degenerate


def test_conf_yaml_mirrors_config_defaults():
    path = Path(__file__).resolve().parents[2] / "conf" / "slam" / "icp.yaml"
    conf = yaml.safe_load(path.read_text())
    assert conf["frontend"] == "icp"
    for section, cls in (("pose_graph", PoseGraphConfig), ("scan_matcher", ScanMatcherConfig)):
        assert conf[section] == dataclasses.asdict(cls()), section


def test_sequence_spans_a_degenerate_frame():
    """A floor-only keyframe falls back to the wheel delta; the next match is measured
    from the last registered keyframe (span 2), free of that wheel error."""
    rng = np.random.default_rng(4)
    matcher = ScanMatcher(ScanMatcherConfig(max_span=5))
    poses = [np.array([1.5 + 0.4 * k, 2.0 + 0.1 * k, 0.1 * k]) for k in range(6)]
    wheel_error = np.array([0.03, -0.02, 0.01])
    matcher.register(scan(room_points(rng), poses[0], rng), np.eye(4))
    for k in range(1, len(poses)):
        wheel = se2_between(poses[k - 1], poses[k]) + wheel_error
        world = floor_points(rng) if k == 3 else room_points(rng)
        match = matcher.register(scan(world, poses[k], rng), se2_to_matrix(wheel))
        if k == 3:
            assert match.degenerate
            assert np.allclose(matrix_to_se2(match.relative), wheel)
            continue
        assert match.usable and match.span == (2 if k == 4 else 1), k
        reference = poses[k - match.span]
        error = se2_between(se2_between(reference, poses[k]), matrix_to_se2(match.span_relative))
        assert np.hypot(error[0], error[1]) < 0.01 and abs(error[2]) < np.deg2rad(0.2), (k, error)
        if k == 4:  # the one-step relative carries the wheel error of keyframe 3
            one_step = se2_between(se2_between(poses[3], poses[4]), matrix_to_se2(match.relative))
            assert np.hypot(one_step[0], one_step[1]) > 0.02


def test_far_face_of_a_thin_wall_is_not_matched_to_its_near_face():
    """Through a door, the scan sees the wall's far face, 0.2 m from the mapped near
    face. Matching them would pull the pose 0.2 m back with confidence; instead the
    forward direction is weak and keeps the (5 cm off) wheel prior."""
    rng = np.random.default_rng(5)
    a, b = np.array([0.0, -0.3, np.pi / 2]), np.array([0.0, 0.35, np.pi / 2])
    matcher = ScanMatcher(ScanMatcherConfig())
    matcher.register(scan(thin_wall_points(rng, 0.0), a, rng), np.eye(4))
    wheel = se2_between(a, b) + np.array([0.05, 0.0, 0.0])
    match = matcher.register(scan(thin_wall_points(rng, 0.2), b, rng), se2_to_matrix(wheel))
    assert match.usable and match.weak_directions >= 1
    error = se2_between(se2_between(a, b), matrix_to_se2(match.span_relative))
    assert abs(error[0] - 0.05) < 0.01 and abs(error[1]) < 0.01, error
    assert np.sqrt(match.covariance[3, 3]) > 0.5  # forward (body x) inflated
