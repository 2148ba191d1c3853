"""The exploration graph (paper Sec. III-A): what the learned policy sees at a decision.

Nodes: every keyframe pose; the frontier nearest the robot (shortest path); every frontier
whose path closes a loop (:func:`explore_rl.planning.actions.select_actions`, the same
set EM and the reward evaluate). Edges: pose-pose wherever a SLAM factor joins two
keyframes (odometry, scan matching, loop closures), current pose - nearest frontier, and
loop frontier - every keyframe its path revisits. Edge weight = Euclidean distance (m).

Node features ``[uncertainty, distance, bearing, identity]``:

* uncertainty: trace of the world-frame xy covariance -- a pose's ``R Sigma_t R^T`` from
  its Pose3 marginal, a frontier's virtual landmark (the virtual-map cell it lies in);
* distance from the current pose, and the world-frame bearing ``arctan2(dy, dx)`` to it;
* identity: 0 the current pose, 1 a frontier, -1 any other pose.

The current pose is the newest keyframe (the robot stands at most one keyframe spacing
past it). :func:`build_graph` works from plain arrays, so a robot with its own SLAM can
build the same graph (``explore_rl.deploy``); :func:`graph_from_state` feeds it from a
running exploration.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from explore_rl.graph.features import (
    PAPER,
    frontier_extras,
    has_frontier_extras,
    has_loop_length,
    kept_columns,
    loop_lengths,
)

if TYPE_CHECKING:  # annotations only: the graph layer imports nothing from planning at run time
    from explore_rl.planning.actions import Action
    from explore_rl.planning.em import DecisionContext
    from explore_rl.state import ExplorationState

CURRENT, FRONTIER, POSE = 0.0, 1.0, -1.0  # identity feature
FEATURES = PAPER  # the paper's node features (graph.features=paper); explore_rl/graph/features.py


@dataclass
class ExplorationGraph:
    """Nodes (keyframes first, in keyframe order, then frontiers, nearest first) and edges."""

    xy: np.ndarray  # (n, 2) world positions
    features: np.ndarray  # (n, F) the paper's FEATURES, then any extended columns (or graph.features' selection)
    edges: np.ndarray  # (E, 2) int node pairs, i < j, unique
    weights: np.ndarray  # (E,) Euclidean length of each edge (m)
    keyframe: np.ndarray  # (n,) keyframe index of a pose node, -1 for a frontier
    candidate: np.ndarray  # (n,) index into state.candidates of a frontier node, -1 for a pose
    current: int  # node of the current pose

    @property
    def num_nodes(self) -> int:
        return len(self.xy)

    @property
    def frontier_nodes(self) -> np.ndarray:
        """Node indices of the frontiers (the actions), nearest first."""
        return np.flatnonzero(self.candidate >= 0)

    @property
    def nearest_node(self) -> int:
        """Node of the nearest frontier (the first frontier node)."""
        return int(self.frontier_nodes[0])

    def adjacency(self) -> np.ndarray:
        """Dense symmetric ``(n, n)`` weighted adjacency."""
        adj = np.zeros((self.num_nodes, self.num_nodes))
        if len(self.edges):
            adj[self.edges[:, 0], self.edges[:, 1]] = self.weights
            adj[self.edges[:, 1], self.edges[:, 0]] = self.weights
        return adj


def build_graph(
    pose_xy: np.ndarray,
    pose_uncertainty: np.ndarray,
    pose_edges: np.ndarray,
    frontier_xy: np.ndarray,
    frontier_uncertainty: np.ndarray,
    frontier_revisits: Sequence[Sequence[int]],
    current: int | None = None,
    frontier_candidates: Sequence[int] | None = None,
    frontier_extra: np.ndarray | None = None,
    loop_length: bool = False,
) -> ExplorationGraph:
    """The exploration graph from plain arrays.

    ``pose_xy (K, 2)``/``pose_uncertainty (K,)``: keyframe estimates and the trace of their
    world-frame xy covariances; ``pose_edges (M, 2)``: keyframe pairs joined by a SLAM
    factor (duplicates and either order allowed); ``frontier_xy (F, 2)``,
    ``frontier_uncertainty (F,)``: the action frontiers, **nearest first**, and the trace
    of their virtual landmarks' covariance; ``frontier_revisits[f]``: keyframes the path to
    frontier ``f`` revisits. ``current``: the current keyframe (default: the newest).
    ``frontier_candidates``: what each frontier node refers to (default ``0..F-1``).
    ``frontier_extra (F, E)``: extra frontier columns (``graph.features=extended``), 0 on poses.
    ``loop_length``: append the ``loop_length`` column (``graph.features=loops``), computed
    here from the graph's own edges (:func:`explore_rl.graph.features.loop_lengths`).
    """
    pose_xy = np.asarray(pose_xy, float).reshape(-1, 2)
    frontier_xy = np.asarray(frontier_xy, float).reshape(-1, 2)
    n_poses, n_frontiers = len(pose_xy), len(frontier_xy)
    if n_poses == 0 or n_frontiers == 0:
        raise ValueError(f"an exploration graph needs a pose and a frontier, got {n_poses} and {n_frontiers}")
    if len(frontier_revisits) != n_frontiers:
        raise ValueError(f"frontier_revisits has {len(frontier_revisits)} entries for {n_frontiers} frontiers")
    current = n_poses - 1 if current is None else int(current)
    xy = np.vstack([pose_xy, frontier_xy])
    frontier_nodes = n_poses + np.arange(n_frontiers)

    pairs = [np.asarray(pose_edges, dtype=np.int64).reshape(-1, 2), [[current, frontier_nodes[0]]]]
    pairs += [[[k, node] for k in keyframes] for node, keyframes in zip(frontier_nodes, frontier_revisits)]
    edges = unique_edges(np.vstack([np.asarray(p, dtype=np.int64).reshape(-1, 2) for p in pairs]))
    weights = np.linalg.norm(xy[edges[:, 0]] - xy[edges[:, 1]], axis=1)

    offset = xy - xy[current]
    identity = np.r_[np.full(n_poses, POSE), np.full(n_frontiers, FRONTIER)]
    identity[current] = CURRENT
    features = np.column_stack([
        np.r_[np.asarray(pose_uncertainty, float), np.asarray(frontier_uncertainty, float)],
        np.hypot(offset[:, 0], offset[:, 1]),
        np.arctan2(offset[:, 1], offset[:, 0]),
        identity,
    ])
    if frontier_extra is not None:
        frontier_extra = np.asarray(frontier_extra, float).reshape(n_frontiers, -1)
        features = np.column_stack([features, np.vstack([np.zeros((n_poses, frontier_extra.shape[1])),
                                                         frontier_extra])])
    if loop_length:
        loops = loop_lengths(n_poses, edges, weights, current, frontier_nodes)
        features = np.column_stack([features, np.r_[np.zeros(n_poses), loops]])
    candidates = np.arange(n_frontiers) if frontier_candidates is None else np.asarray(frontier_candidates)
    return ExplorationGraph(
        xy=xy, features=features, edges=edges, weights=weights,
        keyframe=np.r_[np.arange(n_poses), np.full(n_frontiers, -1)],
        candidate=np.r_[np.full(n_poses, -1), candidates].astype(np.int64),
        current=current,
    )


def unique_edges(pairs: np.ndarray) -> np.ndarray:
    """``(E, 2)`` sorted unique undirected pairs ``i < j`` (self-loops dropped)."""
    pairs = np.sort(np.asarray(pairs, dtype=np.int64).reshape(-1, 2), axis=1)
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    if not len(pairs):
        return pairs
    size = int(pairs.max()) + 1  # one integer key per pair orders them as (i, j) does
    keys = np.unique(pairs[:, 0] * size + pairs[:, 1])
    return np.column_stack([keys // size, keys % size])


def factor_edges(edges: Sequence[tuple[int, int, str]]) -> np.ndarray:
    """Keyframe pairs ``(M, 2)`` of a pose graph's between factors (``PoseGraph.edges``)."""
    pairs = itertools.chain.from_iterable((i, j) for i, j, _ in edges)
    return np.fromiter(pairs, dtype=np.int64, count=2 * len(edges)).reshape(-1, 2)


