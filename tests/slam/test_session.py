"""The SLAM session: metrics as DESIGN.md defines them, degenerate scans, re-projection."""

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.robot import Robot
from explore_rl.scene.build import make_scene
from explore_rl.sensors.lidar import Lidar, Scan
from explore_rl.slam.session import SlamSession, map_error


def make_config(*overrides):
    return load_config(["scene=office", "scene.start_index=1", *overrides])


def drive(config, lidar_factory=Lidar, goals=((11.5, 10.0), (11.5, 11.0))):
    scene = make_scene(config.scene, config.robot, config.lidar)
    start = scene.start_pose
    lidar = lidar_factory(scene, config.lidar, np.random.default_rng(1))
    robot = Robot(config.robot, start, scene.is_free, np.random.default_rng(2))
    session = SlamSession(config.slam, config.mapping, scene, lidar, start, np.random.default_rng(3))
    for step in robot.follow(np.array(goals)):
        if session.observe(step):
            robot.correct_belief(session.belief(robot.odom_pose))
    return session


@pytest.fixture(scope="module")
def session():
    return drive(make_config())


def test_map_error_is_zero_for_true_poses_and_positive_for_shifted(session):
    truth = session.true_poses()
    assert session.metrics(truth).map_error_m == pytest.approx(0.0, abs=1e-12)
    assert session.metrics(truth).ate_m == pytest.approx(0.0, abs=1e-12)
    shifted = truth + np.array([0.1, 0.0, 0.0])
    assert session.metrics(shifted).map_error_m == pytest.approx(0.1, rel=1e-9)
    assert session.metrics(shifted).ate_m == pytest.approx(0.1, rel=1e-9)


def test_map_error_of_a_rotation_grows_with_point_range():
    points = [np.array([[1.0, 0.0, 0.0], [3.0, 0.0, 0.0]])]
    true = np.eye(4)[None]
    rotated = np.eye(4)
    angle = 0.01
    rotated[:2, :2] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    expected = np.mean([2 * np.sin(angle / 2) * r for r in (1.0, 3.0)])
    assert map_error(rotated[None], true, points) == pytest.approx(expected, rel=1e-9)


def test_session_records_keyframes_and_explores(session):
    metrics = session.metrics()
    assert metrics.keyframes == len(session.keyframes) >= 3
    assert 0 < metrics.explored < 1 and metrics.volume_m3 > 0
    assert session.occupancy.known_free.sum() > 100 and session.occupancy.known_occupied.sum() > 10


class BlindLidar(Lidar):
    """A LiDAR whose scans come back empty (every ray without return)."""

    def scan(self, pose):
        return Scan(points=np.zeros((0, 3)), no_return_dirs=self.directions.copy(),
                    ranges=-np.ones(len(self.directions)))


class FloorOnlyLidar(Lidar):
    """Keeps only the floor returns of each scan."""

    def scan(self, pose):
        scan = super().scan(pose)
        floor = scan.points[:, 2] < -self.config.mount_height + 0.05
        return Scan(points=scan.points[floor], no_return_dirs=scan.no_return_dirs, ranges=scan.ranges)


@pytest.mark.parametrize("lidar_factory", [BlindLidar, FloorOnlyLidar])
def test_empty_or_floor_only_scans_never_crash_and_fall_back_to_odometry(lidar_factory):
    session = drive(make_config(), lidar_factory)
    assert len(session.keyframes) >= 3
    assert session.degenerate_registrations == len(session.keyframes) - 1
    assert np.allclose(session.graph.poses_se2(), session.odometry_poses(), atol=1e-6)


def test_reprojection_after_moving_poses_moves_the_map(session):
    session.rebuild_maps()
    before = session.occupancy.known_occupied.copy()
    offset = np.array([0.0, 0.5, 0.0])  # across the corridor walls the robot saw
    session.rebuild_maps(session.graph.poses_se2() + offset)
    after = session.occupancy.known_occupied
    shift = int(round(0.5 / session.scene.grid.resolution))
    assert after.sum() == pytest.approx(before.sum(), rel=0.05)
    overlap_shifted = (after[shift:, :] & before[:-shift, :]).sum()
    assert overlap_shifted > 0.8 * before.sum()
    assert (after & before).sum() < 0.5 * before.sum()
    session.rebuild_maps()
    assert np.array_equal(session.occupancy.known_occupied, before)
