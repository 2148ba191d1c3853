"""The torch.export program of the actor agrees with the eager actor."""

from __future__ import annotations

import pytest
import torch

from explore_rl.models.actor_critic import GraphActor
from explore_rl.models.config import ModelConfig
from explore_rl.models.export import ExportableActor, ExportedActor, export_actor
from tests.models.graphs import pad, random_graphs


@pytest.fixture(scope="module")
def actor():
    torch.manual_seed(0)
    return GraphActor(ModelConfig(hidden=24, mlp_hidden=16), 4).eval()


@pytest.fixture(scope="module")
def exported(actor, tmp_path_factory):
    path = tmp_path_factory.mktemp("export") / "actor.pt2"
    export_actor(actor, path, graph_max_nodes=640)
    return ExportedActor.load(path)


def eager(actor, graph):
    with torch.no_grad():
        return actor(graph.x[None], graph.adj[None], torch.ones(1, len(graph.x), dtype=torch.bool))[0]


@pytest.mark.parametrize("n", [2, 3, 17, 64, 91, 300])
def test_exported_and_eager_agree_on_graphs_of_any_size(actor, exported, n):
    graph = random_graphs([n], seed=n)[0]
    expected = eager(actor, graph)
    got = exported(graph.x, graph.adj, torch.ones(n, dtype=torch.bool))
    assert got.shape == (n,)
    torch.testing.assert_close(got, expected, atol=1e-5, rtol=1e-4)


def test_exported_ignores_padding_as_the_eager_actor_does(actor, exported):
    batch = pad(random_graphs([45], seed=1), 77)
    expected = actor(batch["x"], batch["adj"], batch["node_mask"])[0]
    got = exported(batch["x"][0], batch["adj"][0], batch["node_mask"][0])
    torch.testing.assert_close(got, expected.detach(), atol=1e-5, rtol=1e-4)
    assert torch.all(got[45:] == 0)


def test_the_saved_program_keeps_the_training_padding(exported):
    assert exported.graph_max_nodes == 640 and exported.multiple == 8


@pytest.mark.parametrize("options", [dict(sum_res=False), dict(edge_weight="inverse", mlp_hidden=0),
                                     dict(relative_features=["distance", "uncertainty"])])
def test_the_dense_single_graph_forward_matches_other_model_options(options):
    """What export traces (ExportableActor) equals the eager actor for other model options too."""
    torch.manual_seed(1)
    actor = GraphActor(ModelConfig(hidden=12, **options), 4).eval()
    for graph in random_graphs([5, 40, 133], seed=2):
        with torch.no_grad():
            got = ExportableActor(actor)(graph.x, graph.adj, torch.ones(len(graph.x), dtype=torch.bool))
        torch.testing.assert_close(got, eager(actor, graph), atol=1e-5, rtol=1e-4)


def test_the_default_policys_shipped_program_agrees_with_its_actor_file():
    """policies/<default>/actor.pt2 (what explore_rl.deploy loads) was exported from the same weights as actor.pt
    (what policy=learned loads): a stale program beside a new actor file would fail here."""
    from explore_rl.models.actor_file import DEFAULT_ACTOR, load_actor, resolve

    actor, actor_file = load_actor(None)
    program = ExportedActor.load(resolve(DEFAULT_ACTOR).with_name("actor.pt2"))
    for graph in random_graphs([4, 57, 210], seed=3, n_features=actor_file.n_features):
        got = program(graph.x, graph.adj, torch.ones(len(graph.x), dtype=torch.bool))
        torch.testing.assert_close(got, eager(actor, graph), atol=1e-5, rtol=1e-4)
