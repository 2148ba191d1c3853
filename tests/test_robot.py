import numpy as np
import pytest

from explore_rl.geometry import se2_between
from explore_rl.robot import PathStatus, Robot, RobotConfig


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
