"""A kinematic UGV: follows waypoints stop-and-turn, with noisy motion and wheel odometry.

Motion is cut into *motion steps* of at most ``step_distance`` metres of travel or
``step_angle_deg`` of turn, independent of any control rate. Per step (DESIGN.md):

* commanded motion ``u`` in the body frame — this is also the wheel odometry;
* executed motion ``u + N(0, diag(sigma_xy, sigma_xy, sigma_yaw))`` moves the true pose.

The robot steers by its *belief* pose: odometry since the last correction composed onto
the latest SLAM estimate (``correct_belief``). Every step is checked with the footprint
disc against the scene's analytic 2D geometry; a step that would enter an obstacle is not
taken, and the path ends with status ``blocked``.

With a ``guard`` (the local safety layer, explore_rl/local_planner.py, on by default in the
runner) every step of :meth:`Robot.follow` is first checked against a LiDAR ring cast at
the true pose and steered clear of what it sees; the adjusted step is an ordinary motion
step (same noise, odometry = command). Without one, paths are followed as they always were.
Either way the robot counts ``contacts`` (steps not taken because the true footprint would
have entered an obstacle) and the least true footprint clearance of its steps.

A blocked robot may stop with its footprint touching an obstacle; from there even a turn
in place can fail (the motion noise moves it sideways into the obstacle). ``escape()``
backs it off with ordinary motion steps: it picks the escape heading from the footprint
clearance around the robot (the same analytic geometry as the collision check, i.e. what
a bumper / proximity ring would sense), turns towards it (or away from it, to reverse)
and translates until the clearance reaches :attr:`EscapeConfig.clearance`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from enum import Enum
from typing import Callable, Iterator

import numpy as np

from explore_rl.geometry import se2_compose, wrap_angle
from explore_rl.robot_config import EscapeConfig as EscapeConfig  # the configs live there
from explore_rl.robot_config import RobotConfig as RobotConfig

log = logging.getLogger(__name__)

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
        is_free: Callable[[np.ndarray], np.ndarray] | None,
        rng: np.random.Generator,
        clearance: Callable[[np.ndarray], np.ndarray] | None = None,
        guard=None,
    ):
        """``is_free(xy)``: whether the footprint at ``xy (..., 2)`` is clear; None: where
        ``clearance`` is >= 0 (one distance query per step instead of two).
        ``clearance(xy)``: footprint clearance (m) at ``xy``, negative in collision;
        :meth:`escape` needs it, and with it every step's true clearance is measured
        (``min_clearance``). ``guard``: the local safety layer
        (:class:`~explore_rl.local_planner.LocalPlanner`) that adjusts each step of
        :meth:`follow`; None follows paths unguarded."""
        if is_free is None and clearance is None:
            raise ValueError("Robot needs is_free or clearance to tell free poses from collisions")
        self.config = config
        self._noise_scale = np.array([config.noise_xy, config.noise_xy, np.deg2rad(config.noise_yaw_deg)])
        self.is_free = is_free
        self.clearance = clearance
        self.guard = guard
        self.rng = rng
        self.true_pose = np.asarray(start_pose, dtype=float).copy()
        self.odom_pose = self.true_pose.copy()
        self.belief_pose = self.true_pose.copy()
        self.travelled = 0.0
        self.elapsed = 0.0
        self.status: PathStatus = PathStatus.REACHED
        # measured, never used to steer: motion steps whose true footprint would have entered
        # an obstacle (not taken), and the least true footprint clearance of the steps taken
        self.contacts = 0
        self.min_clearance = float("inf")
        self.capped_paths = 0  # paths ended by the step cap (RobotConfig.path_step_factor)

    def correct_belief(self, pose: np.ndarray) -> None:
        """Replace the belief pose (e.g. by the SLAM estimate of the current keyframe)."""
        self.belief_pose = np.asarray(pose, dtype=float).copy()

    def follow(self, waypoints: np.ndarray) -> Iterator[MotionStep]:
        """Drive through ``waypoints (K, 2)`` (world frame), one motion step per yield.

        Sets ``self.status`` to ``reached`` or ``blocked`` when the generator ends. With a
        ``guard`` every step is first adjusted by it (it may also end the waypoint, or give
        up on the path: ``blocked``). After :meth:`step_cap` motion steps the path ends
        ``blocked`` and a warning says why.
        """
        self.status = PathStatus.REACHED
        waypoints = np.asarray(waypoints, dtype=float).reshape(-1, 2)
        cap, steps = self.step_cap(waypoints), 0
        for index, target in enumerate(waypoints):
            if self.guard is not None:
                self.guard.begin(target, final=index == len(waypoints) - 1)
            while True:
                command = self.next_command(target)
                if self.guard is not None:
                    command = self.guard.adjust(self, target, command)
                    if isinstance(command, str):
                        self.status = PathStatus.BLOCKED
                        return
                if command is None:
                    break
                if steps >= cap:
                    self.capped_paths += 1
                    self.status = PathStatus.BLOCKED
                    log.warning("path ended as blocked: %d motion steps without reaching waypoint %d of %d "
                                "(%.2f m away; cap %d from robot.path_step_factor and path_step_slack); "
                                "check robot.waypoint_tolerance, step_distance, step_angle_deg", steps,
                                index + 1, len(waypoints), float(np.hypot(*(target - self.belief_pose[:2]))), cap)
                    return
                step = self.execute(command)
                if step is None:
                    self.status = PathStatus.BLOCKED
                    return
                steps += 1
                yield step

    def step_cap(self, waypoints: np.ndarray) -> int:
        """Motion steps a path through ``waypoints (K, 2)`` may take: ``path_step_factor``
        times the steps it needs from the belief pose (length / ``step_distance`` plus a
        half turn per waypoint / ``step_angle_deg``) plus ``path_step_slack``."""
        cfg = self.config
        points = np.vstack([self.belief_pose[:2], np.asarray(waypoints, dtype=float).reshape(-1, 2)])
        length = float(np.hypot(*np.diff(points, axis=0).T).sum())
        if not (cfg.step_distance > 0 and cfg.step_angle_deg > 0):  # unvalidated sizes: the slack alone
            return int(cfg.path_step_slack)
        needed = length / cfg.step_distance + (len(points) - 1) * 180.0 / cfg.step_angle_deg
        return int(np.ceil(cfg.path_step_factor * needed)) + int(cfg.path_step_slack)

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
        noise = self.rng.normal(0.0, self._noise_scale)
        new_true = se2_compose(self.true_pose, command + noise)
        if self.is_free is None:  # free where the clearance is >= 0: one distance query
            gap = float(self.clearance(new_true[:2]))
            free = gap >= 0.0
        else:
            free = bool(self.is_free(new_true[:2]))
            gap = float(self.clearance(new_true[:2])) if free and self.clearance is not None else np.inf
        if not free:
            self.contacts += 1
            return None
        self.min_clearance = min(self.min_clearance, gap)
        self.true_pose = new_true
        self.odom_pose = se2_compose(self.odom_pose, command)
        self.belief_pose = se2_compose(self.belief_pose, command)
        distance = float(np.hypot(command[0], command[1]))
        self.travelled += distance
        self.elapsed += distance / cfg.speed + abs(command[2]) / np.deg2rad(cfg.turn_rate_deg)
        return MotionStep(command, self.true_pose.copy(), self.odom_pose.copy(),
                          self.belief_pose.copy(), self.travelled, self.elapsed)

    # ------------------------------------------------------------------ escape

    def needs_escape(self, config: EscapeConfig) -> bool:
        """Whether the footprint is closer than ``config.clearance`` to an obstacle."""
        return self.clearance is not None and self.footprint_clearance() < config.clearance

    def footprint_clearance(self) -> float:
        """Clearance (m) of the footprint at the true pose; inf without a clearance function."""
        if self.clearance is None:
            return float("inf")
        return float(self.clearance(self.true_pose[:2]))

    def escape(self, config: EscapeConfig) -> Iterator[MotionStep]:
        """Back off an obstacle through ordinary motion steps, one per yield.

        Repeats: pick an escape heading (:meth:`escape_heading`), turn in place by its
        body-frame bearing (or by the bearing minus 180 deg to reverse), translate one
        ``step_distance``. A step the noise would push into an obstacle is not taken and is
        retried. Ends with ``status`` ``reached`` once the clearance is at least
        ``config.clearance``, ``blocked`` if no heading gains clearance or after
        ``config.max_steps`` steps. Odometry and noise are those of :meth:`execute`.
        """
        cfg = self.config
        max_turn = np.deg2rad(cfg.step_angle_deg)
        attempts = 0
        while attempts < config.max_steps:
            if not self.needs_escape(config):
                self.status = PathStatus.REACHED
                return
            choice = self.escape_heading(config)
            if choice is None:
                break
            turn, drive = choice
            while abs(turn) > 1e-9 and attempts < config.max_steps:
                attempts += 1
                step = self.execute(np.array([0.0, 0.0, float(np.clip(turn, -max_turn, max_turn))]))
                if step is not None:
                    turn -= step.commanded[2]
                    yield step
            while attempts < config.max_steps:
                attempts += 1
                step = self.execute(np.array([drive, 0.0, 0.0]))
                if step is not None:
                    yield step
                    break
        self.status = PathStatus.REACHED if not self.needs_escape(config) else PathStatus.BLOCKED

    def escape_heading(self, config: EscapeConfig) -> tuple[float, float] | None:
        """``(turn, drive)``: the in-place turn (rad) and signed translation (m) of the next
        escape leg, or None if no heading gains clearance.

        Headings ``k * 360 / directions`` deg from the current heading are scored by the
        footprint clearance one ``step_distance`` along them. Among those that reach
        ``config.clearance``, the one needing the least turn wins (driving backwards
        counts as no turn), so a robot that drove into something simply reverses; if none
        reaches it, the heading with the most clearance (if it gains any).
        """
        cfg = self.config
        x, y, yaw = self.true_pose
        now = self.footprint_clearance()
        bearing = 2.0 * np.pi * np.arange(config.directions) / config.directions  # body frame
        heading = yaw + bearing
        ends = np.stack([x + cfg.step_distance * np.cos(heading), y + cfg.step_distance * np.sin(heading)], -1)
        after = np.asarray(self.clearance(ends), dtype=float)
        forward = np.asarray(wrap_angle(bearing), dtype=float)  # turn to drive forwards
        backward = np.asarray(wrap_angle(bearing - np.pi), dtype=float)  # turn to reverse
        reverse = np.abs(backward) < np.abs(forward) - 1e-9
        turn = np.where(reverse, backward, forward)
        enough = after >= config.clearance
        if enough.any():
            order = np.lexsort((-after, np.round(np.abs(turn), 9), ~enough))
            best = int(order[0])
        else:
            best = int(np.argmax(after))
            if not after[best] > now:
                return None
        return float(turn[best]), (-1.0 if reverse[best] else 1.0) * cfg.step_distance
