"""Checkpoints and actor files for tests, built in a second (random weights, tiny model)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import torch

from explore_rl.config import Config, load_config
from explore_rl.envs.keys import NEAREST_ACTION
from explore_rl.models.actor_file import export_actor_file
from explore_rl.trainer.a2c import Learner, RunState
from explore_rl.models.checkpoint import Checkpoint, save_checkpoint

TINY_MODEL = ["model.hidden=16", "model.mlp_hidden=16"]


def training_checkpoint(path: Path, config: Config | None = None, seed: int = 0) -> tuple[Path, Learner]:
    """A training checkpoint of a freshly initialised learner (``TINY_MODEL`` by default)."""
    config = config or load_config(TINY_MODEL)
    torch.manual_seed(seed)
    learner = Learner(config)
    checkpoint = Checkpoint(config=config, actor=learner.actor.state_dict(), critic=learner.critic.state_dict(),
                            optimizer=learner.optimizer.state_dict(), state=dataclasses.asdict(RunState()),
                            torch_rng=torch.get_rng_state())
    return save_checkpoint(path, checkpoint), learner


def actor_file(directory: Path, config: Config | None = None, seed: int = 0) -> tuple[Path, Learner]:
    """An actor file (``directory/actor.pt``) exported from :func:`training_checkpoint`."""
    checkpoint, learner = training_checkpoint(directory / "training.pt", config, seed)
    return export_actor_file(checkpoint, directory / "actor.pt"), learner


def env_decisions(config: Config, learner: Learner, steps: int):
    """Yield ``(decision, candidate)``: the env's decisions along an episode driven by the
    nearest frontier, each with the candidate the learner's TorchRL actor picks greedily
    there (``MaskedCategorical``'s deterministic sample, as evaluation acts). The decision's
    state is live: use it before asking for the next one."""
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from explore_rl.envs import make_env

    env = make_env(config)
    td = env.reset()
    for _ in range(steps):
        decision = env.decision
        with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
            row = int(learner.actor(td.clone())["action"])
        yield decision, decision.actions[decision.action_of_row(row)].candidate
        td = env.step(td.set("action", td[NEAREST_ACTION]))["next"]
        if bool(td["done"]):
            return
