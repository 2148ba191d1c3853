"""Traversability and Dijkstra paths, checked against brute-force references."""

import heapq

import numpy as np
import pytest

from explore_rl.grid import GridSpec
from explore_rl.mapping.config import FrontierConfig, OccupancyConfig, PathConfig
from explore_rl.mapping.frontiers import find_frontiers
from explore_rl.mapping.occupancy import OccupancyGrid, collapse_scan
from explore_rl.mapping.paths import (
    PathPlanner,
    grid_graph,
    grid_graph_reference,
    path_length,
    simplify_path,
    traversability,
    traversability_reference,
)
from explore_rl.robot import RobotConfig
from explore_rl.sensors.lidar import Lidar, LidarConfig

RES = 0.1


def reference_dijkstra(traversable, cost, start, allow_corner_cutting):
    """Textbook heap Dijkstra over the 8-connected grid (same edge rule, written with loops)."""
    ny, nx = traversable.shape
    dist = np.full((ny, nx), np.inf)
    dist[start] = 0.0
    heap = [(0.0, start)]
    while heap:
        d, (iy, ix) = heapq.heappop(heap)
        if d > dist[iy, ix]:
            continue
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                jy, jx = iy + dy, ix + dx
                if (dy, dx) == (0, 0) or not (0 <= jy < ny and 0 <= jx < nx):
                    continue
                if not traversable[jy, jx]:
                    continue
                diagonal = dy != 0 and dx != 0
                if diagonal and not allow_corner_cutting:
                    if not (traversable[iy + dy, ix] and traversable[iy, ix + dx]):
                        continue
                step = RES * (2**0.5 if diagonal else 1.0)
                nd = d + step * (cost[iy, ix] + cost[jy, jx]) / 2
                if nd < dist[jy, jx]:
                    dist[jy, jx] = nd
                    heapq.heappush(heap, (nd, (jy, jx)))
    return dist


def random_map(seed, shape=(14, 17)):
    rng = np.random.default_rng(seed)
    traversable = rng.random(shape) > 0.3
    cost = np.where(traversable, 1.0 + 2.0 * rng.random(shape), np.inf)
    start = tuple(int(v) for v in np.argwhere(traversable)[0])
    return GridSpec((0.0, 0.0), RES, shape), traversable, cost, start


@pytest.mark.parametrize("corner_cutting", [False, True])
@pytest.mark.parametrize("seed", [0, 1])
def test_distances_match_reference_dijkstra(seed, corner_cutting):
    grid, traversable, cost, start = random_map(seed)
    planner = PathPlanner(grid, traversable, cost, PathConfig(allow_corner_cutting=corner_cutting))
    field = planner.from_start(grid.cell_to_world(np.array(start)))
    expected = reference_dijkstra(traversable, cost, start, corner_cutting)
    assert field.start_cell.tolist() == list(start)
    np.testing.assert_array_equal(np.isinf(field.distances), np.isinf(expected))
    finite = np.isfinite(expected)
    np.testing.assert_allclose(field.distances[finite], expected[finite], rtol=1e-12)
    assert finite.sum() > 20  # the comparison is not vacuous


@pytest.mark.parametrize("seed", [0, 1])
def test_paths_connect_start_to_goal_and_add_up(seed):
    grid, traversable, cost, start = random_map(seed)
    field = PathPlanner(grid, traversable, cost).from_start(grid.cell_to_world(np.array(start)))
    reachable = np.argwhere(np.isfinite(field.distances))
    goal = reachable[np.argmax(field.distances[tuple(reachable.T)])]  # the farthest cell
    cells = field.path_cells(goal)
    path = field.path_to(goal)

    assert cells[0].tolist() == list(start) and cells[-1].tolist() == goal.tolist()
    np.testing.assert_allclose(path, grid.cell_to_world(cells))
    steps = np.diff(cells, axis=0)
    assert np.abs(steps).max() == 1 and np.all(np.abs(steps).sum(axis=1) > 0)
    assert traversable[tuple(cells.T)].all()
    step_lengths = np.where(np.abs(steps).sum(axis=1) == 2, RES * 2**0.5, RES)
    edge_costs = step_lengths * (cost[tuple(cells[:-1].T)] + cost[tuple(cells[1:].T)]) / 2
    assert edge_costs.sum() == pytest.approx(field.distances[tuple(goal)])
    assert field.cost_to(goal) == pytest.approx(field.distances[tuple(goal)])
    assert path_length(path) == pytest.approx(step_lengths.sum())


