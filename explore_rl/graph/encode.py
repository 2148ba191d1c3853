"""Exploration graph -> fixed-size padded arrays: what the actor-critic and TorchRL consume.

``x[N, 4]`` node features, ``adj[N, N]`` weighted symmetric adjacency, ``node_mask[N]``
(real nodes) and ``action_mask[N]`` (frontier nodes), with ``N = graph.max_nodes``; real
nodes come first, padding stays zero. An edge of length 0 (the odometry factor of a turn on
the spot) is no entry of ``adj``; with the g-U-Net's ``model.edge_weight=distance`` (every
shipped policy) its GCN weight would be 0 anyway, so nothing is lost; ``unit`` and
``inverse`` do not see such an edge (explore_rl/models/graph_unet.py).

A graph larger than ``N`` loses pose nodes that have no frontier edge, farthest from the
current pose first (they matter least to where to go next); the current pose and the
frontiers are never dropped.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from explore_rl.graph.exploration_graph import ExplorationGraph
from explore_rl.graph.features import loop_lengths

log = logging.getLogger(__name__)


@dataclass
class EncodedGraph:
    """Padded arrays of one graph, plus which graph node each row holds."""

    x: np.ndarray  # (N, 4) float32
    adj: np.ndarray  # (N, N) float32
    node_mask: np.ndarray  # (N,) bool
    action_mask: np.ndarray  # (N,) bool
    nodes: np.ndarray  # (n_kept,) graph node index of each real row
    dropped: int  # pose nodes dropped to fit N
    entries: np.ndarray | None = None  # (M, 2) (row, column) of adj's nonzero entries, row-major (np.argwhere)

    def row_of(self, node: int) -> int:
        """Row of graph node ``node``; ValueError if it was dropped."""
        rows = np.flatnonzero(self.nodes == node)
        if len(rows) == 0:
            raise ValueError(f"graph node {node} was dropped from the encoding")
        return int(rows[0])


def nodes_to_keep(graph: ExplorationGraph, max_nodes: int) -> np.ndarray:
    """Sorted node indices that fit in ``max_nodes`` (see the module docstring).

    If even the protected nodes do not fit, pose nodes with frontier edges go too,
    farthest first; the current pose and the frontiers always stay.
    """
    n = graph.num_nodes
    if n <= max_nodes:
        return np.arange(n)
    frontier = graph.candidate >= 0
    if frontier.sum() + 1 > max_nodes:
        raise ValueError(f"graph.max_nodes={max_nodes} cannot hold the current pose and "
                         f"{int(frontier.sum())} frontiers: raise graph.max_nodes")
    touches_frontier = np.zeros(n, dtype=bool)
    frontier_edges = frontier[graph.edges].any(axis=1)
    touches_frontier[graph.edges[frontier_edges].ravel()] = True
    protected = frontier.copy()
    protected[graph.current] = True
    distance = np.hypot(*(graph.xy - graph.xy[graph.current]).T)  # the distance feature, whatever the columns
    # drop order: unlinked poses farthest first, then frontier-linked poses farthest first
    droppable = np.flatnonzero(~protected)
    order = droppable[np.lexsort((-distance[droppable], touches_frontier[droppable]))]
    dropped = order[: n - max_nodes]
    if touches_frontier[dropped].any():
        log.warning("graph.max_nodes=%d: dropped %d poses linked to frontiers too (raise graph.max_nodes)",
                    max_nodes, int(touches_frontier[dropped].sum()))
    keep = np.ones(n, dtype=bool)
    keep[dropped] = False
    return np.flatnonzero(keep)


def encode(graph: ExplorationGraph, max_nodes: int, compact: bool = False) -> EncodedGraph:
    """Padded arrays of ``graph`` with ``N = max_nodes`` rows (what TorchRL's fixed specs
    need). ``compact``: the same nodes (dropped ones too) with no padding rows, ``N`` = the
    nodes kept -- for one decision at inference, where the g-U-Net's outputs on real rows
    do not depend on the padding (it packs the real nodes; tests/planning/test_learned.py
    compares the logits) and padding buys nothing."""
    nodes = nodes_to_keep(graph, max_nodes)
    dropped = graph.num_nodes - len(nodes)
    if dropped:
        log.debug("exploration graph of %d nodes: dropped %d far poses to fit graph.max_nodes=%d",
                  graph.num_nodes, dropped, max_nodes)
    k = len(nodes)
    rows = k if compact else max_nodes
    x = np.zeros((rows, graph.features.shape[1]), dtype=np.float32)
    x[:k] = graph.features[nodes]
    adj = np.zeros((rows, rows), dtype=np.float32)
    i, j, weights = kept_edges(graph, nodes)
    adj[i, j] = weights
    adj[j, i] = weights
    node_mask = np.zeros(rows, dtype=bool)
    node_mask[:k] = True
    action_mask = np.zeros(rows, dtype=bool)
    action_mask[:k] = graph.candidate[nodes] >= 0
    return EncodedGraph(x, adj, node_mask, action_mask, nodes, dropped, nonzero_entries(adj, i, j))


def kept_edges(graph: ExplorationGraph, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows ``(i, j)`` and weights of the edges between the kept ``nodes`` (sorted):
    ``graph.adjacency()[np.ix_(nodes, nodes)]`` holds them at ``[i, j]`` and ``[j, i]``
    (no dense ``n x n`` of the whole graph first)."""
    row = np.full(graph.num_nodes, -1)
    row[nodes] = np.arange(len(nodes))
    if not len(graph.edges):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
    i, j = row[graph.edges[:, 0]], row[graph.edges[:, 1]]
    kept = (i >= 0) & (j >= 0)
    return i[kept], j[kept], graph.weights[kept]


def nonzero_entries(adj: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``np.argwhere(adj)`` for a symmetric ``adj`` nonzero at most at ``[i, j]`` and
    ``[j, i]``: from those pairs, without scanning its ``N^2`` entries (the g-U-Net packs
    a graph from them: :class:`~explore_rl.models.graph_unet.InputLevelCache`)."""
    rows, cols = np.concatenate([i, j]), np.concatenate([j, i])
    keys = np.unique(rows.astype(np.int64) * adj.shape[1] + cols)
    rows, cols = np.divmod(keys, adj.shape[1])
    nonzero = adj[rows, cols] != 0
    return np.stack([rows[nonzero], cols[nonzero]], axis=1)


def loop_length_rows(graph: ExplorationGraph, encoded: EncodedGraph) -> np.ndarray:
    """``(N,)``: each encoded frontier row's ``loop_length`` (the pose-graph distance from the
    current keyframe to the farthest keyframe its path revisits; the ``loops`` node feature,
    computed here whatever the actor reads): what the loop prior (``policy.loop_bias``, and
    ``loop_bias`` of :meth:`explore_rl.deploy.DeployedPolicy.decide`) adds per metre. 0 on pose
    and padding rows."""
    rows = np.flatnonzero(encoded.action_mask)
    n_poses = int((graph.keyframe >= 0).sum())
    values = np.zeros(len(encoded.action_mask), dtype=np.float32)
    values[rows] = loop_lengths(n_poses, graph.edges, graph.weights, graph.current, encoded.nodes[rows])
    return values
