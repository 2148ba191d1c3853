"""A Graph U-Net (Gao & Ji, "Graph U-Nets", 2019) on padded batches.

The same network as PyG's ``torch_geometric.nn.GraphUNet`` (the tests copy PyG's weights
into it and compare outputs). Callers hand it padded tensors, as PyG's dense modules:

* ``x[B, N, F]`` node features, ``adj[B, N, N]`` symmetric edge weights (the diagonal is
  ignored), ``mask[B, N]`` True for real nodes. Whatever padded slots hold is ignored and
  their outputs are exactly zero. Any leading batch dims are flattened and restored.

Inside, the batch is **packed**: real nodes only, graph after graph (PyG's layout), with
each level's adjacency as a sparse CSR matrix. Exploration graphs are near-chains (~2
edges per node) of a few hundred nodes and a batch mixes sizes, so dense ``N x N``
products spent their time on zeros and on padding. Now the row-wise linear layers (most
of the flops from ~128 features up) run on real nodes only and propagation costs
``edges x features``; ``benchmarks/bench_policy.py`` measures this against PyG's
scatter-based message passing. What else keeps the overhead small, every step exact:

* one fused sparse ``addmm`` per propagation (bias included), forward and backward;
* each level's CSR layout is built once, without sorting, and serves both the GCN
  operator and the ``(A + I)^2`` augmentation (a sparse-sparse product);
* :class:`InputLevelCache`: the actor and the critic read the same observation; the
  second packs it from the first's work after an exact check;
* :class:`Linear`'s backward multiplies only the rows where the gradient is nonzero (the
  actor's loss reads the frontier nodes only);
* the padded output remembers its packed rows, so :func:`packed_rows` feeds a head these.

The layers, as in PyG:

* **GCN** (Kipf & Welling, ``improved=True``): ``A_hat = A + 2 I``,
  ``out = D^-1/2 A_hat D^-1/2 X W + b`` with ``D`` the row sums of ``A_hat``.
* **Graph augmentation** before each pooling: ``(A + I)^2`` without its diagonal, so
  two-hop neighbours stay connected when the node between them is pooled away.
* **Top-k pooling**: score ``y = tanh(X p / |p|)``; each graph keeps its
  ``k = ceil(ratio * n_valid)`` best real nodes; ``X' = (X * y)`` of them. PyG lists the
  kept nodes best first, we keep their order; no output depends on it.
* **Unpooling**: coarse features go back to the node they came from, zeros elsewhere;
  the skip connection adds them (``sum_res``) or concatenates them.

The adjacency at every level depends on the input graph and on which nodes top-k kept,
never on a parameter, so it is built without autograd; gradients flow through the node
features and the pooling gate only, as in PyG.

**Edge weights.** The exploration graph's edges carry Euclidean lengths in metres (paper
Sec. II-B). The authors' code passed these lengths, unchanged, as GCN edge weights, and
PyG uses whatever weights it gets; ``edge_weight="distance"`` (the default) does the
same, so a longer edge couples its nodes more strongly — not a similarity, but the
published network. ``"unit"`` ignores lengths; ``"inverse"`` weighs an edge by
``1 / max(length, min_edge_length)`` so near neighbours count more. The choice applies to
the input graph; augmented levels combine those weights exactly as PyG does.
"""

from __future__ import annotations

import math
import warnings
from typing import NamedTuple

import torch
import torch.nn.functional as F
from torch import Tensor, nn

# PyG GCNConv(improved=True) adds self loops of weight 2 (a node counts twice itself).
IMPROVED_SELF_LOOP_WEIGHT = 2.0


class Edges(NamedTuple):
    """A level's weighted edges between packed nodes: no self loops, grouped by ``row`` in
    ascending order (columns within a row in any order)."""

    row: Tensor  # [E] long
    col: Tensor  # [E] long
    weight: Tensor  # [E]


