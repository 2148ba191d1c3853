"""Actor files: the trained policy alone (weights + model config + a format tag), for
evaluation and deployment.

A training checkpoint (explore_rl/models/checkpoint.py) also holds the critic, the
optimiser and the run's counters -- three times the size, and tied to the trainer. An
actor file holds what choosing a frontier needs:

* ``format``: ``"explore_rl.actor/1"``;
* ``model``: the ``ModelConfig`` as a dict (the network is rebuilt from it, so the file
  carries its own size: hidden 1000 is ~25 MB of float32);
* ``features``: the node features the actor reads, in order (the exploration graph's);
* ``actor``: the ``GraphActor`` state dict; ``graph_max_nodes``: the padding it was trained
  with; ``meta``: where it came from (run, updates, decisions, scene, front end).

:func:`load_actor` also accepts a training checkpoint (its actor is used), so
``policy.checkpoint=RUN/checkpoints/best.pt`` works before anything is exported. Every
failure -- missing, unreadable, not ours, a model that does not match the file's weights
or the caller's expectation, a different feature count -- is a :class:`CheckpointError`
with one line naming the file and what does not match (the checks are checkpoint.py's).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from explore_rl.graph.exploration_graph import FEATURES
from explore_rl.graph.features import feature_names, feature_scales, feature_set_of
from explore_rl.models.actor_critic import FEATURE_SCALE, GraphActor, dropped_input_weight, selected_inputs
from explore_rl.models.config import ModelConfig
from explore_rl.resources import shipped_file
from explore_rl.models.checkpoint import FORMAT as TRAINING_FORMAT
from explore_rl.models.checkpoint import CheckpointError, check_model, check_weights, read_checkpoint

ACTOR_FORMAT = "explore_rl.actor/1"
DEFAULT_ACTOR = "policies/buildings_dagger_em_choice/actor.pt"  # the shipped policy (explore_rl/resources.py finds it)
TRAINING_PREFIX = "module.0.module."  # ProbabilisticActor -> TensorDictModule -> GraphActor
HOW_TO_GET_ONE = ("train one with `explore-rl-train scene=office slam=model out=runs/office`, then "
                  "`explore-rl-export runs/office/checkpoints/best.pt " + DEFAULT_ACTOR + "`")


@dataclass
class ActorFile:
    """The contents of an actor file (or the actor part of a training checkpoint)."""

    model: ModelConfig
    weights: dict[str, torch.Tensor]  # GraphActor state dict
    features: list[str] = field(default_factory=lambda: list(FEATURES))
    graph_max_nodes: int = 512
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n_features(self) -> int:
        return len(self.features)

    @property
    def feature_set(self) -> str:
        """The ``graph.features`` this actor reads (paper or extended)."""
        return feature_set_of(self.features)


def resolve(path: str | Path | None) -> Path:
    """``path``; None or the default ``policies/buildings_dagger_em_choice/actor.pt`` mean the shipped policy,
    found from the working directory or else where the package keeps it (the repository of
    an editable install, the wheel's package data)."""
    if path in (None, "") or Path(path) == Path(DEFAULT_ACTOR):
        local = Path(DEFAULT_ACTOR)
        try:
            shipped = shipped_file(DEFAULT_ACTOR)  # the repository's or the wheel's (explore_rl/resources.py)
        except FileNotFoundError:
            return local
        return local if local.exists() or not shipped.exists() else shipped
    return Path(path)


def read_actor_file(path: str | Path) -> ActorFile:
    """The actor of an actor file or a training checkpoint; CheckpointError if unusable."""
    path = Path(path)
    payload = read_checkpoint(path, formats=(ACTOR_FORMAT, TRAINING_FORMAT), missing_hint=HOW_TO_GET_ONE)
    try:
        model = ModelConfig(**payload["model"])
        model.validate()
    except (KeyError, TypeError, ValueError) as error:
        raise CheckpointError(f"{path}: its model config is not usable ({error})") from None
    if payload["format"] == TRAINING_FORMAT:
        weights = {key[len(TRAINING_PREFIX):]: value for key, value in payload["actor"].items()
                   if key.startswith(TRAINING_PREFIX)}
        config = payload.get("config", {})
        meta = {"source": str(path), "kind": "training checkpoint", **payload.get("state", {})}
        meta.pop("episodes", None)
        meta.update(scene=config.get("scene", {}).get("name"), slam=config.get("slam", {}).get("frontend"),
                    seed=config.get("seed"), scene_seed=config.get("scene", {}).get("seed"),
                    train_layouts=config.get("env", {}).get("train_layouts"))
        features = list(feature_names(config.get("graph", {}).get("features", "paper")))
        return ActorFile(model, weights, features, int(config.get("graph", {}).get("max_nodes", 512)), meta)
    return ActorFile(model, payload["actor"], list(payload.get("features", FEATURES)),
                     int(payload.get("graph_max_nodes", 512)), dict(payload.get("meta", {})))


def build_actor(path: str | Path, actor_file: ActorFile, expected_model: ModelConfig | None = None) -> GraphActor:
    """The checked ``GraphActor`` of ``actor_file`` (read from ``path``), in eval mode."""
    path = Path(path)
    try:
        feature_set_of(actor_file.features)
    except ValueError as error:
        raise CheckpointError(f"{path}: {error}") from None
    if expected_model is not None:
        check_model(path, dataclasses.asdict(actor_file.model), expected_model)
    try:
        actor = GraphActor(actor_file.model, actor_file.n_features)
    except ValueError as error:  # e.g. feature_scale of the wrong length
        raise CheckpointError(f"{path}: {error}") from None
    check_weights(path, "actor", actor_file.weights, actor)
    check_finite(path, actor_file.weights)
    actor.load_state_dict(actor_file.weights)
    return actor.eval()


def check_finite(path: str | Path, weights: dict[str, torch.Tensor]) -> None:
    """Every weight finite: a NaN or inf (a diverged run) would make every logit NaN and the
    policy silently choose like the nearest frontier."""
    bad = [key for key, tensor in weights.items()
           if torch.is_tensor(tensor) and tensor.is_floating_point() and not bool(torch.isfinite(tensor).all())]
    if bad:
        raise CheckpointError(f"{path}: actor weight {bad[0]!r} holds NaN or inf ({len(bad)} of {len(weights)} "
                              "tensors are not finite; the training diverged): use an earlier checkpoint")


def check_output_file(path: str | Path, example: str = "actor.pt") -> Path:
    """``path`` names a file that can be written (not a folder): ValueError in one line."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder: give the file to write, e.g. {path / example}")
    if path.parent.exists() and not path.parent.is_dir():
        raise ValueError(f"{path}: {path.parent} is a file, not a folder")
    return path


def load_actor(path: str | Path | None = None, expected_model: ModelConfig | None = None
               ) -> tuple[GraphActor, ActorFile]:
    """The actor of ``path`` (default: the shipped policy), checked, in eval mode.

    ``expected_model``: fail unless the file's model has this shape (hidden, depth, ...)."""
    path = resolve(path)
    actor_file = read_actor_file(path)
    return build_actor(path, actor_file, expected_model), actor_file


def save_actor_file(path: str | Path, actor_file: ActorFile) -> Path:
    """Write ``actor_file`` atomically (a temporary file renamed into place; removed again
    if writing fails). ValueError if ``path`` is a folder."""
    path = check_output_file(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {
        "format": ACTOR_FORMAT,
        "model": dataclasses.asdict(actor_file.model),
        "features": list(actor_file.features),
        "graph_max_nodes": int(actor_file.graph_max_nodes),
        "actor": {key: value.detach().to(torch.float32).contiguous().clone() for key, value in actor_file.weights.items()},
        "meta": actor_file.meta,
    }
    partial = path.with_name(path.name + ".tmp")
    try:
        torch.save(payload, partial)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
    return path


def with_features(actor_file: ActorFile, feature_set: str) -> ActorFile:
    """The same actor reading ``graph.features=feature_set``: the input layer's columns selected
    (:func:`~explore_rl.models.actor_critic.selected_inputs`). Only exact: every feature it leaves out must
    have input weight 0 (an actor trained blind to them, e.g. ``no_covariance`` from an ``extended`` one
    fine-tuned without its covariance columns), else ValueError naming the largest such weight. New
    features get weight 0, so it scores every graph as before."""
    wanted = list(feature_names(feature_set))
    dropped = dropped_input_weight(actor_file.weights, actor_file.features, wanted)
    if dropped != 0.0:
        raise ValueError(f"--features {feature_set}: the actor's input weights on the features it would leave out "
                         f"reach {dropped:.3g}, so it would decide differently; only an actor blind to them converts")
    scale = torch.tensor(feature_scales(feature_set), dtype=torch.float32)
    weights = selected_inputs(actor_file.weights, actor_file.features, wanted, scale)
    model = actor_file.model
    if model.feature_scale is not None:
        model = dataclasses.replace(model, feature_scale=[float(s) for s in weights[FEATURE_SCALE]])
    meta = {**actor_file.meta, "converted_from_features": actor_file.feature_set}
    return ActorFile(model, weights, wanted, actor_file.graph_max_nodes, meta)


def export_actor_file(checkpoint: str | Path, out: str | Path, features: str | None = None) -> Path:
    """An actor file at ``out`` from a training checkpoint (or another actor file), checked
    by loading it back; ``features``: converted to that feature set (:func:`with_features`)."""
    checkpoint = Path(checkpoint)
    check_output_file(out)
    actor_file = read_actor_file(checkpoint)
    build_actor(checkpoint, actor_file)  # the weights fit the model before anything is written
    if features is not None:
        actor_file = with_features(actor_file, features)
    path = save_actor_file(out, actor_file)
    load_actor(path)
    return path
