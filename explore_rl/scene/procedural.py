"""Seeded procedural floor plans: ``office`` (training), ``street`` and ``garage`` (test).

Each generator returns a plain :class:`~explore_rl.scene.layout.Layout`. The structure
(walls, doors, starts) is fixed per scene; ``config.seed`` only places the objects, as the
paper placed its 8 office objects once. Objects keep ``object_clearance`` from every
solid and ``start_clearance`` from every start, so no passage is ever blocked.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Callable

import numpy as np

from explore_rl.scene.config import SceneConfig
from explore_rl.scene.layout import Box, Cylinder, Geometry2D, Layout, Wall

Start = tuple[float, float, float]


def wall_with_doors(
    start: tuple[float, float],
    end: tuple[float, float],
    door_centers: list[float],
    door_width: float,
    thickness: float,
) -> list[Wall]:
    """Split the wall ``start -> end`` into segments, leaving a gap at each door.

    ``door_centers`` are distances along the wall from ``start``.
    """
    p0, p1 = np.asarray(start, float), np.asarray(end, float)
    length = float(np.linalg.norm(p1 - p0))
    direction = (p1 - p0) / length
    cuts = [0.0]
    for center in sorted(door_centers):
        cuts += [center - door_width / 2, center + door_width / 2]
    cuts.append(length)
    walls = []
    for a, b in zip(cuts[0::2], cuts[1::2]):
        if b - a > 1e-6:
            pa, pb = p0 + a * direction, p0 + b * direction
            walls.append(Wall(tuple(pa), tuple(pb), thickness))
    return walls


def office_layout(config: SceneConfig) -> Layout:
    """20 m x 20 m office: a corridor, three rooms south, two rooms north, loops via doors."""
    sx, sy = config.size
    w, t = config.door_width, config.wall_thickness
    corridor_south, corridor_north = 0.425 * sy, 0.575 * sy
    walls = (
        wall_with_doors((0, corridor_south), (sx, corridor_south), [3.5, 10.0, 16.5], w, t)
        + wall_with_doors((0, corridor_north), (sx, corridor_north), [5.0, 15.0], w, t)
        + wall_with_doors((7.0, 0), (7.0, corridor_south), [4.0], w, t)
        + wall_with_doors((13.0, 0), (13.0, corridor_south), [], w, t)
        + wall_with_doors((10.0, corridor_north), (10.0, sy), [4.5], w, t)
    )
    starts: list[Start] = [
        (2.5, 10.0, 0.0), (10.0, 10.0, 0.0), (17.5, 10.0, np.pi),
        (3.5, 4.5, np.pi / 2), (10.0, 4.5, np.pi / 2), (16.5, 4.5, np.pi / 2),
        (5.0, 16.0, -np.pi / 2), (15.0, 16.0, -np.pi / 2), (2.5, 18.5, 0.0),
    ]
    base = Layout("office", (sx, sy), walls=tuple(walls), starts=tuple(starts),
                  wall_height=config.wall_height, perimeter_thickness=t)
    return place_random_objects(base, config, random_office_object)


def street_layout(config: SceneConfig) -> Layout:
    """20 m x 20 m street: four building blocks around a crossing, a few street objects."""
    sx, sy = config.size
    rng = np.random.default_rng(config.seed)
    blocks = []
    for cx, cy in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)]:
        bx, by = rng.uniform(0.22, 0.28, size=2) * np.array([sx, sy])
        blocks.append(Box((cx * sx, cy * sy), (float(bx), float(by), config.wall_height)))
    starts: list[Start] = [(sx / 2, sy / 2, 0.0), (sx / 2, 0.06 * sy, 0.0), (0.06 * sx, sy / 2, 0.0)]
    base = Layout("street", (sx, sy), boxes=tuple(blocks), starts=tuple(starts),
                  wall_height=config.wall_height, perimeter_thickness=config.wall_thickness)
    return place_random_objects(base, config, random_street_object, seed_offset=1)


def garage_layout(config: SceneConfig) -> Layout:
    """30 m x 30 m garage: 15 evenly spaced cars in three rows; the centre is a drive lane."""
    sx, sy = config.size
    rng = np.random.default_rng(config.seed)
    rows = config.car_rows_y
    per_row = config.num_objects // len(rows)
    if per_row * len(rows) != config.num_objects:
        raise ValueError(
            f"scene.num_objects={config.num_objects} must be a multiple of "
            f"len(scene.car_rows_y)={len(rows)} for the garage"
        )
    xs = (np.arange(per_row) + 0.5) * sx / per_row
    cars = []
    for y in rows:
        for x in xs:
            jitter = rng.uniform(-config.car_jitter, config.car_jitter, size=3)
            cars.append(Box((float(x + jitter[0]), float(y + jitter[1])),
                            tuple(config.car_size), float(jitter[2])))
    starts: list[Start] = [(sx / 2, sy / 2, 0.0), (sx / 2, sy / 2, np.pi / 2)]
    return Layout("garage", (sx, sy), boxes=tuple(cars), starts=tuple(starts),
                  wall_height=config.wall_height, perimeter_thickness=config.wall_thickness)


def random_office_object(rng: np.random.Generator, config: SceneConfig) -> Box | Cylinder:
    """Boxes and cylinders of varied sizes (furniture)."""
    height = float(rng.uniform(config.object_min_height, config.object_max_height))
    if rng.random() < 0.6:
        sx, sy = rng.uniform(config.object_min_size, config.object_max_size, size=2)
        return Box((0.0, 0.0), (float(sx), float(sy), height), float(rng.uniform(-np.pi, np.pi)))
    diameter = rng.uniform(config.object_min_size, config.object_max_size)
    return Cylinder((0.0, 0.0), float(diameter / 2), height)


def random_street_object(rng: np.random.Generator, config: SceneConfig) -> Box | Cylinder:
    """Poles (thin, tall cylinders) and benches (long, low boxes): unlike the office's."""
    if rng.random() < 0.5:
        return Cylinder((0.0, 0.0), float(rng.uniform(0.1, 0.2)), float(rng.uniform(1.8, 2.4)))
    length = float(rng.uniform(1.4, 2.2))
    return Box((0.0, 0.0), (length, 0.45, 0.5), float(rng.choice([0.0, np.pi / 2])))


