"""Configs of the robot group (``conf/robot/``) and of ``explore.escape``: plain dataclasses.

Imports no runtime code (explore_rl/config.py assembles them without loading the
simulator); the robot (explore_rl/robot.py) and the local safety layer
(explore_rl/local_planner.py) read them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from explore_rl import checks

MIN_STEP_DISTANCE = 1e-3  # m: the smallest robot.step_distance validate() accepts
MIN_STEP_ANGLE_DEG = 0.1  # deg: the smallest robot.step_angle_deg


@dataclass
class SafetyConfig:
    """The local safety layer (``robot.safety``, conf/robot/jackal.yaml)."""

    enabled: bool = True
    # hard: the commanded footprint sweep keeps this gap (m) to every scanned obstacle point
    # (several motion-noise sigmas: one step moves the true pose ~1 cm off the command)
    margin: float = 0.04
    # soft: below this gap a direction is penalised by comfort_weight rad per metre
    comfort: float = 0.12
    comfort_weight: float = 5.0
    # rad of cost per rad of in-place turn a direction needs (keeps the robot from dithering)
    turn_weight: float = 0.3
    # length (m) of the sweep a direction must keep clear (capped at the waypoint's distance)
    lookahead: float = 0.4
    # candidate directions, evenly spaced over the full circle (plus the exact bearing)
    headings: int = 72
    # once the layer has changed a step towards a waypoint: steps without getting `progress`
    # (m) closer to it than before, after which the layer gives up on the waypoint
    patience: int = 15
    progress: float = 0.05
    # a waypoint the layer gives up on this close (m) counts as reached; so does one this
    # close that the direct way to is not clear. Intermediate waypoints of a path (corners)
    # get the larger tolerance: the path goes on from them anyway
    reach_tolerance: float = 0.5
    corner_tolerance: float = 0.6
    # directions deviating more than this (deg) from the waypoint's bearing are not taken
    # (except to step out of the margin): no driving away from the goal
    max_deviation_deg: float = 80.0
    # the ring: channels from min to max elevation, azimuth step, range (m)
    channels: int = 2
    min_elevation_deg: float = -15.0
    max_elevation_deg: float = 0.0
    azimuth_resolution_deg: float = 2.0
    max_range: float = 1.5
    # scan points below this height (m, above the floor) are floor, not obstacles
    floor_height: float = 0.05
    # cast a fresh ring every this many motion steps (in between, the last ring is moved by
    # the odometry)
    scan_every: int = 1

    def validate(self) -> None:
        """Raise with the key and the fix for values the layer cannot work with."""
        checks = {
            "margin": self.margin >= 0, "comfort": self.comfort >= 0, "comfort_weight": self.comfort_weight >= 0,
            "turn_weight": self.turn_weight >= 0, "lookahead": self.lookahead > 0, "headings": self.headings >= 8,
            "patience": self.patience >= 1, "progress": self.progress >= 0,
            "reach_tolerance": self.reach_tolerance >= 0, "corner_tolerance": self.corner_tolerance >= 0,
            "max_deviation_deg": 0 < self.max_deviation_deg <= 180, "channels": self.channels >= 1,
            "azimuth_resolution_deg": self.azimuth_resolution_deg > 0, "max_range": self.max_range > 0,
            "scan_every": self.scan_every >= 1,
        }
        bad = [key for key, ok in checks.items() if not ok]
        if bad:
            values = ", ".join(f"robot.safety.{key}={getattr(self, key)}" for key in bad)
            raise ValueError(f"{values}: margins, weights, tolerances >= 0; lookahead, ranges, azimuth step > 0; "
                             f"headings >= 8; patience, channels, scan_every >= 1; max_deviation_deg in (0, 180]")


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
    # Step cap of one path (Robot.follow): a path that has not ended after path_step_factor
    # times the motion steps it needs (its length / step_distance plus a half turn per
    # waypoint / step_angle_deg) plus path_step_slack steps ends blocked, and the log says why
    # -- whatever the settings or the situation, following a path cannot loop forever.
    path_step_factor: float = 10.0
    path_step_slack: int = 100
    # the local safety layer on the live scan (explore_rl/local_planner.py); enabled=false: off
    safety: SafetyConfig = field(default_factory=SafetyConfig)

    def validate(self) -> None:
        """Values path following can work with (a zero tolerance or turn step never ends a
        waypoint; a negative or NaN noise breaks the motion model); one line per bad key."""
        for key in ("radius", "speed", "turn_rate_deg", "waypoint_tolerance", "path_step_factor"):
            checks.positive(f"robot.{key}", getattr(self, key))
        # motion steps of at least 1 mm / 0.1 deg: smaller ones make a path take millions of steps
        checks.in_range("robot.step_distance", self.step_distance, MIN_STEP_DISTANCE, 10.0)
        checks.in_range("robot.step_angle_deg", self.step_angle_deg, MIN_STEP_ANGLE_DEG, 180.0)
        checks.in_range("robot.heading_tolerance_deg", self.heading_tolerance_deg, 0.0, 180.0, low_open=True)
        for key in ("noise_xy", "noise_yaw_deg"):
            checks.non_negative(f"robot.{key}", getattr(self, key))
        checks.at_least("robot.path_step_slack", self.path_step_slack, 0)
        if len(self.body_size) != 3:
            raise ValueError(f"robot.body_size must be three positive sizes [x, y, z] (m), got {self.body_size}")
        for i, size in enumerate(self.body_size):
            checks.positive(f"robot.body_size[{i}]", size)
        if self.safety.enabled:
            self.safety.validate()


@dataclass
class EscapeConfig:
    """How a robot touching an obstacle backs off (``Robot.escape``; config ``explore.escape``)."""

    # footprint clearance (m, beyond the robot radius) the robot backs off to; a robot with
    # at least this much is left alone. Several motion-noise sigmas, so turns are safe again.
    clearance: float = 0.1
    # escape headings tried, evenly spaced from the current heading (even: straight ahead
    # and straight back are among them, so a plain back-off needs no turn)
    directions: int = 36
    # motion steps one escape may use: turns, translations and noisy steps that would have
    # collided (not taken, retried with fresh noise)
    max_steps: int = 40
