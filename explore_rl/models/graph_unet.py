"""A dense, padded-batch Graph U-Net (Gao & Ji, "Graph U-Nets", 2019).

The same network as PyG's ``torch_geometric.nn.GraphUNet`` (the tests copy PyG's weights
into it and compare outputs), but on padded tensors instead of edge lists:

* ``x[B, N, F]`` node features, ``adj[B, N, N]`` symmetric edge weights with a zero
  diagonal, ``mask[B, N]`` True for real nodes. Padded nodes have zero rows and columns.

Exploration graphs are small (a few hundred nodes) and a training batch pads them to one
size, so batched dense matmuls beat scatter-based message passing on a CPU
(``benchmarks/bench_policy.py`` measures both).

The layers, as in PyG:

* **GCN** (Kipf & Welling, ``improved=True``): ``A_hat = A + 2 I``,
  ``out = D^-1/2 A_hat D^-1/2 X W + b`` with ``D`` the row sums of ``A_hat``.
* **Graph augmentation** before each pooling: ``(A + I)^2`` without its diagonal, so
  two-hop neighbours stay connected when the node between them is pooled away.
* **Top-k pooling**: score ``y = tanh(X p / |p|)``; each graph keeps its
  ``k = ceil(ratio * n_valid)`` best real nodes; ``X' = (X * y)`` of the kept nodes.
  Kept nodes are gathered to the front, so every level computes on fewer node slots.
* **Unpooling**: coarse features go back to the node they came from, zeros elsewhere;
  the skip connection adds them (``sum_res``) or concatenates them.

**Edge weights.** The exploration graph's edges carry Euclidean lengths in metres (paper
Sec. II-B). The authors' code passed these lengths, unchanged, as GCN edge weights, and
PyG uses whatever weights it gets; ``edge_weight="distance"`` (the default) does the
same, so a longer edge couples its nodes more strongly — not a similarity, but the
published network. ``"unit"`` ignores lengths; ``"inverse"`` weighs an edge by
``1 / max(length, min_edge_length)`` so near neighbours count more. The choice applies to
the input graph; augmented levels combine those weights exactly as PyG does.

**Padding.** Padded nodes never influence real ones (their rows and columns are zero,
top-k never selects them) and their outputs are exactly zero. Each call first trims the
node axis to the slots that hold real nodes, then pads the output back.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import Tensor, nn

# PyG GCNConv(improved=True) adds self loops of weight 2 (a node counts twice itself).
IMPROVED_SELF_LOOP_WEIGHT = 2.0


def prepare_adjacency(adj: Tensor, mask: Tensor, mode: str, min_edge_length: float) -> Tensor:
    """The GCN's edge weights from metre lengths (see the module docstring), with zero
    rows/columns for padded nodes and a zero diagonal whatever the caller passed."""
    if mode == "distance":
        weights = adj
    elif mode == "unit":
        weights = (adj > 0).to(adj.dtype)
    elif mode == "inverse":
        weights = torch.where(adj > 0, 1.0 / adj.clamp_min(min_edge_length), torch.zeros_like(adj))
    else:
        raise ValueError(f"unknown edge_weight mode {mode!r}")
    return zero_diagonal(weights * pair_mask(mask, mask).to(adj.dtype))


def pair_mask(rows: Tensor, cols: Tensor) -> Tensor:
    """``[B, N, M]`` True where both the row's and the column's node are real."""
    return rows.unsqueeze(-1) & cols.unsqueeze(-2)


def zero_diagonal(adj: Tensor) -> Tensor:
    """``adj`` (a fresh tensor) with its diagonal set to zero in place."""
    adj.diagonal(dim1=-2, dim2=-1).zero_()
    return adj


def gcn_normalize(adj: Tensor, mask: Tensor, self_loop_weight: float = IMPROVED_SELF_LOOP_WEIGHT) -> Tensor:
    """``D^-1/2 (A + w I) D^-1/2`` for ``adj`` with a zero diagonal, self loops on real
    nodes only; padded rows stay zero."""
    loops = self_loop_weight * mask.to(adj.dtype)
    degree = adj.sum(-1) + loops
    inv_sqrt = torch.where(degree > 0, degree.clamp_min(torch.finfo(adj.dtype).tiny).rsqrt(),
                           torch.zeros_like(degree))
    norm = inv_sqrt.unsqueeze(-1) * adj * inv_sqrt.unsqueeze(-2)
    norm.diagonal(dim1=-2, dim2=-1).add_(loops * inv_sqrt.square())
    return norm


def used_node_slots(mask: Tensor) -> int:
    """How many leading node slots hold every real node of the batch: the last real node's
    index + 1 (= the largest graph's size when real nodes come first, as encode.py does)."""
    slots = torch.arange(1, mask.shape[-1] + 1, device=mask.device)
    return int((slots * mask).max()) if mask.numel() else 0


def gather_nodes(values: Tensor, index: Tensor) -> Tensor:
    """``values[b, index[b, k], ...]`` for ``values[B, N, ...]`` and ``index[B, K]``."""
    expanded = index.view(*index.shape, *([1] * (values.dim() - 2))).expand(-1, -1, *values.shape[2:])
    return values.gather(1, expanded)


def unpool(coarse: Tensor, index: Tensor, n_fine: int) -> Tensor:
    """Put each coarse node's features back at the fine node ``index`` it was pooled from;
    zeros elsewhere. Coarse padding rows are zero, so their (distinct) slots get zero too."""
    fine = coarse.new_zeros(coarse.shape[0], n_fine, coarse.shape[-1])
    return fine.scatter(1, index.unsqueeze(-1).expand(-1, -1, coarse.shape[-1]), coarse)


class DenseGCNConv(nn.Module):
    """One GCN layer on a normalised dense adjacency (PyG ``GCNConv``: glorot weight,
    zero bias, bias added after propagation). Padded nodes' outputs are zero."""

    def __init__(self, in_features: int, out_features: int):
        super().__init__()
        self.lin = nn.Linear(in_features, out_features, bias=False)
        self.bias = nn.Parameter(torch.empty(out_features))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        nn.init.xavier_uniform_(self.lin.weight)
        nn.init.zeros_(self.bias)

    def forward(self, x: Tensor, norm_adj: Tensor, mask: Tensor) -> Tensor:
        # (A X) W == A (X W): propagate the narrower of the two (the input layer has 4 features).
        if self.lin.in_features < self.lin.out_features:
            out = packed_rows(self.lin, norm_adj @ x, mask)
        else:
            out = norm_adj @ packed_rows(self.lin, x, mask)
        return (out + self.bias) * mask.unsqueeze(-1).to(out.dtype)


def packed_rows(layer: nn.Module, x: Tensor, mask: Tensor) -> Tensor:
    """``layer`` applied to the real nodes' rows of ``x[B, N, F]`` only, zeros elsewhere.
    The row-wise layers are most of the flops at large widths, and a padded batch is
    often half padding."""
    if bool(mask.all()):
        return layer(x)
    rows = layer(x[mask])
    out = rows.new_zeros(*mask.shape, *rows.shape[1:])
    out[mask] = rows
    return out


class Pooled(NamedTuple):
    """One top-k pooling step: the coarse graph and where its nodes came from."""

    x: Tensor  # [B, K, H] gated features of the kept nodes (zero rows past each graph's k)
    adj: Tensor  # [B, K, K] augmented adjacency among the kept nodes
    mask: Tensor  # [B, K] True for the k kept nodes of each graph
    index: Tensor  # [B, K] fine-level node each coarse slot came from


class DenseTopKPool(nn.Module):
    """PyG ``TopKPooling`` (tanh gate, ``k = ceil(ratio * n)`` per graph) on padded
    batches, fused with the graph augmentation PyG's ``GraphUNet`` applies before it."""

    def __init__(self, channels: int, ratio: float):
        super().__init__()
        self.ratio = ratio
        self.weight = nn.Parameter(torch.empty(1, channels))  # the projection p
        self.reset_parameters()

    def reset_parameters(self) -> None:
        bound = 1.0 / math.sqrt(self.weight.shape[1])  # as PyG's inits.uniform
        nn.init.uniform_(self.weight, -bound, bound)

    def forward(self, x: Tensor, adj: Tensor, mask: Tensor) -> Pooled:
        gate = torch.tanh((x @ self.weight.t()).squeeze(-1) / self.weight.norm(p=2))
        k = torch.ceil(self.ratio * mask.sum(-1).to(x.dtype)).long()
        index = gate.masked_fill(~mask, -math.inf).topk(int(k.max()), dim=-1).indices
        kept = torch.arange(index.shape[1], device=x.device) < k.unsqueeze(-1)
        kept_gate = gather_nodes(gate, index) * kept.to(x.dtype)
        pooled_x = gather_nodes(x, index) * kept_gate.unsqueeze(-1)
        return Pooled(pooled_x, augmented_adjacency(adj, mask, index, kept), kept, index)


def augmented_adjacency(adj: Tensor, mask: Tensor, index: Tensor, kept: Tensor) -> Tensor:
    """``(A + I)^2`` restricted to the kept nodes, diagonal dropped (PyG ``augment_adj``
    followed by ``filter_adj``). Only the kept rows are multiplied (``K x N x K`` instead
    of ``N^3``); ``A`` is symmetric, so the kept columns are the rows transposed."""
    loops = gather_nodes(mask.to(adj.dtype), index).unsqueeze(-1)  # the kept rows' "+ I"
    rows = gather_nodes(adj, index).scatter_add(2, index.unsqueeze(-1), loops)  # [B, K, N]
    squared = rows @ rows.transpose(1, 2)
    return zero_diagonal(squared * pair_mask(kept, kept).to(adj.dtype))


class DenseGraphUNet(nn.Module):
    """Graph U-Net on padded batches; input ``[..., N, F]``, output ``[..., N, out]``.

    Same parameters (names aside) and outputs as ``torch_geometric.nn.GraphUNet(
    in_features, hidden, out_features, depth, pool_ratio, sum_res)`` with ReLU."""

    def __init__(self, in_features: int, hidden: int, out_features: int, depth: int,
                 pool_ratio: float = 0.5, sum_res: bool = True, edge_weight: str = "distance",
                 min_edge_length: float = 0.1):
        super().__init__()
        self.depth = depth
        self.sum_res = sum_res
        self.edge_weight = edge_weight
        self.min_edge_length = min_edge_length
        self.out_features = out_features
        self.down_convs = nn.ModuleList([DenseGCNConv(in_features, hidden)]
                                        + [DenseGCNConv(hidden, hidden) for _ in range(depth)])
        self.pools = nn.ModuleList([DenseTopKPool(hidden, pool_ratio) for _ in range(depth)])
        up_in = hidden if sum_res else 2 * hidden
        up_out = [hidden] * (depth - 1) + [out_features]
        self.up_convs = nn.ModuleList([DenseGCNConv(up_in, width) for width in up_out])

    def forward(self, x: Tensor, adj: Tensor, mask: Tensor) -> Tensor:
        """Flatten leading batch dims, trim padding, run the U-Net, restore both."""
        batch_shape, n_nodes = x.shape[:-2], x.shape[-2]
        x = x.reshape(-1, n_nodes, x.shape[-1])
        adj = adj.reshape(-1, n_nodes, n_nodes)
        mask = mask.reshape(-1, n_nodes).bool()
        n_used = used_node_slots(mask)
        if n_used == 0:
            return x.new_zeros(*batch_shape, n_nodes, self.out_features)
        out = self.forward_dense(x[:, :n_used], adj[:, :n_used, :n_used], mask[:, :n_used])
        out = F.pad(out, (0, 0, 0, n_nodes - n_used))
        return out.reshape(*batch_shape, n_nodes, self.out_features)

    def forward_dense(self, x: Tensor, adj: Tensor, mask: Tensor) -> Tensor:
        """The U-Net on ``x[B, N, F]``, ``adj[B, N, N]``, ``mask[B, N]`` (PyG's forward)."""
        x = x * mask.unsqueeze(-1).to(x.dtype)
        adj = prepare_adjacency(adj, mask, self.edge_weight, self.min_edge_length)
        norm_adj = gcn_normalize(adj, mask)
        x = F.relu(self.down_convs[0](x, norm_adj, mask))

        skips = [(x, norm_adj, mask)]  # per level: features, normalised adjacency, mask
        indices = []
        for level in range(1, self.depth + 1):
            x, adj, mask, index = self.pools[level - 1](x, adj, mask)
            norm_adj = gcn_normalize(adj, mask)
            x = F.relu(self.down_convs[level](x, norm_adj, mask))
            indices.append(index)
            if level < self.depth:
                skips.append((x, norm_adj, mask))

        for i, up_conv in enumerate(self.up_convs):
            residual, norm_adj, mask = skips[-1 - i]
            up = unpool(x, indices[-1 - i], residual.shape[1])
            x = residual + up if self.sum_res else torch.cat((residual, up), dim=-1)
            x = up_conv(x, norm_adj, mask)
            if i < self.depth - 1:
                x = F.relu(x)
        return x


def state_dict_from_pyg(pyg_state: dict[str, Tensor]) -> dict[str, Tensor]:
    """A ``DenseGraphUNet`` state dict from a ``torch_geometric.nn.GraphUNet`` one (the
    parameter names differ only in the pooling projection: ``pools.i.select.weight``)."""
    return {name.replace(".select.", "."): value for name, value in pyg_state.items()}
