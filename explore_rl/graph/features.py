"""Node feature sets of the exploration graph: the paper's four, an extended set, and ``loops``.

``graph.features=paper`` gives the paper's ``[uncertainty, distance, bearing, identity]``
(explore_rl/graph/exploration_graph.py). ``extended`` appends per-frontier columns that EM's
utility depends on but the paper's four do not show (an offline probe: the frontier's size
alone closes ~45 % of the random-to-EM gap, no paper feature does better than random):

* ``path_length``: metres along the Dijkstra path to the frontier (what alpha charges);
* ``frontier_size``: length of the frontier (cells x resolution, m);
* ``unknown_nearby``: fraction of unknown cells within the LiDAR range of the waypoint
  (what a visit can still reveal);
* ``revisits``: keyframes the path revisits (predicted loop closures);
* ``revisit_uncertainty``: the largest trace of the xy covariance among them (m^2; 0 if none);
* ``landmark_uncertainty``: mean trace of the virtual landmarks' covariance within the
  LiDAR range of the waypoint (m^2).

``loops`` appends one more, a function of the exploration graph itself (:func:`loop_lengths`):

* ``loop_length``: the largest distance through the pose graph (SLAM factor edges, metres)
  from the current keyframe to a keyframe the path revisits (0 if none): how long a loop
  the revisit would close. What a loop closure corrects grows with the robot's uncertainty
  *relative to* the revisited keyframe, which the marginals do not show (a recent keyframe,
  or one an earlier loop already joined, is close through the graph however uncertain it
  is); a g-U-Net of depth 3 cannot find a shortest path over hundreds of poses.

``no_covariance`` keeps the columns of ``extended`` that need no covariance: the paper's ``distance``, ``bearing``,
``identity`` and ``path_length``, ``frontier_size``, ``unknown_nearby``, ``revisits``. Its graph is built as the
extended one with the three covariance columns (``uncertainty``, ``revisit_uncertainty``, ``landmark_uncertainty``)
left out (:func:`kept_columns`), so a decision needs neither the pose marginals nor the virtual map's fusion: the
learned policy's largest costs besides the action set (issue 24's decision-time target).

Pose nodes carry 0 in the frontier columns. Each feature has a scale (multiplied in by the
model, ``model.feature_scale``) that brings it to order one.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

if TYPE_CHECKING:
    from explore_rl.planning.actions import Action
    from explore_rl.state import ExplorationState

PAPER = ("uncertainty", "distance", "bearing", "identity")
FRONTIER_EXTRAS = ("path_length", "frontier_size", "unknown_nearby", "revisits", "revisit_uncertainty",
                   "landmark_uncertainty")
LOOP_EXTRAS = ("loop_length",)
COVARIANCE_FEATURES = ("uncertainty", "revisit_uncertainty", "landmark_uncertainty")
NO_COVARIANCE = tuple(name for name in PAPER + FRONTIER_EXTRAS if name not in COVARIANCE_FEATURES)
FEATURE_SETS = {"paper": PAPER, "extended": PAPER + FRONTIER_EXTRAS, "loops": PAPER + FRONTIER_EXTRAS + LOOP_EXTRAS,
                "no_covariance": NO_COVARIANCE}
SCALES = {
    "uncertainty": 10.0, "distance": 0.1, "bearing": 1.0 / math.pi, "identity": 1.0,
    "path_length": 0.05, "frontier_size": 0.5, "unknown_nearby": 1.0, "revisits": 0.1,
    "revisit_uncertainty": 10.0, "landmark_uncertainty": 10.0, "loop_length": 0.05,
}


def feature_names(feature_set: str) -> tuple[str, ...]:
    """The node features of ``graph.features``; ValueError naming the key otherwise."""
    if feature_set not in FEATURE_SETS:
        raise ValueError(f"graph.features={feature_set!r}: choose one of {', '.join(FEATURE_SETS)}")
    return FEATURE_SETS[feature_set]


def has_frontier_extras(feature_set: str) -> bool:
    """Whether ``graph.features`` reads the per-frontier columns of :func:`frontier_extras`."""
    return FRONTIER_EXTRAS[0] in feature_names(feature_set)


def has_loop_length(feature_set: str) -> bool:
    """Whether ``graph.features`` reads ``loop_length`` (:func:`loop_lengths`)."""
    return LOOP_EXTRAS[0] in feature_names(feature_set)


def reads_covariances(feature_set: str) -> bool:
    """Whether ``graph.features`` reads a column made from covariances (pose marginals or the virtual map)."""
    return any(name in COVARIANCE_FEATURES for name in feature_names(feature_set))


def built_names(feature_set: str) -> tuple[str, ...]:
    """The columns a graph is built with for ``graph.features``: the paper's four, then the frontier extras and
    ``loop_length`` if it reads any of them (``build_graph``'s order); :func:`kept_columns` selects its own."""
    names = PAPER
    if has_frontier_extras(feature_set):
        names += FRONTIER_EXTRAS
    if has_loop_length(feature_set):
        names += LOOP_EXTRAS
    return names


def kept_columns(feature_set: str) -> list[int] | None:
    """Indices into :func:`built_names` of the columns ``graph.features`` reads; None if it reads them all."""
    built, names = built_names(feature_set), feature_names(feature_set)
    return None if names == built else [built.index(name) for name in names]


def feature_set_of(names: list[str] | tuple[str, ...]) -> str:
    """The ``graph.features`` whose columns are ``names``; ValueError otherwise."""
    for feature_set, columns in FEATURE_SETS.items():
        if tuple(names) == columns:
            return feature_set
    raise ValueError(f"node features {list(names)} are no feature set of this version "
                     f"({', '.join(FEATURE_SETS)})")


def feature_scales(feature_set: str) -> list[float]:
    """The default ``model.feature_scale`` of a feature set."""
    return [SCALES[name] for name in feature_names(feature_set)]


def names_for(n_features: int) -> tuple[str, ...]:
    """The columns of the feature set with ``n_features`` columns; ValueError if none has."""
    for names in FEATURE_SETS.values():
        if len(names) == n_features:
            return names
    raise ValueError(f"no feature set has {n_features} node features ({', '.join(FEATURE_SETS)})")


def scales_for(n_features: int) -> list[float]:
    """The scales of the feature set with ``n_features`` columns (``model.feature_scale:
    null``); ValueError if no set has that many."""
    try:
        names = names_for(n_features)
    except ValueError:
        raise ValueError(f"no feature set has {n_features} node features: give model.feature_scale explicitly") from None
    return [SCALES[name] for name in names]


def disc_fraction(mask: np.ndarray, cell: np.ndarray, radius_cells: int) -> float:
    """Fraction of ``mask`` cells within ``radius_cells`` of ``cell`` ([iy, ix]), inside the grid."""
    iy, ix = int(cell[0]), int(cell[1])
    y0, y1 = max(iy - radius_cells, 0), min(iy + radius_cells + 1, mask.shape[0])
    x0, x1 = max(ix - radius_cells, 0), min(ix + radius_cells + 1, mask.shape[1])
    if y1 <= y0 or x1 <= x0:
        return 0.0
    top, left = iy - radius_cells, ix - radius_cells
    inside = disc(radius_cells)[y0 - top: y1 - top, x0 - left: x1 - left]  # the disc's cells inside the grid
    return float(mask[y0:y1, x0:x1][inside].mean()) if inside.any() else 0.0


@functools.lru_cache(maxsize=8)
def disc(radius_cells: int) -> np.ndarray:
    """``(2r + 1, 2r + 1)``: the cells within ``r`` cells of the centre one (built once per radius)."""
    offset = np.arange(-radius_cells, radius_cells + 1)
    inside = offset[:, None] ** 2 + offset[None, :] ** 2 <= radius_cells ** 2
    inside.flags.writeable = False
    return inside


def frontier_extras(state: ExplorationState, actions: list[Action], pose_covs: np.ndarray,
                    landmark_xy: np.ndarray, landmark_covs: np.ndarray, sensor_range: float) -> np.ndarray:
    """``(F, len(FRONTIER_EXTRAS))`` for the action frontiers, nearest first.

    ``pose_covs (K, 3, 3)``: keyframe world-frame marginals; ``landmark_xy (L, 2)`` and
    ``landmark_covs (L, 2, 2)``: virtual landmarks (at least every one within
    ``sensor_range`` of a frontier waypoint) and their current covariances."""
    occupancy = state.session.occupancy
    grid = occupancy.grid
    radius_cells = max(1, int(round(sensor_range / grid.resolution)))
    landmark_trace = np.trace(landmark_covs, axis1=1, axis2=2)
    pose_trace = np.trace(pose_covs[:, :2, :2], axis1=1, axis2=2)
    unknown = occupancy.unknown
    rows = []
    for action in actions:
        candidate = state.candidates[action.candidate]
        frontier = candidate.frontier
        revisited = [r.keyframe_index for r in action.prediction.revisits]
        near = np.linalg.norm(landmark_xy - frontier.waypoint_xy, axis=1) <= sensor_range
        rows.append([
            candidate.length,
            frontier.size * grid.resolution,
            disc_fraction(unknown, frontier.waypoint_cell, radius_cells),
            len(revisited),
            float(pose_trace[revisited].max()) if revisited else 0.0,
            float(landmark_trace[near].mean()) if near.any() else 0.0,
        ])
    return np.asarray(rows, dtype=float).reshape(len(actions), len(FRONTIER_EXTRAS))


def loop_lengths(n_poses: int, edges: np.ndarray, weights: np.ndarray, current: int,
                 frontier_nodes: np.ndarray) -> np.ndarray:
    """``(F,)`` ``loop_length`` of the frontier nodes of an exploration graph.

    Nodes ``0..n_poses-1`` are keyframes; ``edges (E, 2)`` with lengths ``weights (E,)``
    are all the graph's edges. Distances run through the pose-pose edges only (SLAM
    factors), from ``current``; a frontier's value is the largest over the keyframes it is
    joined to (the ones its path revisits; the nearest frontier's edge to the current pose
    adds 0), 0 if it is joined to none. ValueError if a joined keyframe cannot be reached
    from the current one (the pose graph of a running exploration is connected)."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    weights = np.asarray(weights, dtype=float).reshape(-1)
    poses = (edges < n_poses).all(axis=1)
    pairs, lengths = shortest_of_parallel_edges(np.sort(edges[poses], axis=1), weights[poses], n_poses)
    graph = sp.coo_matrix((lengths, (pairs[:, 0], pairs[:, 1])), shape=(n_poses, n_poses)).tocsr()
    distance = dijkstra(graph, directed=False, indices=int(current))
    keyframe, node = np.sort(edges[~poses], axis=1).T  # frontier edges: (keyframe, frontier node)
    frontier_nodes = np.asarray(frontier_nodes, dtype=np.int64)
    row_of = np.full(max(int(node.max(initial=-1)), int(frontier_nodes.max(initial=-1))) + 1, -1)
    row_of[frontier_nodes] = np.arange(len(frontier_nodes))
    rows = row_of[node]
    counted = (rows >= 0) & (keyframe < n_poses)  # edges between a keyframe and a frontier asked for
    keyframe, rows = keyframe[counted], rows[counted]
    reach = distance[keyframe]
    if not np.isfinite(reach).all():
        bad = ~np.isfinite(reach)
        raise ValueError(f"frontier node {int(frontier_nodes[rows[bad][0]])}: keyframes {keyframe[bad].tolist()} "
                         f"are not reachable from keyframe {current} through the pose graph")
    values = np.zeros(len(frontier_nodes))
    np.maximum.at(values, rows, reach)
    return values


def shortest_of_parallel_edges(pairs: np.ndarray, lengths: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Sorted pairs ``(E, 2)`` (``i <= j``) with one edge per pair, the shortest: a sparse
    matrix would add the lengths of repeated pairs."""
    if len(pairs) == 0:
        return pairs, lengths
    keys = pairs[:, 0] * n + pairs[:, 1]
    order = np.lexsort((lengths, keys))
    first = np.r_[True, keys[order][1:] != keys[order][:-1]]
    return pairs[order][first], lengths[order][first]