class Operator(NamedTuple):
    """A constant sparse ``[T, T]`` matrix applied to node features, and its transpose
    (the same object when the matrix is symmetric) for the backward pass."""

    matrix: Tensor
    transposed: Tensor

    def __call__(self, x: Tensor, bias: Tensor | None = None) -> Tensor:
        """``matrix @ x (+ bias)`` (without autograd, the product alone: the same op)."""
        if not torch.is_grad_enabled():
            return sparse_addmm(self.matrix, x, bias)
        return Propagate.apply(self.matrix, self.transposed, x, bias)


class Level(NamedTuple):
    """One level of the U-Net on packed nodes: each graph's nodes in ascending ``slot``
    order, graph after graph."""

    graph: Tensor  # [T] the graph each node belongs to
    slot: Tensor  # [T] its slot in that graph: the padded index at level 0, its rank below
    width: int  # slots per graph (> every slot)
    sizes: Tensor  # [B] nodes per graph
    edges: Edges
    pattern: Pattern  # where ``edges`` and self loops sit in a CSR matrix
    reverse: tuple[Edges, Pattern] | None  # the transposed edges; None if symmetric
    propagate: Operator  # the GCN's normalised adjacency


class Propagate(torch.autograd.Function):
    """``matrix @ x + bias`` for a constant sparse matrix; the backward multiplies by its
    transpose (sparse too). One fused sparse ``addmm`` each way: ``csr @ x`` alone
    zero-fills and copies its result, about twice the time at 1000 features."""

    @staticmethod
    def forward(ctx, matrix: Tensor, transposed: Tensor, x: Tensor,  # type: ignore[override]
                bias: Tensor | None) -> Tensor:
        ctx.transposed = transposed
        ctx.has_bias = bias is not None
        return sparse_addmm(matrix, x, bias)

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[None, None, Tensor | None, Tensor | None]:  # type: ignore[override]
        grad_x = sparse_addmm(ctx.transposed, grad, None) if ctx.needs_input_grad[2] else None
        grad_bias = grad.sum(0) if ctx.has_bias and ctx.needs_input_grad[3] else None
        return None, None, grad_x, grad_bias


def sparse_addmm(matrix: Tensor, x: Tensor, bias: Tensor | None) -> Tensor:
    """``matrix @ x (+ bias)`` for a sparse CSR ``matrix``."""
    shape = (matrix.shape[0], x.shape[1])
    if bias is None:  # beta=0: the uninitialised input is ignored (NaN included)
        return torch.addmm(x.new_empty(shape), matrix, x, beta=0)
    return torch.addmm(bias.expand(shape), matrix, x)


class Pattern(NamedTuple):
    """Where the entries of ``A + c I`` sit in a CSR matrix, for edges grouped by row: each
    row's edges, then its self loop. Built once per level, filled with different values."""

    crow: Tensor  # [n + 1]
    col: Tensor  # [E + n]
    edge_at: Tensor  # [E] each edge's entry
    loop_at: Tensor  # [n] each self loop's entry


def csr_pattern(edges: Edges, n: int) -> Pattern:
    """The CSR layout of ``edges`` plus self loops: no sort, since edges are grouped by row."""
    device, n_edges = edges.row.device, edges.row.numel()
    crow = torch.zeros(n + 1, dtype=torch.long, device=device)
    torch.cumsum(torch.bincount(edges.row, minlength=n) + 1, 0, out=crow[1:])
    edge_at = torch.arange(n_edges, device=device) + edges.row  # row r's edges move by r loops
    loop_at = crow[1:] - 1
    col = torch.empty(n_edges + n, dtype=torch.long, device=device)
    col[edge_at], col[loop_at] = edges.col, torch.arange(n, device=device)
    return Pattern(crow, col, edge_at, loop_at)


def csr_matrix(pattern: Pattern, edge_values: Tensor, loop_values: float | Tensor) -> Tensor:
    """The ``[n, n]`` CSR matrix of ``pattern`` with these edge and self-loop values."""
    n = pattern.loop_at.numel()
    value = edge_values.new_empty(pattern.col.numel())
    value[pattern.edge_at], value[pattern.loop_at] = edge_values, loop_values
    with warnings.catch_warnings():  # "sparse CSR support is in beta": it does what we use
        warnings.simplefilter("ignore", UserWarning)
        return torch.sparse_csr_tensor(pattern.crow, pattern.col, value, (n, n), check_invariants=False)