def footprint_radius(obj: Box | Cylinder) -> float:
    if isinstance(obj, Cylinder):
        return obj.radius
    return float(np.hypot(obj.size[0], obj.size[1]) / 2)


def moved(obj: Box | Cylinder, center: tuple[float, float]) -> Box | Cylinder:
    if isinstance(obj, Cylinder):
        return Cylinder(center, obj.radius, obj.height)
    return Box(center, obj.size, obj.yaw)


def place_random_objects(
    base: Layout,
    config: SceneConfig,
    make_object: Callable[[np.random.Generator, SceneConfig], Box | Cylinder],
    seed_offset: int = 0,
    max_attempts: int = 10_000,
) -> Layout:
    """Rejection-sample ``config.num_objects`` objects clear of solids, starts and each other.

    The base's geometry is built once and the placed objects' only when one is added (the
    clearance is the smaller of the two), so a try costs two distance queries.
    """
    rng = np.random.default_rng([config.seed, seed_offset])
    fixed, placed = Geometry2D.from_layout(base), Geometry2D()
    boxes, cylinders = list(base.boxes), list(base.cylinders)
    starts_xy = np.array([s[:2] for s in base.starts]).reshape(-1, 2)
    sx, sy = base.size
    target = len(boxes) + len(cylinders) + config.num_objects
    for _ in range(max_attempts):
        if len(boxes) + len(cylinders) == target:
            break
        obj = make_object(rng, config)
        radius = footprint_radius(obj)
        margin = radius + config.object_clearance
        center = (float(rng.uniform(margin, sx - margin)), float(rng.uniform(margin, sy - margin)))
        xy = np.array(center)
        clear_of_solids = min(fixed.signed_distance(xy), placed.signed_distance(xy)) >= margin
        clear_of_starts = np.all(
            np.linalg.norm(starts_xy - center, axis=1) >= radius + config.start_clearance
        )
        if clear_of_solids and clear_of_starts:
            (cylinders if isinstance(obj, Cylinder) else boxes).append(moved(obj, center))
            new = Layout(base.name, base.size, boxes=tuple(boxes[len(base.boxes):]),
                         cylinders=tuple(cylinders[len(base.cylinders):]), perimeter=False)
            placed = Geometry2D.from_layout(new)
    if len(boxes) + len(cylinders) < target:
        raise RuntimeError(
            f"could not place {config.num_objects} objects in scene {base.name!r}: "
            "lower scene.num_objects or scene.object_clearance"
        )
    return replace(base, boxes=tuple(boxes), cylinders=tuple(cylinders))


GENERATORS: dict[str, Callable[[SceneConfig], Layout]] = {
    "office": office_layout,
    "street": street_layout,
    "garage": garage_layout,
}
