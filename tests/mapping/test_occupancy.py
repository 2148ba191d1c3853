"""2D scan collapse, log-odds occupancy, rebuilds and the explored fraction."""

from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy import ndimage

from explore_rl.grid import GridSpec
from explore_rl.mapping.config import MappingConfig, OccupancyConfig
from explore_rl.mapping.occupancy import (
    OccupancyGrid,
    RayGridCollapse,
    Scan2D,
    collapse_scan,
    explored_fraction,
    moved_poses,
    needs_rebuild,
)
from explore_rl.sensors.lidar import Lidar, LidarConfig, ray_directions

N_BINS = 900
SENSOR_HEIGHT = 0.5
CONFIG = OccupancyConfig()  # floor < 0.1, obstacles 0.15..0.6, max range 3


def bin_centre(k: int) -> float:
    """Bin k is centred on k * 0.4 deg (so VLP-16 azimuths fall on bin centres)."""
    angle = k * 2 * np.pi / N_BINS
    return angle if angle < np.pi else angle - 2 * np.pi


def point_at(k: int, horizontal: float, z_base: float) -> list[float]:
    """A sensor-frame point in azimuth bin k at the given horizontal range and base height."""
    a = bin_centre(k)
    return [horizontal * np.cos(a), horizontal * np.sin(a), z_base - SENSOR_HEIGHT]


def direction_at(k: int, elevation: float) -> list[float]:
    a = bin_centre(k)
    return [np.cos(elevation) * np.cos(a), np.cos(elevation) * np.sin(a), np.sin(elevation)]


# --- collapse_scan ---------------------------------------------------------------------
def test_collapse_scan_classifies_by_height_and_bins_by_azimuth():
    points = [
        point_at(10, 2.5, 0.05),  # floor far away ...
        point_at(10, 1.5, 0.40),  # ... an obstacle ...
        point_at(10, 1.0, 0.20),  # ... and a nearer obstacle: it wins
        point_at(20, 1.0, 0.02),  # floor only: free to the farthest floor point
        point_at(20, 2.2, 0.08),
        point_at(30, 0.8, 1.50),  # above robot height: ignored
        point_at(700, 0.8, 1.50),  # above robot height, with floor behind it
        point_at(700, 1.7, 0.00),
        point_at(40, 1.2, 0.12),  # between floor and obstacle band: ignored
    ]
    scan = collapse_scan(np.array(points), np.zeros((0, 3)), SENSOR_HEIGHT, CONFIG)

    assert len(scan) == N_BINS
    np.testing.assert_allclose(scan.angles[[10, 20]], [bin_centre(10), bin_centre(20)])
    assert scan.hit[10] and scan.ranges[10] == pytest.approx(1.0)
    assert not scan.hit[20] and scan.ranges[20] == pytest.approx(2.2)
    assert scan.ranges[30] == 0.0 and not scan.hit[30]
    assert not scan.hit[700] and scan.ranges[700] == pytest.approx(1.7)
    assert scan.ranges[40] == 0.0
    informative = {10, 20, 700}
    others = [k for k in range(N_BINS) if k not in informative]
    assert np.all(scan.ranges[others] == 0.0) and not scan.hit[others].any()


def test_no_return_direction_clears_to_max_range():
    dirs = np.array([direction_at(100, 0.0), direction_at(200, np.radians(-1.0))])
    scan = collapse_scan(np.zeros((0, 3)), dirs, SENSOR_HEIGHT, CONFIG)
    assert not scan.hit[[100, 200]].any()
    assert scan.ranges[100] == pytest.approx(CONFIG.max_range)
    assert scan.ranges[200] == pytest.approx(CONFIG.max_range * np.cos(np.radians(1.0)))
    assert np.count_nonzero(scan.ranges) == 2


def test_upward_no_return_clears_only_inside_the_obstacle_band():
    elevation = np.radians(15.0)
    dirs = np.array([direction_at(7, elevation)])
    scan = collapse_scan(np.zeros((0, 3)), dirs, SENSOR_HEIGHT, CONFIG)
    # The ray reaches the top of the band (0.6 m) after 0.1 / tan(15 deg) horizontally.
    expected = (CONFIG.obstacle_max_height - SENSOR_HEIGHT) / np.tan(elevation)
    assert scan.ranges[7] == pytest.approx(expected)


def test_no_return_beats_nearer_floor_but_not_an_obstacle():
    points = np.array([point_at(5, 1.9, 0.0), point_at(6, 1.9, 0.0), point_at(6, 1.2, 0.3)])
    dirs = np.array([direction_at(5, 0.0), direction_at(6, 0.0)])
    scan = collapse_scan(points, dirs, SENSOR_HEIGHT, CONFIG)
    assert not scan.hit[5] and scan.ranges[5] == pytest.approx(CONFIG.max_range)
    assert scan.hit[6] and scan.ranges[6] == pytest.approx(1.2)


