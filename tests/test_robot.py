import numpy as np
import pytest

from explore_rl.geometry import se2_between, se2_compose
from explore_rl.local_planner import LocalPlanner, SafetyConfig
from explore_rl.robot import EscapeConfig, PathStatus, Robot, RobotConfig


def open_floor(xy):
    return np.ones(np.asarray(xy).shape[:-1], dtype=bool)


def test_reaches_waypoints_and_odometry_equals_commands(rng):
    robot = Robot(RobotConfig(), np.array([0.0, 0.0, 0.0]), open_floor, rng)
    steps = list(robot.follow(np.array([[2.0, 0.0], [2.0, 2.0]])))
    assert robot.status is PathStatus.REACHED
    assert np.linalg.norm(robot.belief_pose[:2] - [2.0, 2.0]) <= RobotConfig().waypoint_tolerance
    commanded = sum(np.hypot(s.commanded[0], s.commanded[1]) for s in steps)
    assert robot.travelled == pytest.approx(commanded)
    # the true pose drifted, the odometry pose did not
    assert np.allclose(robot.odom_pose, robot.belief_pose)
    assert not np.allclose(robot.true_pose, robot.odom_pose)


def test_motion_steps_respect_step_limits(rng):
    config = RobotConfig()
    robot = Robot(config, np.array([0.0, 0.0, 0.0]), open_floor, rng)
    for step in robot.follow(np.array([[3.0, 1.0], [0.0, 3.0]])):
        assert np.hypot(*step.commanded[:2]) <= config.step_distance + 1e-12
        assert abs(step.commanded[2]) <= np.deg2rad(config.step_angle_deg) + 1e-12


def test_motion_noise_statistics_match_configured_sigmas():
    config = RobotConfig(noise_xy=0.01, noise_yaw_deg=0.08)
    rng = np.random.default_rng(7)
    robot = Robot(config, np.zeros(3), open_floor, rng)
    errors = []
    for _ in range(4000):
        before = robot.true_pose.copy()
        command = np.array([0.2, 0.0, 0.05])
        step = robot.execute(command)
        errors.append(se2_between(before, step.true_pose) - command)
    errors = np.array(errors)
    std = errors.std(axis=0)
    assert np.allclose(errors.mean(axis=0), 0.0, atol=3 * std / np.sqrt(len(errors)) + 1e-9)
    assert std[0] == pytest.approx(0.01, rel=0.06)
    assert std[1] == pytest.approx(0.01, rel=0.06)
    assert np.rad2deg(std[2]) == pytest.approx(0.08, rel=0.06)


def test_blocked_path_stops_before_the_obstacle(rng):
    wall_x = 1.0
    radius = RobotConfig().radius

    def is_free(xy):
        return np.asarray(xy)[..., 0] + radius <= wall_x

    robot = Robot(RobotConfig(), np.array([0.0, 0.0, 0.0]), is_free, rng)
    list(robot.follow(np.array([[3.0, 0.0]])))
    assert robot.status is PathStatus.BLOCKED
    assert robot.true_pose[0] + radius <= wall_x


def test_never_ends_inside_an_obstacle_over_random_paths(office):
    rng = np.random.default_rng(3)
    free_cells = np.argwhere(office.truth.reachable)
    for trial in range(30):
        robot = Robot(RobotConfig(), office.start_pose, office.is_free, rng)
        goals = office.grid.cell_to_world(free_cells[rng.choice(len(free_cells), 3)])
        for step in robot.follow(goals):
            assert office.geometry.signed_distance(step.true_pose[:2]) >= RobotConfig().radius
        assert office.is_free(robot.true_pose[:2])


# ---------------------------------------------------------------- escape

RADIUS = RobotConfig().radius


def walls(x_max=None, y_max=None):
    """Footprint clearance and is_free for walls at x = x_max and/or y = y_max."""

    def clearance(xy):
        xy = np.asarray(xy, dtype=float)
        gap = np.full(xy.shape[:-1], np.inf)
        if x_max is not None:
            gap = np.minimum(gap, x_max - xy[..., 0])
        if y_max is not None:
            gap = np.minimum(gap, y_max - xy[..., 1])
        return gap - RADIUS

    return clearance, lambda xy: clearance(xy) >= 0


def touching_robot(pose, clearance, is_free, seed):
    return Robot(RobotConfig(), np.asarray(pose, dtype=float), is_free, np.random.default_rng(seed),
                 clearance=clearance)