def graph_from_state(state: ExplorationState, context: DecisionContext,
                     actions: list[Action], features: str = "paper", sensor_range: float = 3.0) -> ExplorationGraph:
    """The exploration graph of a running exploration at a decision.

    ``context`` (:func:`explore_rl.planning.em.make_decision_context`) holds the keyframe
    marginals and the virtual map; ``actions`` the frontiers (nearest first) and their
    predicted revisits. ``features``: ``graph.features`` (``extended`` adds the columns of
    explore_rl/graph/features.py, measured within ``sensor_range`` of each frontier;
    ``loops`` those and ``loop_length``).
    """
    frontier_covs = context.vmap.frontier_landmark_covariance(action_frontiers(state, actions),
                                                              context.landmark_covs)
    extra = None
    if has_frontier_extras(features):
        extra = frontier_extras(state, actions, context.pose_covs, context.vmap.landmark_xy, context.landmark_covs,
                                sensor_range)
    graph = graph_from_estimates(state, actions, context.poses, context.pose_covs, frontier_covs,
                                 factor_edges(context.graph.edges), extra, has_loop_length(features))
    return select_features(graph, features)


def select_features(graph: ExplorationGraph, features: str) -> ExplorationGraph:
    """``graph`` with the node-feature columns ``graph.features`` reads, of those it was built with
    (:func:`explore_rl.graph.features.kept_columns`: ``no_covariance`` leaves the covariance columns out)."""
    kept = kept_columns(features)
    return graph if kept is None else dataclasses.replace(graph, features=graph.features[:, kept])


def action_frontiers(state: ExplorationState, actions: list[Action]) -> np.ndarray:
    """``(F, 2)`` waypoints of the action set's frontiers, nearest first."""
    return np.array([state.candidates[a.candidate].frontier.waypoint_xy for a in actions]).reshape(-1, 2)


def graph_from_estimates(state: ExplorationState, actions: list[Action], poses: np.ndarray,
                         pose_covs: np.ndarray, frontier_covs: np.ndarray,
                         pose_edges: np.ndarray, frontier_extra: np.ndarray | None = None,
                         loop_length: bool = False) -> ExplorationGraph:
    """The exploration graph from keyframe estimates ``poses (K, 3)``, their world-frame
    covariances ``pose_covs (K, 3, 3)`` (only the xy block is read), the action frontiers'
    virtual-landmark covariances ``frontier_covs (F, 2, 2)`` and the factor pairs.

    :func:`graph_from_state` reads these from EM's decision context; the learned policy
    computes only what the graph needs (explore_rl/planning/learned.py)."""
    pose_uncertainty = np.trace(pose_covs[:, :2, :2], axis1=1, axis2=2)
    frontier_uncertainty = np.trace(frontier_covs, axis1=1, axis2=2)
    revisits = [[r.keyframe_index for r in a.prediction.revisits] for a in actions]
    return build_graph(poses[:, :2], pose_uncertainty, pose_edges, action_frontiers(state, actions),
                       frontier_uncertainty, revisits, frontier_candidates=[a.candidate for a in actions],
                       frontier_extra=frontier_extra, loop_length=loop_length)
