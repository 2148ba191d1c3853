"""The actor as a self-contained ``torch.export`` program (no explore_rl code needed to run it).

Why a second forward pass: the eager g-U-Net (graph_unet.py) packs the real nodes of a
padded batch and sizes every level by data -- how many slots hold real nodes, ``k.max()``
of the top-k pooling, sparse matrices built from ``nonzero`` -- which ``torch.export``
cannot trace (a data-dependent size becomes an unbacked symbol and the first branch on it
fails; ``draft_export`` "succeeds" by specialising the program to the example's size).
TorchScript fails on the same code and is deprecated. What exports is the same network
written densely for **one** graph whose level sizes follow from the input's *shape*:

* ``x[N, F]``, ``adj[N, N]``, ``node_mask[N]``; ``N`` is a dynamic dimension, a multiple
  of ``2 ** depth`` and at least ``MIN_NODES`` (:func:`pad_for_program` pads any graph to
  that with masked nodes: then each level's ``ceil(N / 2)`` is exact and export can prove
  every size it needs);
* level ``l`` has ``ceil(ratio * slots_{l-1})`` slots -- exactly the kept nodes when the
  graph is not padded, an upper bound (the extra slots masked, as in the eager padded
  batch) when it is;
* every operation is dense (``N x N`` adjacency), so the program costs ``O(N^2 hidden)``
  where the eager, sparse network costs ``O(edges x hidden)``: the eager actor stays the
  fast path in Python, the program is the artefact to ship to other runtimes.

:class:`ExportableActor` shares the weights of a :class:`~explore_rl.models.actor_critic.GraphActor`
(PyG's ``GraphUNet`` maths: GCN with ``A + 2I``, top-k with a tanh gate, ``(A + I)^2``
augmentation, unpooling with summed or concatenated skips); tests/models/test_export.py
checks the exported program against the eager actor on real and random graphs.
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from explore_rl.models.actor_critic import GraphActor
from explore_rl.models.actor_file import check_output_file
from explore_rl.models.graph_unet import IMPROVED_SELF_LOOP_WEIGHT

# Smallest node count the program accepts: each of the 3 pooling levels must keep >= 2
# slots, or torch.export specialises sizes 0/1. Smaller graphs are padded (pad_for_program).
MIN_NODES = 16
MAX_NODES = 1 << 16
MULTIPLE_FILE = "node_multiple"  # extra file of a saved program: N must be a multiple of it
MAX_NODES_FILE = "graph_max_nodes"  # extra file: graph.max_nodes of training


def ceil_ratio(n, ratio: float):
    """``ceil(ratio * n)`` in integer arithmetic (works on torch.export's symbolic sizes)."""
    fraction = Fraction(ratio).limit_denominator(1 << 20)
    return (n * fraction.numerator + fraction.denominator - 1) // fraction.denominator


def edge_weights(adj: Tensor, mode: str, min_edge_length: float) -> Tensor:
    """The GCN weights of metre edge lengths (graph_unet.py's ``edge_weight`` modes)."""
    if mode == "distance":
        return adj
    if mode == "unit":
        return (adj > 0).to(adj.dtype)
    if mode == "inverse":
        return torch.where(adj > 0, 1.0 / adj.clamp_min(min_edge_length), torch.zeros_like(adj))
    raise ValueError(f"unknown edge_weight mode {mode!r}")


def without_diagonal(adj: Tensor) -> Tensor:
    return adj * (1.0 - torch.eye(adj.shape[0], dtype=adj.dtype, device=adj.device))


def gcn_normalize(adj: Tensor, mask: Tensor) -> Tensor:
    """``D^-1/2 (A + 2I) D^-1/2`` with self loops on real nodes only (``mask`` float)."""
    loops = IMPROVED_SELF_LOOP_WEIGHT * mask
    degree = adj.sum(-1) + loops
    inv_sqrt = torch.where(degree > 0, degree.clamp_min(torch.finfo(adj.dtype).tiny).rsqrt(),
                           torch.zeros_like(degree))
    return inv_sqrt[:, None] * adj * inv_sqrt[None, :] + torch.diag(loops * inv_sqrt * inv_sqrt)


class ExportableActor(nn.Module):
    """A :class:`GraphActor`'s logits for one graph, dense, sized by shape (module docstring)."""

    def __init__(self, actor: GraphActor):
        super().__init__()
        self.actor = actor

    def conv(self, layer: nn.Module, x: Tensor, norm: Tensor, mask: Tensor) -> Tensor:
        return (norm @ (x @ layer.lin.weight.t()) + layer.bias) * mask[:, None]

    def pool(self, pool: nn.Module, x: Tensor, adj: Tensor, mask: Tensor):
        """Top-k pooling into ``ceil(ratio * slots)`` slots; ``(A + I)^2`` among the kept."""
        weight = pool.weight
        gate = torch.tanh((x @ weight.t()).squeeze(-1) / weight.norm(p=2))
        k = torch.ceil(pool.ratio * mask.sum())
        slots = ceil_ratio(x.shape[0], pool.ratio)
        index = gate.masked_fill(mask == 0, float("-inf")).topk(slots).indices
        kept = (torch.arange(slots, device=x.device) < k).to(x.dtype)
        pooled = x[index] * (gate[index] * kept)[:, None]
        rows = adj[index] + torch.diag(mask)[index]  # the kept rows of A + I
        augmented = without_diagonal((rows @ rows.t()) * kept[:, None] * kept[None, :])
        return pooled, augmented, kept, index

    def forward(self, x: Tensor, adj: Tensor, node_mask: Tensor) -> Tensor:
        """Logits ``[N]`` of ``x[N, F]``, ``adj[N, N]`` (metres), ``node_mask[N]``; 0 on padding."""
        unet = self.actor.unet
        mask = node_mask.to(x.dtype)
        x = self.actor.inputs(x, node_mask) * mask[:, None]
        adj = without_diagonal(edge_weights(adj, unet.edge_weight, unet.min_edge_length)
                               * mask[:, None] * mask[None, :])
        norm = gcn_normalize(adj, mask)
        x = F.relu(self.conv(unet.down_convs[0], x, norm, mask))
        skips, indices = [(x, norm, mask)], []
        for level in range(1, unet.depth + 1):
            x, adj, mask, index = self.pool(unet.pools[level - 1], x, adj, mask)
            norm = gcn_normalize(adj, mask)
            x = F.relu(self.conv(unet.down_convs[level], x, norm, mask))
            indices.append(index)
            if level < unet.depth:
                skips.append((x, norm, mask))
        for i, up_conv in enumerate(unet.up_convs):
            residual, norm, mask = skips[-1 - i]
            up = torch.zeros_like(residual).index_copy(0, indices[-1 - i], x)
            x = residual + up if unet.sum_res else torch.cat((residual, up), dim=-1)
            x = self.conv(up_conv, x, norm, mask)
            if i < unet.depth - 1:
                x = F.relu(x)
        node_mask = node_mask.to(x.dtype)
        return self.actor.head(x).squeeze(-1) * node_mask


def pad_for_program(x: Tensor, adj: Tensor, node_mask: Tensor, multiple: int) -> tuple[Tensor, Tensor, Tensor]:
    """The graph padded with masked nodes to a size the program takes: a multiple of
    ``multiple`` (``2 ** depth``), at least ``MIN_NODES``."""
    n = x.shape[0]
    size = max(MIN_NODES, -(-n // multiple) * multiple)
    extra = size - n
    if extra == 0:
        return x, adj, node_mask
    return F.pad(x, (0, 0, 0, extra)), F.pad(adj, (0, extra, 0, extra)), F.pad(node_mask, (0, extra))


def export_actor(actor: GraphActor, path: str | Path | None = None,
                 graph_max_nodes: int = 512) -> torch.export.ExportedProgram:
    """``torch.export`` the actor's single-graph logits (``N`` dynamic: a multiple of
    ``2 ** depth``, see :func:`pad_for_program`); saved to ``path`` (``torch.export.save``,
    conventionally ``*.pt2``) if given, with the padding size of training
    (``graph_max_nodes``) for the deployment's encoder."""
    if path is not None:
        check_output_file(path, "actor.pt2")
    module = ExportableActor(actor).eval()
    multiple = 2 ** actor.unet.depth
    n = max(MIN_NODES, 4 * multiple)
    generator = torch.Generator().manual_seed(0)
    lengths = 0.3 + torch.rand(n - 1, generator=generator)
    adj = torch.diag(lengths, 1)
    example = (torch.randn(n, actor.scale.scale.numel(), generator=generator), adj + adj.t(),
               torch.ones(n, dtype=torch.bool))
    # N = multiple x blocks: then every level's ceil(N / 2) is exact and export can prove
    # each slice fits (with any N it cannot prove ceil(N / 2) <= N and refuses)
    nodes = multiple * torch.export.Dim("blocks", min=-(-MIN_NODES // multiple), max=MAX_NODES // multiple)
    with torch.no_grad():
        program = torch.export.export(module, example, dynamic_shapes=({0: nodes}, {0: nodes, 1: nodes}, {0: nodes}),
                                      strict=False)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        torch.export.save(program, str(path), extra_files={MULTIPLE_FILE: str(multiple),
                                                          MAX_NODES_FILE: str(int(graph_max_nodes))})
    return program


class ExportedActor:
    """A saved program as a callable ``(x[N, F], adj[N, N], node_mask[N]) -> logits[N]``
    for any ``N`` (padded for the program, see :func:`pad_for_program`)."""

    def __init__(self, program: torch.export.ExportedProgram, multiple: int, graph_max_nodes: int = 512):
        self.module = program.module()
        self.multiple = multiple
        self.graph_max_nodes = graph_max_nodes

    @classmethod
    def load(cls, path: str | Path) -> ExportedActor:
        extra = {MULTIPLE_FILE: "", MAX_NODES_FILE: ""}
        program = torch.export.load(str(path), extra_files=extra)
        return cls(program, int(extra[MULTIPLE_FILE] or 8), int(extra[MAX_NODES_FILE] or 512))

    def __call__(self, x: Tensor, adj: Tensor, node_mask: Tensor) -> Tensor:
        n = x.shape[0]
        with torch.no_grad():
            return self.module(*pad_for_program(x, adj, node_mask.bool(), self.multiple))[:n]