def test_robot_touching_a_wall_backs_off_and_reaches_a_goal_behind_it():
    clearance, is_free = walls(x_max=1.0)
    start = [1.0 - RADIUS - 0.001, 0.0, 0.0]  # 1 mm from the wall, facing it
    goal = np.array([[-2.0, 0.0]])
    seeds = range(6)
    # Without an escape, turning round 1 mm from the wall fails: the motion noise pushes
    # most turn steps into the wall.
    plain = [touching_robot(start, clearance, is_free, seed) for seed in seeds]
    for robot in plain:
        list(robot.follow(goal))
    assert sum(robot.status is PathStatus.BLOCKED for robot in plain) >= 4
    for seed in seeds:
        robot = touching_robot(start, clearance, is_free, seed)
        steps = list(robot.escape(EscapeConfig()))
        assert robot.status is PathStatus.REACHED
        assert robot.footprint_clearance() >= EscapeConfig().clearance
        # it drove straight back: no turn, one reverse step
        assert [s.commanded.tolist() for s in steps] == [[-RobotConfig().step_distance, 0.0, 0.0]]
        list(robot.follow(goal))
        assert robot.status is PathStatus.REACHED
        assert np.linalg.norm(robot.belief_pose[:2] - goal[0]) <= RobotConfig().waypoint_tolerance


@pytest.mark.parametrize("yaw_deg", [90.0, 45.0, -135.0, 180.0])
def test_escape_from_a_corner_is_collision_free_ordinary_motion(yaw_deg):
    clearance, is_free = walls(x_max=1.0, y_max=1.0)
    config = EscapeConfig()
    start = np.array([1.0 - RADIUS - 0.002, 1.0 - RADIUS - 0.001, np.deg2rad(yaw_deg)])
    for seed in range(5):
        robot = touching_robot(start, clearance, is_free, seed)
        odom = start.copy()
        steps = list(robot.escape(config))
        assert robot.status is PathStatus.REACHED and steps
        assert robot.footprint_clearance() >= config.clearance
        for step in steps:
            assert clearance(step.true_pose[:2]) >= 0
            assert np.hypot(*step.commanded[:2]) <= RobotConfig().step_distance + 1e-12
            assert abs(step.commanded[2]) <= np.deg2rad(RobotConfig().step_angle_deg) + 1e-12
            odom = se2_compose(odom, step.commanded)
        # odometry is the commanded motion, as on any path; the noise moved the true pose
        assert np.allclose(robot.odom_pose, odom)
        assert robot.travelled == pytest.approx(sum(np.hypot(*s.commanded[:2]) for s in steps))
        assert len(steps) <= config.max_steps


def test_escape_alongside_a_wall_turns_the_least():
    clearance, is_free = walls(x_max=1.0)
    robot = touching_robot([1.0 - RADIUS - 0.001, 0.0, np.pi / 2], clearance, is_free, 0)
    steps = list(robot.escape(EscapeConfig()))
    assert robot.status is PathStatus.REACHED
    turned = sum(abs(s.commanded[2]) for s in steps)
    assert turned <= np.deg2rad(30.0) + 1e-9  # not the 90 deg a face-the-free-side turn takes


def test_escape_is_a_no_op_when_clear_and_gives_up_cleanly_when_boxed_in():
    clearance, is_free = walls(x_max=1.0)
    clear = touching_robot([0.0, 0.0, 0.0], clearance, is_free, 0)
    assert list(clear.escape(EscapeConfig())) == [] and clear.status is PathStatus.REACHED
    no_sensor = Robot(RobotConfig(), np.array([1.0 - RADIUS, 0.0, 0.0]), is_free, np.random.default_rng(0))
    assert not no_sensor.needs_escape(EscapeConfig())

    # a slot 2 cm wider than the robot: no heading gains clearance
    def slot(xy):
        return 0.31 - np.abs(np.asarray(xy, dtype=float)[..., 1]) - RADIUS

    boxed = touching_robot([0.0, 0.0, 0.0], slot, lambda xy: slot(xy) >= 0, 0)
    assert list(boxed.escape(EscapeConfig())) == []
    assert boxed.status is PathStatus.BLOCKED


def test_contacts_and_the_least_true_clearance_are_counted(rng):
    clearance, is_free = walls(x_max=1.0)
    robot = Robot(RobotConfig(), np.array([0.0, 0.0, 0.0]), is_free, rng, clearance=clearance)
    steps = list(robot.follow(np.array([[3.0, 0.0]])))
    assert robot.status is PathStatus.BLOCKED
    assert robot.contacts == 1  # the step that would have entered the wall, not taken
    assert robot.min_clearance == pytest.approx(min(clearance(s.true_pose[:2]) for s in steps))
    assert 0.0 <= robot.min_clearance < RobotConfig().step_distance
    unmeasured = Robot(RobotConfig(), np.zeros(3), is_free, rng)
    list(unmeasured.follow(np.array([[3.0, 0.0]])))
    assert unmeasured.contacts == 1 and unmeasured.min_clearance == float("inf")


# ---------------------------------------------------------------- step cap (issue 20 item 3)