def transpose(edges: Edges) -> Edges:
    """The transposed edges, grouped by row again."""
    order = torch.sort(edges.col, stable=True).indices
    return Edges(edges.col[order], edges.row[order], edges.weight[order])


def graph_level(graph: Tensor, slot: Tensor, width: int, sizes: Tensor, edges: Edges,
                symmetric: bool = True) -> Level:
    """A level on these packed nodes and edges, with its GCN operator."""
    n = graph.numel()
    pattern = csr_pattern(edges, n)
    reverse = None
    if not symmetric:
        transposed = transpose(edges)
        reverse = (transposed, csr_pattern(transposed, n))
    return Level(graph, slot, width, sizes, edges, pattern, reverse, gcn_operator(edges, pattern, reverse))


def gcn_operator(edges: Edges, pattern: Pattern, reverse: tuple[Edges, Pattern] | None = None,
                 self_loop_weight: float = IMPROVED_SELF_LOOP_WEIGHT) -> Operator:
    """``D^-1/2 (A + w I) D^-1/2`` as a sparse operator, ``D`` the row sums of ``A + w I``;
    ``reverse``: the transposed edges, if ``A`` is not symmetric."""
    n = pattern.loop_at.numel()
    degree = torch.full((n,), self_loop_weight, dtype=edges.weight.dtype,
                        device=edges.weight.device).index_add_(0, edges.row, edges.weight)
    inv_sqrt = torch.where(degree > 0, degree.clamp_min(torch.finfo(degree.dtype).tiny).rsqrt(),
                           torch.zeros_like(degree))
    loops = self_loop_weight * inv_sqrt.square()

    def normalised(e: Edges) -> Tensor:
        return inv_sqrt[e.row] * e.weight * inv_sqrt[e.col]

    matrix = csr_matrix(pattern, normalised(edges), loops)
    if reverse is None:
        return Operator(matrix, matrix)
    return Operator(matrix, csr_matrix(reverse[1], normalised(reverse[0]), loops))


def edge_weights(lengths: Tensor, mode: str, min_edge_length: float) -> Tensor:
    """The GCN's weights of edges of these (nonzero) metre lengths; see the module docstring."""
    if mode == "distance":
        return lengths
    if mode == "unit":
        return (lengths > 0).to(lengths.dtype)
    if mode == "inverse":
        return torch.where(lengths > 0, 1.0 / lengths.clamp_min(min_edge_length), torch.zeros_like(lengths))
    raise ValueError(f"unknown edge_weight mode {mode!r}")


def select(mask: Tensor, *values: Tensor) -> tuple[Tensor, ...]:
    """``values`` at the True entries of ``mask`` (one ``nonzero`` for all of them)."""
    if bool(mask.all()):
        return values
    index = mask.nonzero().squeeze(1)
    return tuple(v.index_select(0, index) for v in values)


def input_level(adj: Tensor, mask: Tensor, mode: str, min_edge_length: float,
                entries: tuple[Tensor, Tensor, Tensor] | None = None) -> Level:
    """Pack the real nodes of ``adj[B, N, N]``/``mask[B, N]`` and their edges (pairs of
    distinct real nodes with a nonzero weight; ``unit``/``inverse``: a positive one).
    ``entries``: ``adj.nonzero()`` as ``(b, i, j)``, if already known."""
    n_graphs, width = mask.shape
    real = mask.reshape(-1)
    where = real.nonzero().squeeze(1)
    position = torch.cumsum(real, 0) - 1  # packed index of each real slot
    b, i, j = adj.nonzero().unbind(1) if entries is None else entries  # (b, i, j) order: rows grouped
    b, i, j = select(real[b * width + i] & real[b * width + j] & (i != j), b, i, j)
    lengths, reverse = adj[b, i, j], adj[b, j, i]
    edges = Edges(position[b * width + i], position[b * width + j], edge_weights(lengths, mode, min_edge_length))
    if mode != "distance":  # as with dense weights: zero-weight pairs are no edge
        edges = Edges(*select(edges.weight != 0, *edges))
    return graph_level(torch.div(where, width, rounding_mode="floor"), where % width, width, mask.sum(-1),
                       edges, symmetric=torch.equal(lengths, reverse))