def wall_with_gap_map():
    """A 3 m x 2 m free map with a wall across x = 1.5 m, open for y in [0.8, 1.6)."""
    grid = GridSpec((0.0, 0.0), RES, (20, 30))
    occupied = np.zeros(grid.shape, dtype=bool)
    occupied[:, 15] = True
    occupied[8:16, 15] = False
    return grid, ~occupied, occupied


def brute_force_clearance(grid, occupied, border):
    """Distance from each cell centre to the nearest blocked cell centre, minus half a cell."""
    ny, nx = grid.shape
    blocked = [tuple(c) for c in np.argwhere(occupied)]
    if border:
        blocked += [(iy, ix) for iy in range(-1, ny + 1) for ix in (-1, nx)]
        blocked += [(iy, ix) for iy in (-1, ny) for ix in range(nx)]
    walls = grid.cell_to_world(np.array(blocked))
    centres = grid.cell_centers().reshape(-1, 2)
    distance = np.linalg.norm(centres[:, None] - walls[None], axis=-1).min(axis=1)
    return distance.reshape(grid.shape) - RES / 2


@pytest.mark.parametrize("border", [True, False])
def test_traversability_inflates_known_obstacles_only(border):
    grid, free, occupied = wall_with_gap_map()
    free[10, 5] = False  # an unknown cell far from obstacles
    radius = 0.27  # clearances are (k - 0.5) x 0.1 m on the axes: avoid ties
    config = PathConfig(grid_border_is_obstacle=border)
    traversable, cost = traversability(free, occupied, grid, radius, config)

    clearance = brute_force_clearance(grid, occupied, border)
    np.testing.assert_array_equal(traversable, free & (clearance > radius + 1e-9))
    assert not traversable[10, 5] and traversable[10, 4]
    assert traversable[0, 0] != border  # 0.05 m from the grid edge
    assert np.all(np.isinf(cost[~traversable])) and np.all(cost[traversable] >= 1.0)
    extra = clearance - radius
    expected_cost = 1.0 + config.clearance_weight * np.exp(-extra / config.clearance_scale)
    np.testing.assert_allclose(cost[traversable], expected_cost[traversable])
    # Cost falls as clearance grows.
    order = np.argsort(clearance[traversable])
    by_clearance = cost[traversable][order]
    assert np.all(np.diff(by_clearance) <= 1e-12) and by_clearance[0] > by_clearance[-1]


def test_no_obstacles_gives_uniform_minimum_cost():
    grid = GridSpec((0.0, 0.0), RES, (5, 5))
    free, occupied = np.ones(grid.shape, bool), np.zeros(grid.shape, bool)
    config = PathConfig(grid_border_is_obstacle=False)
    traversable, cost = traversability(free, occupied, grid, 0.3, config)
    assert traversable.all() and np.all(cost == 1.0)
    # With the border as an obstacle only the centre cell is > 0.17 m from the edge.
    traversable, _ = traversability(free, occupied, grid, 0.17)
    assert np.argwhere(traversable).tolist() == [[2, 2]]


def test_path_stays_out_of_inflated_obstacles():
    grid, free, occupied = wall_with_gap_map()
    radius = 0.2
    traversable, cost = traversability(free, occupied, grid, radius)
    field = PathPlanner(grid, traversable, cost).from_start(np.array([0.35, 0.35]))
    path = field.path_to(grid.world_to_cell(np.array([2.65, 0.35])))
    assert path is not None

    # Sample the polyline densely: every sample lies in a traversable cell and keeps
    # more than the robot radius from every wall cell centre.
    t = np.linspace(0.0, 1.0, 11)[:, None, None]
    samples = (path[:-1] * (1 - t) + path[1:] * t).reshape(-1, 2)
    cells = grid.world_to_cell(samples)
    assert traversable[cells[:, 0], cells[:, 1]].all()
    walls = grid.cell_to_world(np.argwhere(occupied))
    assert np.linalg.norm(samples[:, None] - walls[None], axis=-1).min() > radius
    # It goes through the gap and is longer than the straight line.
    assert path[:, 1].max() > 0.8
    assert path_length(path) > 2.3


