"""The structured config: one dataclass per Hydra group, registered with the ConfigStore.

Hydra merges ``conf/config.yaml`` and the chosen group files into :class:`Config`, so a
misspelt key or a wrong type fails at start-up with a message naming it. The dataclasses
live next to the code they configure; this module only assembles them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Sequence

from hydra.core.config_store import ConfigStore

from explore_rl.comparison import EvaluateConfig
from explore_rl.envs.config import EnvConfig
from explore_rl.graph.config import GraphConfig
from explore_rl.mapping.config import MappingConfig
from explore_rl.models.config import ModelConfig
from explore_rl.planning.config import PlanningConfig
from explore_rl.planning.policies import PolicyConfig
from explore_rl.robot import RobotConfig
from explore_rl.runner import ExploreConfig
from explore_rl.scene.config import SceneConfig
from explore_rl.sensors.lidar import LidarConfig
from explore_rl.slam.config import SlamConfig
from explore_rl.tour import TourConfig
from explore_rl.trainer.config import (
    BACKENDS,
    ESTIMATORS,
    IMITATION_TARGETS,
    LOGGERS,
    AlgoConfig,
    CollectorConfig,
    LoggerConfig,
    TrainConfig,
)

CONF_DIR = str(Path(__file__).resolve().parent.parent / "conf")


@dataclass
class CompareConfig:
    """``explore-rl-compare``: the policies explored one after the other on the same scene."""

    policies: list[str] = field(default_factory=lambda: ["nearest", "em"])


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
    from omegaconf import OmegaConf

    register_configs()
    with initialize_config_dir(CONF_DIR, version_base="1.3"):
        composed = compose("config", overrides=list(overrides))
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
    merged = OmegaConf.merge(OmegaConf.structured(Config), OmegaConf.load(path),
                             OmegaConf.from_dotlist(list(overrides)))
    config: Config = OmegaConf.to_object(merged)  # type: ignore[assignment]
    validate(config)
    return config


def validate(config: Config) -> None:
    """Checks a type system can't express; raise with the key and the fix."""
    if config.scene.name == "file" and not config.scene.path:
        raise ValueError("scene=file needs scene.path=/path/to/scene.yaml")
    positive = {
        "robot.radius": config.robot.radius,
        "robot.speed": config.robot.speed,
        "robot.step_distance": config.robot.step_distance,
        "lidar.max_range": config.lidar.max_range,
        "lidar.azimuth_resolution_deg": config.lidar.azimuth_resolution_deg,
        "scene.grid_resolution": config.scene.grid_resolution,
        "mapping.paths.clearance_scale": config.mapping.paths.clearance_scale,
        "tour.clearance_scale": config.tour.clearance_scale,
    }
    for key, value in positive.items():
        if not value > 0:
            raise ValueError(f"{key} must be positive, got {value}")
    non_negative = {  # path costs: negative weights would break Dijkstra
        "mapping.paths.inflation_margin": config.mapping.paths.inflation_margin,
        "mapping.paths.clearance_weight": config.mapping.paths.clearance_weight,
        "tour.inflation_margin": config.tour.inflation_margin,
        "tour.clearance_weight": config.tour.clearance_weight,
    }
    for key, value in non_negative.items():
        if not value >= 0:
            raise ValueError(f"{key} must be >= 0, got {value}")
    if config.slam.frontend not in ("icp", "model"):
        raise ValueError(f"slam.frontend={config.slam.frontend!r}: choose slam=icp or slam=model")
    if config.policy.name not in ("nearest", "random", "em", "learned"):
        raise ValueError(f"policy.name={config.policy.name!r}: choose policy=nearest, random, em or learned")
    if not 0 < config.explore.target_explored <= 1:
        raise ValueError(f"explore.target_explored must be in (0, 1], got {config.explore.target_explored}")
    if config.lidar.channels < 1:
        raise ValueError(f"lidar.channels must be >= 1, got {config.lidar.channels}")
    if config.explore.escape.directions < 2:
        raise ValueError(f"explore.escape.directions must be >= 2, got {config.explore.escape.directions}")
    if config.env.starts not in ("auto", "cycle", "sample", "default"):
        raise ValueError(f"env.starts={config.env.starts!r}: choose auto, cycle, sample or default")
    if config.planning.actions.kind not in ("graph", "nearest"):
        raise ValueError(f"planning.actions.kind={config.planning.actions.kind!r}: choose graph or nearest")
    if config.planning.actions.max_frontiers < 1:
        raise ValueError(f"planning.actions.max_frontiers must be >= 1, got {config.planning.actions.max_frontiers}")
    if config.graph.max_nodes <= config.planning.actions.max_frontiers:
        raise ValueError(f"graph.max_nodes={config.graph.max_nodes} must exceed planning.actions.max_frontiers="
                         f"{config.planning.actions.max_frontiers} (the current pose and every frontier are nodes)")
    config.model.validate()
    config.evaluate.validate()
    validate_training(config)
    if config.lidar.tile_size < 0:
        raise ValueError(f"lidar.tile_size must be >= 0 (0 = cast on the full scene model), "
                         f"got {config.lidar.tile_size}")