def node_extents(mask: Tensor) -> list[int]:
    """Per graph of ``mask[B, N]``, its last real node's slot + 1 (0 for an empty graph)."""
    slots = torch.arange(1, mask.shape[-1] + 1, device=mask.device)
    return (slots * mask).amax(-1).tolist()


# Scan each graph's own block of the adjacency (a Python loop over graphs) when the blocks
# hold less than this share of the batch's trimmed B x n x n entries; else scan it whole.
BLOCKWISE_SCAN_SHARE = 0.6


def blockwise(extents: list[int], n: int) -> bool:
    return sum(m * m for m in extents) < BLOCKWISE_SCAN_SHARE * len(extents) * n * n


def nonzero_entries(adj: Tensor, extents: list[int]) -> tuple[Tensor, Tensor, Tensor]:
    """``adj[B, n, n].nonzero()`` as ``(b, i, j)`` among each graph's slots up to its last
    real node: padded slots past it need no scan (a batch mixes sizes)."""
    if not blockwise(extents, adj.shape[-1]):
        return adj.nonzero().unbind(1)
    parts = [F.pad(adj[b, :m, :m].nonzero(), (1, 0), value=b)
             for b, m in enumerate(extents) if m > 0]
    return torch.cat(parts).unbind(1)


def count_entries(adj: Tensor, extents: list[int]) -> int:
    """How many entries :func:`nonzero_entries` finds."""
    if not blockwise(extents, adj.shape[-1]):
        return int(torch.count_nonzero(adj))
    return sum(int(torch.count_nonzero(adj[b, :m, :m])) for b, m in enumerate(extents) if m > 0)


class CachedInput(NamedTuple):
    """An input level and exactly what it was built from."""

    key: tuple  # shapes and edge-weight settings
    mask: Tensor  # [B, n] the trimmed bool mask
    entries: tuple[Tensor, Tensor, Tensor]  # (b, i, j) of every nonzero adjacency entry
    values: Tensor  # their values
    level: Level


class InputLevelCache:
    """The last input level built, reused for an input with provably the same content:
    the actor and the critic read the same observation, and packing it scans every
    graph's ``n^2`` adjacency entries (``nonzero``). The check is exact and about a third
    of that: the same mask, as many nonzero entries, and the same values at the cached
    ones (then no other scanned entry can be nonzero). No tensor identity or version
    counter is trusted, so buffers rewritten behind autograd's back (shared memory) are
    safe."""

    def __init__(self):
        self.entry: CachedInput | None = None

    def clear(self) -> None:
        """Forget the cached level (benchmarks: every step a new observation)."""
        self.entry = None

    def get(self, adj: Tensor, mask: Tensor, mode: str, min_edge_length: float,
            entries: Tensor | None = None) -> Level | None:
        """The input level of ``adj[..., N, N]``/``mask[..., N]`` (leading dims flattened
        into graphs, slots past the last real node trimmed); None if no node is real.
        ``entries``: ``adj.nonzero()`` of the flattened ``adj[B, N, N]`` (``(M, 3)``:
        graph, row, column), when the caller knows it (a graph encoded from its edges):
        no scan and no check, the level is built from it."""
        n_nodes = mask.shape[-1]
        mask = mask.reshape(-1, n_nodes).bool()
        extents = node_extents(mask)
        n_used = max(extents, default=0)
        if n_used == 0:
            return None
        mask = mask[:, :n_used]
        adj = adj.reshape(-1, n_nodes, n_nodes)[:, :n_used, :n_used]
        key = (tuple(adj.shape), adj.dtype, adj.device, mode, min_edge_length)
        entry = self.entry
        if entries is not None:
            entries = entries[(entries[:, 1] < n_used) & (entries[:, 2] < n_used)].unbind(1)
        elif (entry is not None and entry.key == key and torch.equal(entry.mask, mask)
                and count_entries(adj, extents) == entry.values.numel()
                and torch.equal(adj[entry.entries], entry.values)):
            return entry.level
        else:
            entries = nonzero_entries(adj, extents)
        level = input_level(adj, mask, mode, min_edge_length, entries)
        self.entry = CachedInput(key, mask.clone(), entries, adj[entries], level)
        return level


