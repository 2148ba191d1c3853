"""What a policy sees at a decision: the candidates (frontier + path) and the SLAM state.

These types sit below the runner, the planners and the environment (all of them import
this module; it imports none of them), so that a planner never needs the runner.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from explore_rl.mapping.frontiers import Frontier
from explore_rl.mapping.paths import DistanceField

if TYPE_CHECKING:
    from explore_rl.slam.session import SlamSession


@dataclass
class Candidate:
    """A reachable frontier and the path the robot would drive to it."""

    frontier: Frontier
    path: np.ndarray  # (K, 2) world xy from the robot to the frontier's waypoint
    length: float


@dataclass
class ExplorationState:
    """What a policy sees at a decision."""

    session: SlamSession
    pose: np.ndarray  # belief pose [x, y, yaw]
    travel: float
    candidates: list[Candidate]
    nearest: int  # index into candidates of the shortest path
    distance_field: DistanceField
    traversable: np.ndarray

    def same_observation(self, other: ExplorationState) -> bool:
        """Whether ``other`` observed the same moment identically: the same candidates
        (frontier cells, waypoints, paths, lengths), nearest, traversable cells and distance
        field, bit for bit (the runner's observation against its reference)."""
        if len(self.candidates) != len(other.candidates) or self.nearest != other.nearest:
            return False
        for mine, theirs in zip(self.candidates, other.candidates):
            if not (np.array_equal(mine.frontier.cells, theirs.frontier.cells)
                    and np.array_equal(mine.frontier.waypoint_cell, theirs.frontier.waypoint_cell)
                    and np.array_equal(mine.path, theirs.path) and mine.length == theirs.length):
                return False
        return (np.array_equal(self.traversable, other.traversable)
                and np.array_equal(self.distance_field.distances, other.distance_field.distances)
                and np.array_equal(self.distance_field.predecessors, other.distance_field.predecessors))
