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
