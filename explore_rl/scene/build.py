"""Layout -> ``mujoco.MjSpec`` -> ``MjModel``, and the :class:`Scene` that holds them.

Structure and state are kept apart (as in dm_control): a :class:`Scene` is regenerated
only from its config (layout + model), while the robot's pose is state that is set on
it. Each wall segment and object is one geom, so a procedural scene stays well under
~60 geoms and ray casting stays fast. The robot is a mocap body whose geoms sit in
``ROBOT_GEOM_GROUP``; the LiDAR leaves that group out, so the robot never sees itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from explore_rl.grid import GridSpec
from explore_rl.scene.building import building_layout
from explore_rl.scene.config import SceneConfig
from explore_rl.scene.layout import Box, Geometry2D, Layout
from explore_rl.scene.procedural import GENERATORS
from explore_rl.scene.scene_file import load_scene_file
from explore_rl.scene.truth import GroundTruth, free_space, layout_grid

ROBOT_GEOM_GROUP = 3
SCENE_GEOM_GROUP = 0


@dataclass
class RobotBodyConfig:
    """What the model needs to know of the robot (a subset of ``RobotConfig``)."""

    radius: float
    body_size: tuple[float, float, float]
    lidar_height: float


def make_layout(config: SceneConfig, robot_radius: float) -> Layout:
    """The layout named by ``config.name``: a procedural scene or a YAML scene file."""
    if config.name == "file":
        if not config.path:
            raise ValueError("scene=file needs a path: add scene.path=/path/to/scene.yaml")
        return load_scene_file(config.path, robot_radius=robot_radius)
    if config.name == "building":  # the one generator that checks connectivity for the footprint
        return building_layout(config, robot_radius)
    if config.name not in GENERATORS:
        choices = ", ".join([*GENERATORS, "building", "file"])
        raise ValueError(f"unknown scene.name={config.name!r}; choose one of: {choices}")
    return GENERATORS[config.name](config)


def split_box(box: Box, max_length: float) -> list[Box]:
    """Cut a box along its long side into equal pieces no longer than ``max_length``.

    ``mj_multiRay`` culls geoms per ray by their angular extent and by distance; a 20 m
    wall passes both tests for half the rays of every scan, six-metre pieces do not.
    """
    long_axis = 0 if box.size[0] >= box.size[1] else 1
    pieces = max(1, int(np.ceil(box.size[long_axis] / max_length)))
    if pieces == 1:
        return [box]
    size = list(box.size)
    size[long_axis] /= pieces
    direction = np.array([np.cos(box.yaw), np.sin(box.yaw)])
    if long_axis == 1:
        direction = np.array([-direction[1], direction[0]])
    offsets = (np.arange(pieces) + 0.5) * size[long_axis] - box.size[long_axis] / 2
    return [Box(tuple(np.asarray(box.center) + o * direction), tuple(size), box.yaw) for o in offsets]


def build_spec(layout: Layout, robot: RobotBodyConfig, max_geom_length: float = np.inf) -> mujoco.MjSpec:
    """A MuJoCo spec of the layout: floor, walls and objects as static geoms, a mocap robot."""
    spec = mujoco.MjSpec()
    spec.modelname = layout.name
    world = spec.worldbody
    sx, sy = layout.size
    margin = 2.0 * layout.perimeter_thickness + 1.0
    world.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[sx / 2 + margin, sy / 2 + margin, 0.1], pos=[sx / 2, sy / 2, 0.0],
        group=SCENE_GEOM_GROUP, rgba=[0.85, 0.85, 0.8, 1],
    )
    walls = [piece for box in layout.wall_boxes() for piece in split_box(box, max_geom_length)]
    for i, box in enumerate(walls):
        add_box_geom(world, f"wall{i}", box, rgba=[0.6, 0.6, 0.65, 1])
    for i, box in enumerate(layout.boxes):
        add_box_geom(world, f"box{i}", box, rgba=[0.8, 0.5, 0.3, 1])
    for i, cyl in enumerate(layout.cylinders):
        world.add_geom(
            name=f"cylinder{i}", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[cyl.radius, cyl.height / 2, 0.0], pos=[*cyl.center, cyl.height / 2],
            group=SCENE_GEOM_GROUP, rgba=[0.3, 0.6, 0.8, 1],
        )
    body = world.add_body(name="robot", mocap=True)
    half = np.asarray(robot.body_size) / 2
    body.add_geom(
        name="robot_chassis", type=mujoco.mjtGeom.mjGEOM_BOX,
        size=half.tolist(), pos=[0, 0, half[2]], group=ROBOT_GEOM_GROUP,
        contype=0, conaffinity=0, rgba=[0.9, 0.8, 0.1, 1],
    )
    body.add_geom(
        name="robot_lidar", type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.05, 0.04, 0], pos=[0, 0, robot.lidar_height - 0.04], group=ROBOT_GEOM_GROUP,
        contype=0, conaffinity=0, rgba=[0.1, 0.1, 0.1, 1],
    )
    body.add_site(name="lidar", pos=[0, 0, robot.lidar_height])
    return spec


def add_box_geom(world: mujoco.MjsBody, name: str, box, rgba: list[float]) -> None:
    world.add_geom(
        name=name, type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[box.size[0] / 2, box.size[1] / 2, box.size[2] / 2],
        pos=[box.center[0], box.center[1], box.size[2] / 2],
        quat=[np.cos(box.yaw / 2), 0.0, 0.0, np.sin(box.yaw / 2)],
        group=SCENE_GEOM_GROUP, rgba=rgba,
    )


class Scene:
    """A built scene: layout, MuJoCo model/data, analytic 2D geometry and ground truth.

    Pickles by config only (MuJoCo objects are rebuilt on unpickling), so TorchRL
    workers can receive one. Rebuilding from the same config gives an identical model.
    """

    def __init__(self, config: SceneConfig, robot: RobotBodyConfig):
        self.config = config
        self.robot_body = robot
        self._build()

    def _build(self) -> None:
        self.layout = make_layout(self.config, self.robot_body.radius)
        self.model = build_spec(self.layout, self.robot_body, self.config.max_geom_length).compile()
        self.data = mujoco.MjData(self.model)
        self.robot_body_id = self.model.body("robot").id
        self.geometry: Geometry2D = self.layout.geometry()
        self.grid: GridSpec = layout_grid(self.layout, self.config.grid_resolution)
        self.set_robot_pose(np.asarray(self.start_pose))
        self.truth: GroundTruth = free_space(
            self.layout, self.grid, self.robot_body.radius, self.start_pose[:2]
        )

    def __getstate__(self) -> dict:
        return {"config": self.config, "robot_body": self.robot_body}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._build()

    @property
    def start_pose(self) -> np.ndarray:
        starts = self.layout.starts
        index = self.config.start_index
        if not 0 <= index < len(starts):
            raise ValueError(
                f"scene.start_index={index} but scene {self.layout.name!r} has {len(starts)} "
                f"starts: use 0..{len(starts) - 1}"
            )
        return np.asarray(starts[index], dtype=float)

    @property
    def ngeom(self) -> int:
        return int(self.model.ngeom)

    def set_robot_pose(self, pose: np.ndarray) -> None:
        """Move the robot's mocap body to the planar pose ``[x, y, yaw]``."""
        x, y, yaw = (float(v) for v in pose)
        self.data.mocap_pos[0] = [x, y, 0.0]
        self.data.mocap_quat[0] = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        mujoco.mj_kinematics(self.model, self.data)

    def footprint_clearance(self, xy: np.ndarray, radius: float | None = None) -> np.ndarray:
        """Gap (m) between a footprint disc at ``xy`` (…, 2) and the nearest solid; < 0: collision."""
        r = self.robot_body.radius if radius is None else radius
        return self.geometry.signed_distance(xy) - r

    def is_free(self, xy: np.ndarray, radius: float | None = None) -> np.ndarray:
        """Whether a footprint disc at ``xy`` (…, 2) stays clear of every solid."""
        return self.footprint_clearance(xy, radius) >= 0.0


def make_scene(scene: SceneConfig, robot, lidar) -> Scene:
    """Build a :class:`Scene` from the scene, robot and lidar config groups."""
    body = RobotBodyConfig(
        radius=robot.radius, body_size=tuple(robot.body_size), lidar_height=lidar.mount_height
    )
    return Scene(scene, body)
