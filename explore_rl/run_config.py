"""Configs of what a command runs: ``explore`` (the exploration loop, explore_rl/runner.py),
``tour`` (explore_rl/tour.py) and ``evaluate`` (explore_rl/comparison.py).

Plain dataclasses that import no runtime code, so explore_rl/config.py assembles the
whole config without loading the simulator or SLAM.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from explore_rl import checks
from explore_rl.robot_config import EscapeConfig

POLICIES = ("learned", "em", "nearest", "random")


@dataclass
class ExploreConfig:
    """The ``explore`` config group: when a run ends and what it writes."""

    target_explored: float = 0.85
    travel_budget: float = 400.0
    max_decisions: int = 300
    # a frontier whose path was blocked before the robot moved this far is skipped from then on
    blocked_progress: float = 0.05
    # frontiers whose waypoint lies this close to an already visited waypoint are skipped
    # (frontier cells that stay unknown after a visit, e.g. noisy wall cells)
    visited_radius: float = 0.5
    # backing off when the robot starts a decision touching an obstacle (explore_rl/robot.py)
    escape: EscapeConfig = field(default_factory=EscapeConfig)
    progress_bar: bool = True
    animation: bool = False
    out_dir: str = "out/explore"


@dataclass
class TourConfig:
    start_index: int = 1
    goals: list[list[float]] = field(default_factory=list)
    # extra clearance (m) of tour paths from obstacles: the robot steers by its estimate
    inflation_margin: float = 0.1
    # The tour's own path costs (see mapping.paths): kept at the values the benchmarks'
    # tours (bench_slam, bench_frontends, the calibrations) were recorded with, so the
    # tours stay the same trajectories when the exploration defaults change.
    clearance_weight: float = 1.0
    clearance_scale: float = 0.3

    def validate(self) -> None:
        """Tour settings that can be planned; one line naming the key and the allowed range."""
        checks.at_least("tour.start_index", self.start_index, 0)
        for i, goal in enumerate(self.goals):
            checks.finite_pair(f"tour.goals[{i}]", goal, positive_entries=False)
        checks.non_negative("tour.inflation_margin", self.inflation_margin)
        checks.non_negative("tour.clearance_weight", self.clearance_weight)
        checks.positive("tour.clearance_scale", self.clearance_scale)


@dataclass
class EvaluateConfig:
    """The ``evaluate`` config group (``explore-rl-eval``)."""

    policies: list[str] = field(default_factory=lambda: list(POLICIES))
    trials: int = 10
    first_trial: int = 0  # trials first_trial .. first_trial + trials - 1: more trials of the same study
    workers: int = 2  # worker processes (spawned); 1 runs the trials in this process
    threads: int = 1  # torch / BLAS threads per worker
    progress_bar: bool = True

    def validate(self) -> None:
        unknown = [p for p in self.policies if p not in POLICIES]
        if unknown or not self.policies:
            raise ValueError(f"evaluate.policies={list(self.policies)}: choose from {', '.join(POLICIES)}")
        for key in ("trials", "workers", "threads"):
            if getattr(self, key) < 1:
                raise ValueError(f"evaluate.{key} must be >= 1, got {getattr(self, key)}")
        if self.first_trial < 0:
            raise ValueError(f"evaluate.first_trial must be >= 0, got {self.first_trial}")
