"""The dense g-U-Net: equal to PyG's GraphUNet with shared weights, blind to padding."""

from __future__ import annotations

import math
import warnings

import pytest
import torch
from torch_geometric.nn import GraphUNet

from explore_rl.models.graph_unet import (
    INPUT_LEVELS,
    DenseGraphUNet,
    DenseTopKPool,
    augmented_edges,
    input_level,
    sparse_product,
    state_dict_from_pyg,
    used_node_slots,
)
from tests.models.graphs import N_FEATURES, pad, random_graphs, to_pyg

HIDDEN, OUT = 32, 8
TOLERANCE = 1e-5


def pyg_and_dense(depth: int = 3, sum_res: bool = True, edge_weight: str = "distance",
                  seed: int = 0) -> tuple[GraphUNet, DenseGraphUNet]:
    """A PyG GraphUNet and a DenseGraphUNet holding the same weights, in eval mode."""
    torch.manual_seed(seed)
    pyg = GraphUNet(N_FEATURES, HIDDEN, OUT, depth, pool_ratios=0.5, sum_res=sum_res).eval()
    dense = DenseGraphUNet(N_FEATURES, HIDDEN, OUT, depth, pool_ratio=0.5, sum_res=sum_res,
                           edge_weight=edge_weight).eval()
    dense.load_state_dict(state_dict_from_pyg(pyg.state_dict()))
    return pyg, dense


def run_pyg(pyg: GraphUNet, graphs, weight_fn=lambda w: w) -> torch.Tensor:
    x, edge_index, batch, edge_weight = to_pyg(graphs)
    with warnings.catch_warnings():  # PyG's augment_adj: "sparse CSR support is in beta"
        warnings.simplefilter("ignore")
        return pyg(x, edge_index, batch=batch, edge_weight=weight_fn(edge_weight))


@pytest.mark.parametrize("n", [1, 2, 3, 7, 40, 129])
def test_matches_pyg_on_single_graphs(n):
    pyg, dense = pyg_and_dense()
    graphs = random_graphs([n], seed=n)
    batch = pad(graphs)
    with torch.no_grad():
        expected = run_pyg(pyg, graphs)
        got = dense(batch["x"], batch["adj"], batch["node_mask"])[0]
    assert got.shape == (n, OUT)
    torch.testing.assert_close(got, expected, atol=TOLERANCE, rtol=TOLERANCE)


@pytest.mark.parametrize("depth,sum_res", [(1, True), (2, False), (3, True), (3, False), (4, True)])
def test_matches_pyg_on_batches_of_different_sizes(depth, sum_res):
    pyg, dense = pyg_and_dense(depth, sum_res, seed=depth)
    graphs = random_graphs([50, 13, 1, 31, 2, 64], seed=10 + depth)
    batch = pad(graphs, n_slots=70)
    with torch.no_grad():
        expected = run_pyg(pyg, graphs)
        got = dense(batch["x"], batch["adj"], batch["node_mask"])
    torch.testing.assert_close(got[batch["node_mask"]], expected, atol=TOLERANCE, rtol=TOLERANCE)


@pytest.mark.parametrize("mode,weight_fn", [
    ("unit", torch.ones_like),
    ("inverse", lambda w: 1.0 / w.clamp_min(0.1)),
])
def test_edge_weight_modes_match_pyg_given_those_weights(mode, weight_fn):
    pyg, dense = pyg_and_dense(edge_weight=mode)
    graphs = random_graphs([30, 12], seed=5)
    batch = pad(graphs)
    with torch.no_grad():
        expected = run_pyg(pyg, graphs, weight_fn)
        got = dense(batch["x"], batch["adj"], batch["node_mask"])
        as_distance = DenseGraphUNet(N_FEATURES, HIDDEN, OUT, 3).eval()
        as_distance.load_state_dict(dense.state_dict())
        with_lengths = as_distance(batch["x"], batch["adj"], batch["node_mask"])
    torch.testing.assert_close(got[batch["node_mask"]], expected, atol=TOLERANCE, rtol=TOLERANCE)
    assert not torch.allclose(got, with_lengths, atol=1e-3)  # the weights do matter