def test_unreachable_and_blocked_goals_return_none():
    grid, free, occupied = wall_with_gap_map()
    occupied[:, 15] = True  # close the gap
    traversable, cost = traversability(free, occupied, grid, 0.15)
    field = PathPlanner(grid, traversable, cost).from_start(np.array([0.35, 0.35]))
    assert field.path_to(np.array([5, 25])) is None  # other side of the wall
    assert field.path_to(np.array([5, 15])) is None  # inside the wall
    assert field.path_to(np.array([50, 50])) is None  # off the grid
    assert field.path_to_xy(np.array([-1.0, 0.3])) is None
    np.testing.assert_array_equal(field.cost_to(np.array([[5, 25], [50, 50], [-1, 0]])), np.inf)
    assert np.isfinite(field.cost_to(np.array([5, 5])))
    assert field.path_to(field.start_cell).shape == (1, 2)


def test_start_inside_inflation_snaps_to_nearest_traversable_cell():
    grid, free, occupied = wall_with_gap_map()
    traversable, cost = traversability(free, occupied, grid, 0.27)
    planner = PathPlanner(grid, traversable, cost, PathConfig(start_snap_radius=0.3))
    # The wall cells start at x = 1.5: cells need centres < 1.23 m (ix <= 11, x < 1.2).
    field = planner.from_start(np.array([1.32, 0.35]))
    assert field.start_cell.tolist() == [3, 11]
    assert np.isfinite(field.distances).sum() > 100

    # Deep inside the wall, nothing is within the snap radius: everything unreachable.
    blocked = PathPlanner(grid, traversable, cost, PathConfig(start_snap_radius=0.1)).from_start(
        np.array([1.55, 0.35])
    )
    assert blocked.start_cell is None
    assert blocked.path_to(np.array([3, 5])) is None and not blocked.reachable.any()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_paths_walked_together_are_the_paths_walked_one_by_one(seed):
    """:meth:`DistanceField.paths_to` (every chain in step) returns :meth:`path_to` of each
    cell, array for array: reachable cells near and far, the start itself, unreachable
    cells, cells off the grid, and a repeated cell, in the order given."""
    rng = np.random.default_rng(seed)
    traversable = rng.random((23, 31)) > 0.15
    traversable[:, 20] = False  # a wall: the cells beyond it are unreachable
    traversable[11, 20] = seed == 2  # with a door in one map
    cost = np.where(traversable, 1.0 + 2.0 * rng.random(traversable.shape), np.inf)
    grid = GridSpec((0.0, 0.0), RES, traversable.shape)
    start = tuple(int(v) for v in np.argwhere(traversable[:, :20])[len(np.argwhere(traversable[:, :20])) // 2])
    field = PathPlanner(grid, traversable, cost).from_start(grid.cell_to_world(np.array(start)))
    reachable = np.argwhere(np.isfinite(field.distances))
    assert len(reachable) > 100  # long chains of many lengths
    unreachable = np.argwhere(~np.isfinite(field.distances))[:3]
    cells = np.vstack([reachable[::5], [start], unreachable, [[-1, 0], [40, 3]], reachable[:1]])
    together = field.paths_to(cells)
    assert len(together) == len(cells)
    for cell, path in zip(cells, together):
        expected = field.path_to(cell)
        if expected is None:
            assert path is None
        else:
            np.testing.assert_array_equal(path, expected)
    assert sum(path is None for path in together) == len(unreachable) + 2
    assert field.paths_to(np.zeros((0, 2), dtype=int)) == []


def test_a_broken_predecessor_chain_is_refused_not_walked_forever():
    grid, traversable, cost, start = random_map(0)
    field = PathPlanner(grid, traversable, cost).from_start(grid.cell_to_world(np.array(start)))
    far = np.argwhere(np.isfinite(field.distances))[-1]
    broken = field.predecessors.copy()
    broken[tuple(far)] = -9999  # scipy's "no predecessor" on a cell that is not the start
    field.predecessors = broken
    with pytest.raises(RuntimeError, match="does not reach the start"):
        field.paths_to(far[None])
    looped = field.predecessors.copy()
    here = int(np.ravel_multi_index(tuple(far), grid.shape))
    looped[tuple(far)] = here  # a cell its own predecessor
    field.predecessors = looped
    with pytest.raises(RuntimeError, match="cycle"):
        field.paths_to(far[None])


def known_map(seed, shape=(37, 29)):
    """A partly known map: a known blob (free, with occupied specks and a wall) away from
    or touching the grid's edges, the rest unknown."""
    rng = np.random.default_rng(seed)
    known = np.zeros(shape, dtype=bool)
    top, left = [(0, 0), (6, 4), (2, 9), (12, 0)][seed % 4]
    known[top: top + 20, left: left + 17] = True
    occupied = known & (rng.random(shape) < 0.06)
    occupied[top + 10, left: left + 12] = known[top + 10, left: left + 12]
    return GridSpec((0.0, 0.0), RES, shape), known & ~occupied, occupied


@pytest.mark.parametrize("border", [True, False])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_traversability_over_the_known_window_is_the_whole_grids(seed, border):
    """:func:`traversability` (over the window of known cells, the border ring by its
    distance) equals :func:`traversability_reference` (the whole grid) bit for bit: maps
    whose known part touches the grid's edges or not, with and without occupied cells,
    and a map with nothing known."""
    config = PathConfig(grid_border_is_obstacle=border, inflation_margin=0.02)
    grid, free, occupied = known_map(seed)
    cases = [(free, occupied), (free | occupied, np.zeros_like(occupied)),
             (np.zeros_like(free), np.zeros_like(occupied))]
    for known_free, known_occupied in cases:
        fast = traversability(known_free, known_occupied, grid, 0.12, config)
        reference = traversability_reference(known_free, known_occupied, grid, 0.12, config)
        for got, expected in zip(fast, reference):
            np.testing.assert_array_equal(got, expected)
    assert traversability(free, occupied, grid, 0.12, config)[0].sum() > 50  # not vacuous


def test_path_length_and_simplify():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [3.0, 2.0], [4.0, 3.0]])
    assert path_length(path) == pytest.approx(3.0 + 2 * 2**0.5)
    assert path_length(path[:1]) == 0.0 and path_length(None) == np.inf
    np.testing.assert_array_equal(simplify_path(path), path[[0, 2, 3, 5]])
    assert path_length(simplify_path(path)) == pytest.approx(path_length(path))
    back_and_forth = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.0]])
    np.testing.assert_array_equal(simplify_path(back_and_forth), back_and_forth)


