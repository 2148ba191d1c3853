"""Structured config of the scene group (``conf/scene/*.yaml``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional


@dataclass
class SceneConfig:
    """Which scene to build and the knobs of its generator.

    ``name`` is ``office``, ``street``, ``garage`` or ``file`` (then ``path`` names a YAML
    scene file). ``seed`` places the objects; the structure of a procedural scene is fixed.
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
    # garage only: car footprint/height and the y of each parking row
    car_size: list[float] = field(default_factory=lambda: [1.9, 4.5, 1.5])
    car_rows_y: list[float] = field(default_factory=lambda: [4.0, 11.25, 22.5])
    car_jitter: float = 0.15
    # walls longer than this are built as several geoms (faster ray casting, see build.py)
    max_geom_length: float = 6.0
    # resolution of the ground-truth grid (and of every 2D map built on it)
    grid_resolution: float = 0.1
