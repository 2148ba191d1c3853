"""A scripted tour: drive through given goals on shortest true-free-space paths, with SLAM.

Used by ``explore-rl-tour`` and ``benchmarks/bench_slam.py``: a repeatable trajectory
that visits the rooms and comes back near its start, before any exploration policy.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from explore_rl.mapping.config import PathConfig
from explore_rl.mapping.paths import PathPlanner, simplify_path, traversability
from explore_rl.robot import PathStatus, Robot
from explore_rl.run_config import TourConfig as TourConfig  # the config lives there
from explore_rl.scene.build import Scene
from explore_rl.slam.session import SlamSession


def tour_paths(config) -> PathConfig:
    """The path settings of the tour: the exploration's, with the tour's margin and costs."""
    tour = config.tour
    return replace(config.mapping.paths, inflation_margin=tour.inflation_margin,
                   clearance_weight=tour.clearance_weight, clearance_scale=tour.clearance_scale)


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


@dataclass
class TourRun:
    scene: Scene
    robot: Robot
    session: SlamSession
    status: PathStatus


def run_tour(config, goals_limit: int | None = None) -> TourRun:
    """Build the scene of ``config`` and drive its tour with SLAM (seeded by ``config.seed``)."""
    from explore_rl.scene.build import make_scene
    from explore_rl.sensors.lidar import Lidar

    config.scene.start_index = config.tour.start_index
    scene = make_scene(config.scene, config.robot, config.lidar)
    start = scene.start_pose
    goals = config.tour.goals[:goals_limit] if goals_limit else config.tour.goals
    waypoints = plan_tour(scene, start[:2], goals, config.robot.radius, tour_paths(config))
    lidar = Lidar(scene, config.lidar, np.random.default_rng([config.seed, 1]))
    robot = Robot(config.robot, start, scene.is_free, np.random.default_rng([config.seed, 2]))
    session = SlamSession(config.slam, config.mapping, scene, lidar, start,
                          np.random.default_rng([config.seed, 3]))
    status = drive_with_slam(robot, session, waypoints)
    return TourRun(scene, robot, session, status)


def drive_with_slam(robot: Robot, session: SlamSession, waypoints: np.ndarray) -> PathStatus:
    """Follow ``waypoints``; feed every motion step to SLAM; steer by the SLAM belief."""
    for step in robot.follow(waypoints):
        if session.observe(step):
            robot.correct_belief(session.belief(robot.odom_pose))
    return robot.status
