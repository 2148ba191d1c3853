"""Compiled loops of the map updates (numba), beside the numpy code they stand for.

A keyframe's map update is a few hundred thousand tiny operations (beam samples, ray
returns, cell updates). numpy makes each a pass over a temporary array, and a keyframe
pays ~1.5 ms of such passes; as loops compiled by numba they cost a fraction of that.
Each kernel performs the same float operations as the numpy code it stands for (products,
sums, comparisons, ``floor``, min and max, in float32 where the grid is float32; ``cos``,
``sin`` and ``hypot`` stay in numpy and come in as arrays), so it gives the same cells and
values, and the tests compare the two on real scans (``tests/mapping/test_compiled.py``).

The numpy code stays as the reference (``mapping.updates=rebuild`` runs it); kernels are
compiled on first use and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

FREE, OCCUPIED = 1, 2  # cell labels of one scan in the tracer's scratch (occupied wins)


@numba.njit(cache=True)
def trace_beams(origin_x: float, origin_y: float, cos: np.ndarray, sin: np.ndarray,
                ranges: np.ndarray, hit: np.ndarray, step: float, n_samples: int,
                hit_nudge: float, nx: int, ny: int, marks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted flat indices of the cells beams see free and occupied (cell units): the
    loops of :meth:`~explore_rl.mapping.occupancy.OccupancyGrid.beam_cells_reference`.

    Each beam is sampled at ``k * step`` (``k < n_samples``) while below its range; a beam
    without a hit also frees its end cell, a hit beam occupies the cell ``hit_nudge``
    beyond its end, and an occupied cell is never free. ``marks`` (``nx * ny`` zeros) is
    scratch, zero again on return; only the square the beams can reach is read back.
    """
    for b in range(len(ranges)):
        r, c, s = ranges[b], cos[b], sin[b]
        for k in range(n_samples):
            t = k * step
            if not t < r:
                break
            _label(origin_x + c * t, origin_y + s * t, nx, ny, FREE, marks)
        if hit[b]:
            end = r + hit_nudge
            _label(origin_x + c * end, origin_y + s * end, nx, ny, OCCUPIED, marks)
        else:
            _label(origin_x + c * r, origin_y + s * r, nx, ny, FREE, marks)
    reach = np.abs(hit_nudge) + 1.0  # every labelled cell lies within the longest beam plus this
    if len(ranges):
        reach += ranges.max()
    x0, x1 = max(0, math.floor(origin_x - reach)), min(nx - 1, math.floor(origin_x + reach))
    y0, y1 = max(0, math.floor(origin_y - reach)), min(ny - 1, math.floor(origin_y + reach))
    return _collect(marks, nx, x0, x1, y0, y1)


@numba.njit(cache=True, inline="always")
def _label(cx: float, cy: float, nx: int, ny: int, label: int, marks: np.ndarray) -> None:
    """Raise the label of the in-bounds cell holding the point ``(cx, cy)`` to ``label``."""
    ix, iy = math.floor(cx), math.floor(cy)
    if 0 <= ix < nx and 0 <= iy < ny:
        flat = iy * nx + ix
        if marks[flat] < label:
            marks[flat] = label


@numba.njit(cache=True)
def _collect(marks: np.ndarray, nx: int, x0: int, x1: int, y0: int, y1: int) -> tuple[np.ndarray, np.ndarray]:
    """The free and occupied flat indices in the window, in increasing order, and the
    window's labels cleared."""
    n_free = n_occupied = 0
    for iy in range(y0, y1 + 1):
        for ix in range(x0, x1 + 1):
            label = marks[iy * nx + ix]
            n_free += label == FREE
            n_occupied += label == OCCUPIED
    free = np.empty(n_free, dtype=np.int64)
    occupied = np.empty(n_occupied, dtype=np.int64)
    n_free = n_occupied = 0
    for iy in range(y0, y1 + 1):
        for ix in range(x0, x1 + 1):
            flat = iy * nx + ix
            if marks[flat] == FREE:
                free[n_free] = flat
                n_free += 1
            elif marks[flat] == OCCUPIED:
                occupied[n_occupied] = flat
                n_occupied += 1
            marks[flat] = 0
    return free, occupied


@numba.njit(cache=True)
def step_log_odds(log_odds: np.ndarray, free: np.ndarray, occupied: np.ndarray, step_free: float,
                  step_occupied: float, low: float, high: float) -> None:
    """Add the free and occupied steps to the cells of one scan and clamp to ``[low, high]``,
    in the grid's float32 (the numpy code's ``clip(flat[cells] + step, low, high)``)."""
    _step_cells(log_odds, free, np.float32(step_free), np.float32(low), np.float32(high))
    _step_cells(log_odds, occupied, np.float32(step_occupied), np.float32(low), np.float32(high))