def test_office_frontiers_are_reachable_from_the_start(office):
    """One real scan at the office start: frontiers, traversability and Dijkstra fit together."""
    lidar_config, radius = LidarConfig(), RobotConfig().radius
    scan = Lidar(office, lidar_config, np.random.default_rng(0)).scan(office.start_pose)
    occupancy = OccupancyGrid(office.grid, OccupancyConfig())
    scan2d = collapse_scan(scan.points, scan.no_return_dirs, lidar_config.mount_height)
    occupancy.integrate(scan2d, office.start_pose)
    free, occupied, grid = occupancy.known_free, occupancy.known_occupied, office.grid
    traversable, cost = traversability(free, occupied, grid, radius)
    frontiers = find_frontiers(free, occupancy.unknown, grid, FrontierConfig(), traversable)
    field = PathPlanner(office.grid, traversable, cost).from_start(office.start_pose)

    assert frontiers
    for frontier in frontiers:
        path = field.path_to(frontier.waypoint_cell)
        assert path is not None
        assert office.truth.drivable[tuple(frontier.waypoint_cell)]
        assert office.is_free(path, radius).all()  # the real footprint never touches a solid


def assert_same_fields(windowed, whole):
    np.testing.assert_array_equal(windowed.distances, whole.distances)
    np.testing.assert_array_equal(windowed.predecessors, whole.predecessors)
    np.testing.assert_array_equal(windowed.start_cell, whole.start_cell)


