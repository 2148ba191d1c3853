import numpy as np
import pytest

from explore_rl.geometry import rotation_2d, se2_to_matrix, transform_points
from explore_rl.robot import RobotConfig
from explore_rl.scene.build import make_scene
from explore_rl.scene.config import SceneConfig
from explore_rl.sensors.analytic import cast_rays
from explore_rl.sensors.lidar import Lidar, LidarConfig, ray_directions


def test_vlp16_pattern():
    dirs = ray_directions(LidarConfig())
    assert dirs.shape == (16 * 900, 3)
    assert np.allclose(np.linalg.norm(dirs, axis=1), 1.0)
    elevation = np.rad2deg(np.arcsin(dirs[:, 2]))
    assert elevation.min() == pytest.approx(-15.0) and elevation.max() == pytest.approx(15.0)


def test_rays_hit_at_analytic_distances(any_scene):
    lidar = Lidar(any_scene, LidarConfig(), np.random.default_rng(0))
    rng = np.random.default_rng(1)
    cells = np.argwhere(any_scene.truth.traversable & any_scene.truth.reachable)
    for k in rng.choice(len(cells), 5):
        pose = np.array([*any_scene.grid.cell_to_world(cells[k]), rng.uniform(-np.pi, np.pi)])
        ranges = lidar.cast(pose)
        world_dirs = lidar.directions.copy()
        world_dirs[:, :2] = world_dirs[:, :2] @ rotation_2d(pose[2]).T
        expected = cast_rays(any_scene.layout, lidar.sensor_position(pose), world_dirs, 3.0)
        assert np.array_equal(ranges > 0, expected > 0)
        hit = ranges > 0
        assert hit.any()
        assert np.abs(ranges[hit] - expected[hit]).max() < 1e-9


def test_floor_hit_distance_matches_elevation(office):
    lidar = Lidar(office, LidarConfig(), np.random.default_rng(0))
    ranges = lidar.cast(office.start_pose)
    lowest = lidar.directions[:, 2] < -0.25  # the -15 deg channel
    expected = LidarConfig().mount_height / np.sin(np.deg2rad(15.0))
    floor_hits = ranges[lowest][np.isclose(ranges[lowest], expected, atol=1e-9)]
    assert len(floor_hits) > 0.5 * lowest.sum()


@pytest.mark.parametrize("tile_size", [0.0, 3.0])
def test_no_point_comes_from_the_robot(tile_size):
    """A robot with a big chassis right under the sensor: no return comes from it."""
    import mujoco

    robot = RobotConfig(body_size=[1.6, 1.6, 0.35])
    scene = make_scene(SceneConfig(name="office", num_objects=0), robot, LidarConfig())
    lidar = Lidar(scene, LidarConfig(range_noise=0.0, tile_size=tile_size), np.random.default_rng(0))
    pose = scene.start_pose
    scan = lidar.scan(pose)
    horizontal = np.hypot(scan.points[:, 0], scan.points[:, 1])
    assert horizontal.min() > 0.8 * np.sqrt(2)
    # the same rays without the exclusions do hit the chassis, so the check has teeth
    geomid = np.empty(lidar.rays_per_scan, dtype=np.int32)
    dist = np.empty(lidar.rays_per_scan)
    world_dirs = lidar.directions.copy()
    world_dirs[:, :2] = world_dirs[:, :2] @ rotation_2d(pose[2]).T
    mujoco.mj_multiRay(scene.model, scene.data, lidar.sensor_position(pose), world_dirs.ravel(),
                       None, 1, -1, geomid, dist, None, lidar.rays_per_scan, 4.0)
    assert np.isin(geomid, scene.model.body("robot").geomadr[0] + np.arange(2)).any()


def test_scan_returns_points_and_no_return_directions(office):
    config = LidarConfig()
    lidar = Lidar(office, config, np.random.default_rng(0))
    scan = lidar.scan(office.start_pose)
    assert len(scan.points) + len(scan.no_return_dirs) == lidar.rays_per_scan
    assert np.all(np.linalg.norm(scan.points, axis=1) <= config.max_range + 5 * config.range_noise)
    assert np.allclose(np.linalg.norm(scan.no_return_dirs, axis=1), 1.0)