# --- occupancy in a square room ----------------------------------------------------------
ROOM = 6.0  # interior [0, 6] x [0, 6]; the wall surfaces lie on cell boundaries
GRID = GridSpec((-1.0, -1.0), 0.1, (80, 80))  # interior cells: iy, ix in 10..69


def room_scan(sensor_xy: np.ndarray, n_bins: int = N_BINS) -> Scan2D:
    """Exact ranges from ``sensor_xy`` to the walls of the room, every beam a hit."""
    angles = -np.pi + (np.arange(n_bins) + 0.5) * 2 * np.pi / n_bins
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (ROOM - sensor_xy[0]) / c, -sensor_xy[0] / c)
        ty = np.where(s > 0, (ROOM - sensor_xy[1]) / s, -sensor_xy[1] / s)
    return Scan2D(angles, np.minimum(np.abs(tx), np.abs(ty)), np.ones(n_bins, dtype=bool))


def ring_mask() -> np.ndarray:
    """The wall cells just outside the interior, without the four corners."""
    ring = np.zeros(GRID.shape, dtype=bool)
    ring[9, 10:70] = ring[70, 10:70] = True
    ring[10:70, 9] = ring[10:70, 70] = True
    return ring


def test_room_scan_marks_walls_occupied_interior_free_outside_unknown():
    occupancy = OccupancyGrid(GRID)
    occupancy.integrate(room_scan(np.array([3.0, 3.0])), np.array([3.0, 3.0, 0.0]))

    ring = ring_mask()
    interior = np.zeros(GRID.shape, dtype=bool)
    interior[10:70, 10:70] = True
    corners = np.zeros(GRID.shape, dtype=bool)
    corners[[9, 9, 70, 70], [9, 70, 9, 70]] = True

    assert occupancy.known_occupied[ring].all()
    assert not occupancy.known_occupied[~(ring | corners)].any()
    assert occupancy.known_free[interior].all()
    assert occupancy.unknown[~(interior | ring | corners)].all()


def test_yaw_rotates_beams():
    occupancy = OccupancyGrid(GRID)
    scan = Scan2D(np.array([0.0]), np.array([1.0]), np.array([True]))
    occupancy.integrate(scan, np.array([3.05, 3.05, np.pi / 2]))
    # Beam along body +x = world +y: from (3.05, 3.05) to (3.05, 4.05).
    assert np.argwhere(occupancy.known_occupied).tolist() == [[50, 40]]
    assert occupancy.known_free[40:50, 40].all() and occupancy.known_free.sum() == 10


def test_repeated_scans_clamp_log_odds():
    occupancy = OccupancyGrid(GRID)
    scan = room_scan(np.array([3.0, 3.0]))
    for _ in range(20):
        occupancy.integrate(scan, np.array([3.0, 3.0, 0.0]))
    assert occupancy.log_odds.max() == pytest.approx(CONFIG.log_odds_max)
    assert occupancy.log_odds.min() == pytest.approx(CONFIG.log_odds_min)


def test_rebuild_moves_the_map_with_the_pose():
    scans = [room_scan(np.array([3.0, 3.0])), room_scan(np.array([2.0, 4.0]))]
    poses = np.array([[3.0, 3.0, 0.0], [2.0, 4.0, 0.0]])
    occupancy = OccupancyGrid(GRID)
    occupancy.rebuild(scans, poses)
    before_occupied, before_free = occupancy.known_occupied.copy(), occupancy.known_free.copy()

    shift = np.array([0.5, -0.3, 0.0])  # +5 cells in x, -3 cells in y
    occupancy.rebuild(scans, poses + shift)

    expected_occupied = np.roll(before_occupied, (-3, 5), axis=(0, 1))
    expected_free = np.roll(before_free, (-3, 5), axis=(0, 1))
    np.testing.assert_array_equal(occupancy.known_occupied, expected_occupied)
    np.testing.assert_array_equal(occupancy.known_free, expected_free)
    assert not np.array_equal(occupancy.known_occupied, before_occupied)


def test_rebuild_equals_fresh_integration():
    scans = [room_scan(np.array([3.0, 3.0])), room_scan(np.array([1.5, 2.0]))]
    poses = np.array([[3.0, 3.0, 0.0], [1.5, 2.0, 0.0]])
    stale = OccupancyGrid(GRID)
    stale.integrate(scans[0], poses[0] + [0.7, 0.0, 0.0])
    stale.rebuild(scans, poses)
    fresh = OccupancyGrid(GRID)
    for scan, pose in zip(scans, poses):
        fresh.integrate(scan, pose)
    np.testing.assert_array_equal(stale.log_odds, fresh.log_odds)


