"""Configuration of the mapping stage (plain dataclasses: they double as Hydra structured configs).

Every tunable number used by ``occupancy``, ``voxels``, ``frontiers`` and ``paths`` lives
here; ``conf/mapping/default.yaml`` repeats the same defaults.
"""

from __future__ import annotations

from dataclasses import dataclass, field

MAP_UPDATES = ("incremental", "rebuild")  # mapping.updates


@dataclass
class OccupancyConfig:
    """3D scan -> 2D scan collapse and the 2D log-odds occupancy grid."""

    # Height classes in the gravity-aligned base frame (metres above the floor).
    floor_max_height: float = 0.1  # below: floor, i.e. free-space evidence
    obstacle_min_height: float = 0.15  # from here ...
    obstacle_max_height: float = 0.6  # ... to here (robot height + margin); above: ignored
    azimuth_bins: int = 900  # 360 deg / 0.4 deg
    max_range: float = 3.0  # sensor range (m); no-return rays clear up to it
    # Log-odds update per scan and clamping.
    log_odds_free: float = -0.4
    log_odds_occupied: float = 0.85
    log_odds_min: float = -2.0
    log_odds_max: float = 3.5
    # A cell is known free below / known occupied above these log-odds.
    free_threshold: float = -0.2
    occupied_threshold: float = 0.5
    # Beam sampling step, as a fraction of a cell.
    ray_step_cells: float = 0.5
    # A hit point is pushed this fraction of a cell along its beam, so a surface lying
    # exactly on a cell boundary marks the cell behind it (inside the obstacle).
    hit_nudge_cells: float = 0.01


@dataclass
class VoxelConfig:
    """3D voxel map used for the coverage-volume metric."""

    voxel_size: float = 0.1
    # mapping.updates=incremental: when loop closures move a keyframe by more than a 2D
    # cell, every keyframe whose 3D cloud lies more than this (m; turns: this at the
    # sensor range) from its estimate is re-projected too. A cell (0.1 m) let the 3D
    # volume run 6 % above a rebuild at the final estimates on a 40-decision office
    # exploration (walls thickened by stale clouds); the reference rebuild re-projects all.
    reproject_shift: float = 0.02


@dataclass
class FrontierConfig:
    """Frontier detection and clustering on the 2D grid."""

    neighbourhood: int = 4  # a free cell touching unknown through 4 or 8 neighbours is a frontier
    min_cluster_cells: int = 5  # smaller clusters are dropped
    # clusters longer than this (m) are cut into tiles of this size, one waypoint each
    max_cluster_extent: float = 2.0
    # If no cell of a cluster is traversable, look for a waypoint this far (m) around it;
    # a cluster with none is dropped (it cannot be reached).
    waypoint_search_radius: float = 0.5


@dataclass
class PathConfig:
    """Traversability and grid Dijkstra."""

    inflation_margin: float = 0.0  # added to the robot radius when inflating obstacles (m)
    grid_border_is_obstacle: bool = True  # the scene grid ends at the walls: keep clear of its edge
    clearance_weight: float = 1.0  # cell cost = 1 + weight * exp(-clearance / scale)
    clearance_scale: float = 0.3  # m; clearance counted from the inflated boundary
    allow_corner_cutting: bool = False  # diagonal steps need both side cells traversable
    start_snap_radius: float = 0.3  # m; a blocked start snaps to a traversable cell this close


@dataclass
class MappingConfig:
    """The ``mapping`` config group: one section per module."""

    # How the SLAM session keeps its maps in step when loop closures move poses:
    # "incremental" re-projects only the keyframes whose pose moved by more than a cell
    # (counted 3D voxels, kept 2D beam cells, the 2D collapse on the LiDAR's ray grid);
    # "rebuild" is the reference: every keyframe again whenever any moved, collapse_scan
    # (slow; equivalence tests and benchmarks/bench_drive.py).
    updates: str = "incremental"
    occupancy: OccupancyConfig = field(default_factory=OccupancyConfig)
    voxels: VoxelConfig = field(default_factory=VoxelConfig)
    frontiers: FrontierConfig = field(default_factory=FrontierConfig)
    paths: PathConfig = field(default_factory=PathConfig)
