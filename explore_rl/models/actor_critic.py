"""The actor and the critic: two g-U-Nets, each followed by dropout and an MLP (paper Sec. III-A).

* :class:`GraphActor` scores every node; TorchRL's ``MaskedCategorical`` turns the scores of
  the frontier nodes (``action_mask``) into the policy, so the action is a node index.
* :class:`GraphCritic` scores every node and averages the real nodes' scores into V(G).

Both read the padded tensors of ``explore_rl.graph.encode``: ``x[..., N, F]``,
``adj[..., N, N]`` and ``node_mask[..., N]``; any leading batch dims (e.g. TorchRL's
``[workers, T]``) are kept. :func:`make_actor` and :func:`make_critic` wrap them as
TorchRL modules that read and write those tensordict keys.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import torch
from torch import Tensor, nn

from explore_rl.graph.features import names_for, scales_for
from explore_rl.models.config import ModelConfig
from explore_rl.models.graph_unet import DenseGraphUNet, packed_rows

if TYPE_CHECKING:
    from torchrl.data import TensorSpec
    from torchrl.modules import ProbabilisticActor, ValueOperator

OBSERVATION_KEYS = ["x", "adj", "node_mask"]
ACTION_MASK_KEY = "action_mask"


def make_unet(config: ModelConfig, n_features: int) -> DenseGraphUNet:
    """The g-U-Net of ``config``; its last layer has ``config.hidden`` output features."""
    return DenseGraphUNet(n_features, config.hidden, config.hidden, config.depth,
                          pool_ratio=config.pool_ratio, sum_res=config.sum_res,
                          edge_weight=config.edge_weight, min_edge_length=config.min_edge_length)


class Dropout(nn.Module):
    """Inverted dropout, as ``nn.Dropout``, with the mask drawn by ``rand >= p``: on a
    CPU about 3x faster than ``nn.Dropout``'s ``bernoulli_``, same distribution."""

    def __init__(self, p: float):
        super().__init__()
        self.p = p

    def forward(self, x: Tensor) -> Tensor:
        if not self.training or self.p == 0.0:
            return x
        return x * (torch.rand_like(x) >= self.p).to(x.dtype) / (1.0 - self.p)


class FeatureScale(nn.Module):
    """Multiplies node features by ``model.feature_scale`` (a buffer: saved with the weights)."""

    def __init__(self, config: ModelConfig, n_features: int):
        super().__init__()
        scale = config.feature_scale if config.feature_scale is not None else scales_for(n_features)
        if len(scale) != n_features:
            raise ValueError(f"model.feature_scale has {len(scale)} entries for {n_features} node features")
        self.register_buffer("scale", torch.tensor(scale, dtype=torch.float32))

    def forward(self, x: Tensor) -> Tensor:
        return x * self.scale


class RelativeFeatures(nn.Module):
    """``model.relative_features``: the named columns of ``x`` divided by their largest
    magnitude over each graph's real nodes (padding excluded), ``[..., N, K]``."""

    def __init__(self, config: ModelConfig, n_features: int):
        super().__init__()
        names = names_for(n_features)
        missing = [name for name in config.relative_features if name not in names]
        if missing:
            raise ValueError(f"model.relative_features: {missing} are not among the node features "
                             f"{list(names)}; name some of those (or set graph.features=extended)")
        self.columns = [names.index(name) for name in config.relative_features]

    def forward(self, x: Tensor, node_mask: Tensor) -> Tensor:
        values = x[..., self.columns]
        real = node_mask.bool().unsqueeze(-1)
        largest = torch.where(real, values.abs(), torch.zeros_like(values)).amax(dim=-2, keepdim=True)
        return torch.where(real, values / largest.clamp_min(1e-9), torch.zeros_like(values))


