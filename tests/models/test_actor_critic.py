"""Actor and critic: shapes and masks, TorchRL wrappers, sampling, learning, config."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch
import yaml
from tensordict import TensorDict
from torchrl.envs.utils import ExplorationType, set_exploration_type

from explore_rl.models.actor_critic import (
    Dropout,
    GraphActor,
    GraphCritic,
    RelativeFeatures,
    make_actor,
    make_critic,
)
from explore_rl.models.config import ModelConfig
from tests.models.graphs import N_FEATURES, pad, random_graphs

CONF_DIR = Path(__file__).resolve().parents[2] / "conf" / "model"
SMALL = ModelConfig(hidden=16, mlp_hidden=8)


def batch_td(sizes: list[int], n_slots: int | None = None, seed: int = 0) -> TensorDict:
    batch = pad(random_graphs(sizes, seed=seed), n_slots)
    return TensorDict(batch, batch_size=[len(sizes)])


def test_actor_logits_one_per_node_finite_and_zero_on_padding():
    torch.manual_seed(0)
    actor = GraphActor(SMALL, N_FEATURES).eval()
    td = batch_td([12, 5, 9], n_slots=15)
    logits = actor(td["x"], td["adj"], td["node_mask"])
    assert logits.shape == (3, 15)
    assert torch.isfinite(logits).all()
    assert torch.all(logits[~td["node_mask"]] == 0)


def test_critic_is_the_mean_over_real_nodes_and_ignores_padding():
    torch.manual_seed(0)
    critic = GraphCritic(SMALL, N_FEATURES).eval()
    tight, loose = batch_td([12, 5]), batch_td([12, 5], n_slots=30)
    with torch.no_grad():
        value = critic(tight["x"], tight["adj"], tight["node_mask"])
        value_loose = critic(loose["x"], loose["adj"], loose["node_mask"])
        node_scores = critic.head(critic.unet(critic.scale(tight["x"]), tight["adj"], tight["node_mask"])).squeeze(-1)
    assert value.shape == (2, 1)
    torch.testing.assert_close(value, value_loose, atol=1e-6, rtol=1e-6)
    torch.testing.assert_close(value[1, 0], node_scores[1, :5].mean())


def test_dropout_is_active_in_training_only():
    torch.manual_seed(0)
    actor = GraphActor(SMALL, N_FEATURES)
    td = batch_td([20])
    inputs = (td["x"], td["adj"], td["node_mask"])
    actor.eval()
    torch.testing.assert_close(actor(*inputs), actor(*inputs))
    actor.train()
    assert not torch.allclose(actor(*inputs), actor(*inputs))


def test_dropout_drops_a_fraction_p_and_rescales_the_rest():
    torch.manual_seed(0)
    dropout = Dropout(0.5).train()
    out = dropout(torch.ones(200_000))
    assert abs(float((out == 0).float().mean()) - 0.5) < 0.01
    assert set(out.unique().tolist()) == {0.0, 2.0}
    assert torch.equal(dropout.eval()(torch.ones(10)), torch.ones(10))


def test_torchrl_modules_read_and_write_their_keys_with_leading_dims():
    torch.manual_seed(0)
    actor, critic = make_actor(SMALL, N_FEATURES), make_critic(SMALL, N_FEATURES)
    td = batch_td([10, 4, 12, 7, 9, 3]).reshape(2, 3)  # [workers, T]
    with set_exploration_type(ExplorationType.RANDOM):
        actor(td)
    critic(td)
    assert td["logits"].shape == (2, 3, 12)
    assert td["action"].shape == (2, 3)
    assert td["action_log_prob"].shape == (2, 3)
    assert td["state_value"].shape == (2, 3, 1)
    chosen = td["action_mask"].gather(-1, td["action"].unsqueeze(-1))
    assert chosen.all()
    single = batch_td([8])[0]  # one env step, no batch dims
    actor(single)
    critic(single)
    assert single["action"].shape == () and single["state_value"].shape == (1,)


def test_masked_categorical_never_samples_a_masked_node():
    torch.manual_seed(0)
    actor = make_actor(SMALL, N_FEATURES)
    td = batch_td([30, 6, 17], n_slots=32)
    td["action_mask"][0] = False
    td["action_mask"][0, [0, 13, 29]] = True  # frontiers need not be the last nodes
    with torch.no_grad():
        samples = actor.get_dist(td).sample((4000,))  # [4000, 3]
    allowed = td["action_mask"].unsqueeze(0).expand(4000, -1, -1).gather(-1, samples.unsqueeze(-1))
    assert allowed.all()
    assert set(samples[:, 0].tolist()) == {0, 13, 29}  # and every frontier can be drawn


def test_deterministic_action_is_the_best_frontier():
    torch.manual_seed(0)
    actor = make_actor(SMALL, N_FEATURES).eval()
    td = batch_td([14, 9])
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        actor(td)
    best = td["logits"].masked_fill(~td["action_mask"], -torch.inf).argmax(-1)
    assert torch.equal(td["action"], best)


def test_supervised_loss_decreases_with_adam():
    """The actor can learn to pick a given frontier per graph (cross-entropy, fixed batch)."""
    torch.manual_seed(0)
    actor = GraphActor(SMALL, N_FEATURES)
    td = batch_td([20, 14, 25, 8], seed=2)
    frontiers = [torch.nonzero(mask).squeeze(-1) for mask in td["action_mask"]]
    target = torch.stack([f[len(f) // 2] for f in frontiers])
    optimizer = torch.optim.Adam(actor.parameters(), lr=1e-2)

    def loss() -> torch.Tensor:
        logits = actor(td["x"], td["adj"], td["node_mask"])
        return torch.nn.functional.cross_entropy(logits.masked_fill(~td["action_mask"], -1e9), target)

    actor.eval()
    before = loss().item()
    actor.train()
    for _ in range(40):
        optimizer.zero_grad()
        loss().backward()
        optimizer.step()
    actor.eval()
    assert loss().item() < 0.5 * before


def test_a2c_style_loss_has_finite_gradients_everywhere():
    torch.manual_seed(0)
    actor, critic = make_actor(SMALL, N_FEATURES), make_critic(SMALL, N_FEATURES)
    td = batch_td([20, 3, 1, 11], n_slots=24)
    td["action_mask"][2, 0] = True  # the 1-node graph: its only node is the frontier
    with set_exploration_type(ExplorationType.RANDOM):
        actor(td)
    critic(td)
    dist = actor.get_dist(td)
    advantage = torch.randn(4) - td["state_value"].squeeze(-1).detach()
    loss = (-(advantage * dist.log_prob(td["action"])).mean() + td["state_value"].square().mean()
            - 0.01 * dist.entropy().mean())
    loss.backward()
    for module in (actor, critic):
        for name, parameter in module.named_parameters():
            assert parameter.grad is not None and torch.isfinite(parameter.grad).all(), name


@pytest.mark.parametrize("field,value,message", [
    ("hidden", 0, "model.hidden must be a positive int, got 0"),
    ("depth", 1.5, "model.depth must be a positive int"),
    ("mlp_hidden", -1, "model.mlp_hidden"),
    ("pool_ratio", 0.0, "model.pool_ratio"),
    ("pool_ratio", 1.5, "model.pool_ratio"),
    ("dropout", 1.0, "model.dropout"),
    ("edge_weight", "metres", "model.edge_weight must be one of distance, unit, inverse"),
    ("min_edge_length", 0.0, "model.min_edge_length"),
    ("relative_features", ["distance", "distance"], "model.relative_features must be distinct"),
])
def test_bad_config_names_the_field(field, value, message):
    config = dataclasses.replace(ModelConfig(), **{field: value})
    with pytest.raises(ValueError, match=message):
        config.validate()
    with pytest.raises(ValueError, match=message):
        make_actor(config, N_FEATURES)


def test_single_linear_head_when_mlp_hidden_is_zero():
    actor = GraphActor(dataclasses.replace(SMALL, mlp_hidden=0), N_FEATURES)
    linears = [m for m in actor.head if isinstance(m, torch.nn.Linear)]
    assert [(m.in_features, m.out_features) for m in linears] == [(16, 1)]


def test_yaml_files_are_valid_model_configs():
    fields = {f.name for f in dataclasses.fields(ModelConfig)}
    default = yaml.safe_load((CONF_DIR / "gunet.yaml").read_text())
    paper = yaml.safe_load((CONF_DIR / "gunet_paper.yaml").read_text())
    assert set(default) == fields and set(paper) == fields
    assert ModelConfig(**default) == ModelConfig()  # the dataclass defaults are model=gunet
    ModelConfig(**paper).validate()
    assert paper["hidden"] == 1000 and paper["depth"] == 3 and paper["dropout"] == 0.5


def test_relative_features_divide_by_each_graphs_largest_real_value():
    config = dataclasses.replace(SMALL, relative_features=["distance", "uncertainty"])
    relative = RelativeFeatures(config, N_FEATURES)
    batch = pad(random_graphs([5, 9], seed=3), 12)
    x, mask = batch["x"], batch["node_mask"]
    x[0, 5:] = 1e6  # padding must not count as the largest value
    got = relative(x, mask)
    assert got.shape == (2, 12, 2)
    for g, n in enumerate((5, 9)):
        for k, column in enumerate((1, 0)):  # distance, uncertainty in the paper's order
            values = x[g, :n, column]
            torch.testing.assert_close(got[g, :n, k], values / values.abs().max())
        assert torch.all(got[g, n:] == 0)
    scaled = x.clone()
    scaled[..., 1] *= 7.0  # scale-free: metres or tens of metres read the same
    torch.testing.assert_close(relative(scaled, mask), got)


def test_relative_features_widen_the_input_and_unknown_names_fail():
    actor = GraphActor(dataclasses.replace(SMALL, relative_features=["distance"]), N_FEATURES)
    assert actor.unet.down_convs[0].lin.in_features == N_FEATURES + 1
    batch = batch_td([4, 7], 8)
    logits = actor(batch["x"], batch["adj"], batch["node_mask"])
    assert logits.shape == (2, 8) and torch.isfinite(logits).all()
    with pytest.raises(ValueError, match=r"model.relative_features: \['path_length'\] are not among"):
        GraphActor(dataclasses.replace(SMALL, relative_features=["path_length"]), N_FEATURES)
