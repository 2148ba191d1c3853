"""Compiled loops of EM's decision (numba), beside the numpy code they stand for.

EM scores every frontier by fusing each virtual landmark's observations in pose order
(covariance intersection), for the current graph and for every loop candidate's graph at
once. The numpy version (:func:`~explore_rl.planning.em_fast.fuse_batched_reference`) runs
one round per observation rank, ~20 numpy passes a round over ``(landmarks, sets)``
arrays, plus a ``(4, rows, sets)`` temporary of every observation's information: on office
decisions about half of the fast reward's time. Here (:func:`fuse_rounds`) one loop walks
the rounds for each set of pose covariances, in place on one array of running
information; the rounds themselves are laid out by counting (:func:`round_layout`)
instead of three sorts, and the landmarks in range of each pose are found by walking its
window (:func:`window_pairs`) instead of numpy passes over every pose's whole window.

Each kernel performs the same float operations in the same order as the numpy code
(:func:`~explore_rl.planning.em_fast.observed_information`'s sums of products, then
:func:`~explore_rl.planning.em_fast.intersect`'s determinant polynomial and clamped
weight, then :func:`~explore_rl.planning.em_fast.covariances_of`; the window's ``floor``
and the norm's sum of squares), so the answers are the same floats and pairs;
``tests/planning/test_compiled.py`` compares them, and ``benchmarks/bench_kernels.py``
times them against the numpy code on real decisions. Compiled on first use and cached on
disk (``cache=True``).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def fuse_rounds(offsets: np.ndarray, pose_idx: np.ndarray, terms: np.ndarray, pose_covs: np.ndarray,
                initial: np.ndarray) -> np.ndarray:
    """``(C, S, 2, 2)`` fused landmark covariances.

    ``offsets (R + 1,)``, ``pose_idx (M,)``, ``terms (10, M)``: a
    :class:`~explore_rl.planning.em_fast.FuseRounds` (round ``r`` holds the ``r``-th
    observation of columns ``0 .. offsets[r + 1] - offsets[r] - 1``); ``pose_covs (C, N, 3,
    3)``: the sets of pose covariances; ``initial (3, S)``: the landmarks' information
    components before fusion. A zero determinant gives inf or nan, as numpy under
    ``errstate(divide="ignore", invalid="ignore")``.
    """
    num_sets, num_columns = pose_covs.shape[0], initial.shape[1]
    info = np.empty((num_sets, num_columns, 3))  # the running information of each landmark and set
    for c in range(num_sets):
        for s in range(num_columns):
            info[c, s, 0], info[c, s, 1], info[c, s, 2] = initial[0, s], initial[1, s], initial[2, s]
    # Round by round, as the numpy code: a round's landmarks are independent, so their
    # intersections overlap in the pipeline (one landmark's rounds are a chain of divisions).
    for c in range(num_sets):
        for r in range(len(offsets) - 1):
            begin = offsets[r]
            for s in range(offsets[r + 1] - begin):
                row = begin + s
                o0, o1, o2, o3 = _observed(terms, row, pose_covs, c, pose_idx[row])
                info[c, s, 0], info[c, s, 1], info[c, s, 2] = _intersect(info[c, s, 0], info[c, s, 1],
                                                                         info[c, s, 2], o0, o1, o2, o3)
    out = np.empty((num_sets, num_columns, 2, 2))
    for c in range(num_sets):
        for s in range(num_columns):
            i00, i01, i11 = info[c, s, 0], info[c, s, 1], info[c, s, 2]
            det = i00 * i11 - i01 * i01
            out[c, s, 0, 0] = i11 / det
            out[c, s, 0, 1] = out[c, s, 1, 0] = -i01 / det
            out[c, s, 1, 1] = i00 / det
    return out


@numba.njit(cache=True, error_model="numpy", inline="always")
def _observed(terms: np.ndarray, row: int, pose_covs: np.ndarray, c: int, p: int) -> tuple:
    """``(i00, i01, i11, 2 i01)`` of one observation's information ``(noise + gain S
    gain^T)^-1``: ``observed_information`` for one row and one set, operation for operation."""
    s00, s01, s02 = pose_covs[c, p, 0, 0], pose_covs[c, p, 0, 1], pose_covs[c, p, 0, 2]
    s11, s12, s22 = pose_covs[c, p, 1, 1], pose_covs[c, p, 1, 2], pose_covs[c, p, 2, 2]
    c00 = ((terms[1, row] * s02 + terms[0, row]) + s00) + terms[2, row] * s22
    c01 = (((terms[4, row] * s02 + terms[3, row]) + s01) + terms[5, row] * s12) + terms[6, row] * s22
    c11 = ((terms[8, row] * s12 + terms[7, row]) + s11) + terms[9, row] * s22
    det = c00 * c11 - c01 * c01
    o1 = -(c01 / det)
    return c11 / det, o1, c00 / det, o1 * 2.0


@numba.njit(cache=True, error_model="numpy", inline="always")
def _intersect(i00: float, i01: float, i11: float, o0: float, o1: float, o2: float, o3: float) -> tuple:
    """One covariance intersection of the running information with an observation's:
    ``intersect`` for one landmark and one set, operation for operation."""
    d00, d01, d11 = i00 - o0, i01 - o1, i11 - o2
    quad = d00 * d11 - d01 * d01
    lin = (o0 * d11 + o2 * d00) - o3 * d01
    stationary = lin / (-2.0 * quad)
    stationary = 0.0 if stationary < 0.0 else stationary  # np.maximum then np.minimum: a nan stays nan
    stationary = 1.0 if stationary > 1.0 else stationary
    lin += quad
    endpoint = 1.0 if lin > 0 else 0.0
    weight = stationary if quad < 0 else endpoint
    return d00 * weight + o0, d01 * weight + o1, d11 * weight + o2


@numba.njit(cache=True)
def round_layout(landmark_idx: np.ndarray, pose_idx: np.ndarray, gain: np.ndarray,
                 noise: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(offsets, landmarks, pose_idx, terms)`` of a
    :class:`~explore_rl.planning.em_fast.FuseRounds` from observations in pose order, by
    counting instead of sorting: columns are the landmarks by observation count, most
    first (ties by landmark id), round ``r`` holds the ``r``-th observation of each column
    seen more than ``r`` times, and ``terms`` are
    :func:`~explore_rl.planning.em_fast.lever_terms` of each row in round order."""
    num_rows = len(landmark_idx)
    num_ids = landmark_idx.max() + 1 if num_rows else 0
    counts = np.zeros(num_ids, dtype=np.int64)
    for i in range(num_rows):
        counts[landmark_idx[i]] += 1
    most = counts.max() if num_ids else 0
    # columns: by count descending, ids ascending within a count (a stable sort of -count)
    with_count = np.zeros(most + 2, dtype=np.int64)  # with_count[k]: landmarks seen exactly k times
    for lm in range(num_ids):
        with_count[counts[lm]] += 1
    first_column = np.zeros(most + 2, dtype=np.int64)  # first column of the landmarks seen k times
    for k in range(most - 1, 0, -1):
        first_column[k] = first_column[k + 1] + with_count[k + 1]
    num_columns = num_ids - with_count[0]
    column = np.empty(num_ids, dtype=np.int64)
    landmarks = np.empty(num_columns, dtype=np.int64)
    for lm in range(num_ids):
        if counts[lm]:
            column[lm] = first_column[counts[lm]]
            first_column[counts[lm]] += 1
            landmarks[column[lm]] = lm
    offsets = np.zeros(most + 1, dtype=np.int64)  # round r: the columns seen more than r times
    remaining = num_columns
    for r in range(most):
        offsets[r + 1] = offsets[r] + remaining
        remaining -= with_count[r + 1]
    rank = np.zeros(num_ids, dtype=np.int64)
    rows_pose = np.empty(num_rows, dtype=pose_idx.dtype)
    terms = np.empty((10, num_rows))
    for i in range(num_rows):
        lm = landmark_idx[i]
        q = offsets[rank[lm]] + column[lm]
        rank[lm] += 1
        rows_pose[q] = pose_idx[i]
        a, b = gain[i, 0, 2], gain[i, 1, 2]
        terms[0, q], terms[1, q], terms[2, q] = noise[i, 0, 0], -2.0 * a, a * a
        terms[3, q], terms[4, q], terms[5, q], terms[6, q] = noise[i, 0, 1], -b, -a, a * b
        terms[7, q], terms[8, q], terms[9, q] = noise[i, 1, 1], -2.0 * b, b * b
    return offsets, landmarks, rows_pose, terms