def make_node_head(config: ModelConfig) -> nn.Sequential:
    """ReLU -> dropout -> MLP, one scalar per node. The U-Net's last GCN layer is linear;
    the ReLU before the head follows the authors' code. ``mlp_hidden=0``: one linear layer."""
    if config.mlp_hidden == 0:
        mlp = [nn.Linear(config.hidden, 1)]
    else:
        mlp = [nn.Linear(config.hidden, config.mlp_hidden), nn.ReLU(), nn.Linear(config.mlp_hidden, 1)]
    return nn.Sequential(nn.ReLU(), Dropout(config.dropout), *mlp)


def node_scores(head: nn.Module, features: Tensor, node_mask: Tensor) -> Tensor:
    """``head`` on the real nodes' features only, ``[..., N]``; 0 on padded nodes."""
    return packed_rows(head, features, node_mask).squeeze(-1)


class NodeScorer(nn.Module):
    """Feature scaling -> g-U-Net -> head: one score per node, ``[..., N]`` (0 on padding)."""

    def __init__(self, config: ModelConfig, n_features: int):
        super().__init__()
        self.scale = FeatureScale(config, n_features)
        self.relative = RelativeFeatures(config, n_features) if config.relative_features else None
        self.unet = make_unet(config, n_features + len(config.relative_features))
        self.head = make_node_head(config)

    def inputs(self, x: Tensor, node_mask: Tensor) -> Tensor:
        """The g-U-Net's input: the scaled features, then the relative ones if configured."""
        if self.relative is None:
            return self.scale(x)
        return torch.cat((self.scale(x), self.relative(x, node_mask)), dim=-1)

    def node_scores(self, x: Tensor, adj: Tensor, node_mask: Tensor, entries: Tensor | None = None) -> Tensor:
        """``entries``: ``adj.nonzero()`` if known (no scan of the adjacency: :meth:`DenseGraphUNet.forward`)."""
        return node_scores(self.head, self.unet(self.inputs(x, node_mask), adj, node_mask, entries), node_mask)


class GraphActor(NodeScorer):
    """One logit per node, ``[..., N]``; padded nodes get logit 0 (finite, and masked
    away by ``MaskedCategorical`` anyway)."""

    def forward(self, x: Tensor, adj: Tensor, node_mask: Tensor, entries: Tensor | None = None) -> Tensor:
        return self.node_scores(x, adj, node_mask.bool(), entries)


class GraphCritic(NodeScorer):
    """V(G), ``[..., 1]``: the mean of a per-node score over the graph's real nodes."""

    def forward(self, x: Tensor, adj: Tensor, node_mask: Tensor) -> Tensor:
        node_mask = node_mask.bool()
        return masked_mean(self.node_scores(x, adj, node_mask), node_mask).unsqueeze(-1)


def greedy_row(logits: Tensor, action_mask: Tensor) -> int:
    """The most probable action: the row of the largest logit among the ``action_mask``
    rows (what TorchRL's ``MaskedCategorical`` returns as its deterministic sample). The one
    greedy choice of evaluation, the runner's learned policy and deployment."""
    return int(logits.masked_fill(~action_mask, float("-inf")).argmax())


INPUT_WEIGHT = "unet.down_convs.0.lin.weight"  # the g-U-Net's first layer: (hidden, node features)
FEATURE_SCALE = "scale.scale"


def selected_inputs(weights: dict[str, Tensor], own: Sequence[str], wanted: Sequence[str],
                    scale: Tensor) -> dict[str, Tensor]:
    """A scorer's ``weights``, reading the node features ``own``, for the features ``wanted``: the input layer keeps
    its columns of the features both read (in ``wanted``'s order) and gets weight 0 on new ones (e.g. ``extended``
    -> ``loops``: it scores every graph as before until it trains). Columns of ``own`` left out keep the scores only
    if their weights are 0 (:func:`dropped_input_weight`). ``scale``: ``wanted``'s feature scales, of which the
    shared columns keep the weights' own. Input columns past ``own`` (``model.relative_features``) stay last."""
    weight, own_scale = weights[INPUT_WEIGHT], weights[FEATURE_SCALE]
    own = list(own)
    zero = weight.new_zeros(weight.shape[0])
    columns = [weight[:, own.index(name)] if name in own else zero for name in wanted]
    columns += list(weight[:, len(own):].unbind(1))  # relative features, if any
    scales = [own_scale[own.index(name)] if name in own else scale[i].to(own_scale) for i, name in enumerate(wanted)]
    return {**weights, INPUT_WEIGHT: torch.stack(columns, dim=1), FEATURE_SCALE: torch.stack(scales)}


