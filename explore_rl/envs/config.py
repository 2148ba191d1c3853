"""The ``env`` config group: how the TorchRL environment picks episodes."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

START_MODES = ("auto", "cycle", "sample", "default")


@dataclass
class EnvConfig:
    """Episode set-up of :class:`explore_rl.envs.explore_env.ExplorationEnv`.

    One step is one decision; an episode ends like an exploration run (``explore`` group:
    85 % explored or no reachable frontier -> terminated; travel budget or decision cap ->
    truncated).

    Layouts are scene seeds. ``train_layouts = [first, stop)``: every reset draws its
    layout uniformly from that range (seeded by the env's seed and the episode count);
    None trains on ``scene.seed`` alone (the paper's single office).
    ``validation_layouts = [first, stop)``: where models are selected
    (``benchmarks/study_learning.py``); never overlaps ``train_layouts``. Test layouts
    are whatever the evaluation command names, outside both.
    """

    # Start pose of each episode: cycle (through the scene's starts, from an offset set by
    # the seed), sample (uniformly, seeded), default (scene.start_index), or auto (cycle in
    # the office, sample in a building, the default start elsewhere, as in the paper)
    starts: str = "auto"
    train_layouts: Optional[list[int]] = None
    validation_layouts: list[int] = field(default_factory=lambda: [1000, 1010])
    # scenes kept built in one env (a building per layout costs memory; least recently used goes)
    scene_cache: int = 8
    # reward term: minus this times the growth of the map error (m) over the step; the steps add
    # up to the episode's final map error (whole-exploration credit for A2C; 0: the paper's reward)
    map_error_coef: float = 0.0

    def validate(self) -> None:
        """Raise a one-line error naming the key."""
        if self.starts not in START_MODES:
            raise ValueError(f"env.starts={self.starts!r}: choose {', '.join(START_MODES)}")
        for key in ("train_layouts", "validation_layouts"):
            bounds = getattr(self, key)
            if bounds is None and key == "train_layouts":
                continue
            if len(bounds) != 2 or not 0 <= bounds[0] < bounds[1]:
                raise ValueError(f"env.{key}={list(bounds)}: give [first, stop) with 0 <= first < stop "
                                 "(scene seeds; e.g. env.{key}=[0,1000])".replace("{key}", key))
        train, val = self.train_layouts, self.validation_layouts
        if train is not None and train[0] < val[1] and val[0] < train[1]:
            raise ValueError(f"env.train_layouts={list(train)} overlaps env.validation_layouts={list(val)}: "
                             "models must be selected on layouts training never sees")
        if not (self.map_error_coef >= 0 and math.isfinite(self.map_error_coef)):
            raise ValueError(f"env.map_error_coef must be >= 0 (finite), got {self.map_error_coef}")
        if self.scene_cache < 1:
            raise ValueError(f"env.scene_cache must be >= 1, got {self.scene_cache}")
