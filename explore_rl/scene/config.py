"""Structured config of the scene group (``conf/scene/*.yaml``)."""

from __future__ import annotations

from dataclasses import dataclass, field
import math
from typing import Optional

from explore_rl import checks

CORRIDOR_KINDS = ("straight", "L", "loop", "tree")
OBJECT_KINDS = ("table", "box", "pillar")


@dataclass
class BuildingConfig:
    """Knobs of ``scene=building``: a seeded family of single-floor plans (``scene/building.py``).

    Lengths are in metres and snap to ``module`` (the plan is drawn on a raster of
    ``module`` cells). The seed draws the size, the corridor kind, the rooms, the doors,
    the open hall, the clutter and the starts.
    """

    size_min: float = 15.0  # interior side length range (each side drawn independently)
    size_max: float = 35.0
    module: float = 0.5  # raster cell of the plan; every wall lies on its lines
    corridor_kinds: list[str] = field(default_factory=lambda: list(CORRIDOR_KINDS))
    corridor_weights: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0, 1.0])
    corridor_min_width: float = 1.5
    corridor_max_width: float = 2.5
    max_branches: int = 3  # tree corridors: dead-end branches off the spine (1..max)
    end_inset_probability: float = 0.3  # a spine end stops short of the outer wall
    room_min_side: float = 3.0
    room_max_side: float = 9.0  # larger zones are cut (BSP) until every side is below
    hall_probability: float = 0.35  # the plan keeps its largest zone as one open hall
    hall_min_side: float = 6.0
    hall_max_side: float = 16.0  # a larger zone is cut first; the hall is its largest piece
    door_min_width: float = 1.0  # >= 2 (robot.radius + footprint_margin), checked
    door_max_width: float = 1.6
    door_jamb: float = 0.3  # wall kept on each side of a door (no door flush in a corner)
    footprint_margin: float = 0.2  # beyond the robot radius: doors and starts keep it
    room_loop_probability: float = 0.4  # the plan gets extra doors (loops through rooms)
    max_extra_doors: int = 3
    room_door_penalty: float = 1.0  # spanning-tree bias towards doors onto corridors
    clutter_density: float = 1.5  # objects per 100 m2 of floor ...
    clutter_max: int = 14  # ... at most this many
    object_kinds: list[str] = field(default_factory=lambda: list(OBJECT_KINDS))
    object_weights: list[float] = field(default_factory=lambda: [1.0, 1.0, 1.0])
    table_length: list[float] = field(default_factory=lambda: [1.0, 2.0])  # low, long boxes
    table_width: list[float] = field(default_factory=lambda: [0.6, 1.0])
    table_height: float = 0.75
    pillar_radius: list[float] = field(default_factory=lambda: [0.15, 0.3])  # tall: wall height
    num_starts: int = 4
    max_attempts: int = 20  # re-draws (derived RNG) before a seed is given up with an error
    # A parking lot instead (the garage's kind of space): one open floor with rows of parked
    # cars (scene.car_size, scene.car_jitter) and drive lanes between them and around their
    # ends. 0 keeps the family as it was (no draw is made).
    lot_probability: float = 0.0
    lot_lane_width: list[float] = field(default_factory=lambda: [3.0, 7.0])  # between rows, and aisles at their ends
    lot_car_pitch: list[float] = field(default_factory=lambda: [2.5, 6.5])  # car centres along a row
    lot_gap_probability: float = 0.25  # a parking space left empty


@dataclass
class SceneConfig:
    """Which scene to build and the knobs of its generator.

    ``name`` is ``office``, ``street``, ``garage``, ``building`` or ``file`` (then ``path``
    names a YAML scene file). ``seed`` places the objects; the structure of ``office``,
    ``street`` and ``garage`` is fixed, a ``building``'s whole plan changes with it.
    """

    name: str = "office"
    seed: int = 0
    path: Optional[str] = None
    start_index: int = 0
    size: list[float] = field(default_factory=lambda: [20.0, 20.0])
    wall_height: float = 2.5
    wall_thickness: float = 0.2
    door_width: float = 1.2
    num_objects: int = 8
    object_min_size: float = 0.4
    object_max_size: float = 1.2
    object_min_height: float = 0.4
    object_max_height: float = 1.5
    # free space kept around every object so no passage is blocked (> robot diameter)
    object_clearance: float = 0.8
    # free space kept around every start
    start_clearance: float = 1.0
    # garage (and scene=building's parking lots): car footprint/height; garage only: the y of each row
    car_size: list[float] = field(default_factory=lambda: [1.9, 4.5, 1.5])
    car_rows_y: list[float] = field(default_factory=lambda: [4.0, 11.25, 22.5])
    car_jitter: float = 0.15
    # walls longer than this are built as several geoms (faster ray casting, see build.py)
    max_geom_length: float = 6.0
    # resolution of the ground-truth grid (and of every 2D map built on it)
    grid_resolution: float = 0.1
    # scene=building only: the generator's knobs (conf/scene/building.yaml)
    building: BuildingConfig = field(default_factory=BuildingConfig)