def validate_training(config: Config) -> None:
    """The trainer's groups: algo, collector, logger, train."""
    algo, collector, train = config.algo, config.collector, config.train
    positive = {"algo.lr": algo.lr, "algo.gamma": algo.gamma, "algo.max_grad_norm": algo.max_grad_norm}
    for key, value in positive.items():
        if not value > 0:
            raise ValueError(f"{key} must be positive, got {value}")
    if not algo.gamma <= 1 or not 0 <= algo.lmbda <= 1:
        raise ValueError(f"algo.gamma must be in (0, 1] and algo.lmbda in [0, 1], got {algo.gamma}, {algo.lmbda}")
    for key in ("value_coef", "entropy_coef", "imitation_coef"):
        if not getattr(algo, key) >= 0:
            raise ValueError(f"algo.{key} must be >= 0, got {getattr(algo, key)}")
    if algo.estimator not in ESTIMATORS:
        raise ValueError(f"algo.estimator={algo.estimator!r}: choose one of {', '.join(ESTIMATORS)}")
    at_least_one = {"algo.steps_per_update": algo.steps_per_update, "collector.workers": collector.workers,
                    "train.frames": train.frames, "train.checkpoint_every": train.checkpoint_every,
                    "train.threads": train.threads, "algo.imitation_batch": algo.imitation_batch,
                    "algo.imitation_buffer": algo.imitation_buffer}
    if algo.imitation_target not in IMITATION_TARGETS:
        raise ValueError(f"algo.imitation_target={algo.imitation_target!r}: choose one of "
                         f"{', '.join(IMITATION_TARGETS)}")
    if algo.imitation_replay_steps < 0:
        raise ValueError(f"algo.imitation_replay_steps must be >= 0 (0 = no replay), got {algo.imitation_replay_steps}")
    if algo.imitation_replay_steps > 0 and algo.imitation_coef == 0:
        raise ValueError("algo.imitation_replay_steps > 0 needs algo.imitation_coef > 0 (the weight of those steps)")
    if train.snapshot_every < 0:
        raise ValueError(f"train.snapshot_every must be >= 0 (0 = no snapshots), got {train.snapshot_every}")
    for key, value in at_least_one.items():
        if value < 1:
            raise ValueError(f"{key} must be >= 1, got {value}")
    if collector.backend not in BACKENDS:
        raise ValueError(f"collector.backend={collector.backend!r}: choose one of {', '.join(BACKENDS)}")
    if config.logger.kind not in LOGGERS:
        raise ValueError(f"logger.kind={config.logger.kind!r}: choose one of {', '.join(LOGGERS)}")
