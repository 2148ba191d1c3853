"""Segments: clustering, descriptors, matching and RANSAC; segment matching end to end."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from explore_rl.geometry import rotation_2d, se2_between
from explore_rl.slam import segments as seg
from explore_rl.slam.config import LoopClosureConfig, PoseGraphConfig

from .test_frontend import SENSOR_HEIGHT, sample_box, sample_rect, scan
from .test_loop_closure import FakeKeyframe, FakeSession, STEPS_PER_KEYFRAME

SEGMENT_ARGS = dict(ground_height=0.1, max_height=2.0, voxel=0.1, cluster_distance=0.25,
                    min_points=20, max_extent=2.0, min_extent=0.1)


def sample_cylinder(rng, center, radius, height, density=250.0):
    n = rng.poisson(2 * np.pi * radius * height * density)
    angle, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(0, height, n)
    return np.column_stack([center[0] + radius * np.cos(angle), center[1] + radius * np.sin(angle), z])


# Objects of distinct shapes (a hall's furniture), world frame, z = height above floor.
OBJECTS = [
    ("box", (1.0, 1.0, 0.0), (1.8, 1.5, 0.8)),
    ("box", (4.0, 1.2, 0.0), (4.4, 2.4, 1.2)),
    ("cyl", (2.6, 3.2), 0.25, 1.0),
    ("box", (5.5, 3.5, 0.0), (6.5, 3.9, 0.5)),
    ("cyl", (1.2, 4.6), 0.4, 0.6),
    ("box", (3.5, 5.2, 0.0), (4.1, 5.8, 1.4)),
]


def objects_points(rng, objects=OBJECTS) -> np.ndarray:
    parts = []
    for obj in objects:
        if obj[0] == "box":
            parts.append(sample_box(rng, obj[1], obj[2]))
        else:
            parts.append(sample_cylinder(rng, obj[1], obj[2], obj[3]))
    return np.vstack(parts)


def hall_points(rng) -> np.ndarray:
    """An 8 m x 7 m hall (walls 2.5 m) with the objects and a floor."""
    w, d, h = 8.0, 7.0, 2.5
    walls = [
        sample_rect(rng, [-0.5, -0.5, 0], [w, 0, 0], [0, 0, h]),
        sample_rect(rng, [-0.5, d - 0.5, 0], [w, 0, 0], [0, 0, h]),
        sample_rect(rng, [-0.5, -0.5, 0], [0, d, 0], [0, 0, h]),
        sample_rect(rng, [w - 0.5, -0.5, 0], [0, d, 0], [0, 0, h]),
        sample_rect(rng, [-0.5, -0.5, 0], [w, 0, 0], [0, d, 0]),
    ]
    return np.vstack([objects_points(rng), *walls])


def submap_in(frame: np.ndarray, world: np.ndarray, around: np.ndarray, radius: float = 3.5) -> np.ndarray:
    """World points within ``radius`` of ``around`` (xy), in the planar ``frame``."""
    near = world[np.hypot(*(world[:, :2] - around).T) <= radius]
    xy = (near[:, :2] - frame[:2]) @ rotation_2d(frame[2])
    return np.column_stack([xy, near[:, 2]])


def segments_of(points: np.ndarray) -> list[seg.Segment]:
    return seg.segment_submap(points, **SEGMENT_ARGS)


def test_cluster_separates_objects_and_drops_small_clusters():
    rng = np.random.default_rng(0)
    points = np.vstack([rng.normal([0, 0, 0.5], 0.05, (200, 3)), rng.normal([2, 0, 0.5], 0.05, (150, 3)),
                        rng.normal([0, 3, 0.5], 0.01, (5, 3))])
    clusters = seg.cluster(points, 0.25, 20)
    assert [len(c) for c in clusters] == [200, 150]
    assert set(clusters[0]) == set(range(200))


def test_walls_and_floor_are_not_segments():
    rng = np.random.default_rng(1)
    wall = sample_rect(rng, [0, 0, 0], [5.0, 0, 0], [0, 0, 2.5])
    floor = sample_rect(rng, [0, -2, 0], [5.0, 0, 0], [0, 4, 0])
    box = sample_box(rng, (2.0, 1.0, 0.0), (2.6, 1.5, 0.9))
    found = segments_of(np.vstack([wall, floor, box]))
    assert len(found) == 1
    np.testing.assert_allclose(found[0].centroid, [2.3, 1.25], atol=0.1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_segment_matching_recovers_a_known_transform(seed):
    """Two submaps of the same objects seen from different places and headings, in
    their own frames: descriptors + ratio test + RANSAC recover the transform."""
    rng = np.random.default_rng(seed)
    frame_a = np.array([3.0, 3.0, 0.0])
    frame_b = frame_a + np.array([rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), rng.uniform(-np.pi, np.pi)])
    # Independent surface samples and small noise for each submap (different scans).
    a = submap_in(frame_a, objects_points(rng) + rng.normal(0, 0.005, (1, 3)), frame_a[:2])
    b = submap_in(frame_b, objects_points(rng), frame_a[:2])
    seg_a, seg_b = segments_of(a), segments_of(b)
    assert len(seg_a) >= 4 and len(seg_b) >= 4
    scale = np.asarray(LoopClosureConfig().segment_descriptor_scale)
    matches = seg.match_descriptors(seg_b, seg_a, scale, ratio=0.8, max_distance=2.0)
    q = np.array([seg_b[i].centroid for i, _ in matches])
    r = np.array([seg_a[j].centroid for _, j in matches])
    transform, inliers = seg.ransac_rigid_2d(q, r, 0.3, 50, np.random.default_rng(0))
    assert transform is not None and inliers.sum() >= 3
    truth = se2_between(frame_a, frame_b)  # maps b-frame points into the a frame
    error = se2_between(truth, transform)
    assert np.hypot(error[0], error[1]) < 0.05, (truth, transform)
    assert abs(np.rad2deg(error[2])) < 1.0


def test_ransac_ignores_wrong_matches():
    rng = np.random.default_rng(4)
    truth = np.array([0.7, -1.2, 0.9])
    source = rng.uniform(-3, 3, (8, 2))
    target = seg.apply_2d(truth, source) + rng.normal(0, 0.02, (8, 2))
    target[[1, 5]] += [[2.0, 0.5], [-1.5, 1.0]]  # two wrong matches
    transform, inliers = seg.ransac_rigid_2d(source, target, 0.2, 50, rng)
    assert inliers.tolist() == [True, False, True, True, True, False, True, True]
    np.testing.assert_allclose(transform, truth, atol=0.03)
    # Fewer than two pairs: nothing to estimate.
    assert seg.ransac_rigid_2d(source[:1], target[:1], 0.2, 50, rng)[0] is None


def test_rigid_2d_is_exact_on_noise_free_points():
    truth = np.array([-2.0, 0.5, -2.5])
    source = np.array([[0.0, 0.0], [1.0, 0.0], [0.3, 2.0]])
    np.testing.assert_allclose(seg.rigid_2d(source, seg.apply_2d(truth, source)), truth, atol=1e-12)


def test_segment_matching_closes_a_loop_pose_matching_cannot():
    """A loop through the hall; pose matching's gate refuses every candidate (as when
    the relative pose is too uncertain for its starts: ``max_sigma_translation`` 0),
    segment matching finds the objects again and adds a true ``segment_matching``
    factor."""
    from explore_rl.slam.loop_closure import IcpLoopCloser
    from explore_rl.slam.pose_graph import PoseGraph

    config = dataclasses.replace(LoopClosureConfig(), line_of_sight=False, max_sigma_translation=0.0)
    closer = IcpLoopCloser(config, mount_height=SENSOR_HEIGHT)
    rng = np.random.default_rng(0)
    # A 4 m x 3 m loop around the middle of the hall, twice, keyframes every 0.5 m.
    corners = np.array([[1.0, 2.2], [5.0, 2.2], [5.0, 4.6], [1.0, 4.6]])
    truth = []
    for lap in range(2):
        for k in range(4):
            a, b = corners[k], corners[(k + 1) % 4]
            n = int(round(np.linalg.norm(b - a) / 0.5))
            heading = np.arctan2(*(b - a)[::-1])
            truth += [[*(a + (b - a) * t / n), heading] for t in range(n)]
    truth = np.array(truth[: len(truth) - 4])
    graph_config = PoseGraphConfig()
    session = FakeSession(PoseGraph(graph_config, truth[0]))
    sigma = np.sqrt(STEPS_PER_KEYFRAME) * np.array([0.01, 0.01, np.deg2rad(0.08)])
    travel = 0.0
    for j, pose in enumerate(truth):
        if j:
            delta = se2_between(truth[j - 1], pose) + rng.normal(0.0, sigma)
            session.graph.add_keyframe(delta, STEPS_PER_KEYFRAME)
            travel += float(np.hypot(*(pose[:2] - truth[j - 1][:2])))
        session.keyframes.append(FakeKeyframe(j, pose.copy(), travel, scan(hall_points(rng), pose, rng)))
        closer.process(session)
    assert closer.segment_sets, "no rolling submap was segmented"
    pose_matching = [a for a in closer.attempts if a.source == "pose_matching"]
    assert pose_matching and all(a.reason == "gate_uncertain" for a in pose_matching
                                 if a.reason != "gate_far")
    accepted = [a for a in closer.attempts if a.source == "segment_matching" and a.accepted]
    assert accepted, sorted({a.reason for a in closer.attempts if a.source == "segment_matching"})
    assert session.graph.factor_counts["segment_matching"] == len(accepted) == closer.closures["segment_matching"]
    # True closures (the benchmark's bound: 0.3 m, 3 deg) that improve on the estimate;
    # both rolling submaps are placed by odometry alone here, so a few cm of error remain.
    for a in accepted:
        assert a.matches >= config.min_segment_matches
        assert a.error_translation < 0.3 and a.error_rotation_deg < 3.0, a
    assert np.mean([a.error_translation for a in accepted]) < np.mean(
        [a.prior_error_translation for a in accepted])