def validate_building(scene: SceneConfig, robot_radius: float) -> None:
    """Every ``scene.building.*`` knob in its range (see :class:`BuildingConfig`); one-line
    ``ValueError`` naming the key, the allowed range and what it depends on."""
    b, wall_thickness, key = scene.building, scene.wall_thickness, "scene.building."
    for name in ("size_min", "size_max", "module", "corridor_min_width", "corridor_max_width", "room_min_side",
                 "room_max_side", "hall_min_side", "hall_max_side", "door_min_width", "door_max_width", "door_jamb", "table_height"):
        checks.positive(key + name, getattr(b, name))
    for name in ("footprint_margin", "room_door_penalty", "clutter_density"):
        checks.non_negative(key + name, getattr(b, name))
    for name, low in (("clutter_max", 0), ("max_extra_doors", 0), ("max_branches", 1), ("num_starts", 1),
                      ("max_attempts", 1)):
        checks.at_least(key + name, getattr(b, name), low)
    for name in ("end_inset_probability", "hall_probability", "room_loop_probability", "lot_probability",
                 "lot_gap_probability"):
        checks.in_range(key + name, getattr(b, name), 0.0, 1.0)
    at_least = [  # (key, value, lower bound, what the bound is)
        ("size_max", b.size_max, b.size_min, "scene.building.size_min"),
        ("corridor_max_width", b.corridor_max_width, b.corridor_min_width, "scene.building.corridor_min_width"),
        ("door_max_width", b.door_max_width, b.door_min_width, "scene.building.door_min_width"),
        ("door_min_width", b.door_min_width, 2 * (robot_radius + b.footprint_margin),
         "2 (robot.radius + scene.building.footprint_margin): the robot must pass every door"),
        ("corridor_min_width", b.corridor_min_width, b.door_min_width + wall_thickness,
         "scene.building.door_min_width + scene.wall_thickness: no corridor narrower than a door"),
        ("room_min_side", b.room_min_side, b.door_min_width + 2 * b.door_jamb,
         "scene.building.door_min_width + 2 scene.building.door_jamb: a door fits on every wall"),
        ("room_min_side", b.room_min_side, 2 * b.module, "2 scene.building.module"),
        ("room_max_side", b.room_max_side, 2 * b.room_min_side, "2 scene.building.room_min_side (to cut a zone)"),
        ("hall_min_side", b.hall_min_side, b.room_min_side, "scene.building.room_min_side"),
        ("hall_max_side", b.hall_max_side, max(b.hall_min_side, 2 * b.room_min_side),
         "scene.building.hall_min_side and 2 scene.building.room_min_side"),
        ("door_jamb", b.door_jamb, wall_thickness / 2, "scene.wall_thickness / 2"),
        ("size_min", b.size_min, 3 * b.room_min_side + 2 * b.corridor_max_width,
         "3 scene.building.room_min_side + 2 scene.building.corridor_max_width (a loop corridor fits)"),
    ]
    for name, value, bound, what in at_least:
        if not value >= bound - 1e-9:
            raise ValueError(f"{key}{name}={value} must be >= {what} = {bound:g}")
    _check_choice(f"{key}corridor_kinds", b.corridor_kinds, CORRIDOR_KINDS, f"{key}corridor_weights",
                  b.corridor_weights)
    _check_choice(f"{key}object_kinds", b.object_kinds, OBJECT_KINDS, f"{key}object_weights", b.object_weights)
    for name in ("table_length", "table_width", "pillar_radius", "lot_lane_width", "lot_car_pitch"):
        low_high = list(getattr(b, name))
        if len(low_high) != 2 or not 0 < low_high[0] <= low_high[1] < float("inf"):
            raise ValueError(f"{key}{name} must be [min, max] with 0 < min <= max (finite), got {low_high}")
    _check_lot(scene, robot_radius)
    footprints = {"table_length": math.hypot(b.table_length[1], b.table_width[1]) / 2,
                  "pillar_radius": b.pillar_radius[1],
                  "scene.object_max_size": math.hypot(scene.object_max_size, scene.object_max_size) / 2}
    for name, radius in footprints.items():
        if radius + scene.object_clearance >= b.size_min / 2:
            raise ValueError(f"{name if '.' in name else key + name}: objects of footprint radius {radius:g} m "
                             f"+ scene.object_clearance={scene.object_clearance:g} must fit in half of "
                             f"scene.building.size_min={b.size_min:g}")


def _check_lot(scene: SceneConfig, robot_radius: float) -> None:
    """The parking-lot knobs (their [min, max] ranges already checked): a car shape, lanes
    the robot drives and rows of cars that fit."""
    b, key = scene.building, "scene.building."
    car = list(scene.car_size)
    if len(car) != 3 or not all(0 < v < float("inf") for v in car):
        raise ValueError(f"scene.car_size must be [across, along, height] > 0 (m), got {car}")
    lane = 2 * (robot_radius + b.footprint_margin)
    if b.lot_lane_width[0] < lane:
        raise ValueError(f"{key}lot_lane_width={list(b.lot_lane_width)}: its min must be >= 2 (robot.radius + "
                         f"scene.building.footprint_margin) = {lane:g} so the robot drives every lane")
    if b.lot_car_pitch[0] < car[0]:
        raise ValueError(f"{key}lot_car_pitch={list(b.lot_car_pitch)}: its min must be >= the car's width "
                         f"scene.car_size[0]={car[0]:g} (cars must not overlap)")
    if b.lot_probability > 0 and b.size_min < car[1] + 2 * b.lot_lane_width[0]:
        raise ValueError(f"{key}size_min={b.size_min:g} must be >= a car's length + 2 narrowest lanes "
                         f"({car[1] + 2 * b.lot_lane_width[0]:g}) for a parking lot (lot_probability > 0)")


def _check_choice(key: str, kinds: list[str], allowed: tuple[str, ...], weights_key: str,
                  weights: list[float]) -> None:
    """``kinds`` drawn from ``allowed`` with one non-negative weight each, not all zero."""
    unknown = [k for k in kinds if k not in allowed]
    if not kinds or unknown:
        raise ValueError(f"{key}={list(kinds)}: choose a non-empty list from {', '.join(allowed)}")
    if len(weights) != len(kinds) or any(not 0 <= w < float("inf") for w in weights) or not sum(weights) > 0:
        raise ValueError(f"{weights_key}={list(weights)} needs one finite weight >= 0 per entry of {key} "
                         f"({len(kinds)}), not all zero")
