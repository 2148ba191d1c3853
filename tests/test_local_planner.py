"""The local safety layer: stops or steers before contact, reports what it cannot pass,
never commands a step into what its scan sees, and leaves the robot untouched when off."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.local_planner import LocalPlanner, SafetyConfig, make_local_planner, sweep_clearance
from explore_rl.robot import PathStatus, Robot, RobotConfig
from explore_rl.runner import Explorer
from explore_rl.scene.build import make_scene
from explore_rl.scene.config import SceneConfig
from explore_rl.sensors.lidar import LidarConfig

RADIUS = RobotConfig().radius
REFERENCE = Path(__file__).resolve().parent / "data" / "robot_follow_before_safety.npz"


def file_scene(tmp_path: Path, text: str):
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return make_scene(SceneConfig(name="file", path=str(path)), RobotConfig(), LidarConfig())


def guarded_robot(scene, seed: int, safety: SafetyConfig | None = None, start=None) -> Robot:
    """A robot in ``scene`` with the layer on (its own ring) and the true clearance measured."""
    guard = make_local_planner(safety or SafetyConfig(), RobotConfig(), scene, LidarConfig(),
                               np.random.default_rng([seed, 5]))
    start = scene.start_pose if start is None else np.asarray(start, dtype=float)
    return Robot(RobotConfig(), start, scene.is_free, np.random.default_rng(seed),
                 clearance=scene.footprint_clearance, guard=guard)


@pytest.fixture(scope="module")
def walled(tmp_path_factory):
    """A 6 m x 4 m room cut in two by a wall at x = 3: the far half cannot be reached."""
    return file_scene(tmp_path_factory.mktemp("walled"),
                      "version: 1\nname: walled\nsize: [6.0, 4.0]\n"
                      "walls:\n  - {from: [3.0, 0.0], to: [3.0, 4.0]}\n"
                      "starts:\n  - [1.0, 2.0, 0.0]\n")


@pytest.fixture(scope="module")
def slot(tmp_path_factory):
    """The same room, but the wall has a 0.5 m slot: narrower than the 0.6 m footprint."""
    return file_scene(tmp_path_factory.mktemp("slot"),
                      "version: 1\nname: slot\nsize: [6.0, 4.0]\n"
                      "walls:\n  - {from: [3.0, 0.0], to: [3.0, 1.75]}\n"
                      "  - {from: [3.0, 2.25], to: [3.0, 4.0]}\n"
                      "starts:\n  - [1.0, 2.0, 0.0]\n")


# ---------------------------------------------------------------- behaviour in scenes


@pytest.mark.parametrize("yaw_deg", [0.0, 20.0, -35.0])
def test_driven_straight_at_a_wall_it_stops_or_turns_before_contact(walled, yaw_deg):
    wall_face = 3.0 - 0.1  # wall centred on x = 3, 0.2 m thick
    goal = np.array([[5.0, 2.0 + 3.0 * np.tan(np.deg2rad(yaw_deg))]])
    start = [1.0, 2.0, np.deg2rad(yaw_deg)]
    for seed in range(4):
        plain = Robot(RobotConfig(), np.array(start), walled.is_free, np.random.default_rng(seed),
                      clearance=walled.footprint_clearance)
        list(plain.follow(goal))
        assert plain.status is PathStatus.BLOCKED and plain.contacts == 1  # today: it hits the wall

        robot = guarded_robot(walled, seed, start=start)
        steps = list(robot.follow(goal))
        assert robot.status is PathStatus.BLOCKED  # the goal is behind the wall
        assert robot.contacts == 0
        assert robot.min_clearance > 0.0
        assert all(walled.footprint_clearance(s.true_pose[:2]) > 0.0 for s in steps)
        assert robot.true_pose[0] + RADIUS < wall_face
        assert robot.travelled < 20.0  # it gave up; no endless wandering


def test_corridor_narrower_than_the_footprint_is_reported_blocked_not_driven_through(slot):
    for seed in range(4):
        robot = guarded_robot(slot, seed)
        steps = list(robot.follow(np.array([[2.0, 2.0], [5.0, 2.0]])))
        assert robot.status is PathStatus.BLOCKED
        assert robot.contacts == 0
        assert all(s.true_pose[0] < 3.0 - 0.1 - RADIUS for s in steps)  # never entered the slot
        assert robot.guard.stops == 1


def test_a_wide_door_is_driven_through(tmp_path):
    door = file_scene(tmp_path, "version: 1\nname: door\nsize: [6.0, 4.0]\n"
                                "walls:\n  - {from: [3.0, 0.0], to: [3.0, 1.5]}\n"
                                "  - {from: [3.0, 2.5], to: [3.0, 4.0]}\n"
                                "starts:\n  - [1.0, 2.0, 0.0]\n")
    for seed in range(3):
        # aimed at the door's edge: without the layer the footprint would graze the wall end
        robot = guarded_robot(door, seed)
        list(robot.follow(np.array([[2.0, 1.75], [5.0, 1.75]])))
        assert robot.status is PathStatus.REACHED
        assert robot.contacts == 0 and robot.true_pose[0] > 4.0


def test_random_paths_through_the_office_never_touch_an_obstacle(office):
    """Legs that clear the walls by only 2 cm in truth (which SLAM-steered paths often do):
    the layer keeps every step off the obstacles, and the paths still get where they go."""
    reached = 0
    for trial in range(6):
        waypoints = clear_waypoints(office, np.random.default_rng([7, trial]))
        robot = guarded_robot(office, trial)
        for step in robot.follow(waypoints):
            assert office.footprint_clearance(step.true_pose[:2]) > 0.0
        assert robot.contacts == 0
        reached += robot.status is PathStatus.REACHED
    assert reached >= 5


def test_a_guarded_run_records_no_contacts_and_the_layer_columns(tmp_path):
    config = load_config(["scene=street", "slam=model", "explore.max_decisions=4", "explore.progress_bar=false",
                          "seed=1"])
    explorer = Explorer(config)
    assert explorer.robot.guard is explorer.local_planner is not None
    rows = explorer.run().table()
    assert rows[-1]["contacts"] == explorer.robot.contacts == 0
    assert rows[-1]["min_clearance_m"] == explorer.robot.min_clearance > 0.0
    assert rows[-1]["blocked_decisions"] == sum(r["path_status"] == "blocked" for r in rows)
    assert sum(r["ms_safety"] for r in rows) > 0.0
    assert explorer.local_planner.sense.casts > 0


# ---------------------------------------------------------------- the rule on synthetic scans


class FakeRobot:
    def __init__(self, pose):
        self.true_pose = np.asarray(pose, dtype=float)
        self.odom_pose = self.true_pose.copy()
        self.belief_pose = self.true_pose.copy()


def test_no_step_enters_what_the_scan_sees():
    """Random scans (walls and clutter in the body frame), random targets and nominal steps:
    every translation the layer commands keeps the margin from the scan points along its
    whole sweep — or, for a robot already inside the margin, gets no closer."""
    rng = np.random.default_rng(0)
    config, robot_config = SafetyConfig(), RobotConfig()
    checked = 0
    for trial in range(1000):
        wall = rng.uniform(0.3, 1.2) * np.array([np.cos(a := rng.uniform(-np.pi, np.pi)), np.sin(a)])
        along = np.array([-wall[1], wall[0]]) / np.linalg.norm(wall)
        points = wall + np.linspace(-2, 2, 120)[:, None] * along
        clutter = rng.uniform(-1.2, 1.2, size=(rng.integers(0, 30), 2))
        points = np.vstack([points, clutter])
        points = points[np.linalg.norm(points, axis=1) > RADIUS + 0.005]  # the robot is not inside one
        planner = LocalPlanner(config, robot_config, lambda pose, pts=points: pts)
        robot = FakeRobot([0.0, 0.0, 0.0])
        target = rng.uniform(-3, 3, 2)
        planner.begin(target)
        heading = float(np.arctan2(target[1], target[0]))
        nominal = (np.array([0.2, 0.0, heading]) if abs(heading) < np.deg2rad(10)
                   else np.array([0.0, 0.0, np.clip(heading, -0.17, 0.17)]))
        command = planner.adjust(robot, target, nominal)
        if command is None or isinstance(command, str):
            continue
        travel = float(np.hypot(command[0], command[1]))
        now = float(np.linalg.norm(points, axis=1).min()) - RADIUS
        if travel > 0:
            direction = np.array([command[:2]]) / travel
            swept = sweep_clearance(points, direction, travel, RADIUS)[0]
            assert swept >= min(config.margin, now) - 1e-3, (trial, command, swept, now)
            checked += 1
        assert abs(command[2]) <= np.deg2rad(robot_config.step_angle_deg) + 1e-9
        assert travel <= robot_config.step_distance + 1e-9
    assert checked > 150


def test_inside_the_margin_it_steps_out_first():
    """1 cm from a wall ahead: the layer backs off (no turn in place next to the wall)."""
    points = np.stack([np.full(50, RADIUS + 0.01), np.linspace(-1, 1, 50)], -1)
    planner = LocalPlanner(SafetyConfig(), RobotConfig(), lambda pose: points)
    robot = FakeRobot([0.0, 0.0, 0.0])
    target = np.array([0.0, 2.0])  # to the left: the nominal step is a turn in place
    planner.begin(target)
    command = planner.adjust(robot, target, np.array([0.0, 0.0, np.deg2rad(10)]))
    assert command[0] < 0  # reverses away from the wall
    end_gap = float(np.linalg.norm(points - command[:2], axis=1).min()) - RADIUS
    assert end_gap >= SafetyConfig().margin


def test_far_from_obstacles_the_nominal_step_is_kept():
    points = np.array([[2.0, 0.0], [0.0, -1.4]])
    planner = LocalPlanner(SafetyConfig(), RobotConfig(), lambda pose: points)
    robot = FakeRobot([0.0, 0.0, 0.0])
    nominal = np.array([0.2, 0.0, 0.01])
    planner.begin(np.array([3.0, 0.0]))
    assert planner.adjust(robot, np.array([3.0, 0.0]), nominal) is nominal
    assert planner.interventions == 0


def test_a_stale_ring_is_moved_by_the_odometry():
    """With ``scan_every`` > 1 the last ring is carried along by the odometry."""
    calls = []

    def sense(pose):
        calls.append(pose.copy())
        return np.array([[1.0, 0.0]])

    planner = LocalPlanner(SafetyConfig(scan_every=3), RobotConfig(), sense)
    robot = FakeRobot([0.0, 0.0, 0.0])
    assert np.allclose(planner.points(robot), [[1.0, 0.0]])
    planner._since_scan = 1
    robot.odom_pose = np.array([0.2, 0.0, np.pi / 2])
    assert np.allclose(planner.points(robot), [[0.0, -0.8]])
    assert len(calls) == 1


# ---------------------------------------------------------------- off: today's behaviour


def clear_waypoints(scene, rng, count=8, gap=0.02):
    """Waypoints from the start, each a straight leg the footprint clears by ``gap`` (truth)."""
    here, out = scene.start_pose[:2].copy(), []
    while len(out) < count:
        goal = here + rng.uniform(-2.0, 2.0, 2)
        leg = here + np.linspace(0.0, 1.0, 40)[:, None] * (goal - here)
        if (scene.geometry.signed_distance(leg) >= RADIUS + gap).all():
            out.append(goal)
            here = goal
    return np.array(out)


def trajectories(scene, make_robot):
    poses, blocked = [], []
    for trial in range(6):
        waypoints = clear_waypoints(scene, np.random.default_rng([7, trial]))
        robot = make_robot(np.random.default_rng([11, trial]))
        for step in robot.follow(waypoints):
            poses.append(np.concatenate([step.true_pose, step.odom_pose, step.belief_pose]))
        blocked.append(robot.status is PathStatus.BLOCKED)
    return np.array(poses), np.array(blocked)


def test_without_the_layer_paths_are_followed_as_before(office):
    """``tests/data/robot_follow_before_safety.npz`` holds these trajectories as the robot
    of commit d2fb94a (before the layer) drove them (same helpers, same seeds). Only a
    deliberate change of the unguarded motion model may regenerate it: save ``poses`` and
    ``blocked`` of this call with ``np.savez_compressed``.

    The stored file was written on another CPU: libm and vectorised numpy kernels may
    differ in the last bits there (5e-15 m seen), so poses are compared to 1e-9 m, far
    below any change of the motion model (one motion step's noise is ~1e-2 m)."""
    reference = np.load(REFERENCE)
    poses, blocked = trajectories(
        office, lambda rng: Robot(RobotConfig(), office.start_pose, office.is_free, rng,
                                  clearance=office.footprint_clearance, guard=None))
    assert poses.shape == reference["poses"].shape
    np.testing.assert_allclose(poses, reference["poses"], rtol=0, atol=1e-9)
    assert blocked.dtype == bool and blocked.tolist() == reference["blocked"].tolist()  # flags: exact


def test_switched_off_in_the_config_no_layer_is_built():
    config = load_config(["scene=street", "slam=model", "robot.safety.enabled=false", "explore.max_decisions=2",
                          "explore.progress_bar=false"])
    explorer = Explorer(config)
    assert explorer.local_planner is None and explorer.robot.guard is None
    rows = explorer.run().table()
    assert all(r["ms_safety"] == 0.0 and r["safety_interventions"] == 0 for r in rows)


def test_bad_layer_settings_fail_with_the_key(office):
    with pytest.raises(ValueError, match=r"robot.safety.headings=2.*robot.safety.scan_every=0"):
        make_local_planner(SafetyConfig(headings=2, scan_every=0), RobotConfig(), office, LidarConfig(),
                           np.random.default_rng(0))
    assert make_local_planner(SafetyConfig(enabled=False, headings=2), RobotConfig(), office, LidarConfig(),
                              np.random.default_rng(0)) is None
