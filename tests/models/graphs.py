"""Small random exploration-like graphs for the model tests, padded (ours) or as edge lists (PyG)."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor

N_FEATURES = 4


@dataclass
class Graph:
    x: Tensor  # [n, n_features] (4 unless asked)
    adj: Tensor  # [n, n] symmetric, metres, zero diagonal
    frontiers: Tensor  # [n] bool


def random_graph(n: int, generator: torch.Generator, n_loops: int = 3, n_features: int = N_FEATURES) -> Graph:
    """A chain of ``n`` nodes about 0.5 m apart plus ``n_loops`` random longer edges; the
    last quarter of the nodes (at least one) are frontiers."""
    x = torch.randn(n, n_features, generator=generator)
    adj = torch.zeros(n, n)
    steps = 0.3 + 0.4 * torch.rand(max(n - 1, 0), generator=generator)
    idx = torch.arange(n - 1)
    adj[idx, idx + 1] = steps
    if n > 3:
        for _ in range(n_loops):
            i, j = torch.randint(0, n, (2,), generator=generator).tolist()
            if abs(i - j) > 1:
                adj[i, j] = 1.0 + 2.0 * float(torch.rand(1, generator=generator))
    adj = torch.maximum(adj, adj.T)
    frontiers = torch.zeros(n, dtype=torch.bool)
    frontiers[n - max(1, n // 4):] = True
    return Graph(x, adj, frontiers)


def random_graphs(sizes: list[int], seed: int = 0, n_features: int = N_FEATURES) -> list[Graph]:
    generator = torch.Generator().manual_seed(seed)
    return [random_graph(n, generator, n_features=n_features) for n in sizes]


def pad(graphs: list[Graph], n_slots: int | None = None) -> dict[str, Tensor]:
    """The padded batch ``x[B, N, 4]``, ``adj[B, N, N]``, ``node_mask``, ``action_mask``."""
    n_slots = n_slots or max(len(g.x) for g in graphs)
    batch = {"x": torch.zeros(len(graphs), n_slots, N_FEATURES),
             "adj": torch.zeros(len(graphs), n_slots, n_slots),
             "node_mask": torch.zeros(len(graphs), n_slots, dtype=torch.bool),
             "action_mask": torch.zeros(len(graphs), n_slots, dtype=torch.bool)}
    for b, g in enumerate(graphs):
        n = len(g.x)
        batch["x"][b, :n] = g.x
        batch["adj"][b, :n, :n] = g.adj
        batch["node_mask"][b, :n] = True
        batch["action_mask"][b, :n] = g.frontiers
    return batch


def to_pyg(graphs: list[Graph]) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """PyG inputs ``x, edge_index, batch, edge_weight`` of the concatenated graphs."""
    xs, edges, weights, batch, offset = [], [], [], [], 0
    for b, g in enumerate(graphs):
        edge_index = g.adj.nonzero().T
        xs.append(g.x)
        edges.append(edge_index + offset)
        weights.append(g.adj[edge_index[0], edge_index[1]])
        batch.append(torch.full((len(g.x),), b, dtype=torch.long))
        offset += len(g.x)
    return torch.cat(xs), torch.cat(edges, dim=1), torch.cat(batch), torch.cat(weights)