def dropped_input_weight(weights: dict[str, Tensor], own: Sequence[str], wanted: Sequence[str]) -> float:
    """The largest input weight on the features of ``own`` that ``wanted`` leaves out (0: leaving them out changes
    no score)."""
    dropped = [i for i, name in enumerate(own) if name not in wanted]
    return float(weights[INPUT_WEIGHT][:, dropped].abs().max()) if dropped else 0.0


def masked_mean(values: Tensor, mask: Tensor) -> Tensor:
    """Mean of ``values[..., N]`` over the True entries of ``mask``; 0 for an empty graph."""
    weights = mask.to(values.dtype)
    return (values * weights).sum(-1) / weights.sum(-1).clamp_min(1.0)


def make_actor(config: ModelConfig, n_features: int, action_spec: TensorSpec | None = None,
               return_log_prob: bool = True) -> ProbabilisticActor:
    """The policy as a TorchRL actor: reads ``x``, ``adj``, ``node_mask``, ``action_mask``;
    writes ``logits``, ``action`` (a node index) and, by default, its log-probability.
    Outside ``set_exploration_type(RANDOM)`` (collectors set it) it picks the best node."""
    # TorchRL loads here, not at import: importing torchrl.modules pulls in MuJoCo, and the
    # networks above are what a deployment (explore_rl.deploy) needs, without either.
    from tensordict.nn import TensorDictModule
    from torchrl.modules import MaskedCategorical, ProbabilisticActor

    config.validate()
    module = TensorDictModule(GraphActor(config, n_features), in_keys=OBSERVATION_KEYS,
                              out_keys=["logits"])
    return ProbabilisticActor(module, in_keys={"logits": "logits", "mask": ACTION_MASK_KEY},
                              out_keys=["action"], spec=action_spec,
                              distribution_class=MaskedCategorical, return_log_prob=return_log_prob)


class UniformLogits(nn.Module):
    """Logit 0 for every node: with the mask, a uniform choice among the frontier rows."""

    def forward(self, action_mask: Tensor) -> Tensor:
        return torch.zeros(action_mask.shape, dtype=torch.float32, device=action_mask.device)


def make_random_actor() -> ProbabilisticActor:
    """A uniformly random *frontier* as a TorchRL actor: reads ``action_mask`` from each
    tensordict, so it stays valid in any collector and in spawned workers (it pickles).
    TorchRL's ``RandomPolicy`` samples a clone of the action spec taken when it is built,
    so it cannot follow a mask that changes every decision (the env's ``update_mask``
    reaches ``env.rand_action`` and ``env.rollout`` without a policy, not that clone).
    Like every masked policy here, it is never asked to act on a final observation (all
    actions masked): TorchRL's rollouts and collectors reset a finished env first."""
    from tensordict.nn import InteractionType, TensorDictModule
    from torchrl.modules import MaskedCategorical, ProbabilisticActor

    module = TensorDictModule(UniformLogits(), in_keys=[ACTION_MASK_KEY], out_keys=["logits"])
    return ProbabilisticActor(module, in_keys={"logits": "logits", "mask": ACTION_MASK_KEY}, out_keys=["action"],
                              distribution_class=MaskedCategorical, default_interaction_type=InteractionType.RANDOM)


def make_critic(config: ModelConfig, n_features: int) -> ValueOperator:
    """The value function as a TorchRL ``ValueOperator`` writing ``state_value``."""
    from torchrl.modules import ValueOperator

    config.validate()
    return ValueOperator(GraphCritic(config, n_features), in_keys=OBSERVATION_KEYS,
                         out_keys=["state_value"])
