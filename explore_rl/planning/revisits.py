"""Revisit prediction: where a path would close a loop with an older keyframe.

One predicate shared by the exploration graph, the EM planner and the model SLAM front
end: a predicted pose within ``r_lc`` of an older keyframe's current estimate, with more
than ``min_travel_gap`` of travel between them and line of sight on the 2D map. Each
revisit keeps only its closest predicted pose.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight, line_of_sight_by_length
from explore_rl.planning.config import RevisitConfig
from explore_rl.sorting import stable_argsort, unique_first_inverse


@dataclass(frozen=True)
class Revisit:
    """Path pose ``path_index`` would close a loop with keyframe ``keyframe_index``."""

    path_index: int
    keyframe_index: int
    distance: float  # m, between the predicted pose and the keyframe estimate


def cumulative_length(path_xy: np.ndarray) -> np.ndarray:
    """Arc length ``(P,)`` at each vertex of a polyline ``(P, 2)``, starting at 0."""
    path_xy = np.asarray(path_xy, float).reshape(-1, 2)
    seg = np.linalg.norm(np.diff(path_xy, axis=0), axis=1)
    return np.concatenate(([0.0], np.cumsum(seg)))


def sample_path(
    path_xy: np.ndarray, keyframe_spacing: float, include_start: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Planar poses ``(P, 3)`` every ``keyframe_spacing`` along a polyline and their arc
    length ``(P,)`` from the path start.

    Samples sit at ``s, 2s, ...`` and at the path end (the start too if
    ``include_start``); yaw is the direction of travel of the segment each sample lies on
    (the next segment at a vertex, the last segment at the end).
    """
    pts = np.asarray(path_xy, float).reshape(-1, 2)
    if len(pts) > 1:  # (called per candidate per decision: plain concatenate, no np.r_)
        keep = np.concatenate(([True], np.any(np.diff(pts, axis=0) != 0, axis=1)))
        pts = pts[keep]
    if len(pts) < 2:
        if include_start and len(pts) == 1:
            return np.array([[pts[0, 0], pts[0, 1], 0.0]]), np.zeros(1)
        return np.zeros((0, 3)), np.zeros(0)
    direction = np.diff(pts, axis=0)
    length = np.linalg.norm(direction, axis=1)
    vertex_s = np.concatenate(([0.0], np.cumsum(length)))  # cumulative_length(pts)
    total = vertex_s[-1]
    s = keyframe_spacing * np.arange(1, int(np.floor(total / keyframe_spacing)) + 1)
    if len(s) == 0 or not _isclose(s[-1], total):
        s = np.append(s, total)
    if include_start:
        s = np.concatenate(([0.0], s))
    seg = np.minimum(np.maximum(np.searchsorted(vertex_s, s, side="right") - 1, 0), len(pts) - 2)
    unit = direction / length[:, None]
    xy = pts[seg] + (s - vertex_s[seg])[:, None] * unit[seg]
    yaw = np.arctan2(unit[seg, 1], unit[seg, 0])
    return np.column_stack([xy, yaw]), s