def test_more_padding_and_junk_in_padded_slots_change_nothing():
    _, dense = pyg_and_dense()
    graphs = random_graphs([20, 9], seed=3)
    tight = pad(graphs)
    loose = pad(graphs, n_slots=45)
    generator = torch.Generator().manual_seed(0)
    padded = ~loose["node_mask"]
    loose["x"][padded] = torch.randn(int(padded.sum()), N_FEATURES, generator=generator) * 100
    junk = torch.rand(loose["adj"].shape, generator=generator) * 5
    pair_padded = padded.unsqueeze(-1) | padded.unsqueeze(-2)
    loose["adj"] = torch.where(pair_padded, junk, loose["adj"])
    with torch.no_grad():
        out_tight = dense(tight["x"], tight["adj"], tight["node_mask"])
        out_loose = dense(loose["x"], loose["adj"], loose["node_mask"])
    assert out_loose.shape == (2, 45, OUT)
    torch.testing.assert_close(out_loose[:, :20], out_tight, atol=1e-6, rtol=1e-6)
    assert torch.all(out_loose[padded] == 0)
    assert torch.all(out_tight[~tight["node_mask"]] == 0)


def test_a_graph_gives_the_same_outputs_alone_and_in_a_batch():
    _, dense = pyg_and_dense()
    graphs = random_graphs([15, 60, 33], seed=4)
    batch = pad(graphs)
    alone = pad(graphs[:1])
    with torch.no_grad():
        in_batch = dense(batch["x"], batch["adj"], batch["node_mask"])[0, :15]
        by_itself = dense(alone["x"], alone["adj"], alone["node_mask"])[0]
    torch.testing.assert_close(in_batch, by_itself, atol=1e-6, rtol=1e-6)


def test_real_nodes_may_sit_anywhere_among_the_slots():
    _, dense = pyg_and_dense()
    graph = random_graphs([25], seed=6)[0]
    front = pad([graph], n_slots=40)
    slots = torch.randperm(40, generator=torch.Generator().manual_seed(1))[:25]  # where node i goes
    scattered = {key: torch.zeros_like(value) for key, value in front.items()}
    scattered["x"][0, slots] = graph.x
    scattered["adj"][0, slots.unsqueeze(-1), slots.unsqueeze(0)] = graph.adj
    scattered["node_mask"][0, slots] = True
    with torch.no_grad():
        out_front = dense(front["x"], front["adj"], front["node_mask"])[0, :25]
        out_scattered = dense(scattered["x"], scattered["adj"], scattered["node_mask"])[0]
    torch.testing.assert_close(out_scattered[slots], out_front, atol=1e-5, rtol=1e-5)
    assert torch.all(out_scattered[~scattered["node_mask"][0]] == 0)


def test_leading_batch_dims_are_flattened_and_restored():
    _, dense = pyg_and_dense()
    graphs = random_graphs([10, 4, 12, 7, 9, 1], seed=7)
    batch = pad(graphs)
    grid = {key: value.reshape(2, 3, *value.shape[1:]) for key, value in batch.items()}
    with torch.no_grad():
        flat = dense(batch["x"], batch["adj"], batch["node_mask"])
        nested = dense(grid["x"], grid["adj"], grid["node_mask"])
        single = dense(batch["x"][2], batch["adj"][2], batch["node_mask"][2])
    assert nested.shape == (2, 3, 12, OUT)
    assert single.shape == (12, OUT)
    torch.testing.assert_close(nested.reshape(6, 12, OUT), flat)
    torch.testing.assert_close(single, flat[2], atol=1e-6, rtol=1e-6)


