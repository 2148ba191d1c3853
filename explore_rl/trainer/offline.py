"""Train the actor offline on a dataset of EM-scored decisions (explore_rl/trainer/dataset.py).

The objective is distillation of EM's per-frontier evaluation, ``expected_reward``: minus
the policy's expected Algorithm 1 reward over every frontier node -- the same loss as
``Learner.distill_loss`` (it *is* that method, on a learner whose distillation weight is 1),
in minibatches of ``algo.dagger_batch`` drawn uniformly from the chosen decisions,
Adam at ``algo.lr``, gradient clipping at ``algo.max_grad_norm``, and dropout on (as in
the DAgger steps). No environment runs: the whole cost is the network's. The node-feature
columns are the ``graph.features`` of the config, taken by name from the dataset (an
``extended`` dataset also trains a ``paper`` actor).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import torch

from explore_rl.config import Config
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import TRAINING_PREFIX, ActorFile, save_actor_file
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DecisionDataset, padded_batch

log = logging.getLogger(__name__)

EVAL_CHUNK = 64  # decisions per forward pass when measuring the loss of a whole set


@dataclass
class OfflineResult:
    """What an offline run did: steps, how many decisions it drew from, losses, seconds."""

    steps: int
    rows: int
    seconds: float
    losses: list[float] = field(default_factory=list)  # per step (dropout on)
    skipped_steps: int = 0


def offline_config(config: Config) -> Config:
    """``config`` with the distillation objective on: weight 1, target ``expected_reward``."""
    return dataclasses.replace(config, algo=dataclasses.replace(
        config.algo, distill_coef=1.0, distill_target="expected_reward"))


def check_index(dataset: DecisionDataset, index: torch.Tensor | None) -> torch.Tensor:
    """The decisions to train on (all by default); ValueError in one line."""
    available = len(dataset)
    if available == 0:
        raise ValueError(f"{dataset.path}: the dataset holds no decisions yet")
    if index is None:
        return torch.arange(available)
    index = torch.as_tensor(index, dtype=torch.int64).flatten()
    if len(index) == 0:
        raise ValueError(f"no decisions chosen to train on (the dataset at {dataset.path} holds {available})")
    if int(index.min()) < 0 or int(index.max()) >= available:
        raise ValueError(f"decision index {int(index.max())} is outside the dataset at {dataset.path} "
                         f"(0..{available - 1})")
    return index


def distill_loss_of(learner: Learner, dataset: DecisionDataset, index: torch.Tensor, columns: list[int]) -> float:
    """Mean distillation loss over the decisions ``index`` (dropout off), in chunks."""
    learner.set_training(False)
    total, count = 0.0, 0
    with torch.no_grad():
        for chunk in index.split(EVAL_CHUNK):
            batch = padded_batch(dataset.rows(chunk), columns)
            known = int((batch["em_action"] >= 0).sum())
            if known:
                total += learner.distill_loss(batch).item() * known
                count += known
    return total / max(count, 1)


def train_offline(config: Config, dataset: DecisionDataset, steps: int, index: torch.Tensor | None = None,
                  learner: Learner | None = None) -> tuple[Learner, OfflineResult]:
    """``steps`` Adam steps of the distillation loss on minibatches of the decisions
    ``index`` (all by default), dropout on; returns the learner and what happened.
    The minibatches come from the global torch RNG (seed it for a repeatable run)."""
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    index = check_index(dataset, index)
    config = offline_config(config)
    columns = dataset.columns_for(feature_names(config.graph.features))
    learner = learner or Learner(config)
    result = OfflineResult(steps=steps, rows=len(index), seconds=0.0)
    start = time.perf_counter()
    learner.set_training(True)
    try:
        for step in range(steps):
            drawn = index[torch.randint(len(index), (min(config.algo.dagger_batch, len(index)),))]
            loss = learner.distill_loss(padded_batch(dataset.rows(drawn), columns))
            grad_norm, why_not = learner.gradient_step(loss)
            if grad_norm is None:
                result.skipped_steps += 1
                log.warning("offline step %d skipped (%s)", step, why_not)
                continue
            result.losses.append(loss.item())
    finally:
        learner.set_training(False)
    result.seconds = time.perf_counter() - start
    return learner, result


def actor_weights(learner: Learner) -> dict[str, torch.Tensor]:
    """The ``GraphActor`` state dict inside the learner's TorchRL actor."""
    return {key[len(TRAINING_PREFIX):]: value for key, value in learner.actor.state_dict().items()
            if key.startswith(TRAINING_PREFIX)}


def save_offline_actor(learner: Learner, path: str | Path, meta: dict | None = None) -> Path:
    """An actor file of the learner's actor (explore_rl/models/actor_file.py)."""
    config = learner.config
    actor_file = ActorFile(model=config.model, weights=actor_weights(learner),
                           features=list(feature_names(config.graph.features)),
                           graph_max_nodes=config.graph.max_nodes,
                           meta={"kind": "offline distillation (expected_reward)", "scene": config.scene.name,
                                 "train_layouts": config.env.train_layouts, **(meta or {})})
    return save_actor_file(path, actor_file)
