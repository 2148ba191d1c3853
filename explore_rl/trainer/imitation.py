"""EM-labelled decisions kept for imitation: a TorchRL replay buffer of compact graphs.

The env scores every decision with EM (the Algorithm 1 reward) and so knows EM's choice
(``("expert", "em_action")``) at no extra cost. A2C uses each decision once; kept here,
every labelled decision the policy has visited also feeds ``algo.dagger_steps`` supervised
steps per update (DAgger: the states come from the learner's own policy, the labels from
the expert), which is what makes an hour of CPU collection enough to move the policy.

Graphs have different sizes, and a padded ``adj[N, N]`` per decision would cost a
megabyte, so each decision is stored trimmed to its real nodes with its edges as a list
(``ListStorage`` holds tensordicts of any shape); :func:`pad_graphs` rebuilds a padded
batch, as wide as the largest graph sampled, for the actor.

A compact decision is a stored row, not an observation: its label columns keep the flat
names ``em_action`` and ``action_rewards`` (as the dataset's on-disk columns and the
buffers in older checkpoints do), and a padded batch returns them under ``("expert", ...)``
as the env does (explore_rl/envs/keys.py), where no policy reads.

With ``train.dataset=PATH`` the buffer is an on-disk dataset instead
(explore_rl/trainer/dataset.py: fixed-size rows in a ``LazyMemmapStorage``): every labelled
decision of the run is appended there, and a run can start from decisions other runs or
collectors stored (``algo.dagger_buffer`` is then not the limit, ``train.dataset_capacity`` is).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import ListStorage, ReplayBuffer

from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, EXPERT
from explore_rl.trainer.dataset import DatasetSchema, DecisionDataset

if TYPE_CHECKING:
    from explore_rl.config import Config

METADATA = ("layout", "episode")  # per-decision keys kept when the batch has them


def compact_decisions(batch: TensorDictBase) -> list[TensorDict]:
    """The decisions of ``batch`` (any batch shape) that have an EM label and a frontier,
    each as a small tensordict: ``x[n, F]``, ``edges[2, E]`` (i < j), ``weights[E]``,
    ``action_mask[n]``, ``action_rewards[n]``, ``em_action`` (and ``layout``, ``episode``
    when the batch has them)."""
    flat = batch.reshape(-1)
    labelled = (flat[EM_ACTION] >= 0) & flat["action_mask"].any(-1)
    decisions = []
    for index in torch.nonzero(labelled).flatten().tolist():
        node_mask = flat["node_mask"][index].bool()
        n = int(node_mask.sum())  # real nodes come first (explore_rl.graph.encode)
        upper = torch.triu(flat["adj"][index, :n, :n], diagonal=1)
        edges = torch.nonzero(upper).T.to(torch.int32)
        decision = TensorDict({
            "x": flat["x"][index, :n].clone(),
            "edges": edges,
            "weights": upper[edges[0].long(), edges[1].long()],
            "action_mask": flat["action_mask"][index, :n].clone(),
            "action_rewards": flat[ACTION_REWARDS][index, :n].clone(),
            "em_action": flat[EM_ACTION][index].clone(),
        }, batch_size=[])
        for key in METADATA:
            if key in flat.keys():
                decision[key] = flat[key][index].clone()
        decisions.append(decision)
    return decisions


def pad_graphs(decisions: list[TensorDictBase]) -> TensorDict:
    """A padded batch ``[B]`` (``x``, symmetric ``adj``, ``node_mask``, ``action_mask``,
    ``("expert", "action_rewards")``, ``("expert", "em_action")``) of compact decisions,
    ``n = `` the largest graph's size."""
    sizes = [d["x"].shape[0] for d in decisions]
    width, features = max(sizes), decisions[0]["x"].shape[-1]
    count = len(decisions)
    x = torch.zeros(count, width, features)
    adj = torch.zeros(count, width, width)
    node_mask = torch.zeros(count, width, dtype=torch.bool)
    action_mask = torch.zeros(count, width, dtype=torch.bool)
    action_rewards = torch.zeros(count, width)
    for row, (decision, n) in enumerate(zip(decisions, sizes)):
        x[row, :n] = decision["x"]
        i, j = decision["edges"].long()
        adj[row, i, j] = decision["weights"]
        adj[row, j, i] = decision["weights"]
        node_mask[row, :n] = True
        action_mask[row, :n] = decision["action_mask"]
        action_rewards[row, :n] = decision["action_rewards"]
    labels = torch.stack([d["em_action"] for d in decisions])
    return TensorDict({"x": x, "adj": adj, "node_mask": node_mask, "action_mask": action_mask,
                       EXPERT: {ACTION_REWARDS[1]: action_rewards, EM_ACTION[1]: labels}}, batch_size=[count])


def make_label_buffer(capacity: int, batch_size: int) -> ReplayBuffer:
    """A replay buffer of the last ``capacity`` labelled decisions, sampled uniformly
    (with the global torch RNG, so an exact resume samples the same minibatches)."""
    return ReplayBuffer(storage=ListStorage(max_size=capacity), batch_size=batch_size,
                        collate_fn=pad_graphs)


class DatasetLabels:
    """The DAgger buffer on disk (``train.dataset``): the same ``extend``/``sample``/``len``
    as the in-memory buffer; the decisions persist in the dataset folder, so a checkpoint
    holds only where they are (a resume reads what is on disk then)."""

    def __init__(self, dataset: DecisionDataset, scene: str):
        self.dataset, self.scene = dataset, scene

    def extend(self, decisions: list[TensorDictBase]) -> None:
        self.dataset.append(decisions, self.scene)

    def sample(self) -> TensorDict:
        return self.dataset.sample()

    def __len__(self) -> int:
        return len(self.dataset)

    def state_dict(self) -> dict:
        return {"dataset": str(Path(self.dataset.path).resolve()), "decisions": len(self.dataset)}

    def load_state_dict(self, state: dict) -> None:
        """Nothing to restore: the decisions are on disk (possibly more than at the save)."""


def make_labels(config: Config) -> ReplayBuffer | DatasetLabels:
    """The DAgger buffer of ``config``: in memory (``algo.dagger_buffer`` decisions), or the
    dataset at ``train.dataset`` (created with the run's graph shapes, or opened: its shapes
    must match the run's)."""
    from explore_rl.graph.features import feature_names

    algo, train = config.algo, config.train
    if train.dataset is None:
        return make_label_buffer(algo.dagger_buffer, algo.dagger_batch)
    schema = DatasetSchema(max_nodes=config.graph.max_nodes, max_edges=train.dataset_max_edges,
                           features=list(feature_names(config.graph.features)), capacity=train.dataset_capacity)
    return DatasetLabels(DecisionDataset(train.dataset, schema, batch_size=algo.dagger_batch), config.scene.name)