def test_needs_rebuild_thresholds():
    res, max_range = 0.1, 3.0
    old = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5]])
    assert not needs_rebuild(old, old + [0.05, 0.05, 0.0], res, max_range)
    assert needs_rebuild(old, old + [[0, 0, 0], [0.08, 0.08, 0]], res, max_range)
    assert not needs_rebuild(old, old + [0.0, 0.0, 0.03], res, max_range)
    assert needs_rebuild(old, old + [0.0, 0.0, 0.04], res, max_range)
    # Only poses present in both are compared; new keyframes never trigger a rebuild.
    assert not needs_rebuild(old, np.vstack([old, [[9.0, 9.0, 3.0]]]), res, max_range)
    # Yaw wraps around.
    assert not needs_rebuild([[0, 0, np.pi - 0.01]], [[0, 0, -np.pi + 0.01]], res, max_range)


# --- explored fraction -------------------------------------------------------------------
def test_explored_fraction():
    grid = GridSpec((0.0, 0.0), 0.1, (10, 10))
    occupancy = OccupancyGrid(grid)
    truth = np.zeros(grid.shape, dtype=bool)
    truth[2:7, 2:6] = True  # |F| = 20
    assert explored_fraction(occupancy, truth) == 0.0

    occupancy.log_odds[2, 2:6] = -1.0  # 4 known free in F
    occupancy.log_odds[3, 2] = 1.0  # 1 known occupied in F
    occupancy.log_odds[3, 3] = -0.1  # observed but not yet known: does not count
    occupancy.log_odds[0, :] = -1.0  # known, but outside F
    assert explored_fraction(occupancy, truth) == pytest.approx(5 / 20)

    occupancy.log_odds[truth] = -1.0
    assert explored_fraction(occupancy, truth) == 1.0


# --- config ------------------------------------------------------------------------------
def test_yaml_defaults_match_the_dataclasses():
    path = Path(__file__).resolve().parents[2] / "conf" / "mapping" / "default.yaml"
    assert yaml.safe_load(path.read_text()) == asdict(MappingConfig())


def test_hit_cell_stays_occupied_when_another_beam_passes_through_it():
    occupancy = OccupancyGrid(GRID)
    # Beam 0 hits inside cell [40, 50]; beam 1, almost parallel, is free through it to 2 m.
    scan = Scan2D(np.array([0.0, 0.01]), np.array([1.0, 2.0]), np.array([True, False]))
    occupancy.integrate(scan, np.array([3.05, 3.05, 0.0]))
    assert occupancy.known_occupied[40, 50]
    assert occupancy.known_free[40, 45] and occupancy.known_free[40, 60]


# --- with the real LiDAR -------------------------------------------------------------------
def test_real_office_scan_agrees_with_ground_truth(office):
    lidar_config = LidarConfig()
    lidar = Lidar(office, lidar_config, np.random.default_rng(0))
    scan = lidar.scan(office.start_pose)
    scan2d = collapse_scan(scan.points, scan.no_return_dirs, lidar_config.mount_height, CONFIG)
    occupancy = OccupancyGrid(office.grid, CONFIG)
    occupancy.integrate(scan2d, office.start_pose)

    solid = ~office.truth.free
    # Padding with solid makes the perimeter walls (outside the grid) count as neighbours.
    padded = np.pad(solid, 1, constant_values=True)
    near_solid = ndimage.binary_dilation(padded, np.ones((3, 3)))[1:-1, 1:-1]
    deep_solid = ndimage.binary_erosion(solid, np.ones((3, 3)))
    assert occupancy.known_occupied.sum() > 50
    # Hits lie on surfaces, give or take a cell of range noise.
    assert not (occupancy.known_occupied & ~near_solid).any()
    assert not (occupancy.known_free & deep_solid).any()
    assert 0.01 < explored_fraction(occupancy, office.truth.reachable) < 0.5


def test_ray_grid_collapse_equals_collapse_scan_on_real_scans(office):
    """The fast path (mapping.updates=incremental) against the reference collapse, exactly,
    on scans from free poses of the office at random headings."""
    lidar_config = LidarConfig()
    lidar = Lidar(office, lidar_config, np.random.default_rng(0))
    collapse = RayGridCollapse(lidar.directions, lidar_config.channels, lidar_config.mount_height, CONFIG)
    rng = np.random.default_rng(5)
    free = np.argwhere(office.truth.reachable)
    obstacles = floors = no_returns = 0
    for _ in range(12):
        xy = office.grid.cell_to_world(free[rng.integers(len(free))])
        scan = lidar.scan(np.array([xy[0], xy[1], rng.uniform(-np.pi, np.pi)]))
        reference = collapse_scan(scan.points, scan.no_return_dirs, lidar_config.mount_height, CONFIG)
        fast = collapse(scan.points, scan.hit_index)
        np.testing.assert_array_equal(fast.angles, reference.angles)
        np.testing.assert_array_equal(fast.ranges, reference.ranges)
        np.testing.assert_array_equal(fast.hit, reference.hit)
        obstacles += int(reference.hit.sum())
        floors += int((~reference.hit & reference.valid).sum())
        no_returns += len(scan.no_return_dirs)
    assert obstacles > 100 and floors > 100 and no_returns > 1000  # every kind of evidence


