"""Train the actor offline on a dataset of EM-scored decisions (explore_rl/trainer/dataset.py).

The objective is distillation of EM's per-frontier evaluation, by default ``expected_reward``:
minus the policy's expected Algorithm 1 reward over every frontier node (or the configured
``algo.distill_target``: ``em_choice``, ``em_choice_stakes``) -- the same loss as
``Learner.distill_loss`` (it *is* that method, on a learner whose distillation weight is 1),
in minibatches of ``algo.dagger_batch`` drawn uniformly from the chosen decisions,
Adam at ``algo.lr``, gradient clipping at ``algo.max_grad_norm``, and dropout on (as in
the DAgger steps). No environment runs: the whole cost is the network's. The node-feature
columns are the ``graph.features`` of the config, taken by name from the dataset (an
``extended`` dataset also trains a ``paper`` actor).

As a command (writes an actor file for ``policy.checkpoint`` or ``train.init_actor``)::

    explore-rl-distill --dataset DIR --out actor.pt [--steps 1000] [--scenes office building] \
        [--seed 0] [--set KEY=VALUE ...]   # e.g. --set graph.features=extended algo.lr=1e-3
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import torch

from explore_rl.config import Config, load_config
from explore_rl.envs.keys import EM_ACTION
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import TRAINING_PREFIX, ActorFile, check_output_file, save_actor_file
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
    """``config`` with the distillation objective on: weight 1, the configured
    ``algo.distill_target`` (``expected_reward`` unless set)."""
    return dataclasses.replace(config, algo=dataclasses.replace(config.algo, distill_coef=1.0))


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
            known = int((batch[EM_ACTION] >= 0).sum())
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


def save_offline_actor(learner: Learner, path: str | Path, meta: dict | None = None,
                       layouts: Sequence[int] = ()) -> Path:
    """An actor file of the learner's actor (explore_rl/models/actor_file.py). Its ``train_layouts`` (what the
    evaluation protocol refuses to test on) are the config's ``env.train_layouts`` if set, else the span
    ``[min, max + 1]`` of ``layouts``, the layouts of the decisions it trained on."""
    config = learner.config
    trained = config.env.train_layouts
    if trained is None and len(layouts):
        trained = [int(min(layouts)), int(max(layouts)) + 1]
    actor_file = ActorFile(model=config.model, weights=actor_weights(learner),
                           features=list(feature_names(config.graph.features)),
                           graph_max_nodes=config.graph.max_nodes,
                           meta={"kind": f"offline distillation ({config.algo.distill_target})", "scene": config.scene.name,
                                 "train_layouts": trained, **(meta or {})})
    return save_actor_file(path, actor_file)


def scene_index(dataset: DecisionDataset, scenes: list[str] | None) -> torch.Tensor:
    """The decisions of ``scenes`` (all by default); ValueError naming a scene it lacks."""
    if not scenes:
        return torch.arange(len(dataset))
    missing = [name for name in scenes if name not in dataset.schema.scenes]
    if missing:
        raise ValueError(f"--scenes {missing[0]}: the dataset at {dataset.path} holds {dataset.schema.scenes}")
    wanted = torch.tensor([dataset.schema.scenes.index(name) for name in scenes])
    return torch.nonzero(torch.isin(dataset.rows()["scene"], wanted)).flatten()


def main(argv: list[str] | None = None) -> None:
    """``explore-rl-distill``: an actor file distilled offline from a dataset (see the module
    docstring); prints one JSON line (steps, decisions, layouts, seconds, final loss)."""
    parser = argparse.ArgumentParser(prog="explore-rl-distill", description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", required=True, help="dataset folder (benchmarks/collect_decisions.py)")
    parser.add_argument("--out", required=True, help="actor file to write, e.g. runs/distilled/actor.pt")
    parser.add_argument("--steps", type=int, default=1000, help="minibatches of algo.dagger_batch decisions")
    parser.add_argument("--scenes", nargs="*", default=None, help="train on these scenes' decisions only")
    parser.add_argument("--seed", type=int, default=0, help="initial weights and minibatch order")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="config overrides, e.g. graph.features=extended algo.lr=1e-3")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        if args.steps < 1:
            raise ValueError(f"--steps must be >= 1, got {args.steps}")
        check_output_file(args.out)
        config = load_config([*args.set, f"seed={args.seed}"])
        dataset = DecisionDataset(args.dataset)
        index = scene_index(dataset, args.scenes)
        torch.manual_seed(args.seed)
        learner, result = train_offline(config, dataset, args.steps, index=index)
    except ValueError as error:  # CheckpointError too
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
    rows = dataset.rows(index)
    layouts = sorted(set(rows["layout"].tolist()))
    scenes = sorted({dataset.schema.scenes[i] for i in set(rows["scene"].tolist())})
    meta = {"dataset": str(Path(args.dataset).resolve()), "decisions": result.rows, "steps": result.steps,
            "layouts": len(layouts), "scenes": scenes, "seconds": round(result.seconds, 1),
            "lr": config.algo.lr, "batch": config.algo.dagger_batch, "seed": args.seed}
    path = save_offline_actor(learner, args.out, meta, layouts)
    final = sum(result.losses[-50:]) / max(len(result.losses[-50:]), 1)
    print(json.dumps({"actor": str(path), **meta, "final_loss": round(final, 4),
                      "skipped_steps": result.skipped_steps}))


if __name__ == "__main__":
    main()
