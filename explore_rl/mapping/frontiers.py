"""Frontiers: known-free cells bordering unknown space, clustered, each with a waypoint."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from explore_rl.grid import GridSpec
from explore_rl.mapping.config import FrontierConfig


@dataclass
class Frontier:
    """One frontier cluster and the cell the robot should drive to in order to explore it."""

    cells: np.ndarray  # (K, 2) int [iy, ix], row-major order
    waypoint_cell: np.ndarray  # (2,) int [iy, ix]
    waypoint_xy: np.ndarray  # (2,) world xy of the waypoint cell centre
    size: int  # K


def frontier_mask(free: np.ndarray, unknown: np.ndarray, neighbourhood: int = 4) -> np.ndarray:
    """Free cells with an unknown 4- or 8-neighbour."""
    if neighbourhood not in (4, 8):
        raise ValueError(f"neighbourhood must be 4 or 8, got {neighbourhood}")
    structure = ndimage.generate_binary_structure(2, 1 if neighbourhood == 4 else 2)
    touches_unknown = ndimage.binary_dilation(np.asarray(unknown, dtype=bool), structure=structure)
    return np.asarray(free, dtype=bool) & touches_unknown


def find_frontiers(
    occupancy_free: np.ndarray,
    unknown: np.ndarray,
    grid: GridSpec,
    config: FrontierConfig | None = None,
    traversable: np.ndarray | None = None,
    reference: bool = False,
) -> list[Frontier]:
    """Frontier clusters (8-connected) of at least ``min_cluster_cells``, sorted by waypoint cell.

    The waypoint is the cluster cell closest to the cluster centroid — among traversable
    cells when ``traversable`` is given. A cluster without a traversable cell takes the
    traversable cell within ``waypoint_search_radius`` closest to its centroid, or is
    dropped if there is none. The clusters are found over the window of the free cells
    (``reference``: over the whole grid, as first written; the same frontiers).
    """
    config = config or FrontierConfig()
    if reference:
        clusters = _clusters(frontier_mask(occupancy_free, unknown, config.neighbourhood))
    else:
        clusters = _frontier_clusters(occupancy_free, unknown, config.neighbourhood)
    frontiers = []
    for cells in _split_long_clusters(clusters, grid, config.max_cluster_extent):
        if len(cells) < config.min_cluster_cells:
            continue
        waypoint = _waypoint(cells, traversable, grid, config)
        if waypoint is None:
            continue
        frontiers.append(Frontier(cells, waypoint, grid.cell_to_world(waypoint), len(cells)))
    frontiers.sort(key=lambda f: (int(f.waypoint_cell[0]), int(f.waypoint_cell[1])))
    return frontiers


def _frontier_clusters(free: np.ndarray, unknown: np.ndarray, neighbourhood: int) -> list[np.ndarray]:
    """:func:`_clusters` of :func:`frontier_mask`, computed over the window of the free cells
    widened by one cell (a frontier cell is free, and its neighbours lie in that window):
    the same clusters, cells and order as over the whole grid (tests/mapping/test_frontiers.py)."""
    free = np.asarray(free, dtype=bool)
    rows, cols = np.flatnonzero(free.any(axis=1)), np.flatnonzero(free.any(axis=0))
    if not len(rows):
        return []
    low = np.maximum([rows[0] - 1, cols[0] - 1], 0)
    high = np.minimum([rows[-1] + 2, cols[-1] + 2], free.shape)
    window = tuple(slice(lo, hi) for lo, hi in zip(low, high))
    return [cells + low for cells in _clusters(frontier_mask(free[window], np.asarray(unknown)[window],
                                                              neighbourhood))]


def _clusters(mask: np.ndarray) -> list[np.ndarray]:
    """8-connected components of ``mask``, each as ``(K, 2)`` row-major cells."""
    labels, count = ndimage.label(mask, structure=np.ones((3, 3), dtype=bool))
    cells = np.argwhere(labels > 0)  # row-major
    ids = labels[cells[:, 0], cells[:, 1]]
    order = np.argsort(ids, kind="stable")  # keeps row-major order inside each cluster
    bounds = np.searchsorted(ids[order], np.arange(1, count + 2))
    return [cells[order[bounds[i] : bounds[i + 1]]] for i in range(count)]


def _split_long_clusters(
    clusters: list[np.ndarray], grid: GridSpec, max_extent: float
) -> list[np.ndarray]:
    """Cut clusters into tiles of ``max_extent`` metres, so a long frontier (the rim of
    open space) offers several waypoints instead of one near its centroid."""
    tile = max(1, int(round(max_extent / grid.resolution)))
    pieces = []
    for cells in clusters:
        if np.ptp(cells, axis=0).max() < tile:
            pieces.append(cells)
            continue
        tiles = cells // tile  # non-negative: one key per tile, in the rows' lexicographic order
        _, ids = np.unique(tiles[:, 0] * (tiles[:, 1].max() + 1) + tiles[:, 1], return_inverse=True)
        pieces += [cells[ids.reshape(-1) == i] for i in range(ids.max() + 1)]
    return pieces


def _closest_to(candidates: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The candidate cell nearest ``point`` (ties: first in row-major order)."""
    return candidates[np.argmin(((candidates - point) ** 2).sum(axis=1))]


def _waypoint(
    cells: np.ndarray, traversable: np.ndarray | None, grid: GridSpec, config: FrontierConfig
) -> np.ndarray | None:
    centroid = cells.mean(axis=0)
    if traversable is None:
        return _closest_to(cells, centroid)
    inside = cells[traversable[cells[:, 0], cells[:, 1]]]
    if len(inside):
        return _closest_to(inside, centroid)
    nearby = _traversable_near(cells, traversable, grid, config.waypoint_search_radius)
    return _closest_to(nearby, centroid) if len(nearby) else None


def _traversable_near(
    cells: np.ndarray, traversable: np.ndarray, grid: GridSpec, radius: float
) -> np.ndarray:
    """Traversable cells within ``radius`` metres of any of ``cells`` (searched in a window)."""
    pad = int(np.ceil(radius / grid.resolution))
    lo = np.maximum(cells.min(axis=0) - pad, 0)
    hi = np.minimum(cells.max(axis=0) + pad + 1, grid.shape)
    window = np.ones(tuple(hi - lo), dtype=bool)
    window[cells[:, 0] - lo[0], cells[:, 1] - lo[1]] = False
    distance = ndimage.distance_transform_edt(window) * grid.resolution
    near = (distance <= radius) & traversable[lo[0] : hi[0], lo[1] : hi[1]]
    return np.argwhere(near) + lo