def test_all_padding_gives_zeros():
    _, dense = pyg_and_dense()
    out = dense(torch.randn(2, 5, N_FEATURES), torch.rand(2, 5, 5), torch.zeros(2, 5, dtype=torch.bool))
    assert out.shape == (2, 5, OUT)
    assert torch.all(out == 0)


def test_an_empty_graph_in_a_batch_gives_zeros_and_leaves_the_others_alone():
    _, dense = pyg_and_dense()
    graphs = random_graphs([12, 7], seed=11)
    batch = pad(graphs)
    batch["node_mask"][1] = False  # graph 1 has no real node (its tensors still hold junk)
    alone = pad(graphs[:1])
    out = dense(batch["x"], batch["adj"], batch["node_mask"])
    torch.testing.assert_close(out[0], dense(alone["x"], alone["adj"], alone["node_mask"])[0],
                               atol=1e-6, rtol=1e-6)
    assert torch.all(out[1] == 0)
    out.square().sum().backward()
    assert all(torch.isfinite(p.grad).all() for p in dense.parameters())


def test_used_node_slots_is_last_real_node_plus_one():
    mask = torch.tensor([[True, True, False, False, False], [False, False, True, False, False]])
    assert used_node_slots(mask) == 3
    assert used_node_slots(torch.zeros(2, 4, dtype=torch.bool)) == 0


def test_topk_keeps_ceil_ratio_of_real_nodes_with_the_best_scores():
    torch.manual_seed(0)
    pool = DenseTopKPool(HIDDEN, ratio=0.5)
    sizes = torch.tensor([7, 1, 4])
    graph = torch.repeat_interleave(torch.arange(3), sizes)
    slot = torch.cat([torch.arange(n) for n in sizes.tolist()])
    x = torch.randn(int(sizes.sum()), HIDDEN)
    pooled = pool(x, graph, slot, 8, sizes)
    assert torch.bincount(pooled.graph, minlength=3).tolist() == [math.ceil(0.5 * n) for n in sizes.tolist()]
    assert pooled.sizes.tolist() == [math.ceil(0.5 * n) for n in sizes.tolist()] and pooled.width == 4
    score = (x @ pool.weight.t()).squeeze(-1) / pool.weight.norm()
    for b in range(3):
        kept = pooled.kept[pooled.graph == b]
        assert torch.all(graph[kept] == b)  # never another graph's node
        best = score.masked_fill(graph != b, -math.inf).topk(len(kept)).indices
        assert kept.tolist() == sorted(best.tolist())  # the best, in their order
        assert pooled.slot[pooled.graph == b].tolist() == list(range(len(kept)))
        gate = torch.tanh(score[kept]).unsqueeze(-1)
        torch.testing.assert_close(pooled.x[pooled.graph == b], x[kept] * gate)


def dense_adjacency(edges, n: int) -> torch.Tensor:
    out = torch.zeros(n, n)
    out[edges.row, edges.col] = edges.weight
    return out


def test_augmented_edges_are_the_square_of_a_plus_i_on_kept_nodes():
    graph = random_graphs([9], seed=8)[0]
    level = input_level(graph.adj.unsqueeze(0), torch.ones(1, 9, dtype=torch.bool), "distance", 0.1)
    kept = torch.tensor([4, 0, 7])
    squared = (graph.adj + torch.eye(9)) @ (graph.adj + torch.eye(9))
    expected = squared[kept][:, kept].clone()
    expected.fill_diagonal_(0)
    torch.testing.assert_close(dense_adjacency(augmented_edges(level, kept), 3), expected)


def random_csr(n: int, entries: int, seed: int) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    index = torch.randint(n, (2, entries), generator=generator)
    values = torch.rand(entries, generator=generator) + 0.1
    return torch.sparse_coo_tensor(index, values, (n, n)).coalesce().to_sparse_csr()