@pytest.mark.parametrize("guarded", [False, True], ids=["without_layer", "with_layer"])
@pytest.mark.parametrize("overrides", [
    {"waypoint_tolerance": -0.1},
    {"step_angle_deg": 0.0, "noise_xy": 0.0, "noise_yaw_deg": 0.0},
])
def test_follow_ends_a_path_that_never_arrives_as_blocked_at_the_step_cap(overrides, guarded, rng, caplog):
    """Settings (which validate() rejects) under which the old ``follow`` looped forever,
    with the safety layer (here seeing nothing) or without: now the path ends blocked at
    the cap, with a warning that says why."""
    config = RobotConfig(**overrides)
    guard = LocalPlanner(SafetyConfig(), config, lambda pose: np.zeros((0, 2))) if guarded else None
    robot = Robot(config, np.array([0.0, 0.0, 0.0]), open_floor, rng, guard=guard)
    waypoints = np.array([[1.0, 0.5], [2.0, 1.5]])
    cap = robot.step_cap(waypoints)
    with caplog.at_level("WARNING", logger="explore_rl.robot"):
        steps = list(robot.follow(waypoints))
    assert robot.status is PathStatus.BLOCKED
    assert len(steps) == cap and robot.capped_paths == 1
    assert "path ended as blocked" in caplog.text and "path_step_factor" in caplog.text


def test_step_cap_scales_with_the_path_and_does_not_bind_on_normal_paths(rng):
    """Cap = factor x (length / step + a half turn per waypoint / step angle) + slack; a
    normal path takes far fewer steps, and the cap changes none of them."""
    config = RobotConfig()
    robot = Robot(config, np.array([0.0, 0.0, 0.0]), open_floor, rng)
    waypoints = np.array([[3.0, 0.0], [3.0, 4.0]])
    needed = 7.0 / config.step_distance + 2 * 180.0 / config.step_angle_deg
    assert robot.step_cap(waypoints) == int(np.ceil(config.path_step_factor * needed)) + config.path_step_slack
    uncapped = Robot(RobotConfig(path_step_factor=1e9), np.zeros(3), open_floor, np.random.default_rng(5))
    capped = Robot(config, np.zeros(3), open_floor, np.random.default_rng(5))
    steps = [s.true_pose for s in capped.follow(waypoints)]
    reference = [s.true_pose for s in uncapped.follow(waypoints)]
    assert capped.status is PathStatus.REACHED and capped.capped_paths == 0
    assert len(steps) < capped.step_cap(waypoints) / 5
    np.testing.assert_array_equal(np.array(steps), np.array(reference))


@pytest.mark.parametrize("key,value,message", [
    ("waypoint_tolerance", 0.0, "robot.waypoint_tolerance must be positive"),
    ("waypoint_tolerance", -0.1, "robot.waypoint_tolerance must be positive"),
    ("step_angle_deg", 0.0, r"robot.step_angle_deg must be in \[0.1, 180\]"),
    ("step_distance", 1e-5, r"robot.step_distance must be in \[0.001, 10\]"),
    ("heading_tolerance_deg", 0.0, r"robot.heading_tolerance_deg must be in \(0, 180\]"),
    ("turn_rate_deg", 0.0, "robot.turn_rate_deg must be positive"),
    ("noise_xy", -0.01, "robot.noise_xy must be >= 0"),
    ("noise_yaw_deg", float("nan"), "robot.noise_yaw_deg must be >= 0"),
    ("path_step_factor", 0.0, "robot.path_step_factor must be positive"),
    ("body_size", [0.5, 0.4], r"robot.body_size must be three positive sizes"),
])
def test_robot_config_validate_names_the_key_and_range(key, value, message):
    RobotConfig().validate()
    with pytest.raises(ValueError, match=message):
        RobotConfig(**{key: value}).validate()


def test_clearance_alone_decides_collisions_like_is_free(office):
    """``is_free=None``: a step is free where the clearance is >= 0 (one distance query per
    step): the same steps, contacts and least clearance as with ``office.is_free`` beside it,
    on straight paths to random goals (most end against a wall)."""
    free_cells = np.argwhere(office.truth.reachable)
    choose = np.random.default_rng(4)
    steps, contacts = 0, 0
    for trial in range(6):
        goals = office.grid.cell_to_world(free_cells[choose.choice(len(free_cells), 3)])
        runs = []
        for is_free in (office.is_free, None):
            robot = Robot(RobotConfig(), office.start_pose, is_free, np.random.default_rng(trial),
                          clearance=office.footprint_clearance)
            poses = [step.true_pose for step in robot.follow(goals)]
            runs.append((np.array(poses).reshape(-1, 3), robot.contacts, robot.min_clearance, robot.status))
        (poses_a, contacts_a, least_a, status_a), (poses_b, contacts_b, least_b, status_b) = runs
        assert poses_a.shape == poses_b.shape
        np.testing.assert_allclose(poses_b, poses_a, rtol=0, atol=1e-12)
        assert (contacts_b, status_b) == (contacts_a, status_a)
        assert least_b == pytest.approx(least_a, abs=1e-12)
        steps, contacts = steps + len(poses_a), contacts + contacts_a
    assert steps > 50 and contacts > 0  # both branches ran: free steps and refused ones


def test_a_robot_without_any_collision_test_is_refused():
    with pytest.raises(ValueError, match="is_free or clearance"):
        Robot(RobotConfig(), np.zeros(3), None, np.random.default_rng(0))
