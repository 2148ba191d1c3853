"""Grid line of sight: whether straight segments cross blocked cells of a 2D grid.

Holds the line-of-sight test shared by SLAM loop-closure candidate selection
(:mod:`explore_rl.slam.loop_closure`) and the planner (:mod:`explore_rl.planning.virtual_map`,
:mod:`explore_rl.planning.revisits`).
"""

from __future__ import annotations

import numpy as np

from explore_rl.grid import GridSpec
from explore_rl.mapping import compiled as _compiled
from explore_rl.sorting import stable_argsort


def line_of_sight(
    start_xy: np.ndarray,
    end_xy: np.ndarray,
    blocked: np.ndarray,
    grid: GridSpec,
    step_fraction: float,
    end_box: float = 0.0,
    max_batch_samples: int = 2_000_000,
) -> np.ndarray:
    """Whether each segment ``start_xy[i] -> end_xy[i]`` (``(N, 2)``) is free of blocked cells.

    Points are sampled every ``step_fraction * grid.resolution`` from the start (excluded)
    towards the end and looked up in ``blocked`` (``grid.shape``; cells outside the grid do
    not block). Samples inside the axis-aligned square of side ``end_box`` centred on the
    end point are ignored (a virtual landmark's own cell may be a wall: seeing the wall is
    seeing the landmark); with ``end_box = 0`` the samples stop at the end point.
    Vectorised, in batches of at most ``max_batch_samples`` samples.
    """
    start_xy, end_xy, blocked = _segment_inputs(start_xy, end_xy, blocked, grid)
    clear = np.ones(len(start_xy), dtype=bool)
    if len(start_xy) == 0:
        return clear
    delta = end_xy - start_xy
    length = np.linalg.norm(delta, axis=1)
    unit = delta / np.where(length > 0, length, 1.0)[:, None]
    stop = _box_entry_distance(length, unit, 0.5 * end_box)
    step = step_fraction * grid.resolution
    n_samples = max(int(np.ceil(np.max(stop) / step)), 1)
    padded = np.pad(blocked, 1).ravel()
    batch = max(1, max_batch_samples // n_samples)
    for lo in range(0, len(start_xy), batch):
        sl = slice(lo, lo + batch)
        clear[sl] = _segments_clear(start_xy[sl], unit[sl], stop[sl], padded, grid, step, n_samples)
    return clear


def _segment_inputs(
    start_xy: np.ndarray, end_xy: np.ndarray, blocked: np.ndarray, grid: GridSpec
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The line-of-sight inputs as ``(N, 2)`` float arrays and a boolean mask of the grid's shape."""
    blocked = np.asarray(blocked, dtype=bool)
    if blocked.shape != grid.shape:
        raise ValueError(f"blocked mask {blocked.shape} != grid shape {grid.shape}")
    return np.asarray(start_xy, float).reshape(-1, 2), np.asarray(end_xy, float).reshape(-1, 2), blocked


def _box_entry_distance(length: np.ndarray, unit: np.ndarray, half: float) -> np.ndarray:
    """Distance along a ray aimed at a box centre (``length`` away) to the box's boundary."""
    if half <= 0:
        return length
    steepest = np.maximum(np.max(np.abs(unit), axis=1), np.finfo(float).tiny)
    return np.maximum(length - half / steepest, 0.0)


def _segments_clear(
    start_xy: np.ndarray,
    unit: np.ndarray,
    stop: np.ndarray,
    padded_blocked: np.ndarray,
    grid: GridSpec,
    step: float,
    n_samples: int,
) -> np.ndarray:
    """One batch of :func:`line_of_sight`; ``padded_blocked`` has a free 1-cell border."""
    t = step * np.arange(1, n_samples + 1)
    # Sample positions in cell units, shifted by the 1-cell border: any point outside the
    # grid lands on the border (truncation equals floor for the non-negative values kept).
    col = (start_xy[:, 0:1] - grid.origin[0]) / grid.resolution + 1.0
    row = (start_xy[:, 1:2] - grid.origin[1]) / grid.resolution + 1.0
    ix = np.clip((col + (t / grid.resolution) * unit[:, 0:1]).astype(np.int64), 0, grid.nx + 1)
    iy = np.clip((row + (t / grid.resolution) * unit[:, 1:2]).astype(np.int64), 0, grid.ny + 1)
    hit = padded_blocked[iy * (grid.nx + 2) + ix]
    hit &= t[None, :] < stop[:, None]
    return ~np.any(hit, axis=1)


LENGTH_GROUPS = 8  # compiled=False: segments sorted by length into this many groups of equal count


def line_of_sight_by_length(
    start_xy: np.ndarray,
    end_xy: np.ndarray,
    blocked: np.ndarray,
    grid: GridSpec,
    step_fraction: float,
    end_box: float = 0.0,
    max_batch_samples: int = 2_000_000,
    compiled: bool = True,
) -> np.ndarray:
    """:func:`line_of_sight`, the same samples and answers, cheaper for many segments of
    mixed lengths on a mostly free grid: a segment whose bounding box (one cell wider
    on each side than any sample can reach) holds no blocked cell is clear without
    sampling (a summed-area table of the blocked cells); the others are walked one at a
    time by a compiled loop (:func:`~explore_rl.mapping.compiled.segments_clear`), each
    only as far as its own stop or its first blocked sample. ``compiled=False`` (the
    numpy baseline of that loop): they are sorted by length into ``LENGTH_GROUPS`` groups,
    each sampled as far as its longest needs (``max_batch_samples`` samples a batch), and
    a segment is blocked when its first blocked sample lies before its stop."""
    start_xy, end_xy, blocked = _segment_inputs(start_xy, end_xy, blocked, grid)
    clear = np.ones(len(start_xy), dtype=bool)
    if len(start_xy) == 0:
        return clear
    delta = end_xy - start_xy
    dx, dy = delta[:, 0], delta[:, 1]
    length = np.sqrt(dx * dx + dy * dy)  # np.linalg.norm's sum of squares, without its reduction
    unit = delta / np.where(length > 0, length, 1.0)[:, None]
    stop = length
    if end_box > 0:  # _box_entry_distance, the steeper component without a reduction
        steepest = np.maximum(np.maximum(np.abs(unit[:, 0]), np.abs(unit[:, 1])), np.finfo(float).tiny)
        stop = np.maximum(length - 0.5 * end_box / steepest, 0.0)
    step = step_fraction * grid.resolution
    samples = np.maximum(np.ceil(stop / step).astype(np.int64), 1)  # every sample before the stop
    padded = np.pad(blocked, 1)
    maybe = np.flatnonzero(_box_holds_blocked(start_xy, end_xy, padded, grid))
    if compiled:
        clear[maybe] = _compiled.segments_clear(start_xy[maybe], unit[maybe], stop[maybe], samples[maybe],
                                                padded.ravel(), float(grid.origin[0]), float(grid.origin[1]),
                                                float(grid.resolution), int(grid.nx), int(grid.ny), step)
        return clear
    order = maybe[stable_argsort(samples[maybe])]
    padded = padded.ravel()
    for group in np.array_split(order, min(LENGTH_GROUPS, len(order))) if len(order) else []:
        n_samples = int(samples[group[-1]])
        batch = max(1, max_batch_samples // n_samples)
        for lo in range(0, len(group), batch):
            rows = group[lo: lo + batch]
            clear[rows] = _first_hit_clear(start_xy[rows], unit[rows], stop[rows], padded, grid, step, n_samples)
    return clear


def _box_holds_blocked(start_xy: np.ndarray, end_xy: np.ndarray, padded_blocked: np.ndarray,
                       grid: GridSpec) -> np.ndarray:
    """Whether the cells (of the grid with its free 1-cell border) that a segment's samples
    can fall in, widened by one cell on each side against round-off, hold a blocked cell."""
    table = np.zeros((padded_blocked.shape[0] + 1, padded_blocked.shape[1] + 1), dtype=np.int32)
    table[1:, 1:] = padded_blocked.cumsum(axis=0, dtype=np.int32).cumsum(axis=1, dtype=np.int32)  # table[i, j]: blocked cells in [:i, :j]
    origin = np.asarray(grid.origin[:2], float)
    low = np.floor((np.minimum(start_xy, end_xy) - origin) / grid.resolution).astype(np.int64)  # +1 border -1 margin
    high = np.floor((np.maximum(start_xy, end_xy) - origin) / grid.resolution).astype(np.int64) + 2
    limit = np.array([grid.nx + 1, grid.ny + 1])
    low, high = np.clip(low, 0, limit), np.clip(high, 0, limit) + 1
    count = (table[high[:, 1], high[:, 0]] - table[low[:, 1], high[:, 0]] - table[high[:, 1], low[:, 0]]
             + table[low[:, 1], low[:, 0]])
    return count > 0


def _first_hit_clear(start_xy: np.ndarray, unit: np.ndarray, stop: np.ndarray, padded_blocked: np.ndarray,
                     grid: GridSpec, step: float, n_samples: int) -> np.ndarray:
    """:func:`_segments_clear` (same sample positions and cells): clipping the sample
    coordinates before truncating them gives the same cells, and a segment is blocked
    iff its first blocked sample lies before its stop."""
    t = step * np.arange(1, n_samples + 1)
    col = (start_xy[:, 0:1] - grid.origin[0]) / grid.resolution + 1.0
    row = (start_xy[:, 1:2] - grid.origin[1]) / grid.resolution + 1.0
    x = (t / grid.resolution) * unit[:, 0:1]
    x += col
    np.clip(x, 0, grid.nx + 1, out=x)
    y = (t / grid.resolution) * unit[:, 1:2]
    y += row
    np.clip(y, 0, grid.ny + 1, out=y)
    cell = y.astype(np.int32)
    cell *= grid.nx + 2
    cell += x.astype(np.int32)
    hit = padded_blocked[cell]
    first = np.argmax(hit, axis=1)
    return ~(hit[np.arange(len(first)), first] & (t[first] < stop))
