"""VLP-16-style LiDAR on batched ``mujoco.mj_multiRay`` — the only ray-casting call site.

A scan casts ``channels x azimuths`` rays from the sensor (mounted ``mount_height`` above
the robot base) and returns the noisy hit points in the sensor frame (x forward, y left,
z up) and, separately, the unit directions that had no return within ``max_range`` (the
mapper clears free space along them). The robot's own geoms are in a group the LiDAR
leaves out, and its body is excluded too, so the robot never sees itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from explore_rl.geometry import rotation_2d
from explore_rl.scene.build import ROBOT_GEOM_GROUP, Scene


@dataclass
class LidarConfig:
    """VLP-16 defaults with the range capped at 3 m (paper, Sec. IV-A)."""

    channels: int = 16
    min_elevation_deg: float = -15.0
    max_elevation_deg: float = 15.0
    azimuth_resolution_deg: float = 0.4
    max_range: float = 3.0
    min_range: float = 0.1
    range_noise: float = 0.01
    mount_height: float = 0.4


@dataclass
class Scan:
    """One scan in the sensor frame."""

    points: np.ndarray  # (K, 3) hit points
    no_return_dirs: np.ndarray  # (M, 3) unit directions with no return within max_range
    ranges: np.ndarray  # (N,) per ray; -1 where no return


def ray_directions(config: LidarConfig) -> np.ndarray:
    """Unit ray directions in the sensor frame, channel-major, shape (channels * azimuths, 3)."""
    elevations = np.deg2rad(
        np.linspace(config.min_elevation_deg, config.max_elevation_deg, config.channels)
    )
    n_azimuth = int(round(360.0 / config.azimuth_resolution_deg))
    azimuths = np.deg2rad(np.arange(n_azimuth) * config.azimuth_resolution_deg)
    el, az = np.meshgrid(elevations, azimuths, indexing="ij")
    dirs = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=-1)
    return dirs.reshape(-1, 3)


class Lidar:
    """Casts one batched ``mj_multiRay`` per scan. Hold one per process (it holds the GIL)."""

    def __init__(self, scene: Scene, config: LidarConfig, rng: np.random.Generator):
        self.scene = scene
        self.config = config
        self.rng = rng
        self.directions = ray_directions(config)
        n = len(self.directions)
        self._world_dirs = np.empty(3 * n, dtype=np.float64)
        self._geomid = np.empty(n, dtype=np.int32)
        self._dist = np.empty(n, dtype=np.float64)
        self._geomgroup = np.ones(6, dtype=np.uint8)
        self._geomgroup[ROBOT_GEOM_GROUP] = 0

    @property
    def rays_per_scan(self) -> int:
        return len(self.directions)

    def sensor_position(self, pose: np.ndarray) -> np.ndarray:
        return np.array([pose[0], pose[1], self.config.mount_height], dtype=np.float64)

    def cast(self, pose: np.ndarray) -> np.ndarray:
        """Noise-free ranges (N,) from the sensor on the robot at planar ``pose``; -1 = none."""
        rot = rotation_2d(float(pose[2]))
        world = self._world_dirs.reshape(-1, 3)
        world[:, :2] = self.directions[:, :2] @ rot.T
        world[:, 2] = self.directions[:, 2]
        mujoco.mj_multiRay(
            self.scene.model, self.scene.data, self.sensor_position(pose), self._world_dirs,
            self._geomgroup, 1, self.scene.robot_body_id, self._geomid, self._dist, None,
            len(self.directions), self.config.max_range,
        )
        ranges = self._dist.copy()
        ranges[(ranges > self.config.max_range) | (ranges < self.config.min_range)] = -1.0
        return ranges

    def scan(self, pose: np.ndarray) -> Scan:
        """A noisy scan from the robot at its *true* planar ``pose``."""
        self.scene.set_robot_pose(pose)
        ranges = self.cast(pose)
        hit = ranges > 0
        noisy = ranges[hit] + self.rng.normal(0.0, self.config.range_noise, size=int(hit.sum()))
        points = self.directions[hit] * noisy[:, None]
        return Scan(points=points, no_return_dirs=self.directions[~hit], ranges=ranges)