INPUT_LEVELS = InputLevelCache()


def augmented_edges(level: Level, kept: Tensor) -> Edges:
    """``(A + I)(A + I)^T`` among the ``kept`` nodes (coarse node ``k`` is fine node
    ``kept[k]``, ``kept`` ascending), diagonal dropped: PyG's ``augment_adj`` followed by
    ``filter_adj``."""
    n = level.graph.numel()
    plus_identity = csr_matrix(level.pattern, level.edges.weight, 1.0)
    other = plus_identity if level.reverse is None else csr_matrix(level.reverse[1], level.reverse[0].weight, 1.0)
    row, col, values = sparse_product(plus_identity, other)
    coarse = torch.full((n,), -1, dtype=torch.long, device=kept.device)
    coarse[kept] = torch.arange(kept.numel(), device=kept.device)  # ascending: rows stay grouped
    row, col = coarse[row], coarse[col]
    return Edges(*select((row >= 0) & (col >= 0) & (row != col), row, col, values))


def sparse_product(left: Tensor, right: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """``left @ right`` of two ``[n, n]`` CSR matrices as ``(row, col, value)`` of its
    entries, row-major. Multiplied as COO matrices: torch's CSR ``@`` on the CPU (MKL)
    leaks ~0.5 MB a call in torch 2.13 (an offline run of 15,000 steps grew to 12 GB);
    the COO product is as fast and frees its memory (tests/models/test_graph_unet.py
    checks it against a dense product and that repeated calls do not grow the process)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        square = torch.sparse.mm(left.to_sparse_coo(), right.to_sparse_coo()).coalesce()
    row, col = square.indices()
    return row, col, square.values()


def used_node_slots(mask: Tensor) -> int:
    """How many leading node slots hold every real node of the batch: the last real node's
    index + 1 (= the largest graph's size when real nodes come first, as encode.py does)."""
    slots = torch.arange(1, mask.shape[-1] + 1, device=mask.device)
    return int((slots * mask).max()) if mask.numel() else 0


class Linear(torch.autograd.Function):
    """``x @ weight.T (+ bias)``, with a backward that multiplies only the rows where the
    incoming gradient is nonzero. The actor's loss reads the frontier nodes' logits only,
    so near the output most rows of its gradient are exactly zero; skipping them changes
    no value. The weight gradient is formed in the layout that suits a narrow input (the
    4-feature first layer: ``grad^T @ x`` of that shape is ~20x slower)."""

    @staticmethod
    def forward(ctx, x: Tensor, weight: Tensor, bias: Tensor | None) -> Tensor:  # type: ignore[override]
        ctx.save_for_backward(x, weight)
        ctx.has_bias = bias is not None
        return x @ weight.t() if bias is None else torch.addmm(bias, x, weight.t())

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[Tensor | None, Tensor | None, Tensor | None]:  # type: ignore[override]
        x, weight = ctx.saved_tensors
        grad_bias = grad.sum(0) if ctx.has_bias and ctx.needs_input_grad[2] else None
        rows = ((grad.amax(1) != 0) | (grad.amin(1) != 0)).nonzero().squeeze(1)  # NaN counts as nonzero
        if rows.numel() > DENSE_GRAD_FRACTION * grad.shape[0]:
            grad_rows, x_rows = grad, x
        else:
            grad_rows, x_rows = grad.index_select(0, rows), x.index_select(0, rows)
        grad_x = None
        if ctx.needs_input_grad[0]:
            grad_x = grad_rows @ weight
            if grad_rows is not grad:
                grad_x = grad_x.new_zeros(x.shape).index_copy_(0, rows, grad_x)
        grad_weight = None
        if ctx.needs_input_grad[1]:
            narrow = x.shape[1] < grad.shape[1]
            grad_weight = (x_rows.t() @ grad_rows).t() if narrow else grad_rows.t() @ x_rows
        return grad_x, grad_weight, grad_bias


# Above this fraction of nonzero gradient rows, Linear's backward multiplies all rows.
DENSE_GRAD_FRACTION = 0.8


class DenseGCNConv(nn.Module):
    """One GCN layer on packed nodes and a normalised sparse adjacency (PyG ``GCNConv``:
    glorot weight, zero bias, bias added after propagation)."""

    def __init__(self, in_features: int, out_features: int):
        super().__init__()
        self.lin = nn.Linear(in_features, out_features, bias=False)
        self.bias = nn.Parameter(torch.empty(out_features))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        nn.init.xavier_uniform_(self.lin.weight)
        nn.init.zeros_(self.bias)

    def forward(self, x: Tensor, propagate: Operator) -> Tensor:
        # (A X) W == A (X W): propagate the narrower of the two (the input layer has 4 features).
        if self.lin.in_features < self.lin.out_features:
            return linear(propagate(x), self.lin.weight, self.bias)
        return propagate(linear(x, self.lin.weight, None), self.bias)


def linear(x: Tensor, weight: Tensor, bias: Tensor | None) -> Tensor:
    """:class:`Linear` (without autograd, its forward alone: the same op)."""
    if torch.is_grad_enabled():
        return Linear.apply(x, weight, bias)
    return x @ weight.t() if bias is None else torch.addmm(bias, x, weight.t())


class PackedRows(NamedTuple):
    """Where a padded ``DenseGraphUNet`` output came from: its real rows, packed. Kept on
    the output (attribute ``PACKED_ROWS``) so that :func:`packed_rows` can feed a head
    these rows directly instead of gathering them back (and scattering their gradient)."""

    rows: Tensor  # [T, F]
    where: Tensor  # [T] each row's index along the flattened node axis
    mask: Tensor  # [numel of the node axes] bool, the real nodes
    version: int  # the padded output's version counter when made (in-place writes bump it)


PACKED_ROWS = "_explore_rl_packed_rows"


def pad_rows(rows: Tensor, where: Tensor, node_shape: tuple[int, ...]) -> Tensor:
    """``rows[T, ...]`` placed at the flattened node indices ``where``, zeros elsewhere."""
    out = rows.new_zeros(math.prod(node_shape), *rows.shape[1:]).index_copy_(0, where, rows)
    return out.view(*node_shape, *rows.shape[1:])


def packed_rows(layer: nn.Module, x: Tensor, mask: Tensor) -> Tensor:
    """``layer`` applied to the real nodes' rows of ``x[..., N, F]`` only, zeros elsewhere.
    The row-wise layers are most of the flops at large widths, and a padded batch is
    often half padding."""
    source: PackedRows | None = getattr(x, PACKED_ROWS, None)
    if (source is not None and x._version == source.version and source.mask.shape == (mask.numel(),)
            and torch.equal(source.mask, mask.reshape(-1).bool())):
        return pad_rows(layer(source.rows), source.where, tuple(mask.shape))
    if bool(mask.all()):
        return layer(x)
    where = mask.reshape(-1).nonzero().squeeze(1)
    return pad_rows(layer(x.reshape(-1, x.shape[-1]).index_select(0, where)), where, tuple(mask.shape))


class Pooled(NamedTuple):
    """One top-k pooling step: the kept nodes' gated features and the coarse level's nodes."""

    x: Tensor  # [K, H] gated features of the kept nodes
    kept: Tensor  # [K] fine-level packed node each coarse node came from, ascending
    graph: Tensor  # [K]
    slot: Tensor  # [K] position among its graph's kept nodes
    width: int  # the largest k
    sizes: Tensor  # [B] k of each graph


class DenseTopKPool(nn.Module):
    """PyG ``TopKPooling`` (tanh gate, ``k = ceil(ratio * n)`` per graph) on packed nodes.
    The kept nodes keep their order (PyG orders them best first; nothing downstream
    depends on it)."""

    def __init__(self, channels: int, ratio: float):
        super().__init__()
        self.ratio = ratio
        self.weight = nn.Parameter(torch.empty(1, channels))  # the projection p
        self.reset_parameters()

    def reset_parameters(self) -> None:
        bound = 1.0 / math.sqrt(self.weight.shape[1])  # as PyG's inits.uniform
        nn.init.uniform_(self.weight, -bound, bound)

    def forward(self, x: Tensor, graph: Tensor, slot: Tensor, width: int, sizes: Tensor) -> Pooled:
        """``x[T, H]`` packed; node ``t`` sits in ``slot[t] < width`` of ``graph[t]``."""
        gate = torch.tanh((x @ self.weight.t()).squeeze(-1) / self.weight.norm(p=2))
        n_graphs = sizes.numel()
        scores = gate.new_full((n_graphs, width), -math.inf)
        scores[graph, slot] = gate.detach()
        k = torch.ceil(self.ratio * sizes.to(x.dtype)).long()
        k_max = int(k.max())
        best = scores.topk(k_max, dim=-1).indices  # [B, k_max] slots
        in_k = torch.arange(k_max, device=x.device) < k.unsqueeze(-1)
        chosen = torch.zeros(n_graphs, width, dtype=torch.bool, device=x.device).scatter_(1, best, in_k)
        kept = chosen[graph, slot].nonzero().squeeze(1)
        coarse_graph = graph.index_select(0, kept)
        first = torch.cumsum(k, 0) - k  # each graph's first coarse node
        coarse_slot = torch.arange(kept.numel(), device=x.device) - first.index_select(0, coarse_graph)
        pooled = x.index_select(0, kept) * gate.index_select(0, kept).unsqueeze(-1)
        return Pooled(pooled, kept, coarse_graph, coarse_slot, k_max, k)


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

    def forward(self, x: Tensor, adj: Tensor, mask: Tensor, entries: Tensor | None = None) -> Tensor:
        """Flatten leading batch dims, pack the real nodes, run the U-Net, pad back.
        ``entries``: ``adj.nonzero()`` (leading dims flattened), if known
        (:meth:`InputLevelCache.get`)."""
        batch_shape, n_nodes = x.shape[:-2], x.shape[-2]
        level = INPUT_LEVELS.get(adj, mask, self.edge_weight, self.min_edge_length, entries)
        if level is None:
            return x.new_zeros(*batch_shape, n_nodes, self.out_features)
        where = level.graph * n_nodes + level.slot  # each packed node's row in the output
        packed = self.forward_packed(x.reshape(-1, x.shape[-1]).index_select(0, where), level)
        out = pad_rows(packed, where, (*batch_shape, n_nodes))
        setattr(out, PACKED_ROWS, PackedRows(packed, where, mask.reshape(-1).bool(), out._version))
        return out

    def forward_packed(self, x: Tensor, level: Level) -> Tensor:
        """The U-Net on packed nodes ``x[T, F]`` of the input ``level`` (PyG's forward)."""
        x = F.relu(self.down_convs[0](x, level.propagate), inplace=True)
        skips = [(x, level)]  # per level above the bottom: features and graph
        kept_nodes = []
        for depth in range(1, self.depth + 1):
            pooled = self.pools[depth - 1](x, level.graph, level.slot, level.width, level.sizes)
            level = graph_level(pooled.graph, pooled.slot, pooled.width, pooled.sizes,
                                augmented_edges(level, pooled.kept))
            x = F.relu(self.down_convs[depth](pooled.x, level.propagate), inplace=True)
            kept_nodes.append(pooled.kept)
            if depth < self.depth:
                skips.append((x, level))

        for i, up_conv in enumerate(self.up_convs):
            residual, level = skips[-1 - i]
            kept = kept_nodes[-1 - i]
            if self.sum_res:
                x = residual.index_add(0, kept, x)
            else:
                x = torch.cat((residual, torch.zeros_like(residual).index_copy(0, kept, x)), dim=-1)
            x = up_conv(x, level.propagate)
            if i < self.depth - 1:
                x = F.relu(x, inplace=True)
        return x


def state_dict_from_pyg(pyg_state: dict[str, Tensor]) -> dict[str, Tensor]:
    """A ``DenseGraphUNet`` state dict from a ``torch_geometric.nn.GraphUNet`` one (the
    parameter names differ only in the pooling projection: ``pools.i.select.weight``)."""
    return {name.replace(".select.", "."): value for name, value in pyg_state.items()}
