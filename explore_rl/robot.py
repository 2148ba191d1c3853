"""A kinematic UGV: follows waypoints stop-and-turn, with noisy motion and wheel odometry.

Motion is cut into *motion steps* of at most ``step_distance`` metres of travel or
``step_angle_deg`` of turn, independent of any control rate. Per step (DESIGN.md):

* commanded motion ``u`` in the body frame — this is also the wheel odometry;
* executed motion ``u + N(0, diag(sigma_xy, sigma_xy, sigma_yaw))`` moves the true pose.

The robot steers by its *belief* pose: odometry since the last correction composed onto
the latest SLAM estimate (``correct_belief``). Every step is checked with the footprint
disc against the scene's analytic 2D geometry; a step that would enter an obstacle is not
taken, and the path ends with status ``blocked``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Callable, Iterator

import numpy as np

from explore_rl.geometry import se2_compose, wrap_angle


@dataclass
class RobotConfig:
    """Jackal-sized UGV; every number of the motion model."""

    radius: float = 0.3
    body_size: list[float] = field(default_factory=lambda: [0.508, 0.430, 0.25])
    speed: float = 0.5
    turn_rate_deg: float = 45.0
    step_distance: float = 0.2
    step_angle_deg: float = 10.0
    noise_xy: float = 0.01
    noise_yaw_deg: float = 0.08
    # turn in place first when the heading error to the next waypoint exceeds this
    heading_tolerance_deg: float = 10.0
    waypoint_tolerance: float = 0.05


class PathStatus(str, Enum):
    REACHED = "reached"
    BLOCKED = "blocked"


@dataclass
class MotionStep:
    """One motion step: what was commanded (= odometry) and where the robot really is."""

    commanded: np.ndarray
    true_pose: np.ndarray
    odom_pose: np.ndarray
    belief_pose: np.ndarray
    travelled: float
    elapsed: float


class Robot:
    """Kinematic robot state: true pose, odometry pose, belief pose, distance travelled."""

    def __init__(
        self,
        config: RobotConfig,
        start_pose: np.ndarray,
        is_free: Callable[[np.ndarray], np.ndarray],
        rng: np.random.Generator,
    ):
        self.config = config
        self.is_free = is_free
        self.rng = rng
        self.true_pose = np.asarray(start_pose, dtype=float).copy()
        self.odom_pose = self.true_pose.copy()
        self.belief_pose = self.true_pose.copy()
        self.travelled = 0.0
        self.elapsed = 0.0
        self.status: PathStatus = PathStatus.REACHED

    def correct_belief(self, pose: np.ndarray) -> None:
        """Replace the belief pose (e.g. by the SLAM estimate of the current keyframe)."""
        self.belief_pose = np.asarray(pose, dtype=float).copy()

    def follow(self, waypoints: np.ndarray) -> Iterator[MotionStep]:
        """Drive through ``waypoints (K, 2)`` (world frame), one motion step per yield.

        Sets ``self.status`` to ``reached`` or ``blocked`` when the generator ends.
        """
        self.status = PathStatus.REACHED
        for target in np.asarray(waypoints, dtype=float).reshape(-1, 2):
            while True:
                command = self.next_command(target)
                if command is None:
                    break
                step = self.execute(command)
                if step is None:
                    self.status = PathStatus.BLOCKED
                    return
                yield step

    def next_command(self, target: np.ndarray) -> np.ndarray | None:
        """The body-frame motion of the next step towards ``target``; None once there."""
        cfg = self.config
        delta = target - self.belief_pose[:2]
        distance = float(np.hypot(*delta))
        if distance <= cfg.waypoint_tolerance:
            return None
        heading_error = float(wrap_angle(np.arctan2(delta[1], delta[0]) - self.belief_pose[2]))
        if abs(heading_error) > np.deg2rad(cfg.heading_tolerance_deg):
            turn = np.clip(heading_error, -np.deg2rad(cfg.step_angle_deg), np.deg2rad(cfg.step_angle_deg))
            return np.array([0.0, 0.0, turn])
        forward = min(distance, cfg.step_distance)
        return np.array([forward, 0.0, heading_error])

    def execute(self, command: np.ndarray) -> MotionStep | None:
        """Apply one commanded step with motion noise; None (and no motion) if it would collide."""
        cfg = self.config
        noise = self.rng.normal(0.0, [cfg.noise_xy, cfg.noise_xy, np.deg2rad(cfg.noise_yaw_deg)])
        new_true = se2_compose(self.true_pose, command + noise)
        if not bool(self.is_free(new_true[:2])):
            return None
        self.true_pose = new_true
        self.odom_pose = se2_compose(self.odom_pose, command)
        self.belief_pose = se2_compose(self.belief_pose, command)
        distance = float(np.hypot(command[0], command[1]))
        self.travelled += distance
        self.elapsed += distance / cfg.speed + abs(command[2]) / np.deg2rad(cfg.turn_rate_deg)
        return MotionStep(command, self.true_pose.copy(), self.odom_pose.copy(),
                          self.belief_pose.copy(), self.travelled, self.elapsed)