@pytest.mark.parametrize("n, entries", [(1, 1), (7, 5), (40, 120), (300, 600)])
def test_sparse_product_is_the_dense_product_row_major(n, entries):
    left, right = random_csr(n, entries, seed=n), random_csr(n, entries, seed=n + 1)  # not symmetric, empty rows
    row, col, values = sparse_product(left, right)
    dense = left.to_dense() @ right.to_dense()
    keys = row * n + col
    assert torch.equal(keys, torch.unique(keys))  # row-major, each entry once
    assert torch.equal(torch.nonzero(dense).T, torch.stack([row, col]))  # positive values: no cancellation
    torch.testing.assert_close(values, dense[row, col])


def test_sparse_product_does_not_grow_the_process():
    import resource
    import sys

    def peak_mb() -> float:  # ru_maxrss: KiB on Linux, bytes on macOS
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak / 2**20 if sys.platform == "darwin" else peak / 2**10

    left = random_csr(3000, 12000, seed=0)
    for _ in range(50):
        sparse_product(left, left)
    before = peak_mb()
    for _ in range(1000):
        sparse_product(left, left)
    assert peak_mb() - before < 100  # torch 2.13's CSR @ CSR on the CPU: ~470 MB over these calls


def test_gcn_operator_uses_improved_self_loops_and_packs_out_padding():
    adj = torch.tensor([[[0.0, 0.5, 7.0], [0.5, 0.0, 7.0], [7.0, 7.0, 0.0]]])
    mask = torch.tensor([[True, True, False]])
    level = input_level(adj, mask, "distance", 0.1)
    degree = torch.tensor([2.5, 2.5])
    expected = torch.tensor([[2.0, 0.5], [0.5, 2.0]]) / degree.sqrt().outer(degree.sqrt())
    torch.testing.assert_close(level.propagate.matrix.to_dense(), expected)


def test_an_asymmetric_adjacency_gets_the_transpose_in_backward():
    generator = torch.Generator().manual_seed(12)
    adj = torch.rand(1, 6, 6, generator=generator) * (torch.rand(1, 6, 6, generator=generator) < 0.4)
    level = input_level(adj, torch.ones(1, 6, dtype=torch.bool), "distance", 0.1)
    assert level.reverse is not None
    matrix = level.propagate.matrix.to_dense()
    x = torch.randn(6, 3, generator=generator, requires_grad=True)
    level.propagate(x).sin().sum().backward()
    reference = x.detach().clone().requires_grad_()
    (matrix @ reference).sin().sum().backward()
    torch.testing.assert_close(x.grad, reference.grad)


def test_input_gradients_pass_gradcheck():
    """Double precision, finite differences: every backward here starts from one output
    entry, so the skipped-zero-rows path of the linear layers is exercised throughout."""
    torch.manual_seed(0)
    dense = DenseGraphUNet(N_FEATURES, 6, 3, depth=2).double()
    batch = pad(random_graphs([7, 4, 1], seed=15), n_slots=9)
    x = batch["x"].double().requires_grad_()
    adj, mask = batch["adj"].double(), batch["node_mask"]
    assert torch.autograd.gradcheck(lambda features: dense(features, adj, mask), (x,), eps=1e-6, atol=1e-5)


def test_the_input_cache_serves_equal_inputs_and_never_a_changed_graph():
    _, dense = pyg_and_dense()
    batch = pad(random_graphs([20, 9], seed=14))
    x, adj, mask = batch["x"], batch["adj"], batch["node_mask"]

    def fresh() -> torch.Tensor:
        INPUT_LEVELS.entry = None
        return dense(x, adj, mask)

    with torch.no_grad():
        first = fresh()
        level = INPUT_LEVELS.entry.level
        torch.testing.assert_close(dense(x, adj.clone(), mask.clone()), first, atol=0, rtol=0)
        assert INPUT_LEVELS.entry.level is level  # equal content: reused
        adj.numpy()[0, 0, 1] = adj.numpy()[0, 1, 0] = 2.5  # an edge's weight, behind autograd's back
        changed = dense(x, adj, mask)
        assert INPUT_LEVELS.entry.level is not level
        torch.testing.assert_close(changed, fresh(), atol=0, rtol=0)
        assert not torch.allclose(changed, first)
        adj.numpy()[1, 0, 5] = adj.numpy()[1, 5, 0] = 1.0  # a new edge
        torch.testing.assert_close(dense(x, adj, mask), fresh(), atol=0, rtol=0)
        mask[1, 8] = False  # a node fewer
        torch.testing.assert_close(dense(x, adj, mask), fresh(), atol=0, rtol=0)


