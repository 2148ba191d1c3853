"""Checkpoints of a training run: weights, optimiser, RNG and counters in one file.

Written atomically (a temporary file renamed into place), so a run killed while saving
keeps its previous checkpoint. Loading checks the file before anything uses it and fails
with one line naming the file and what does not match (a missing or unreadable file, a
different model, a different feature count).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import torch

if TYPE_CHECKING:  # not imported at run time: explore_rl.config pulls in the simulator and SLAM
    from explore_rl.config import Config

FORMAT = "explore_rl.a2c/1"
MODEL_KEYS_THAT_SHAPE_WEIGHTS = ("hidden", "depth", "mlp_hidden", "sum_res")


@dataclass
class Checkpoint:
    config: Config
    actor: dict[str, Any]
    critic: dict[str, Any]
    optimizer: dict[str, Any]
    state: dict[str, Any]  # RunState as a dict
    torch_rng: torch.Tensor
    label_buffer: dict[str, Any] | None = None  # the imitation replay buffer (last.pt only)


class CheckpointError(ValueError):
    """A checkpoint that cannot be used with this config (the message says why)."""


def save_checkpoint(path: Path, checkpoint: Checkpoint) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "format": FORMAT,
        "model": dataclasses.asdict(checkpoint.config.model),
        "config": dataclasses.asdict(checkpoint.config),
        "actor": checkpoint.actor,
        "critic": checkpoint.critic,
        "optimizer": checkpoint.optimizer,
        "state": checkpoint.state,
        "torch_rng": checkpoint.torch_rng,
        "label_buffer": checkpoint.label_buffer,
    }
    partial = path.with_suffix(".tmp")
    torch.save(payload, partial)
    os.replace(partial, path)
    return path


def load_failure_reason(error: Exception) -> str:
    """The first line of ``torch.load``'s error, without its advice to load with
    ``weights_only=False`` (unsafe, and no help for a file that is not ours)."""
    first_line = str(error).splitlines()[0] if str(error) else ""
    if first_line.startswith("Weights only load failed"):
        return "corrupt, or it holds objects other than tensors and plain data"
    return first_line


def read_checkpoint(path: Path, formats: tuple[str, ...] = (FORMAT,),
                    missing_hint: str = "train first, or check the path / out=") -> dict:
    """The raw payload of ``path``; CheckpointError if it is missing or not ours.

    ``formats``: the format tags accepted (actor files, explore_rl/models/actor_file.py,
    add theirs); ``missing_hint``: what the error for a missing file tells the user to do."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no checkpoint there ({missing_hint})")
    try:
        payload = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:  # noqa: BLE001 -- any unreadable file gets the same one-line error
        raise CheckpointError(f"{path}: not a readable checkpoint ({type(error).__name__}: "
                              f"{load_failure_reason(error)}); check the path, or re-create the file "
                              "with explore-rl-train / explore-rl-export") from None
    if not isinstance(payload, dict) or payload.get("format") not in formats:
        found = payload.get("format") if isinstance(payload, dict) else type(payload).__name__
        expected = repr(formats[0]) if len(formats) == 1 else "one of " + ", ".join(map(repr, formats))
        raise CheckpointError(f"{path}: not an explore_rl {'training ' if formats == (FORMAT,) else ''}"
                              f"checkpoint (format {found!r}, expected {expected})")
    return payload


def check_model(path: Path, saved: dict, config: Config) -> None:
    """The saved model must have the config's shape: name the first field that differs.
    ``config``: a :class:`Config` or just its ``model`` (a ``ModelConfig``)."""
    current = dataclasses.asdict(getattr(config, "model", config))
    for key in MODEL_KEYS_THAT_SHAPE_WEIGHTS:
        if saved.get(key) != current.get(key):
            raise CheckpointError(f"{path}: model.{key} is {saved.get(key)!r} in the checkpoint but "
                                  f"{current.get(key)!r} in the config (use model.{key}={saved.get(key)} "
                                  "or a new run folder)")


def check_weights(path: Path, name: str, saved: dict, module: torch.nn.Module) -> None:
    """Every saved tensor must fit the module (catches a different feature count)."""
    expected = module.state_dict()
    for key, tensor in saved.items():
        if key not in expected:
            raise CheckpointError(f"{path}: {name} weight {key!r} does not exist in this model")
        if tuple(tensor.shape) != tuple(expected[key].shape):
            raise CheckpointError(f"{path}: {name} weight {key!r} has shape {tuple(tensor.shape)}, "
                                  f"this model expects {tuple(expected[key].shape)} (a different feature "
                                  "count or model size)")
    missing = sorted(set(expected) - set(saved))
    if missing:
        raise CheckpointError(f"{path}: {name} weights missing from the checkpoint: {missing[:3]}")


def load_checkpoint(path: Path, config: Config) -> Checkpoint:
    """A checked checkpoint for ``config`` (see the module docstring)."""
    payload = read_checkpoint(path)
    check_model(path, payload["model"], config)
    return Checkpoint(config=config, actor=payload["actor"], critic=payload["critic"],
                      optimizer=payload["optimizer"], state=payload["state"], torch_rng=payload["torch_rng"],
                      label_buffer=payload.get("label_buffer"))
