"""The local safety layer: steer each motion step clear of what the LiDAR sees now.

Paths are planned on the SLAM map and followed by the robot's *belief* pose, so a path
that grazes a wall in the map can put the true footprint into it (belief error, map
error, motion noise). A real robot's local planner steers around what its sensor sees,
whatever the global map says; this module is that layer, between path following
(:meth:`Robot.next_command`) and motion (:meth:`Robot.execute`):

* **Perception** (:class:`ObstacleRing`): a cheap few-channel ring cast with the same
  :class:`~explore_rl.sensors.lidar.Lidar` from the robot's *true* pose (the sensor rides
  on the real robot), range noise included; returns the obstacle points (floor dropped)
  in the body frame. Nothing here reads the analytic geometry or the SLAM map.
* **Rule** (:class:`LocalPlanner`, a vector-field-histogram style heading choice): while
  no scan point comes within ``radius + comfort + lookahead`` the nominal step is kept.
  Otherwise, a robot already inside ``margin`` (motion noise) first steps out of it:
  forward or in reverse, turning at most ``step_angle_deg``. Else each of ``headings``
  directions (plus the exact bearing to the waypoint) is *feasible* if the footprint
  swept along it for ``lookahead`` (or to the waypoint) keeps ``margin`` from every scan
  point, and costs ``|deviation from the bearing| + turn_weight * |turn| +
  comfort_weight * (comfort - sweep clearance)+``; directions deviating more than
  ``max_deviation_deg`` are never taken (no driving away from the goal). If the cheapest
  is the bearing and the nominal step keeps the margin, the nominal step is kept
  unchanged; otherwise the robot turns towards the chosen direction (at most
  ``step_angle_deg`` per step) and, once it is within that, translates along it (at most
  ``step_distance``). Every adjusted command is an ordinary motion step: the same noise,
  odometry = commanded, and SLAM sees it like any other motion.
* **Giving up**: no clear direction, or none within ``max_deviation_deg``, or, once the
  layer has steered, no ``progress`` towards the waypoint for ``patience`` steps. A
  waypoint given up within ``reach_tolerance`` (``corner_tolerance`` for a path's
  intermediate waypoints) counts as reached — it lies too close to an obstacle to stand
  on, as the belief or the map put it there; otherwise the path ends ``blocked``, as a
  path whose step would collide does without the layer (which still happens if the
  motion noise beats the margin: the robot counts those ``contacts``).

``robot.safety.enabled=false`` switches the layer off: the robot then follows paths
exactly as before the layer existed (tests/test_local_planner.py compares trajectories).
"""

from __future__ import annotations

import logging
import time
from typing import Callable

import numpy as np

from explore_rl.geometry import wrap_angle
from explore_rl.robot_config import SafetyConfig as SafetyConfig  # the config lives there

log = logging.getLogger(__name__)


class ObstacleRing:
    """Obstacle points (body frame, floor dropped) of a few-channel ring from ``lidar``.

    ``lidar`` is a :class:`~explore_rl.sensors.lidar.Lidar` built with the ring's config
    (:func:`make_ring_lidar`); its scan is taken at the robot's true pose with range noise.
    """

    def __init__(self, lidar, floor_height: float):
        self.lidar = lidar
        self.floor_height = floor_height
        self.casts = 0
        self.seconds = 0.0

    def __call__(self, true_pose: np.ndarray) -> np.ndarray:
        start = time.perf_counter()
        points = self.lidar.points(true_pose)
        keep = points[:, 2] + self.lidar.config.mount_height >= self.floor_height
        out = points[keep, :2].copy()
        self.casts += 1
        self.seconds += time.perf_counter() - start
        return out


def make_ring_lidar(scene, safety: SafetyConfig, lidar_config, rng: np.random.Generator):
    """A :class:`Lidar` casting the safety ring from the robot's sensor (same mount and noise)."""
    from dataclasses import replace

    from explore_rl.sensors.lidar import Lidar

    ring = replace(lidar_config, channels=safety.channels, min_elevation_deg=safety.min_elevation_deg,
                   max_elevation_deg=safety.max_elevation_deg,
                   azimuth_resolution_deg=safety.azimuth_resolution_deg, max_range=safety.max_range)
    return Lidar(scene, ring, rng)