def test_range_noise_statistics(office):
    config = LidarConfig(range_noise=0.02)
    lidar = Lidar(office, config, np.random.default_rng(5))
    pose = office.start_pose
    clean = lidar.cast(pose)
    scan = lidar.scan(pose)
    noisy = np.linalg.norm(scan.points, axis=1)
    residual = noisy - clean[clean > 0]
    assert residual.std() == pytest.approx(0.02, rel=0.1)
    assert abs(residual.mean()) < 0.002


def test_points_land_on_obstacles_in_world_frame(office):
    lidar = Lidar(office, LidarConfig(range_noise=0.0), np.random.default_rng(0))
    pose = office.start_pose
    scan = lidar.scan(pose)
    world = transform_points(se2_to_matrix(pose, LidarConfig().mount_height), scan.points)
    above_floor = world[:, 2] > 1e-6
    distance = office.geometry.signed_distance(world[above_floor, :2])
    assert np.abs(distance).max() < 1e-6


def test_tiles_give_the_same_ranges_as_the_full_model(any_scene):
    """StaticTiles is an acceleration structure only: every ray, every scene, same range,
    also right at tile borders and corners."""
    full = Lidar(any_scene, LidarConfig(tile_size=0.0), np.random.default_rng(0))
    tiled = Lidar(any_scene, LidarConfig(tile_size=3.0), np.random.default_rng(0))
    rng = np.random.default_rng(2)
    cells = np.argwhere(any_scene.truth.traversable)
    xy = any_scene.grid.cell_to_world(cells[rng.choice(len(cells), 12, replace=False)])
    on_borders = np.round(xy / 3.0) * 3.0 + rng.choice([-1e-9, 1e-9], size=xy.shape)
    for x, y in np.vstack([xy, on_borders]):
        pose = np.array([x, y, rng.uniform(-np.pi, np.pi)])
        expected, got = full.cast(pose), tiled.cast(pose)
        assert np.array_equal(got > 0, expected > 0)
        assert np.abs(got - expected).max() < 1e-12
    assert 0 < len(tiled.tiles) <= 24
    largest_tile = max(tiled.tiles.model_at(pose).__getitem__(0).ngeom for pose in xy)
    assert largest_tile < any_scene.ngeom - 2  # fewer geoms than the scene (minus the robot's)


def test_tile_keeps_every_geom_within_reach(office):
    """geoms_near is conservative: any static geom whose surface comes within max_range of
    a point of the tile (checked on a dense sample of the tile) is in the tile's model."""
    tiles = Lidar(office, LidarConfig(), np.random.default_rng(0)).tiles
    tile = tiles.tile_of(office.start_pose)
    kept = set(tiles.geoms_near(tile).tolist())
    u = (np.arange(13) + 0.5) / 13 * tiles.tile_size
    low = np.asarray(tile) * tiles.tile_size
    sample = np.stack(np.meshgrid(low[0] + u, low[1] + u), -1).reshape(-1, 2)
    for g in np.flatnonzero(office.model.geom_bodyid == 0):
        center = office.data.geom_xpos[g, :2]
        if np.hypot(*(sample - center).T).min() <= LidarConfig().max_range:
            assert g in kept


def test_lidar_pickles_and_casts_the_same(office):
    import pickle

    lidar = Lidar(office, LidarConfig(), np.random.default_rng(0))
    pose = office.start_pose
    before = lidar.cast(pose)
    clone = pickle.loads(pickle.dumps(lidar))
    assert np.array_equal(clone.cast(pose), before)
    assert np.array_equal(clone.scan(pose).points, lidar.scan(pose).points)


def test_points_are_the_scans_points_with_the_same_noise(office):
    """``Lidar.points`` (the safety ring's cast) draws the same noise as ``scan``."""
    poses = [office.start_pose, office.start_pose + np.array([0.3, -0.2, 1.0])]
    for pose in poses:
        scan = Lidar(office, LidarConfig(), np.random.default_rng(11)).scan(pose)
        points = Lidar(office, LidarConfig(), np.random.default_rng(11)).points(pose)
        assert len(points) > 1000
        np.testing.assert_allclose(points, scan.points, rtol=0, atol=1e-12)