@numba.njit(cache=True)
def window_pairs(xy: np.ndarray, origin_x: float, origin_y: float, resolution: float, nx: int, ny: int,
                 window: np.ndarray, landmark_xy: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(pose_index, landmark_index)`` of the landmark cells of a ``ny x nx`` grid (flat
    centres ``landmark_xy``) in each pose's ``window`` of ``[diy, dix]`` offsets around its
    cell (``floor`` of the offset from ``origin`` over ``resolution``) and within ``radius``
    (the norm's sum of squares, then its root): what
    :meth:`~explore_rl.planning.virtual_map.VirtualMap.in_range_pairs_reference` finds, in
    its order (pose, then window slot)."""
    pose_idx = np.empty(len(xy) * len(window), dtype=np.int64)
    landmark_idx = np.empty(len(xy) * len(window), dtype=np.int64)
    found = 0
    for k in range(len(xy)):
        x, y = xy[k, 0], xy[k, 1]
        ix = np.int64(math.floor((x - origin_x) / resolution))
        iy = np.int64(math.floor((y - origin_y) / resolution))
        for w in range(len(window)):
            cy, cx = iy + window[w, 0], ix + window[w, 1]
            if cy < 0 or cy >= ny or cx < 0 or cx >= nx:
                continue
            index = cy * nx + cx
            dx, dy = landmark_xy[index, 0] - x, landmark_xy[index, 1] - y
            if math.sqrt(dx * dx + dy * dy) <= radius:
                pose_idx[found], landmark_idx[found] = k, index
                found += 1
    return pose_idx[:found], landmark_idx[:found]
