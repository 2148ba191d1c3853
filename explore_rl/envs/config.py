"""The ``env`` config group: how the TorchRL environment picks episodes."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class EnvConfig:
    """Episode set-up of :class:`explore_rl.envs.explore_env.ExplorationEnv`.

    One step is one decision; an episode ends like an exploration run (``explore`` group:
    85 % explored or no reachable frontier -> terminated; travel budget or decision cap ->
    truncated).
    """

    # Start pose of each episode: cycle (through the scene's starts, from an offset set by
    # the seed), sample (uniformly, seeded), default (scene.start_index), or auto (cycle in
    # the office, the default start elsewhere, as in the paper)
    starts: str = "auto"
