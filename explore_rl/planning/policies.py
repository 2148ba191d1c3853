"""Exploration policies behind one small interface: given the exploration state, pick a frontier.

Baselines live here (nearest frontier, random frontier); the EM planner and the learned
policy implement the same :class:`Policy` protocol.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np

from explore_rl.planning.config import PolicyConfig as PolicyConfig  # the config lives there

if TYPE_CHECKING:
    from explore_rl.state import ExplorationState


class Policy(Protocol):
    name: str

    def choose(self, state: "ExplorationState") -> int:
        """Index into ``state.candidates`` of the frontier to visit next."""
        ...


class NearestFrontier:
    """Yamauchi's nearest frontier: the candidate with the shortest path."""

    name = "nearest"

    def choose(self, state: "ExplorationState") -> int:
        return state.nearest


class RandomFrontier:
    """A uniformly random reachable frontier (seeded)."""

    name = "random"

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def choose(self, state: "ExplorationState") -> int:
        return int(self.rng.integers(len(state.candidates)))


def make_policy(config: PolicyConfig, rng: np.random.Generator, planning=None, robot=None,
                graph=None) -> Policy:
    """The policy named by ``config.name``; ``planning`` (PlanningConfig), ``robot``
    (RobotConfig) and ``graph`` (GraphConfig) configure the planners that need them."""
    if config.name == "nearest":
        return NearestFrontier()
    if config.name == "random":
        return RandomFrontier(rng)
    if config.name == "em":
        from explore_rl.planning.em import EMPlanner

        return EMPlanner(config, planning, robot=robot)
    if config.name == "learned":
        from explore_rl.planning.learned import LearnedPolicy

        return LearnedPolicy(config, planning, graph=graph, robot=robot)
    raise ValueError(f"unknown policy.name={config.name!r}; choose nearest, random, em or learned")