def test_known_entries_give_the_scanned_level_and_the_same_outputs():
    """``entries`` (the adjacency's nonzero entries, known from the edges): the same input
    level as scanning the adjacency, bit for bit, so the same outputs; entries of padded
    slots are ignored, as their entries are."""
    _, dense = pyg_and_dense()
    batch = pad(random_graphs([20, 9], seed=15))
    x, adj, mask = batch["x"], batch["adj"], batch["node_mask"]
    with torch.no_grad():
        INPUT_LEVELS.entry = None
        scanned = dense(x, adj, mask)
        level = INPUT_LEVELS.entry.level
        INPUT_LEVELS.entry = None
        known = dense(x, adj, mask, adj.nonzero())
    torch.testing.assert_close(known, scanned, atol=0, rtol=0)
    for a, b in zip(INPUT_LEVELS.entry.level.edges, level.edges):
        assert torch.equal(a, b)
    assert not mask[1, 15]
    stray = torch.tensor([[1, 15, 0], [1, 0, 15]])  # a padded slot of the second graph
    INPUT_LEVELS.entry = None
    with torch.no_grad():
        torch.testing.assert_close(dense(x, adj, mask, torch.cat([adj.nonzero(), stray])), scanned, atol=0, rtol=0)


def test_without_autograd_the_same_outputs_bit_for_bit():
    """Under ``no_grad`` the layers skip their autograd functions (the products alone);
    the outputs are bitwise those with autograd."""
    _, dense = pyg_and_dense()
    batch = pad(random_graphs([40, 9, 23], seed=16))
    x, adj, mask = batch["x"], batch["adj"], batch["node_mask"]
    with_grad = dense(x.requires_grad_(), adj, mask)
    assert with_grad.requires_grad
    with torch.no_grad():
        torch.testing.assert_close(dense(x, adj, mask), with_grad.detach(), atol=0, rtol=0)


@pytest.mark.parametrize("few_nodes", [False, True])
def test_parameter_gradients_match_pyg(few_nodes):
    """Also when the loss reads a few nodes only (as the actor's: frontiers), so that most
    rows of the gradient are zero and the backward skips them."""
    pyg, dense = pyg_and_dense()
    graphs = random_graphs([50, 13, 1, 31], seed=13)
    batch = pad(graphs, n_slots=60)
    weights = torch.randn(len(batch["node_mask"].nonzero()), OUT, generator=torch.Generator().manual_seed(0))
    if few_nodes:
        weights[torch.arange(len(weights)) % 9 != 0] = 0.0
    (run_pyg(pyg, graphs) * weights).sum().backward()
    (dense(batch["x"], batch["adj"], batch["node_mask"])[batch["node_mask"]] * weights).sum().backward()
    expected = state_dict_from_pyg({name: p.grad for name, p in pyg.named_parameters()})
    for name, parameter in dense.named_parameters():
        torch.testing.assert_close(parameter.grad, expected[name], atol=1e-4, rtol=1e-4, msg=name)


def test_gradients_are_finite_and_reach_every_parameter():
    _, dense = pyg_and_dense()
    dense.train()
    batch = pad(random_graphs([30, 5, 1], seed=9), n_slots=36)
    out = dense(batch["x"], batch["adj"], batch["node_mask"])
    out.square().sum().backward()
    for name, parameter in dense.named_parameters():
        assert parameter.grad is not None, name
        assert torch.isfinite(parameter.grad).all(), name
        assert parameter.grad.abs().sum() > 0, name
