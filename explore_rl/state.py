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