def sample_paths(paths_xy: Sequence[np.ndarray], keyframe_spacing: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`sample_path` of every polyline of ``paths_xy`` (a decision's candidates: ~25
    paths, each call ~50 µs of numpy overhead), all at once: the same operations on every
    element, so the same values bit for bit (each path's arc lengths by its own running
    sum, a row of one padded ``cumsum``; its segment per sample by counting the path's
    vertices up to it, which is ``searchsorted(..., side="right")``)."""
    pts = [np.asarray(p, float).reshape(-1, 2) for p in paths_xy]
    if not pts:
        return []
    owner = np.repeat(np.arange(len(pts)), [len(p) for p in pts])
    xy = np.concatenate(pts)
    keep = np.ones(len(xy), dtype=bool)  # each path's first point, then the points that move
    keep[1:] = (owner[1:] != owner[:-1]) | np.any(xy[1:] != xy[:-1], axis=1)
    xy, owner = xy[keep], owner[keep]
    counts = np.bincount(owner, minlength=len(pts))
    first = np.cumsum(counts) - counts
    same = owner[1:] == owner[:-1]  # consecutive points of one path: a segment
    seg_owner = owner[1:][same]
    direction = (xy[1:] - xy[:-1])[same]
    length = np.linalg.norm(direction, axis=1)
    segments = np.maximum(counts - 1, 0)  # a path of k points has k - 1
    seg_first = np.cumsum(segments) - segments
    seg_rank = np.arange(len(length)) - seg_first[seg_owner]
    vertex_s = np.full((len(pts), max(int(counts.max()), 1)), np.inf)  # row p: path p's arc lengths
    running = np.zeros((len(pts), max(int(counts.max()) - 1, 1)))
    running[seg_owner, seg_rank] = length
    vertex_s[:, 0] = 0.0
    vertex_s[:, 1:] = np.cumsum(running, axis=1)[:, : vertex_s.shape[1] - 1]
    vertex_s[np.arange(vertex_s.shape[1])[None, :] >= counts[:, None]] = np.inf
    sampled = counts >= 2
    total = np.where(sampled, vertex_s[np.arange(len(pts)), np.maximum(counts - 1, 0)], 0.0)
    steps = np.where(sampled, np.floor(total / keyframe_spacing), 0).astype(np.int64)
    last = keyframe_spacing * steps.astype(float)
    end = sampled & ((steps == 0) | ~(np.abs(last - total) <= 1e-8 + 1e-5 * np.abs(total)))  # as _isclose
    per_path = steps + end
    s_owner = np.repeat(np.arange(len(pts)), per_path)
    s_rank = np.arange(len(s_owner)) - np.repeat(np.cumsum(per_path) - per_path, per_path)
    s = keyframe_spacing * (s_rank + 1).astype(float)
    at_end = s_rank == steps[s_owner]  # the appended path end
    s[at_end] = total[s_owner[at_end]]
    below = np.sum(vertex_s[s_owner] <= s[:, None], axis=1)  # searchsorted(vertex_s, s, side="right")
    seg = np.minimum(np.maximum(below - 1, 0), counts[s_owner] - 2)
    seg_index = seg_first[s_owner] + seg
    unit = direction / length[:, None]
    start = xy[first[s_owner] + seg]
    sample_xy = start + (s - vertex_s[s_owner, seg])[:, None] * unit[seg_index]
    yaw = np.arctan2(unit[seg_index, 1], unit[seg_index, 0])
    poses = np.column_stack([sample_xy, yaw])
    bounds = np.cumsum(per_path)[:-1]
    return list(zip(np.split(poses, bounds), np.split(s, bounds)))


def _isclose(a: float, b: float) -> bool:
    """``np.isclose(a, b)`` (default tolerances) for two finite scalars, without its overhead."""
    return bool(abs(a - b) <= 1e-8 + 1e-5 * abs(b))


def sample_path_poses(
    path_xy: np.ndarray, keyframe_spacing: float, include_start: bool = False
) -> np.ndarray:
    """Poses ``(P, 3)`` of :func:`sample_path` (without the arc lengths)."""
    return sample_path(path_xy, keyframe_spacing, include_start)[0]


def predict_revisits(
    path_xy: np.ndarray,
    keyframe_xy: np.ndarray,
    keyframe_travel: np.ndarray,
    current_travel: float,
    blocked: np.ndarray,
    grid: GridSpec,
    config: RevisitConfig,
    path_travel: np.ndarray | None = None,
) -> list[Revisit]:
    """Loop closures a path would produce, one :class:`Revisit` per revisited place.

    ``path_xy (P, 2)``: predicted poses; ``path_travel (P,)``: travel from the current pose
    to each of them (default: arc length along ``path_xy`` from its first point).
    ``keyframe_xy (K, 2)``/``keyframe_travel (K,)``: keyframe estimates and the cumulative
    travel at each; ``current_travel``: the cumulative travel now. ``blocked`` (on ``grid``)
    marks known-occupied cells, which break line of sight.

    A pair (path pose, keyframe) qualifies when it is within ``r_lc``, its travel gap
    ``current_travel + path_travel - keyframe_travel`` exceeds ``min_travel_gap`` and the
    segment between them is clear. Each keyframe keeps its closest qualifying pose; then
    keyframes whose indices differ by at most ``merge_keyframe_gap`` form one revisit,
    represented by its closest pair. Sorted by keyframe index.
    """
    path_xy = np.asarray(path_xy, float).reshape(-1, 2)
    if path_travel is None:
        path_travel = cumulative_length(path_xy)
    return predict_revisits_of_paths([path_xy], keyframe_xy, keyframe_travel, current_travel, blocked, grid,
                                     config, [path_travel])[0]


def predict_revisits_of_paths(paths_xy: Sequence[np.ndarray], keyframe_xy: np.ndarray, keyframe_travel: np.ndarray,
                              current_travel: float, blocked: np.ndarray, grid: GridSpec, config: RevisitConfig,
                              paths_travel: Sequence[np.ndarray]) -> list[list[Revisit]]:
    """:func:`predict_revisits` of several paths at once (a decision's candidates): one
    KD-tree query for all their poses and one line-of-sight test per distinct segment --
    the candidates' paths leave from the same robot pose along one Dijkstra tree, so
    they share poses, and pairs that qualify for several candidates are tested once. Each
    path's answer is what :func:`predict_revisits` gives it alone (each pair's tests are
    its own)."""
    paths_xy = [np.asarray(p, float).reshape(-1, 2) for p in paths_xy]
    keyframe_xy = np.asarray(keyframe_xy, float).reshape(-1, 2)
    counts = np.array([len(p) for p in paths_xy], dtype=np.int64)
    if counts.sum() == 0 or len(keyframe_xy) == 0:
        return [[] for _ in paths_xy]
    all_xy = np.concatenate(paths_xy)
    all_travel = np.concatenate([np.asarray(t, float).reshape(-1) for t in paths_travel])
    pose_idx, kf_idx, dist = _pairs_within(all_xy, keyframe_xy, config.r_lc)
    gap = current_travel + all_travel[pose_idx] - np.asarray(keyframe_travel)[kf_idx]
    keep = gap > config.min_travel_gap
    pose_idx, kf_idx, dist = pose_idx[keep], kf_idx[keep], dist[keep]
    visible = distinct_line_of_sight(all_xy[pose_idx], distinct_ids(all_xy)[pose_idx], kf_idx, keyframe_xy,
                                     blocked, grid, config.los_step_fraction)
    pose_idx, kf_idx, dist = pose_idx[visible], kf_idx[visible], dist[visible]
    owner = np.repeat(np.arange(len(paths_xy)), counts)[pose_idx]
    path_idx = pose_idx - (np.cumsum(counts) - counts)[owner]
    found: list[list[Revisit]] = [[] for _ in paths_xy]
    closest = _closest_per_place(owner, path_idx, kf_idx, dist, len(keyframe_xy), config.merge_keyframe_gap)
    for path, index, keyframe, distance in zip(*closest):
        found[path].append(Revisit(int(index), int(keyframe), float(distance)))
    return found


def _closest_per_place(owner: np.ndarray, path_idx: np.ndarray, kf_idx: np.ndarray, dist: np.ndarray,
                       n_keyframes: int, max_gap: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per path (``owner``): each keyframe's closest pair (ties: the earliest path pose),
    then runs of keyframes with index gaps ``<= max_gap`` merged into their closest pair
    (ties: the lowest keyframe). Sorted by path, then keyframe. One sort of an integer key
    and segment minima (a decision holds ~10^5 pairs; a 4-key lexsort took ~10 ms)."""
    if len(owner) == 0:
        return owner, path_idx, kf_idx, dist
    key = owner * n_keyframes + kf_idx
    order = stable_argsort(key)
    key, path_idx, dist = key[order], path_idx[order], dist[order]
    first = _group_starts(key != np.roll(key, 1))
    closest = np.minimum.reduceat(dist, first)
    tied = dist == np.repeat(closest, np.diff(np.append(first, len(key))))
    earliest = np.minimum.reduceat(np.where(tied, path_idx, np.iinfo(np.int64).max), first)
    owner, kf_idx, path_idx, dist = key[first] // n_keyframes, key[first] % n_keyframes, earliest, closest
    new_run = np.ones(len(owner), dtype=bool)
    new_run[1:] = (owner[1:] != owner[:-1]) | (kf_idx[1:] - kf_idx[:-1] > max_gap)
    runs = _group_starts(new_run)
    closest = np.minimum.reduceat(dist, runs)
    tied = dist == np.repeat(closest, np.diff(np.append(runs, len(dist))))
    best = np.minimum.reduceat(np.where(tied, np.arange(len(dist)), len(dist)), runs)
    return owner[best], path_idx[best], kf_idx[best], dist[best]


def _group_starts(new: np.ndarray) -> np.ndarray:
    """Indices where a group starts (``new``: the row differs from the previous; row 0 always)."""
    new = new.copy()
    new[0] = True
    return np.flatnonzero(new)


def distinct_ids(xy: np.ndarray) -> np.ndarray:
    """``(N,)`` ids of the rows of ``xy (N, 2)``: equal rows, equal ids."""
    order = np.lexsort((xy[:, 1], xy[:, 0]))
    ranked = xy[order]
    new = np.ones(len(xy), dtype=bool)
    new[1:] = np.any(ranked[1:] != ranked[:-1], axis=1)
    ids = np.empty(len(xy), dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids


def predict_revisits_reference(path_xy: np.ndarray, keyframe_xy: np.ndarray, keyframe_travel: np.ndarray,
                               current_travel: float, blocked: np.ndarray, grid: GridSpec, config: RevisitConfig,
                               path_travel: np.ndarray | None = None) -> list[Revisit]:
    """:func:`predict_revisits` as first written, one path alone (the reference the
    paths-at-once version must equal; tests and ``LearnedPolicy(reference=True)``)."""
    path_xy = np.asarray(path_xy, float).reshape(-1, 2)
    keyframe_xy = np.asarray(keyframe_xy, float).reshape(-1, 2)
    if len(path_xy) == 0 or len(keyframe_xy) == 0:
        return []
    if path_travel is None:
        path_travel = cumulative_length(path_xy)
    path_idx, kf_idx, dist = _pairs_within(path_xy, keyframe_xy, config.r_lc)
    gap = current_travel + np.asarray(path_travel)[path_idx] - np.asarray(keyframe_travel)[kf_idx]
    keep = gap > config.min_travel_gap
    path_idx, kf_idx, dist = path_idx[keep], kf_idx[keep], dist[keep]
    visible = line_of_sight(
        path_xy[path_idx], keyframe_xy[kf_idx], blocked, grid, config.los_step_fraction
    )
    path_idx, kf_idx, dist = path_idx[visible], kf_idx[visible], dist[visible]
    path_idx, kf_idx, dist = _closest_per_keyframe(path_idx, kf_idx, dist)
    return _merge_runs(path_idx, kf_idx, dist, config.merge_keyframe_gap)


def distinct_line_of_sight(start_xy: np.ndarray, start_id: np.ndarray, kf_idx: np.ndarray, keyframe_xy: np.ndarray,
                           blocked: np.ndarray, grid: GridSpec, step_fraction: float) -> np.ndarray:
    """:func:`line_of_sight` from each ``start_xy`` to keyframe ``kf_idx``, each distinct
    (start, keyframe) pair tested once (a segment's test depends on its ends only; the
    same answers by :func:`~explore_rl.mapping.visibility.line_of_sight_by_length`);
    ``start_id``: equal for equal starts (:func:`distinct_ids`)."""
    if len(start_xy) == 0:
        return np.ones(0, dtype=bool)
    _, first, inverse = unique_first_inverse(start_id * len(keyframe_xy) + kf_idx)
    clear = line_of_sight_by_length(start_xy[first], keyframe_xy[kf_idx[first]], blocked, grid, step_fraction)
    return clear[inverse.reshape(-1)]


def _pairs_within(
    a_xy: np.ndarray, b_xy: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """All ``(i, j, distance)`` with ``|a_i - b_j| <= radius`` (KD-trees)."""
    pairs = cKDTree(a_xy).sparse_distance_matrix(cKDTree(b_xy), radius, output_type="ndarray")
    return pairs["i"].astype(np.int64), pairs["j"].astype(np.int64), pairs["v"].astype(float)


def _closest_per_keyframe(
    path_idx: np.ndarray, kf_idx: np.ndarray, dist: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each keyframe, its closest pair (ties: the earliest path pose); by keyframe."""
    order = np.lexsort((path_idx, dist, kf_idx))
    path_idx, kf_idx, dist = path_idx[order], kf_idx[order], dist[order]
    first = np.r_[len(kf_idx) > 0, kf_idx[1:] != kf_idx[:-1]][: len(kf_idx)]
    return path_idx[first], kf_idx[first], dist[first]


def _merge_runs(
    path_idx: np.ndarray, kf_idx: np.ndarray, dist: np.ndarray, max_gap: int
) -> list[Revisit]:
    """Group keyframes (sorted) whose index gaps are ``<= max_gap``; keep each group's
    closest pair."""
    if len(kf_idx) == 0:
        return []
    breaks = np.flatnonzero(np.diff(kf_idx) > max_gap) + 1
    revisits = []
    for group in np.split(np.arange(len(kf_idx)), breaks):
        best = group[np.argmin(dist[group])]
        revisits.append(Revisit(int(path_idx[best]), int(kf_idx[best]), float(dist[best])))
    return revisits
