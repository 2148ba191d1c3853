"""The compiled map-update loops against the numpy code they stand for, exactly."""

import numpy as np
import pytest

from explore_rl.grid import GridSpec
from explore_rl.mapping import compiled
from explore_rl.mapping.config import OccupancyConfig
from explore_rl.mapping.occupancy import OccupancyGrid, RayGridCollapse, Scan2D, azimuth_bin_centres
from explore_rl.sensors.lidar import Lidar, LidarConfig

CONFIG = OccupancyConfig()


def real_scans(scene, count: int, seed: int) -> list[tuple[Scan2D, np.ndarray]]:
    """Collapsed LiDAR scans from random free poses of a scene, at random headings."""
    lidar_config = LidarConfig()
    lidar = Lidar(scene, lidar_config, np.random.default_rng(seed))
    collapse = RayGridCollapse(lidar.directions, lidar_config.channels, lidar_config.mount_height, CONFIG)
    rng = np.random.default_rng(seed)
    free = np.argwhere(scene.truth.reachable)
    scans = []
    for _ in range(count):
        xy = scene.grid.cell_to_world(free[rng.integers(len(free))])
        pose = np.array([xy[0], xy[1], rng.uniform(-np.pi, np.pi)])
        scan = lidar.scan(pose)
        scans.append((collapse(scan.points, scan.hit_index), pose))
    return scans


def assert_same_cells(grid: OccupancyGrid, scan: Scan2D, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    free, occupied = grid.beam_cells(scan, pose)
    free_ref, occupied_ref = grid.beam_cells_reference(scan, pose)
    np.testing.assert_array_equal(free, free_ref)
    np.testing.assert_array_equal(occupied, occupied_ref)
    assert not grid._marks.any()  # the scratch is clean for the next scan
    return free, occupied


def test_traced_cells_equal_the_numpy_tracing_on_real_scans(any_scene):
    grid = OccupancyGrid(any_scene.grid, CONFIG)
    free_cells = occupied_cells = 0
    for scan, pose in real_scans(any_scene, 8, seed=3):
        free, occupied = assert_same_cells(grid, scan, pose)
        free_cells += len(free)
        occupied_cells += len(occupied)
    assert free_cells > 1000 and occupied_cells > 100


def test_traced_cells_equal_at_the_grid_edges_and_on_sample_boundaries():
    """Beams leaving the grid, origins outside it, ranges on whole sample steps (the
    ``t < range`` boundary: cells of 1/8 m make them exact), and scans with no informative beam."""
    grid_spec = GridSpec((0.0, 0.0), 0.125, (40, 60))
    grid = OccupancyGrid(grid_spec, CONFIG)
    rng = np.random.default_rng(0)
    angles = azimuth_bin_centres(90)
    for trial in range(90):
        ranges = rng.uniform(0.0, 3.0, len(angles))
        if trial % 3:  # whole multiples of half a cell: a sample lands exactly on the range
            ranges = np.round(ranges / 0.0625) * 0.0625
        ranges[rng.random(len(angles)) < 0.2] = 0.0
        hit = rng.random(len(angles)) < 0.5
        xy = rng.uniform(-1.0, 8.5, 2) if trial % 2 else rng.integers(-8, 70, 2) * 0.125  # cell corners
        pose = np.array([xy[0], xy[1], rng.choice([0.0, np.pi / 2, rng.uniform(-np.pi, np.pi)])])
        assert_same_cells(grid, Scan2D(angles, ranges, hit), pose)
    empty = Scan2D(angles, np.zeros(len(angles)), np.zeros(len(angles), dtype=bool))
    free, occupied = assert_same_cells(grid, empty, np.array([3.0, 2.0, 0.0]))
    assert len(free) == len(occupied) == 0


@pytest.mark.parametrize("compiled", [True, False])
def test_log_odds_steps_and_clamps_in_float32(compiled):
    """One scan's free and occupied steps, clamped, against the float32 arithmetic by hand."""
    grid = OccupancyGrid(GridSpec((0.0, 0.0), 0.1, (10, 10)), CONFIG, compiled=compiled)
    start = np.linspace(-2.5, 4.0, 100).astype(np.float32)
    grid.log_odds[:] = start.reshape(10, 10)
    free, occupied = np.arange(0, 100, 3), np.arange(1, 100, 3)
    grid.integrate_cells(free, occupied)
    expected = start.copy()
    low, high = np.float32(CONFIG.log_odds_min), np.float32(CONFIG.log_odds_max)
    expected[free] = np.minimum(np.maximum(start[free] + np.float32(CONFIG.log_odds_free), low), high)
    expected[occupied] = np.minimum(np.maximum(start[occupied] + np.float32(CONFIG.log_odds_occupied), low), high)
    np.testing.assert_array_equal(grid.log_odds.reshape(-1), expected)
    assert grid.log_odds.dtype == np.float32


def test_replayed_real_scans_give_the_numpy_grid(office):
    scans = real_scans(office, 10, seed=8)
    fast, reference = OccupancyGrid(office.grid, CONFIG), OccupancyGrid(office.grid, CONFIG, compiled=False)
    fast.replay([fast.beam_cells(*s) for s in scans])
    reference.rebuild([s for s, _ in scans], np.array([p for _, p in scans]))
    np.testing.assert_array_equal(fast.log_odds, reference.log_odds)
    assert fast.known_occupied.sum() > 50 and fast.known_free.sum() > 500


def test_voxel_keys_are_numpy_floors_of_the_finite_points():
    """Points on voxel boundaries (whole multiples of the size), negative ones, and rows
    with a non-finite coordinate (skipped), against ``floor(p / size)`` in numpy."""
    rng = np.random.default_rng(2)
    size = 0.1
    points = np.concatenate([rng.uniform(-5.0, 5.0, (500, 3)), rng.integers(-40, 40, (200, 3)) * size])
    points[[3, 77, 650], [0, 2, 1]] = [np.nan, np.inf, -np.inf]
    finite = np.isfinite(points).all(axis=1)
    keys, low, high = compiled.voxel_keys(points, size)
    expected = np.floor(points[finite].T / size).astype(np.int64)
    np.testing.assert_array_equal(keys, expected)
    np.testing.assert_array_equal(low, expected.min(axis=1))
    np.testing.assert_array_equal(high, expected.max(axis=1))
    lower = expected.min(axis=1) - 2
    box = expected.max(axis=1) - lower + 3
    flat = compiled.flat_voxel_indices(keys, lower, int(box[1]), int(box[2]))
    np.testing.assert_array_equal(flat, np.ravel_multi_index(tuple(expected - lower[:, None]), tuple(box)))
