"""Segments for segment-matching loop closures (after SegMatch, Dube et al. 2017).

A rolling submap (the last few keyframe clouds, placed at their current estimates in
the frame of the newest one) is reduced to its *structure* (points above the floor),
clustered by Euclidean distance into segments, and each segment that looks like an
object -- not a wall: small horizontal extent, enough points -- is described by its
shape. Two submaps are related by matching descriptors (nearest neighbour with a ratio
test) and verifying a 2D rigid transform between matched centroids with RANSAC.

Everything here is plain numpy/scipy and planar: the pose graph is planar, so the
transform between submaps is ``[x, y, yaw]``. Points are in a base frame (z = height
above the floor).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from kiss_icp.voxelization import voxel_down_sample
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from explore_rl.geometry import rotation_2d

# Descriptor components (all metres): horizontal extents along the two principal axes
# (2 std each), top of the segment, vertical extent, horizontal radius (mean distance
# of the points from the vertical axis through the centroid).
DESCRIPTOR_NAMES = ("major", "minor", "top", "height", "radius")


@dataclass
class Segment:
    """One object-like cluster of a submap."""

    centroid: np.ndarray  # (2,) horizontal centroid, submap frame
    descriptor: np.ndarray  # (len(DESCRIPTOR_NAMES),)
    points: np.ndarray  # (M, 3) submap frame


def cluster(points: np.ndarray, distance: float, min_points: int) -> list[np.ndarray]:
    """Index arrays of the connected components of ``points`` (links shorter than
    ``distance``) with at least ``min_points`` points, largest first."""
    if len(points) < max(min_points, 1):
        return []
    pairs = cKDTree(points).query_pairs(distance, output_type="ndarray")
    n = len(points)
    graph = coo_matrix((np.ones(len(pairs), dtype=bool), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    counts = np.bincount(labels)
    keep = np.flatnonzero(counts >= min_points)
    keep = keep[np.argsort(-counts[keep], kind="stable")]
    order = np.argsort(labels, kind="stable")
    bounds = np.r_[0, np.cumsum(counts)]
    return [order[bounds[k]:bounds[k + 1]] for k in keep]


def describe(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal centroid ``(2,)`` and shape descriptor of a segment's points."""
    xy = points[:, :2]
    centroid = xy.mean(axis=0)
    centred = xy - centroid
    values = np.linalg.eigvalsh(centred.T @ centred / len(points))
    major, minor = 2.0 * np.sqrt(np.maximum(values[::-1], 0.0))
    top = float(points[:, 2].max())
    height = float(np.ptp(points[:, 2]))
    radius = float(np.linalg.norm(centred, axis=1).mean())
    return centroid, np.array([major, minor, top, height, radius])


def segment_submap(
    points: np.ndarray,
    ground_height: float,
    max_height: float,
    voxel: float,
    cluster_distance: float,
    min_points: int,
    max_extent: float,
    min_extent: float,
) -> list[Segment]:
    """Object-like segments of a submap (base-frame points ``(N, 3)``, z above the floor).

    Points between ``ground_height`` and ``max_height`` are thinned to ``voxel`` and
    clustered; clusters with at least ``min_points`` points whose horizontal bounding
    extent is within ``[min_extent, max_extent]`` are kept (walls are longer)."""
    points = np.asarray(points, float).reshape(-1, 3)
    points = points[np.all(np.isfinite(points), axis=1)]
    points = points[(points[:, 2] > ground_height) & (points[:, 2] < max_height)]
    if len(points) == 0:
        return []
    points = voxel_down_sample(points, voxel)
    segments = []
    for idx in cluster(points, cluster_distance, min_points):
        part = points[idx]
        centroid, descriptor = describe(part)
        # Extent along the principal axes of the horizontal footprint.
        centred = part[:, :2] - centroid
        _, axes = np.linalg.eigh(centred.T @ centred)
        extent = np.ptp(centred @ axes, axis=0)
        if extent.max() > max_extent or extent.max() < min_extent:
            continue
        segments.append(Segment(centroid, descriptor, part))
    return segments


def match_descriptors(
    query: list[Segment], reference: list[Segment], scale: np.ndarray, ratio: float,
    max_distance: float,
) -> list[tuple[int, int]]:
    """``(query index, reference index)`` pairs: nearest reference descriptor (distances
    divided by ``scale``) within ``max_distance`` and closer than ``ratio`` times the
    second nearest (if there is one)."""
    if not query or not reference:
        return []
    a = np.array([s.descriptor for s in query]) / scale
    b = np.array([s.descriptor for s in reference]) / scale
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    order = np.argsort(d, axis=1)
    matches = []
    for q in range(len(query)):
        best = order[q, 0]
        if d[q, best] > max_distance:
            continue
        if len(reference) > 1 and d[q, best] > ratio * d[q, order[q, 1]]:
            continue
        matches.append((q, int(best)))
    return matches


def rigid_2d(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Least-squares ``[x, y, yaw]`` with ``R(yaw) source + [x, y] ~ target`` (``(K, 2)``)."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    a, b = source - cs, target - ct
    yaw = np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b))
    t = ct - rotation_2d(yaw) @ cs
    return np.array([t[0], t[1], yaw])


def apply_2d(transform: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ rotation_2d(transform[2]).T + transform[:2]


def ransac_rigid_2d(
    source: np.ndarray, target: np.ndarray, inlier_distance: float, iterations: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray | None, np.ndarray]:
    """RANSAC over matched centroid pairs ``(K, 2)``: the 2D rigid transform with most
    inliers (refit on them) and the inlier mask; ``(None, all False)`` below 2 pairs.

    Minimal samples are two pairs whose centroid spacings agree within
    ``inlier_distance`` (a rigid transform preserves distances)."""
    k = len(source)
    best_mask = np.zeros(k, dtype=bool)
    if k < 2:
        return None, best_mask
    pairs = np.array([(i, j) for i in range(k) for j in range(i + 1, k)])
    if len(pairs) > iterations:
        pairs = pairs[rng.choice(len(pairs), iterations, replace=False)]
    best = None
    for i, j in pairs:
        ds = np.linalg.norm(source[i] - source[j])
        dt = np.linalg.norm(target[i] - target[j])
        if abs(ds - dt) > inlier_distance or ds < inlier_distance:
            continue
        transform = rigid_2d(source[[i, j]], target[[i, j]])
        residual = np.linalg.norm(apply_2d(transform, source) - target, axis=1)
        mask = residual < inlier_distance
        if mask.sum() > best_mask.sum():
            best, best_mask = transform, mask
    if best is None:
        return None, best_mask
    refit = rigid_2d(source[best_mask], target[best_mask])
    mask = np.linalg.norm(apply_2d(refit, source) - target, axis=1) < inlier_distance
    return (refit, mask) if mask.sum() >= best_mask.sum() else (best, best_mask)
