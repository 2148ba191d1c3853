"""Hydra entry points: ``explore-rl-view`` (and later -explore, -train, -eval).

The config directory is the repository's ``conf/`` (the package is installed editable by
``make``); ``hydra.job.chdir`` stays false so relative paths mean what the user typed.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import hydra
import numpy as np
from omegaconf import DictConfig, OmegaConf

from explore_rl.config import Config, register_configs, validate

CONF_DIR = str(Path(__file__).resolve().parent.parent / "conf")
log = logging.getLogger("explore_rl")

register_configs()


def to_config(cfg: DictConfig) -> Config:
    """The typed, validated config object of a Hydra job."""
    config: Config = OmegaConf.to_object(cfg)  # type: ignore[assignment]
    validate(config)
    return config


def fail(message: str) -> None:
    """Print one clear error line and exit with status 2 (no traceback)."""
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


@hydra.main(config_path=CONF_DIR, config_name="config", version_base="1.3")
def view(cfg: DictConfig) -> None:
    """Render a scene top-down: obstacles, true free space, the robot and one LiDAR scan."""
    from explore_rl import viz
    from explore_rl.scene.build import make_scene
    from explore_rl.sensors.lidar import Lidar

    try:
        config = to_config(cfg)
        scene = make_scene(config.scene, config.robot, config.lidar)
    except ValueError as error:
        fail(str(error))
    lidar = Lidar(scene, config.lidar, np.random.default_rng(config.seed))
    pose = scene.start_pose
    scan = lidar.scan(pose)
    fig, ax = viz.new_figure(scene.layout)
    viz.draw_mask(ax, scene.grid, scene.truth.reachable, "tab:green", alpha=0.15)
    viz.draw_layout(ax, scene.layout)
    viz.draw_scan(ax, pose, scan.points, config.lidar.mount_height)
    viz.draw_robot(ax, pose, config.robot.radius)
    ax.set_title(f"{scene.layout.name} (seed {config.scene.seed}, {scene.ngeom} geoms)")
    out = config.out or f"{scene.layout.name}.png"
    print(f"wrote {viz.save(fig, out)}")


@hydra.main(config_path=CONF_DIR, config_name="config", version_base="1.3")
def tour(cfg: DictConfig) -> None:
    """Drive the scripted office tour with SLAM; draw true, odometry and SLAM trajectories."""
    from explore_rl import viz
    from explore_rl.robot import Robot
    from explore_rl.scene.build import make_scene
    from explore_rl.sensors.lidar import Lidar
    from explore_rl.slam.session import SlamSession
    from explore_rl.tour import drive_with_slam, plan_tour

    try:
        config = to_config(cfg)
        config.scene.start_index = config.tour.start_index
        scene = make_scene(config.scene, config.robot, config.lidar)
        start = scene.start_pose
        waypoints = plan_tour(scene, start[:2], config.tour.goals, config.robot.radius,
                              config.mapping.paths)
    except ValueError as error:
        fail(str(error))
    rng = np.random.default_rng(config.seed)
    lidar = Lidar(scene, config.lidar, rng)
    robot = Robot(config.robot, start, scene.is_free, rng)
    session = SlamSession(config.slam, config.mapping, scene, lidar, start, rng)
    status = drive_with_slam(robot, session, waypoints)
    slam, odom = session.metrics(), session.metrics(session.odometry_poses())
    log.info("tour %s after %.1f m: %d keyframes", status.value, robot.travelled, slam.keyframes)
    log.info("ATE %.3f m (odometry %.3f m), map error %.3f m (odometry %.3f m)",
             slam.ate_m, odom.ate_m, slam.map_error_m, odom.map_error_m)
    fig, ax = viz.new_figure(scene.layout)
    viz.draw_layout(ax, scene.layout, color="0.8")
    session.draw(ax)
    viz.draw_robot(ax, robot.true_pose, config.robot.radius)
    ax.set_title(f"{scene.layout.name} tour: ATE {slam.ate_m:.3f} m (odometry {odom.ate_m:.3f} m)")
    out = config.out or "tour.png"
    print(f"wrote {viz.save(fig, out)}")