@pytest.mark.parametrize("corner_cutting", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_windowed_graph_gives_the_whole_grids_distances_and_paths(seed, corner_cutting):
    """Dijkstra over the window holding the traversable cells equals it over the whole grid
    (the reference), bit for bit, predecessors included; the map sits inside a larger,
    untraversable grid so the window is smaller than the grid."""
    grid, traversable, cost, start = random_map(seed)
    inner = traversable.shape
    traversable = np.pad(traversable, ((3, 5), (7, 2)), constant_values=False)
    cost = np.pad(cost, ((3, 5), (7, 2)), constant_values=np.inf)
    grid = GridSpec((0.0, 0.0), RES, traversable.shape)
    start_xy = grid.cell_to_world(np.array(start) + [3, 7])
    config = PathConfig(allow_corner_cutting=corner_cutting)
    planner = PathPlanner(grid, traversable, cost, config)
    assert np.all(planner.high - planner.low <= inner) and np.all(planner.high - planner.low < grid.shape)
    windowed = planner.from_start(start_xy)
    whole = PathPlanner(grid, traversable, cost, config, reference=True).from_start(start_xy)
    assert_same_fields(windowed, whole)
    for goal in np.argwhere(np.isfinite(whole.distances))[::7]:
        np.testing.assert_array_equal(windowed.path_to(goal), whole.path_to(goal))


@pytest.mark.parametrize("corner_cutting", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_graph_of_the_traversable_cells_is_the_reference_matrix(seed, corner_cutting):
    """:func:`grid_graph` (built from the traversable cells alone) is the matrix of
    :func:`grid_graph_reference` (every cell): the same CSR arrays, element for element,
    including traversable cells on the grid's border."""
    _, traversable, cost, _ = random_map(seed)
    traversable[0, :] = traversable[-1, :] = True  # border rows whose neighbours fall outside
    cost = np.where(traversable, np.where(np.isfinite(cost), cost, 1.5), np.inf)
    fast = grid_graph(traversable, cost, RES, corner_cutting)
    reference = grid_graph_reference(traversable, cost, RES, corner_cutting)
    assert fast.nnz > 100
    for name in ("indptr", "indices", "data"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(reference, name))


def test_the_windowed_graph_equals_the_whole_grids_on_real_explorations():
    """Street and office after a few decisions of a real exploration: the same distance
    fields and frontier paths from the windowed graph as from the whole grid's."""
    from explore_rl.config import load_config
    from explore_rl.runner import Explorer

    for scene in ("street", "office"):
        explorer = Explorer(load_config([f"scene={scene}", "policy=nearest", "explore.progress_bar=false"]))
        for _ in range(3):
            explorer.step()
        occupancy, grid, paths = explorer.session.occupancy, explorer.scene.grid, explorer.config.mapping.paths
        traversable, cost = traversability(occupancy.known_free, occupancy.known_occupied, grid,
                                           explorer.config.robot.radius, paths)
        for got, expected in zip((traversable, cost), traversability_reference(
                occupancy.known_free, occupancy.known_occupied, grid, explorer.config.robot.radius, paths)):
            np.testing.assert_array_equal(got, expected)
        start = explorer.robot.belief_pose[:2]
        windowed = PathPlanner(grid, traversable, cost, paths).from_start(start)
        whole = PathPlanner(grid, traversable, cost, paths, reference=True).from_start(start)
        assert np.isfinite(whole.distances).sum() > 1000
        assert_same_fields(windowed, whole)
        for frontier in find_frontiers(occupancy.known_free, occupancy.unknown, grid, explorer.config.mapping.frontiers,
                                       traversable):
            np.testing.assert_array_equal(windowed.path_to(frontier.waypoint_cell),
                                          whole.path_to(frontier.waypoint_cell))
        waypoints = np.array([f.waypoint_cell for f in find_frontiers(
            occupancy.known_free, occupancy.unknown, grid, explorer.config.mapping.frontiers, traversable)])
        for together, alone in zip(windowed.paths_to(waypoints), waypoints):
            np.testing.assert_array_equal(together, whole.path_to(alone))


def test_a_map_without_traversable_cells_reaches_nothing():
    grid = GridSpec((0.0, 0.0), RES, (6, 8))
    blocked = np.zeros(grid.shape, dtype=bool)
    field = PathPlanner(grid, blocked, np.full(grid.shape, np.inf)).from_start(np.array([0.25, 0.25]))
    assert field.start_cell is None and not np.isfinite(field.distances).any()