@numba.njit(cache=True, inline="always")
def _step_cells(log_odds: np.ndarray, cells: np.ndarray, step: np.float32, low: np.float32,
                high: np.float32) -> None:
    for cell in cells:
        log_odds[cell] = min(max(log_odds[cell] + step, low), high)


@numba.njit(cache=True)
def collapse_ray_grid(z_points: np.ndarray, horizontal_points: np.ndarray, hit_index: np.ndarray,
                      clearance: np.ndarray, channels: int, n_bins: int, sensor_height: float,
                      floor_max: float, obstacle_min: float, obstacle_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Per azimuth bin the nearest obstacle range (inf if none) and the farthest free
    evidence (at least 0) of a ``channels x n_bins`` ray grid: the reductions of
    :meth:`~explore_rl.mapping.occupancy.RayGridCollapse.__call__`.

    Ray ``hit_index[j]`` returned the point with height ``z_points[j]`` (sensor frame) at
    horizontal range ``horizontal_points[j]``; a ray without return clears ``clearance``.
    """
    nearest = np.full(n_bins, np.inf)
    farthest = np.zeros(n_bins)
    returned = np.zeros(channels * n_bins, dtype=np.bool_)
    for j in range(len(hit_index)):
        ray = hit_index[j]
        returned[ray] = True
        azimuth = ray % n_bins
        z_base = z_points[j] + sensor_height
        if obstacle_min <= z_base <= obstacle_max:
            nearest[azimuth] = min(nearest[azimuth], horizontal_points[j])
        if z_base < floor_max:
            farthest[azimuth] = max(farthest[azimuth], horizontal_points[j])
    for ray in range(channels * n_bins):
        if not returned[ray]:
            farthest[ray % n_bins] = max(farthest[ray % n_bins], clearance[ray])
    return nearest, farthest


@numba.njit(cache=True)
def voxel_keys(points: np.ndarray, voxel_size: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(3, N)`` voxel keys ``floor(p / voxel_size)`` of the finite rows of ``points (M, 3)``
    and their per-axis least and greatest keys (``VoxelCounts``' reference arithmetic;
    ``low > high`` when no row is finite)."""
    finite = np.empty(len(points), dtype=np.bool_)
    count = 0
    for i in range(len(points)):
        finite[i] = np.isfinite(points[i, 0]) and np.isfinite(points[i, 1]) and np.isfinite(points[i, 2])
        count += finite[i]
    keys = np.empty((3, count), dtype=np.int64)
    low = np.full(3, np.iinfo(np.int64).max)
    high = np.full(3, np.iinfo(np.int64).min)
    j = 0
    for i in range(len(points)):
        if finite[i]:
            for axis in range(3):
                key = math.floor(points[i, axis] / voxel_size)
                keys[axis, j] = key
                low[axis] = min(low[axis], key)
                high[axis] = max(high[axis], key)
            j += 1
    return keys, low, high


@numba.njit(cache=True)
def flat_voxel_indices(keys: np.ndarray, lower: np.ndarray, ny: int, nz: int) -> np.ndarray:
    """Flat indices into a ``(nx, ny, nz)`` count box whose first voxel has key ``lower``."""
    flat = np.empty(keys.shape[1], dtype=np.int64)
    for j in range(keys.shape[1]):
        flat[j] = ((keys[0, j] - lower[0]) * ny + (keys[1, j] - lower[1])) * nz + (keys[2, j] - lower[2])
    return flat


@numba.njit(cache=True)
def segments_clear(start_xy: np.ndarray, unit: np.ndarray, stop: np.ndarray, samples: np.ndarray,
                   padded_blocked: np.ndarray, origin_x: float, origin_y: float, resolution: float, nx: int,
                   ny: int, step: float) -> np.ndarray:
    """Whether each segment is clear: the samples of
    :func:`~explore_rl.mapping.visibility.line_of_sight` (at ``k * step``, ``1 <= k <=
    samples``, in cell units shifted by the free 1-cell border of ``padded_blocked``, flat,
    ``(ny + 2) * (nx + 2)``; coordinates clipped to it, then truncated: the same cells as
    truncating first), walked one segment at a time and only until its first blocked
    sample or its ``stop``."""
    clear = np.ones(len(stop), dtype=np.bool_)
    for i in range(len(stop)):
        col = (start_xy[i, 0] - origin_x) / resolution + 1.0
        row = (start_xy[i, 1] - origin_y) / resolution + 1.0
        for k in range(1, samples[i] + 1):
            t = step * k
            if not t < stop[i]:
                break
            x = min(max((t / resolution) * unit[i, 0] + col, 0.0), nx + 1.0)
            y = min(max((t / resolution) * unit[i, 1] + row, 0.0), ny + 1.0)
            if padded_blocked[np.int32(y) * (nx + 2) + np.int32(x)]:
                clear[i] = False
                break
    return clear