def sweep_clearance(points: np.ndarray, directions: np.ndarray, length: float, radius: float) -> np.ndarray:
    """Gap (m) between scan ``points (M, 2)`` and a disc of ``radius`` swept from the origin
    ``length`` metres along each unit direction ``(K, 2)``; inf without points."""
    if len(points) == 0:
        return np.full(len(directions), np.inf)
    along = points @ directions.T  # (M, K)
    t = np.clip(along, 0.0, length)
    squared = (points * points).sum(1)[:, None] - 2.0 * t * along + t * t
    return np.sqrt(np.maximum(squared.min(axis=0), 0.0)) - radius


class LocalPlanner:
    """Adjusts each commanded motion step against the latest ring (module docstring).

    ``sense(true_pose) -> (M, 2)`` returns obstacle points in the body frame. The robot
    calls :meth:`begin` for every waypoint and :meth:`adjust` before every motion step.
    """

    def __init__(self, config: SafetyConfig, robot_config, sense: Callable[[np.ndarray], np.ndarray]):
        self.config = config
        self.robot_config = robot_config
        self.sense = sense
        self.radius = float(robot_config.radius)
        self.step = float(robot_config.step_distance)
        self.max_turn = float(np.deg2rad(robot_config.step_angle_deg))
        angles = 2.0 * np.pi * np.arange(config.headings) / config.headings
        self._angles = np.asarray(wrap_angle(angles), dtype=float)
        self._points = np.zeros((0, 2))
        self._scan_odom: np.ndarray | None = None
        self._since_scan = 0
        self._best = np.inf
        self._idle = 0
        self._engaged = False
        self._tolerance = config.reach_tolerance
        # counters for the run's records
        self.interventions = 0
        self.stops = 0
        self.seconds = 0.0
        self.last_give_up: tuple[str, float, bool] | None = None  # (reason, distance, counted reached)

    # ------------------------------------------------------------------ perception

    def points(self, robot) -> np.ndarray:
        """Obstacle points in the current body frame: a fresh ring every ``scan_every``
        steps, the last one moved by the odometry in between."""
        if self._scan_odom is None or self._since_scan >= self.config.scan_every:
            self._points = self.sense(robot.true_pose)
            self._scan_odom = robot.odom_pose.copy()
            self._since_scan = 0
            return self._points
        # body pose now relative to the body pose of the scan (odometry), points moved into it
        dx, dy = robot.odom_pose[:2] - self._scan_odom[:2]
        c, s = np.cos(self._scan_odom[2]), np.sin(self._scan_odom[2])
        tx, ty = c * dx + s * dy, -s * dx + c * dy
        dyaw = robot.odom_pose[2] - self._scan_odom[2]
        c, s = np.cos(dyaw), np.sin(dyaw)
        shifted = self._points - [tx, ty]
        return np.stack([c * shifted[:, 0] + s * shifted[:, 1], -s * shifted[:, 0] + c * shifted[:, 1]], -1)

    # ------------------------------------------------------------------ rule

    def begin(self, target: np.ndarray, final: bool = True) -> None:
        """A new waypoint (``final``: the path's last): reset the progress watch."""
        self._best = np.inf
        self._idle = 0
        self._engaged = False
        self._tolerance = self.config.reach_tolerance if final else self.config.corner_tolerance

    def adjust(self, robot, target: np.ndarray, command: np.ndarray | None):
        """The step to execute instead of ``command`` (None = the waypoint is done), or
        ``"blocked"`` when the layer gives up on the path."""
        start = time.perf_counter()
        try:
            return self._adjust(robot, np.asarray(target, dtype=float), command)
        finally:
            self._since_scan += 1
            self.seconds += time.perf_counter() - start

    def _adjust(self, robot, target: np.ndarray, command: np.ndarray | None):
        cfg = self.config
        if command is None:
            return None
        delta = target - robot.belief_pose[:2]
        distance = float(np.hypot(*delta))
        # progress watch (by the belief, as the path follower steers), once the layer engaged
        if distance < self._best - cfg.progress:
            self._best, self._idle = distance, 0
        elif self._engaged:
            self._idle += 1
            if self._idle > cfg.patience:
                return self._give_up(distance, "no progress")
        points = self.points(robot)
        reach = self.radius + max(cfg.comfort, cfg.margin) + cfg.lookahead
        if len(points):
            points = points[(points * points).sum(1) <= reach * reach]
        if len(points) == 0:
            return command
        now = float(np.sqrt((points * points).sum(1).min())) - self.radius
        bearing = float(wrap_angle(np.arctan2(delta[1], delta[0]) - robot.belief_pose[2]))
        if now < cfg.margin:  # inside the margin (motion noise): first step out of it
            recovery = self._recover(points, now, bearing)
            if recovery is not None:
                self._intervened()
                return recovery
        # demand only that a robot still inside the margin gets no closer
        margin = min(cfg.margin, now - 1e-3)
        angles = np.append(self._angles, bearing)
        directions = np.stack([np.cos(angles), np.sin(angles)], -1)
        for length in (min(cfg.lookahead, distance), self.step, self.step / 2):
            length = max(length, 1e-3)
            clearance = sweep_clearance(points, directions, length, self.radius)
            feasible = clearance >= margin
            if feasible.any():
                break
        else:
            return self._give_up(distance, "no clear direction")
        deviation = np.abs(np.asarray(wrap_angle(angles - bearing), dtype=float))
        cost = (deviation + cfg.turn_weight * np.abs(angles)
                + cfg.comfort_weight * np.maximum(cfg.comfort - np.minimum(clearance, cfg.comfort), 0.0))
        cost[~feasible | (deviation > np.deg2rad(cfg.max_deviation_deg))] = np.inf
        best = int(np.argmin(cost))
        if best == len(angles) - 1 and self._nominal_ok(points, command, margin):
            return command
        if distance <= self._tolerance or not np.isfinite(cost[best]):
            return self._give_up(distance, "no way on")  # or close enough
        self._intervened()
        heading = float(angles[best])
        if abs(heading) <= self.max_turn + 1e-9:
            travel = min(self.step, length)
            return np.array([travel * np.cos(heading), travel * np.sin(heading), heading])
        return np.array([0.0, 0.0, float(np.clip(heading, -self.max_turn, self.max_turn))])

    def _recover(self, points: np.ndarray, now: float, bearing: float) -> np.ndarray | None:
        """A step (forward or reverse, turning at most ``step_angle_deg``) that takes the
        footprint out of the margin, or at least further from the scan points; the one
        closest to the target's bearing among those that leave the margin, else the one
        gaining most. None if no such step gains clearance."""
        turns = np.linspace(-self.max_turn, self.max_turn, 9)
        headings = np.concatenate([turns, turns + np.pi])
        directions = np.stack([np.cos(headings), np.sin(headings)], -1)
        ends = self.step * directions  # (K, 2)
        gap = np.sqrt(((points[None] - ends[:, None]) ** 2).sum(-1)).min(1) - self.radius
        sweep = sweep_clearance(points, directions, self.step, self.radius)
        gains = (gap >= now + 0.01) & (sweep >= now - 1e-3)
        if not gains.any():
            return None
        out = gains & (gap >= self.config.margin)
        if out.any():
            deviation = np.abs(np.asarray(wrap_angle(headings - bearing), dtype=float))
            best = int(np.argmin(np.where(out, deviation, np.inf)))
        else:
            best = int(np.argmax(np.where(gains, gap, -np.inf)))
        heading = float(headings[best])
        turn = float(wrap_angle(heading)) if best < len(turns) else float(wrap_angle(heading - np.pi))
        return np.array([self.step * np.cos(heading), self.step * np.sin(heading), turn])

    def _nominal_ok(self, points: np.ndarray, command: np.ndarray, margin: float) -> bool:
        """Whether the unchanged nominal step keeps ``margin`` (a turn in place always does)."""
        travel = float(np.hypot(command[0], command[1]))
        if travel == 0.0:
            return True
        direction = np.array([[command[0], command[1]]]) / travel
        return bool(sweep_clearance(points, direction, travel, self.radius)[0] >= margin)

    def _intervened(self) -> None:
        self.interventions += 1
        self._engaged = True

    def _give_up(self, distance: float, reason: str):
        self.last_give_up = (reason, distance, distance <= self._tolerance)
        if distance <= self._tolerance:
            return None
        self.stops += 1
        log.debug("local layer gives up %.2f m from the waypoint: %s", distance, reason)
        return "blocked"


def make_local_planner(safety: SafetyConfig, robot_config, scene, lidar_config,
                       rng: np.random.Generator) -> LocalPlanner | None:
    """The layer for a robot in ``scene`` (None when ``safety.enabled`` is false)."""
    if not safety.enabled:
        return None
    safety.validate()
    ring = ObstacleRing(make_ring_lidar(scene, safety, lidar_config, rng), safety.floor_height)
    return LocalPlanner(safety, robot_config, ring)
