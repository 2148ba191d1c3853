"""The ``graph`` config group: how an exploration graph becomes fixed-size tensors."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class GraphConfig:
    """Padding of the encoded exploration graph (explore_rl/graph/encode.py)."""

    # N of the padded tensors. Over it, pose nodes without a frontier edge are dropped,
    # farthest from the current pose first. An office episode has ~300-550 keyframes;
    # a garage evaluation ~800: raise it there (graph.max_nodes=1024).
    max_nodes: int = 512
    # node features: paper (uncertainty, distance, bearing, identity) | extended (+ per-frontier
    # path length, size, unknown nearby, revisits and their uncertainty, landmark uncertainty)
    # | loops (extended + the pose-graph length of the loop a revisit closes) | no_covariance (extended
    # without uncertainty, revisit and landmark uncertainty: decides without pose marginals)
    features: str = "paper"