def test_ray_grid_collapse_needs_one_azimuth_per_bin():
    lidar_config = LidarConfig()
    directions = ray_directions(lidar_config)
    assert RayGridCollapse.aligned(directions, lidar_config.channels, 900)
    assert not RayGridCollapse.aligned(directions, lidar_config.channels, 720)
    half_bin = directions.copy()  # every ray on a bin edge: rounding would decide the bin
    angle = np.arctan2(directions[:, 1], directions[:, 0]) + np.pi / 900
    half_bin[:, 0], half_bin[:, 1] = np.cos(angle), np.sin(angle)
    assert not RayGridCollapse.aligned(half_bin, lidar_config.channels, 900)
    with pytest.raises(ValueError, match="azimuth_bins=720"):
        RayGridCollapse(directions, lidar_config.channels, 0.4, OccupancyConfig(azimuth_bins=720))


def test_occupied_at_reads_known_occupied_and_treats_outside_as_free():
    grid = GridSpec((0.0, 0.0), 0.1, (20, 30))
    occupancy = OccupancyGrid(grid, OccupancyConfig())
    rng = np.random.default_rng(2)
    occupancy.log_odds[:] = rng.uniform(-2.0, 3.0, grid.shape)
    cells = rng.integers(-5, 35, size=(50, 7, 2))
    inside = (cells[..., 0] >= 0) & (cells[..., 0] < 20) & (cells[..., 1] >= 0) & (cells[..., 1] < 30)
    expected = np.zeros(cells.shape[:2], bool)
    expected[inside] = occupancy.known_occupied[cells[..., 0][inside], cells[..., 1][inside]]
    np.testing.assert_array_equal(occupancy.occupied_at(cells), expected)
    assert expected.any() and (~expected & inside).any()


# --- kept beam cells: replay instead of re-tracing (mapping.updates=incremental) -----------


def test_integrate_cells_of_beam_cells_equals_integrate():
    scan, pose = room_scan(np.array([3.0, 3.0])), np.array([3.0, 3.0, 0.3])
    direct, via_cells = OccupancyGrid(GRID), OccupancyGrid(GRID)
    direct.integrate(scan, pose)
    via_cells.integrate_cells(*via_cells.beam_cells(scan, pose))
    assert direct.known_free.sum() > 100  # the scan did something
    np.testing.assert_allclose(via_cells.log_odds, direct.log_odds, rtol=0, atol=1e-9)


def test_replay_of_kept_cells_equals_rebuild_including_the_clamp():
    """Many overlapping scans (the clamp engages, so order matters) and one moved scan:
    replaying the kept cells, with only the moved scan traced again, equals the reference
    rebuild at the new poses."""
    rng = np.random.default_rng(4)
    centres = rng.uniform(1.5, 4.5, size=(25, 2))
    scans = [room_scan(c) for c in centres]
    poses = np.column_stack([centres, np.zeros(len(centres))])
    occupancy = OccupancyGrid(GRID)
    cells = [occupancy.beam_cells(s, p) for s, p in zip(scans, poses)]
    moved = poses.copy()
    moved[7] += [0.35, -0.2, 0.0]
    cells[7] = occupancy.beam_cells(scans[7], moved[7])
    occupancy.replay(cells)
    reference = OccupancyGrid(GRID)
    reference.rebuild(scans, moved)
    assert reference.log_odds.min() == pytest.approx(CONFIG.log_odds_min)  # clamped cells exist
    np.testing.assert_allclose(occupancy.log_odds, reference.log_odds, rtol=0, atol=1e-9)
    stale = OccupancyGrid(GRID)
    stale.rebuild(scans, poses)
    assert np.abs(stale.log_odds - reference.log_odds).max() > 0.5  # the move changed the map


def test_moved_poses_names_the_poses_needs_rebuild_reacts_to():
    res, max_range = 0.1, 3.0
    old = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [2.0, 0.0, 0.0], [3.0, 0.0, np.pi - 0.01]])
    new = old + [[0.05, 0.05, 0.0], [0.08, 0.08, 0.0], [0.0, 0.0, 0.04], [0.0, 0.0, 0.02]]
    np.testing.assert_array_equal(moved_poses(old, new, res, max_range), [1, 2])
    assert needs_rebuild(old, new, res, max_range)
    assert not needs_rebuild(old[[0, 3]], new[[0, 3]], res, max_range)
    # new keyframes (beyond the old ones) are never "moved"
    assert len(moved_poses(old[:2], new, res, max_range)) == 1
