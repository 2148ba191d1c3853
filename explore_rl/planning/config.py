"""Configuration of the virtual map, revisit prediction and reward (plain dataclasses).

These become Hydra structured configs (``conf/planning/default.yaml`` holds the same
defaults); keep every field a plain type.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class VirtualMapConfig:
    """Virtual landmarks of the EM utility (Wang et al.); values from the paper, Sec. IV."""

    cell_size: float = 0.5  # m; an integer multiple of the occupancy grid's resolution
    prior_std: float = 0.2  # m; every landmark starts at prior_std^2 * I
    sigma_range: float = 0.02  # m; range noise of the virtual range-bearing sensor
    sigma_bearing_deg: float = 0.2  # deg; bearing noise of the virtual sensor
    sensor_range: float = 3.0  # m; landmarks farther than this are not observed
    min_range: float = 0.25  # m; the range is clamped below at this value
    los_step_fraction: float = 0.5  # line-of-sight sample step, in fine grid cells
    max_batch_samples: int = 2_000_000  # line-of-sight samples evaluated per numpy batch


@dataclass
class RevisitConfig:
    """When a predicted pose closes a loop with an older keyframe."""

    r_lc: float = 1.0  # m; calibrate from the front end's loop-closure acceptance stats
    min_travel_gap: float = 3.0  # m; travel between keyframe and pose must exceed this
    merge_keyframe_gap: int = 4  # revisited keyframes this close in index form one revisit
    keyframe_spacing: float = 0.5  # m; spacing of predicted poses along a path
    los_step_fraction: float = 0.5  # line-of-sight sample step, in fine grid cells


@dataclass
class RewardConfig:
    """Raw reward U0 - U' - alpha * path_length and its normalisation (paper Alg. 1)."""

    alpha: float = 1.0  # utility per metre of travel; to be set by the EM sweep (office)
    tie_tolerance: float = 1e-9  # relative spread below which all raw rewards count equal


@dataclass
class PlanningConfig:
    """The ``planning`` config group."""

    virtual_map: VirtualMapConfig = field(default_factory=VirtualMapConfig)
    revisits: RevisitConfig = field(default_factory=RevisitConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)
