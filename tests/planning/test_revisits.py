"""Revisit prediction and path sampling."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight
from explore_rl.planning.config import RevisitConfig
from explore_rl.planning.revisits import (
    Revisit,
    cumulative_length,
    distinct_ids,
    distinct_line_of_sight,
    predict_revisits,
    predict_revisits_of_paths,
    predict_revisits_reference,
    sample_path,
    sample_path_poses,
    sample_paths,
)

CFG = RevisitConfig(r_lc=1.0, min_travel_gap=3.0, merge_keyframe_gap=4)
GRID = GridSpec((0.0, 0.0), 0.1, (100, 100))
FREE = np.zeros(GRID.shape, dtype=bool)


def old_trajectory() -> tuple[np.ndarray, np.ndarray]:
    """Keyframes along y = 2 from x = 1 to 9 every 0.5 m, travelled long ago."""
    x = np.arange(1.0, 9.01, 0.5)
    return np.column_stack([x, np.full_like(x, 2.0)]), x - 1.0


def approach_path() -> np.ndarray:
    """A path coming down x = 5.1 and stopping at y = 2.5 (0.51 m from keyframe x = 5)."""
    return sample_path_poses(np.array([[5.1, 8.0], [5.1, 2.5]]), 0.5, include_start=True)[:, :2]


def brute_force_pairs(path_xy, kf_xy, kf_travel, current_travel, cfg):
    """Qualifying (path, keyframe, distance) by explicit loops (no line of sight)."""
    path_travel = cumulative_length(path_xy)
    out = []
    for i, p in enumerate(path_xy):
        for k, q in enumerate(kf_xy):
            d = float(np.linalg.norm(p - q))
            gap = current_travel + path_travel[i] - kf_travel[k]
            if d <= cfg.r_lc and gap > cfg.min_travel_gap:
                out.append((i, k, d))
    return out


def test_old_keyframe_in_sight_gives_one_revisit_at_closest_pose():
    kf_xy, kf_travel = old_trajectory()
    path = approach_path()
    revisits = predict_revisits(path, kf_xy, kf_travel, 50.0, FREE, GRID, CFG)
    assert len(revisits) == 1
    pairs = brute_force_pairs(path, kf_xy, kf_travel, 50.0, CFG)
    i, k, d = min(pairs, key=lambda t: t[2])
    assert revisits[0] == Revisit(i, k, pytest.approx(d))
    assert i == len(path) - 1 and kf_xy[k, 0] == 5.0
    assert revisits[0].distance == pytest.approx(np.hypot(0.1, 0.5))


def test_recent_keyframe_gives_no_revisit():
    kf_xy, kf_travel = old_trajectory()
    kf_xy, kf_travel = kf_xy[:9], kf_travel[:9]  # up to x = 5, travel 4
    path = np.array([[5.5, 2.0], [5.5, 2.5]])  # the robot just drove on to x = 5.5
    assert predict_revisits(path, kf_xy, kf_travel, 4.5, FREE, GRID, CFG) == []
    # the same geometry after a long excursion does close a loop
    assert len(predict_revisits(path, kf_xy, kf_travel, 20.0, FREE, GRID, CFG)) == 1


def test_wall_between_gives_no_revisit():
    kf_xy, kf_travel = old_trajectory()
    blocked = FREE.copy()
    blocked[22:24, :] = True  # y in [2.2, 2.4): between the keyframes and the path
    assert predict_revisits(approach_path(), kf_xy, kf_travel, 50.0, blocked, GRID, CFG) == []


def test_two_separate_places_give_two_revisits():
    kf_xy, kf_travel = old_trajectory()
    # along y = 2.6 above x in [2, 3] and, after a detour, above x in [7.5, 8]
    path = np.array([[2.0, 2.6], [3.0, 2.6], [3.0, 6.0], [7.5, 6.0], [7.5, 2.6], [8.0, 2.6]])
    path_xy = sample_path_poses(path, 0.5, include_start=True)[:, :2]
    revisits = predict_revisits(path_xy, kf_xy, kf_travel, 50.0, FREE, GRID, CFG)
    assert len(revisits) == 2
    first, second = (kf_xy[r.keyframe_index, 0] for r in revisits)
    assert first in (2.0, 2.5, 3.0) and second in (7.5, 8.0)  # equal distances: any of them
    for r in revisits:
        assert r.distance == pytest.approx(0.6)
        np.testing.assert_allclose(path_xy[r.path_index], kf_xy[r.keyframe_index] + [0, 0.6])


def test_exact_hit_and_custom_path_travel():
    kf_xy = np.array([[1.0, 1.0]])
    revisits = predict_revisits(kf_xy.copy(), kf_xy, np.zeros(1), 10.0, FREE, GRID, CFG)
    assert revisits == [Revisit(0, 0, 0.0)]
    # the same pose reached only after little travel: no loop closure
    assert predict_revisits(kf_xy.copy(), kf_xy, np.zeros(1), 1.0, FREE, GRID, CFG) == []
    # ... unless the path to it is long
    got = predict_revisits(kf_xy, kf_xy, np.zeros(1), 1.0, FREE, GRID, CFG, path_travel=[5.0])
    assert got == [Revisit(0, 0, 0.0)]
    assert predict_revisits(np.zeros((0, 2)), kf_xy, np.zeros(1), 9.0, FREE, GRID, CFG) == []


def test_matches_brute_force_on_random_scenes():
    rng = np.random.default_rng(4)
    for _ in range(5):
        kf_xy = np.cumsum(rng.normal(0, 0.4, (60, 2)), axis=0) + 5.0
        kf_travel = np.r_[0, np.cumsum(np.linalg.norm(np.diff(kf_xy, axis=0), axis=1))]
        path = np.cumsum(rng.normal(0, 0.4, (30, 2)), axis=0) + kf_xy[-1]
        current = kf_travel[-1]
        got = predict_revisits(path, kf_xy, kf_travel, current, FREE, GRID, CFG)
        pairs = brute_force_pairs(path, kf_xy, kf_travel, current, CFG)
        if not pairs:
            assert got == []
            continue
        revisited = sorted({k for _, k, _ in pairs})
        assert {r.keyframe_index for r in got} <= set(revisited)
        # every revisited keyframe belongs to exactly one reported group, and each report is
        # the closest pair of its group
        breaks = np.flatnonzero(np.diff(revisited) > CFG.merge_keyframe_gap) + 1
        groups = np.split(revisited, breaks)
        assert len(got) == len(groups)
        for r, group in zip(got, groups):
            best = min((p for p in pairs if p[1] in set(group)), key=lambda t: (t[2], t[0]))
            assert (r.path_index, r.keyframe_index) == best[:2]


# --------------------------------------------------------------------------- path sampling


def test_sample_path_l_shape():
    path = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.0], [2.0, 1.2]])
    poses, travel = sample_path(path, 0.5)
    np.testing.assert_allclose(travel, [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.2])
    np.testing.assert_allclose(poses[:3, :2], [[0.5, 0], [1.0, 0], [1.5, 0]])
    np.testing.assert_allclose(poses[3:, :2], [[2, 0], [2, 0.5], [2, 1.0], [2, 1.2]], atol=1e-12)
    np.testing.assert_allclose(poses[:, 2], [0, 0, 0] + [np.pi / 2] * 4)
    with_start = sample_path_poses(path, 0.5, include_start=True)
    np.testing.assert_allclose(with_start[0], [0, 0, 0])
    assert len(with_start) == 8


def test_sample_path_degenerate():
    assert sample_path_poses(np.array([[1.0, 1.0]]), 0.5).shape == (0, 3)
    np.testing.assert_allclose(
        sample_path_poses(np.array([[1.0, 1.0], [1.0, 1.0]]), 0.5, include_start=True),
        [[1.0, 1.0, 0.0]],
    )
    poses = sample_path_poses(np.array([[0.0, 0.0], [0.0, -1.0]]), 0.5)
    np.testing.assert_allclose(poses, [[0, -0.5, -np.pi / 2], [0, -1.0, -np.pi / 2]])


@pytest.mark.parametrize("seed", [3, 4])
def test_paths_sampled_at_once_equal_each_path_alone(seed):
    """:func:`sample_paths` gives every path what :func:`sample_path` gives it alone, the
    same floats: lattice paths (arc lengths at exact multiples of the spacing, repeated
    points), off-lattice ones, single points, empty paths and the unsampled first call."""
    rng = np.random.default_rng(seed)
    assert sample_paths([], 0.5) == []
    for _ in range(200):
        paths = []
        for _ in range(rng.integers(1, 7)):
            n = int(rng.integers(0, 9))
            path = rng.uniform(0, 3, (n, 2))
            if rng.random() < 0.5:
                path = np.round(path * 2) / 2
            if n > 2 and rng.random() < 0.4:
                path[1] = path[0]
            paths.append(path)
        spacing = float(rng.choice([0.25, 0.3, 0.5]))
        together = sample_paths(paths, spacing)
        assert len(together) == len(paths)
        for path, (poses, travel) in zip(paths, together):
            alone_poses, alone_travel = sample_path(path, spacing)
            assert poses.shape == alone_poses.shape and travel.shape == alone_travel.shape
            assert np.array_equal(poses, alone_poses) and np.array_equal(travel, alone_travel)


@pytest.mark.parametrize("seed", [7, 8, 9])
def test_paths_at_once_equal_each_path_alone(seed):
    """A decision's candidates: random walks branching off one shared stretch from the
    robot, a wall across part of the map, keyframes on a 0.1 m lattice (equal distances:
    the tie rules count). :func:`predict_revisits_of_paths` gives every path what the
    first implementation gives it alone (empty paths too)."""
    rng = np.random.default_rng(seed)
    kf_xy = np.round(np.clip(np.cumsum(rng.normal(0, 0.4, (120, 2)), axis=0) + 5.0, 0.5, 9.5), 1)
    kf_travel = np.r_[0, np.cumsum(np.linalg.norm(np.diff(kf_xy, axis=0), axis=1))]
    blocked = FREE.copy()
    blocked[48:50, 20:70] = True
    trunk = sample_path_poses(np.array([kf_xy[-1], [5.0, 5.2], [3.0, 3.0]]), 0.5, include_start=True)[:, :2]
    paths = [np.vstack([trunk[: rng.integers(2, len(trunk) + 1)],
                        np.round(np.clip(trunk[-1] + np.cumsum(rng.normal(0, 0.5, (15, 2)), axis=0), 0.2, 9.8), 1)])
             for _ in range(8)] + [np.zeros((0, 2))]
    travels = [cumulative_length(p) for p in paths]
    current = kf_travel[-1]
    together = predict_revisits_of_paths(paths, kf_xy, kf_travel, current, blocked, GRID, CFG, travels)
    alone = [predict_revisits_reference(p, kf_xy, kf_travel, current, blocked, GRID, CFG, path_travel=t)
             for p, t in zip(paths, travels)]
    assert together == alone
    assert [predict_revisits(p, kf_xy, kf_travel, current, blocked, GRID, CFG, path_travel=t)
            for p, t in zip(paths, travels)] == alone
    assert sum(len(found) for found in alone) > 8 and alone[-1] == []


def test_distinct_line_of_sight_tests_each_segment_once_with_the_same_answers():
    rng = np.random.default_rng(3)
    kf_xy = rng.uniform(0.0, 10.0, (30, 2))
    starts = rng.uniform(0.0, 10.0, (40, 2))
    pick = rng.integers(0, 40, 200)
    kf_idx = rng.integers(0, 30, 200)
    blocked = FREE.copy()
    blocked[30:70, 50] = True
    np.testing.assert_array_equal(distinct_ids(starts[pick]) == distinct_ids(starts[pick])[:, None],
                                  pick == pick[:, None])
    got = distinct_line_of_sight(starts[pick], distinct_ids(starts[pick]), kf_idx, kf_xy, blocked, GRID,
                                 CFG.los_step_fraction)
    expected = line_of_sight(starts[pick], kf_xy[kf_idx], blocked, GRID, CFG.los_step_fraction)
    np.testing.assert_array_equal(got, expected)
    assert 0 < expected.sum() < len(expected)
