"""A scripted tour: drive through given goals on shortest true-free-space paths, with SLAM.

Used by ``explore-rl-tour`` and ``benchmarks/bench_slam.py``: a repeatable trajectory
that visits the rooms and comes back near its start, before any exploration policy.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from explore_rl.mapping.config import PathConfig
from explore_rl.mapping.paths import PathPlanner, simplify_path, traversability
from explore_rl.robot import PathStatus, Robot
from explore_rl.scene.build import Scene
from explore_rl.slam.session import SlamSession


@dataclass
class TourConfig:
    start_index: int = 1
    goals: list[list[float]] = field(default_factory=list)


def plan_tour(scene: Scene, start_xy: np.ndarray, goals: list[list[float]], robot_radius: float,
              config: PathConfig) -> np.ndarray:
    """Waypoints (K, 2) through every goal in order, on the true free space."""
    truth = scene.truth
    traversable, cost = traversability(truth.free, ~truth.free, scene.grid, robot_radius, config)
    planner = PathPlanner(scene.grid, traversable, cost, config)
    legs, here = [], np.asarray(start_xy, float)
    for goal in goals:
        path = planner.from_start(here).path_to_xy(np.asarray(goal, float))
        if path is None:
            raise ValueError(f"tour goal {goal} cannot be reached from {here.round(2).tolist()} "
                             f"in scene {scene.layout.name!r}; move it into free space")
        legs.append(simplify_path(path)[1:])
        here = path[-1]
    return np.vstack(legs)


def drive_with_slam(robot: Robot, session: SlamSession, waypoints: np.ndarray) -> PathStatus:
    """Follow ``waypoints``; feed every motion step to SLAM; steer by the SLAM belief."""
    for step in robot.follow(waypoints):
        if session.observe(step):
            robot.correct_belief(session.belief(robot.odom_pose))
    return robot.status
