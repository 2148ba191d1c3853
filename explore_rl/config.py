"""The structured config: one dataclass per Hydra group, registered with the ConfigStore.

Hydra merges ``conf/config.yaml`` and the chosen group files into :class:`Config`, so a
misspelt key or a wrong type fails at start-up with a message naming it. The dataclasses
live next to the code they configure; this module only assembles them.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

from hydra.core.config_store import ConfigStore

from explore_rl import checks
from explore_rl.envs.config import EnvConfig
from explore_rl.graph.config import GraphConfig
from explore_rl.mapping.config import MAP_UPDATES, MappingConfig
from explore_rl.models.config import ModelConfig
from explore_rl.planning.config import PlanningConfig, PolicyConfig
from explore_rl.resources import conf_dir
from explore_rl.robot_config import RobotConfig
from explore_rl.run_config import POLICIES, EvaluateConfig, ExploreConfig, TourConfig
from explore_rl.scene.config import SceneConfig, validate_building
from explore_rl.sensors.config import LidarConfig
from explore_rl.slam.config import SlamConfig, loop_closures_path, scan_matching_path
from explore_rl.trainer.config import (
    ESTIMATORS,
    DISTILL_TARGETS,
    LOGGERS,
    RENAMED,
    RENAMED_VALUES,
    AlgoConfig,
    CollectorConfig,
    LoggerConfig,
    TrainConfig,
)

CONF_DIR = str(conf_dir())  # the repository's conf/ or the wheel's copy (explore_rl/resources.py)


@dataclass
class CompareConfig:
    """``explore-rl-compare``: the policies explored one after the other on the same scene."""

    policies: list[str] = field(default_factory=lambda: ["nearest", "em"])

    def validate(self) -> None:
        """Every name known and at least one, before the first policy runs."""
        unknown = [p for p in self.policies if p not in POLICIES]
        if unknown or not self.policies:
            raise ValueError(f"compare.policies={list(self.policies)}: give one or more of {', '.join(POLICIES)}")


@dataclass
class Config:
    seed: int = 0
    out: Optional[str] = None
    scene: SceneConfig = field(default_factory=SceneConfig)
    robot: RobotConfig = field(default_factory=RobotConfig)
    lidar: LidarConfig = field(default_factory=LidarConfig)
    slam: SlamConfig = field(default_factory=SlamConfig)
    mapping: MappingConfig = field(default_factory=MappingConfig)
    planning: PlanningConfig = field(default_factory=PlanningConfig)
    tour: TourConfig = field(default_factory=TourConfig)
    explore: ExploreConfig = field(default_factory=ExploreConfig)
    policy: PolicyConfig = field(default_factory=PolicyConfig)
    compare: CompareConfig = field(default_factory=CompareConfig)
    graph: GraphConfig = field(default_factory=GraphConfig)
    env: EnvConfig = field(default_factory=EnvConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    algo: AlgoConfig = field(default_factory=AlgoConfig)
    collector: CollectorConfig = field(default_factory=CollectorConfig)
    logger: LoggerConfig = field(default_factory=LoggerConfig)
    train: TrainConfig = field(default_factory=TrainConfig)
    evaluate: EvaluateConfig = field(default_factory=EvaluateConfig)
    # explore-rl-train: continue the run in `out` from its last checkpoint
    resume: bool = False


def register_configs() -> None:
    ConfigStore.instance().store(name="base_config", node=Config)


def load_config(overrides: Sequence[str] = ()) -> Config:
    """The typed, validated config for command-line style ``overrides`` (e.g.
    ``["scene=street", "slam=model", "seed=3"]``), composed from ``conf/`` exactly as the
    command-line tools do: for scripts, benchmarks, notebooks and tests."""
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException
    from omegaconf import OmegaConf

    register_configs()
    try:
        with initialize_config_dir(CONF_DIR, version_base="1.3"):
            composed = compose("config", overrides=list(overrides))
    except HydraException as error:  # an unknown key or group option: one line naming it and the fix, as validate's
        message = " ".join(str(error).split()).split(" Config search path")[0]  # Hydra's search path says nothing here
        raise ValueError(message) from error
    config: Config = OmegaConf.to_object(composed)  # type: ignore[assignment]
    validate(config)
    return config


def load_saved_config(path: str | Path, overrides: Sequence[str] = ()) -> Config:
    """A config saved as YAML (a training run's ``config.yaml``), validated, with
    command-line style ``overrides`` of plain keys applied (e.g. ``["explore.max_decisions=15"]``)."""
    from omegaconf import OmegaConf

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no saved config there")
    saved = OmegaConf.to_container(OmegaConf.load(path))
    migrate_renamed(saved)
    merged = OmegaConf.merge(OmegaConf.structured(Config), saved, OmegaConf.from_dotlist(list(overrides)))
    config: Config = OmegaConf.to_object(merged)  # type: ignore[assignment]
    validate(config)
    return config


def migrate_renamed(saved: dict) -> None:
    """A config saved before the objective's options were renamed (``algo.imitation_*``),
    read with the new names (``RENAMED``): old runs and policy cards stay loadable."""
    algo = saved.get("algo") or {}
    for old, new in RENAMED.items():
        if algo.get(old) is not None:
            value = algo.pop(old)
            algo[new] = RENAMED_VALUES.get(old, {}).get(value, value)
        else:
            algo.pop(old, None)


# procedural scenes whose generators place walls, rooms and starts in metres: the smallest
# size (x, y) they fit in (scene=file has its own checks, explore_rl/scene/scene_file.py)
MIN_SCENE_SIZE = {"office": (20.0, 20.0), "street": (10.0, 10.0), "garage": (10.0, 10.0)}


def validate(config: Config) -> None:
    """Checks a type system can't express, before anything runs: raise with the key, the
    allowed range and the fix (one line). Groups with their own ``validate()`` check themselves."""
    checks.at_least("seed", config.seed, 0)
    validate_scene(config)
    config.robot.validate()
    config.lidar.validate()
    config.tour.validate()
    validate_mapping(config)
    validate_planning(config)
    validate_slam(config)
    validate_explore(config)
    if config.policy.name not in ("nearest", "random", "em", "learned"):
        raise ValueError(f"policy.name={config.policy.name!r}: choose policy=nearest, random, em or learned")
    checks.non_negative("policy.revisit_bias", config.policy.revisit_bias)
    checks.non_negative("policy.loop_bias", config.policy.loop_bias)
    checks.non_negative("policy.loop_bias_until_m", config.policy.loop_bias_until_m)
    checks.non_negative("policy.loop_bias_from_m", config.policy.loop_bias_from_m)
    if 0 < config.policy.loop_bias_until_m <= config.policy.loop_bias_from_m:
        raise ValueError(f"policy.loop_bias_from_m={config.policy.loop_bias_from_m} must lie below "
                         f"policy.loop_bias_until_m={config.policy.loop_bias_until_m} (else the loop prior never "
                         "applies); lower it or set policy.loop_bias_until_m=0")
    checks.non_negative("policy.closure_bias", config.policy.closure_bias)
    checks.at_least("policy.em_top_k", config.policy.em_top_k, 0)
    checks.in_range("policy.em_below_confidence", config.policy.em_below_confidence, 0.0, 1.0)
    if config.policy.em_below_confidence > 0 and config.policy.em_top_k > 0:
        raise ValueError(f"policy.em_below_confidence={config.policy.em_below_confidence} and policy.em_top_k="
                         f"{config.policy.em_top_k}: two hybrids; set one of them and leave the other 0")
    config.env.validate()
    if config.graph.max_nodes <= config.planning.actions.max_frontiers:
        raise ValueError(f"graph.max_nodes={config.graph.max_nodes} must exceed planning.actions.max_frontiers="
                         f"{config.planning.actions.max_frontiers} (the current pose and every frontier are nodes)")
    config.compare.validate()
    config.model.validate()
    validate_features(config)
    config.evaluate.validate()
    validate_training(config)


def validate_scene(config: Config) -> None:
    """The scene group (the procedural scenes' sizes; scene files check themselves)."""
    scene = config.scene
    if scene.name == "file" and not scene.path:
        raise ValueError("scene=file needs scene.path=/path/to/scene.yaml")
    checks.at_least("scene.seed", scene.seed, 0)
    checks.at_least("scene.start_index", scene.start_index, 0)
    checks.positive("scene.grid_resolution", scene.grid_resolution)
    if scene.name == "building":
        validate_building(scene, config.robot.radius)
    if scene.name in MIN_SCENE_SIZE:
        checks.finite_pair("scene.size", scene.size)
        low = MIN_SCENE_SIZE[scene.name]
        if scene.size[0] < low[0] or scene.size[1] < low[1]:
            raise ValueError(f"scene.size={list(scene.size)} is too small for scene={scene.name}: "
                             f"at least [{low[0]:g}, {low[1]:g}] (m)")
    if scene.name == "garage":
        rows, car = scene.car_rows_y, scene.car_size
        if rows and max(rows) + car[1] / 2 > scene.size[1]:
            raise ValueError(f"scene.car_rows_y={list(rows)} puts cars of length {car[1]} outside the garage's "
                             f"scene.size[1]={scene.size[1]}: lower the rows or enlarge the garage")


def validate_mapping(config: Config) -> None:
    mapping = config.mapping
    checks.one_of("mapping.updates", mapping.updates, MAP_UPDATES)
    checks.positive("mapping.occupancy.max_range", mapping.occupancy.max_range)
    checks.at_least("mapping.occupancy.azimuth_bins", mapping.occupancy.azimuth_bins, 1)
    checks.positive("mapping.occupancy.ray_step_cells", mapping.occupancy.ray_step_cells)
    checks.positive("mapping.voxels.voxel_size", mapping.voxels.voxel_size)
    checks.non_negative("mapping.voxels.reproject_shift", mapping.voxels.reproject_shift)
    checks.one_of("mapping.frontiers.neighbourhood", mapping.frontiers.neighbourhood, (4, 8))
    checks.at_least("mapping.frontiers.min_cluster_cells", mapping.frontiers.min_cluster_cells, 1)
    checks.positive("mapping.frontiers.max_cluster_extent", mapping.frontiers.max_cluster_extent)
    checks.non_negative("mapping.frontiers.waypoint_search_radius", mapping.frontiers.waypoint_search_radius)
    checks.positive("mapping.paths.clearance_scale", mapping.paths.clearance_scale)
    # path costs: negative weights would break Dijkstra
    checks.non_negative("mapping.paths.inflation_margin", mapping.paths.inflation_margin)
    checks.non_negative("mapping.paths.clearance_weight", mapping.paths.clearance_weight)
    checks.non_negative("mapping.paths.start_snap_radius", mapping.paths.start_snap_radius)


def validate_planning(config: Config) -> None:
    planning = config.planning
    planning.em.validate()
    if planning.actions.kind not in ("graph", "nearest"):
        raise ValueError(f"planning.actions.kind={planning.actions.kind!r}: choose graph or nearest")
    checks.at_least("planning.actions.max_frontiers", planning.actions.max_frontiers, 1)
    checks.at_least("planning.actions.extra_nearest", planning.actions.extra_nearest, 0)
    virtual_map, resolution = planning.virtual_map, config.scene.grid_resolution
    checks.positive("planning.virtual_map.cell_size", virtual_map.cell_size)
    factor = virtual_map.cell_size / resolution
    if factor < 1 - 1e-9 or abs(factor - round(factor)) > 1e-6:
        raise ValueError(f"planning.virtual_map.cell_size={virtual_map.cell_size} must be a whole multiple "
                         f"(1, 2, 3, ...) of scene.grid_resolution={resolution}")
    for key in ("prior_std", "sigma_range", "sigma_bearing_deg", "sensor_range", "min_range", "los_step_fraction"):
        checks.positive(f"planning.virtual_map.{key}", getattr(virtual_map, key))
    for key in ("r_lc", "keyframe_spacing", "los_step_fraction"):
        checks.positive(f"planning.revisits.{key}", getattr(planning.revisits, key))
    checks.non_negative("planning.revisits.min_travel_gap", planning.revisits.min_travel_gap)
    checks.non_negative("planning.reward.alpha", planning.reward.alpha)
    checks.non_negative("planning.reward.tie_tolerance", planning.reward.tie_tolerance)


def validate_slam(config: Config) -> None:
    slam = config.slam
    if slam.frontend not in ("icp", "model"):
        raise ValueError(f"slam.frontend={slam.frontend!r}: choose slam=icp or slam=model")
    checks.positive("slam.keyframe_distance", slam.keyframe_distance)
    checks.in_range("slam.keyframe_angle_deg", slam.keyframe_angle_deg, 0.0, 180.0, low_open=True)
    checks.at_least("slam.map_error_points", slam.map_error_points, 1)
    checks.positive("slam.loop_closure.model_step_sigma_translation", slam.loop_closure.model_step_sigma_translation)
    checks.positive("slam.loop_closure.model_step_sigma_rotation_deg", slam.loop_closure.model_step_sigma_rotation_deg)
    fits = (("slam.loop_closure.calibration_file", slam.loop_closure.calibration_file, loop_closures_path,
             "calibrate_loop_closures"),
            ("slam.scan_matcher.calibration_file", slam.scan_matcher.calibration_file, scan_matching_path,
             "calibrate_scan_matching"))
    for key, calibration, path, script in fits:  # the model's fits; icp reads neither
        if slam.frontend == "model" and calibration and not path(calibration).is_file():
            raise ValueError(f"{key}={calibration!r}: no such file (give a path, or a file name in "
                             f"conf/calibration/; write one with scripts/{script}.py --out)")


def validate_explore(config: Config) -> None:
    explore = config.explore
    if not 0 < explore.target_explored <= 1:
        raise ValueError(f"explore.target_explored must be in (0, 1], got {explore.target_explored}")
    checks.positive("explore.travel_budget", explore.travel_budget, finite=False)
    checks.at_least("explore.max_decisions", explore.max_decisions, 1)
    checks.non_negative("explore.blocked_progress", explore.blocked_progress)
    checks.non_negative("explore.visited_radius", explore.visited_radius)
    checks.non_negative("explore.escape.clearance", explore.escape.clearance)
    checks.at_least("explore.escape.directions", explore.escape.directions, 2)
    checks.at_least("explore.escape.max_steps", explore.escape.max_steps, 1)


def validate_features(config: Config) -> None:
    """``graph.features`` names a feature set; an explicit ``model.feature_scale`` fits it."""
    from explore_rl.graph.features import feature_names

    names = feature_names(config.graph.features)
    scale = config.model.feature_scale
    if scale is not None and len(scale) != len(names):
        raise ValueError(f"model.feature_scale has {len(scale)} entries but graph.features={config.graph.features} "
                         f"gives {len(names)} node features: give {len(names)} or model.feature_scale=null")


def validate_training(config: Config) -> None:
    """The trainer's groups: algo, collector, logger, train."""
    algo, collector, train = config.algo, config.collector, config.train
    positive = {"algo.lr": algo.lr, "algo.gamma": algo.gamma, "algo.max_grad_norm": algo.max_grad_norm}
    for key, value in positive.items():
        if not value > 0:
            raise ValueError(f"{key} must be positive, got {value}")
    if not algo.gamma <= 1 or not 0 <= algo.lmbda <= 1:
        raise ValueError(f"algo.gamma must be in (0, 1] and algo.lmbda in [0, 1], got {algo.gamma}, {algo.lmbda}")
    for old, new in RENAMED.items():
        if getattr(algo, old) is not None:
            raise ValueError(f"algo.{old} was renamed algo.{new} (distillation of EM's evaluation is not A2C): "
                             f"use algo.{new}={getattr(algo, old)}")
    for key in ("a2c_coef", "value_coef", "entropy_coef", "distill_coef"):
        if not getattr(algo, key) >= 0:
            raise ValueError(f"algo.{key} must be >= 0, got {getattr(algo, key)}")
    if algo.a2c_coef == 0 and algo.distill_coef == 0:
        raise ValueError("algo.a2c_coef and algo.distill_coef are both 0: nothing would be learned")
    if algo.estimator not in ESTIMATORS:
        raise ValueError(f"algo.estimator={algo.estimator!r}: choose one of {', '.join(ESTIMATORS)}")
    at_least_one = {"algo.steps_per_update": algo.steps_per_update, "collector.workers": collector.workers,
                    "train.frames": train.frames, "train.checkpoint_every": train.checkpoint_every,
                    "train.threads": train.threads, "algo.dagger_batch": algo.dagger_batch,
                    "algo.dagger_buffer": algo.dagger_buffer}
    if algo.distill_target not in DISTILL_TARGETS:
        raise ValueError(f"algo.distill_target={algo.distill_target!r}: choose one of {', '.join(DISTILL_TARGETS)}")
    if algo.dagger_steps < 0:
        raise ValueError(f"algo.dagger_steps must be >= 0 (0 = no replay), got {algo.dagger_steps}")
    if algo.dagger_steps > 0 and algo.distill_coef == 0:
        raise ValueError("algo.dagger_steps > 0 needs algo.distill_coef > 0 (the weight of those steps)")
    if not re.fullmatch(r"auto|cpu|cuda(:\d+)?", train.device):
        raise ValueError(f"train.device={train.device!r}: choose auto, cpu or cuda[:index]")
    if not train.max_minutes >= 0:
        raise ValueError(f"train.max_minutes must be >= 0 (0 = no wall-clock budget), got {train.max_minutes}")
    if train.snapshot_every < 0:
        raise ValueError(f"train.snapshot_every must be >= 0 (0 = no snapshots), got {train.snapshot_every}")
    train.validate()  # train.dataset*
    for key, value in at_least_one.items():
        if value < 1:
            raise ValueError(f"{key} must be >= 1, got {value}")
    collector.validate()  # collector.backend, kind, max_policy_lag
    if config.logger.kind not in LOGGERS:
        raise ValueError(f"logger.kind={config.logger.kind!r}: choose one of {', '.join(LOGGERS)}")
