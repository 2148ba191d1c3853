"""VLP-16-style LiDAR on batched ``mujoco.mj_multiRay`` — the only ray-casting call site.

A scan casts ``channels x azimuths`` rays from the sensor (mounted ``mount_height`` above
the robot base) and returns the noisy hit points in the sensor frame (x forward, y left,
z up) and, separately, the unit directions that had no return within ``max_range`` (the
mapper clears free space along them). The robot never sees itself: by default the rays
are cast on :class:`StaticTiles` (models of the static scene near the robot, which have no
robot in them); cast on the full scene model (``tile_size: 0``) the robot's geoms are in a
group the LiDAR leaves out and its body is excluded too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from explore_rl.scene.build import ROBOT_GEOM_GROUP, Scene
from explore_rl.sensors.config import LidarConfig as LidarConfig  # the config lives there


@dataclass
class Scan:
    """One scan in the sensor frame."""

    points: np.ndarray  # (K, 3) hit points
    no_return_dirs: np.ndarray  # (M, 3) unit directions with no return within max_range
    ranges: np.ndarray  # (N,) per ray; -1 where no return
    # Ray of each point (increasing), when the points are exactly the returns of the rays
    # (a LiDAR scan; lets the 2D collapse skip re-binning them: RayGridCollapse).
    hit_index: np.ndarray | None = None


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


class StaticTiles:
    """Small MuJoCo models of the static scene, one per square tile of the floor plan.

    ``mj_multiRay`` visits every geom of its model for every ray, even the ones it culls
    (about ten instructions each: a quarter of a scan in the 41-geom office, measured
    with callgrind). The model of a tile holds only the scene's static geoms whose
    bounding sphere comes within ``reach`` (the LiDAR's range) of some point of the tile,
    in 2D, which is conservative in 3D: a geom left out cannot be hit from a sensor over
    that tile. Same geoms, same poses, so the same ranges (``tests/sensors``); ~10 instead
    of 41 geoms in the office. Tiles are built when first needed (a few ms each) and are
    not pickled. The scene is static: rebuild the tiles if its geoms move.
    """

    def __init__(self, scene: Scene, tile_size: float, reach: float):
        if not tile_size > 0:
            raise ValueError(f"lidar.tile_size must be positive for StaticTiles, got {tile_size}")
        self.scene = scene
        self.tile_size = tile_size
        self.reach = reach
        model, data = scene.model, scene.data
        static = np.flatnonzero(model.geom_bodyid == 0)
        self._static = static
        self._center_xy = data.geom_xpos[static, :2].copy()
        self._reach = reach + model.geom_rbound[static] + 1e-6
        self._plane = model.geom_type[static] == mujoco.mjtGeom.mjGEOM_PLANE
        self._tiles: dict[tuple[int, int], tuple[mujoco.MjModel, mujoco.MjData]] = {}

    def __len__(self) -> int:
        return len(self._tiles)

    def tile_of(self, xy: np.ndarray) -> tuple[int, int]:
        return math.floor(float(xy[0]) / self.tile_size), math.floor(float(xy[1]) / self.tile_size)

    def model_at(self, xy: np.ndarray) -> tuple[mujoco.MjModel, mujoco.MjData]:
        """Model and data of the tile under the planar position ``xy``."""
        tile = self.tile_of(xy)
        if tile not in self._tiles:
            self._tiles[tile] = self._build(tile)
        return self._tiles[tile]

    def geoms_near(self, tile: tuple[int, int]) -> np.ndarray:
        """Scene geom ids that a sensor over ``tile`` could hit (planes always)."""
        low = np.asarray(tile, dtype=float) * self.tile_size
        gap = np.maximum(0.0, np.maximum(low - self._center_xy, self._center_xy - (low + self.tile_size)))
        near = np.hypot(gap[:, 0], gap[:, 1]) <= self._reach
        return self._static[near | self._plane]

    def _build(self, tile: tuple[int, int]) -> tuple[mujoco.MjModel, mujoco.MjData]:
        model, data = self.scene.model, self.scene.data
        spec = mujoco.MjSpec()
        for g in self.geoms_near(tile):
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, data.geom_xmat[g])
            spec.worldbody.add_geom(
                type=mujoco.mjtGeom(model.geom_type[g]), size=model.geom_size[g].tolist(),
                pos=data.geom_xpos[g].tolist(), quat=quat.tolist(), rgba=model.geom_rgba[g].tolist(),
            )
        tile_model = spec.compile()
        tile_data = mujoco.MjData(tile_model)
        mujoco.mj_kinematics(tile_model, tile_data)
        return tile_model, tile_data


class Lidar:
    """Casts one batched ``mj_multiRay`` per scan. Hold one per process (it holds the GIL).

    Everything around the cast is kept lean (preallocated buffers, ``np.take`` instead of
    fancy indexing, a complex multiply for the yaw rotation, no BLAS call that would wake
    a thread pool): the post-processing was a third of a scan before.
    """

    def __init__(self, scene: Scene, config: LidarConfig, rng: np.random.Generator):
        self.scene = scene
        self.config = config
        self.rng = rng
        self.directions = ray_directions(config)
        n = len(self.directions)
        self._directions_xy = self.directions[:, 0] + 1j * self.directions[:, 1]
        self._world_dirs = np.empty((n, 3), dtype=np.float64)
        self._world_dirs[:, 2] = self.directions[:, 2]
        # (x, y) of each world direction seen as one complex number, written in place.
        self._world_xy = self._world_dirs[:, :2].view(np.complex128)[:, 0]
        self._geomid = np.empty(n, dtype=np.int32)
        self._dist = np.empty(n, dtype=np.float64)
        self._geomgroup = np.ones(6, dtype=np.uint8)
        self._geomgroup[ROBOT_GEOM_GROUP] = 0
        # mj_multiRay reports -1 for no hit: a positive lower bound rejects it too.
        self._lowest_range = max(config.min_range, np.finfo(float).tiny)
        self.tiles = StaticTiles(scene, config.tile_size, config.max_range) if config.tile_size > 0 else None

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["tiles"] = None if self.tiles is None else (self.tiles.tile_size, self.tiles.reach)
        return state

    def __setstate__(self, state: dict) -> None:
        tiles = state.pop("tiles")
        self.__dict__.update(state)
        self._world_xy = self._world_dirs[:, :2].view(np.complex128)[:, 0]
        self.tiles = None if tiles is None else StaticTiles(self.scene, *tiles)

    @property
    def rays_per_scan(self) -> int:
        return len(self.directions)

    def sensor_position(self, pose: np.ndarray) -> np.ndarray:
        return np.array([pose[0], pose[1], self.config.mount_height], dtype=np.float64)

    def cast_raw(self, pose: np.ndarray) -> np.ndarray:
        """Raw ``mj_multiRay`` distances (-1: no hit, may exceed the range) from the sensor at
        planar ``pose``, in a buffer reused by the next cast (copy to keep them)."""
        np.multiply(self._directions_xy, np.exp(1j * float(pose[2])), out=self._world_xy)
        if self.tiles is None:
            model, data = self.scene.model, self.scene.data
            geomgroup, exclude = self._geomgroup, self.scene.robot_body_id
        else:
            (model, data), geomgroup, exclude = self.tiles.model_at(pose), None, -1
        mujoco.mj_multiRay(
            model, data, self.sensor_position(pose), self._world_dirs.reshape(-1), geomgroup, 1, exclude,
            self._geomid, self._dist, None, len(self.directions), self.config.max_range,
        )
        return self._dist

    def _returns(self, dist: np.ndarray) -> np.ndarray:
        return (dist >= self._lowest_range) & (dist <= self.config.max_range)

    def cast(self, pose: np.ndarray) -> np.ndarray:
        """Noise-free ranges (N,) from the sensor on the robot at planar ``pose``; -1 = none."""
        dist = self.cast_raw(pose)
        return np.where(self._returns(dist), dist, -1.0)

    def scan(self, pose: np.ndarray) -> Scan:
        """A noisy scan from the robot at its *true* planar ``pose``."""
        points, hit, hit_index, dist = self._noisy_returns(pose)
        no_return_dirs = self.directions.take(np.flatnonzero(~hit), axis=0)
        return Scan(points=points, no_return_dirs=no_return_dirs, ranges=np.where(hit, dist, -1.0),
                    hit_index=hit_index)

    def points(self, pose: np.ndarray) -> np.ndarray:
        """The hit points alone of :meth:`scan` (the same noise draws), for callers that
        need nothing else (the safety layer's ring, cast every motion step)."""
        return self._noisy_returns(pose)[0]

    def _noisy_returns(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Noisy hit points (sensor frame), the rays with a return (mask and indices), the raw distances."""
        self.scene.set_robot_pose(pose)
        dist = self.cast_raw(pose)
        hit = self._returns(dist)
        hit_index = np.flatnonzero(hit)
        noisy = dist.take(hit_index)
        noisy += self.rng.normal(0.0, self.config.range_noise, size=len(hit_index))
        points = self.directions.take(hit_index, axis=0)
        points *= noisy[:, None]
        return points, hit, hit_index, dist
