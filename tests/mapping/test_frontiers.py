"""Frontier detection, clustering and waypoints on hand-made grids."""

import numpy as np
import pytest

from explore_rl.grid import GridSpec
from explore_rl.mapping.config import FrontierConfig
from explore_rl.mapping.frontiers import (
    _clusters,
    _frontier_clusters,
    _split_long_clusters,
    find_frontiers,
    frontier_mask,
)

GRID = GridSpec((0.0, 0.0), 0.1, (20, 20))


def square_in_unknown_sea() -> tuple[np.ndarray, np.ndarray]:
    free = np.zeros(GRID.shape, dtype=bool)
    free[5:15, 5:15] = True
    return free, ~free


def room_with_door(door_cols: slice = slice(6, 10), extra_gap_col: int | None = None):
    """Free interior rows/cols 2..11, occupied walls, a door in the top wall; outside unknown."""
    free = np.zeros(GRID.shape, dtype=bool)
    occupied = np.zeros(GRID.shape, dtype=bool)
    occupied[1:13, 1:13] = True
    free[2:12, 2:12] = True
    occupied[2:12, 2:12] = False
    occupied[12, door_cols] = False
    free[12, door_cols] = True
    if extra_gap_col is not None:
        occupied[1, extra_gap_col] = False
        free[1, extra_gap_col] = True
    unknown = ~(free | occupied)
    return free, unknown


def brute_force_frontier_mask(free, unknown, neighbourhood):
    offsets = [(-1, 0), (1, 0), (0, -1), (0, 1)]
    if neighbourhood == 8:
        offsets += [(-1, -1), (-1, 1), (1, -1), (1, 1)]
    ny, nx = free.shape
    out = np.zeros_like(free)
    for iy in range(ny):
        for ix in range(nx):
            if free[iy, ix]:
                out[iy, ix] = any(
                    0 <= iy + dy < ny and 0 <= ix + dx < nx and unknown[iy + dy, ix + dx]
                    for dy, dx in offsets
                )
    return out


@pytest.mark.parametrize("neighbourhood", [4, 8])
def test_frontier_mask_matches_brute_force(neighbourhood):
    rng = np.random.default_rng(neighbourhood)
    state = rng.integers(0, 3, size=(17, 23))  # 0 free, 1 occupied, 2 unknown
    free, unknown = state == 0, state == 2
    np.testing.assert_array_equal(
        frontier_mask(free, unknown, neighbourhood),
        brute_force_frontier_mask(free, unknown, neighbourhood),
    )


def test_free_square_in_unknown_sea_is_one_ring_frontier():
    free, unknown = square_in_unknown_sea()
    (frontier,) = find_frontiers(free, unknown, GRID, FrontierConfig(min_cluster_cells=5))
    ring = free.copy()
    ring[6:14, 6:14] = False
    assert frontier.size == ring.sum() == 36
    np.testing.assert_array_equal(frontier.cells, np.argwhere(ring))  # both row-major
    # Centroid (9.5, 9.5): the side midpoints tie; the first in row-major order wins.
    assert frontier.waypoint_cell.tolist() == [5, 9]
    np.testing.assert_allclose(frontier.waypoint_xy, [0.95, 0.55])


def test_room_with_one_open_door_has_one_frontier_at_the_door():
    free, unknown = room_with_door()
    frontiers = find_frontiers(free, unknown, GRID, FrontierConfig(min_cluster_cells=3))
    assert len(frontiers) == 1
    assert frontiers[0].cells.tolist() == [[12, 6], [12, 7], [12, 8], [12, 9]]
    assert frontiers[0].waypoint_cell.tolist() == [12, 7]


def test_tiny_clusters_are_dropped():
    free, unknown = room_with_door(extra_gap_col=4)  # a one-cell gap in the bottom wall
    assert len(find_frontiers(free, unknown, GRID, FrontierConfig(min_cluster_cells=3))) == 1
    frontiers = find_frontiers(free, unknown, GRID, FrontierConfig(min_cluster_cells=1))
    assert [f.size for f in frontiers] == [1, 4]  # sorted by waypoint cell: row 1 first
    assert frontiers[0].waypoint_cell.tolist() == [1, 4]


def test_waypoint_prefers_traversable_cells():
    free, unknown = room_with_door()
    traversable = free.copy()
    traversable[12, 6:8] = False
    config = FrontierConfig(min_cluster_cells=3)
    (frontier,) = find_frontiers(free, unknown, GRID, config, traversable)
    assert frontier.waypoint_cell.tolist() == [12, 8]


def test_waypoint_search_around_an_untraversable_frontier():
    free, unknown = room_with_door()
    traversable = np.zeros(GRID.shape, dtype=bool)
    traversable[9, 7] = True  # 0.3 m inside the door
    config = FrontierConfig(min_cluster_cells=3, waypoint_search_radius=0.35)
    (frontier,) = find_frontiers(free, unknown, GRID, config, traversable)
    assert frontier.waypoint_cell.tolist() == [9, 7]
    assert frontier.size == 4  # the cluster itself is unchanged

    config = FrontierConfig(min_cluster_cells=3, waypoint_search_radius=0.25)
    assert find_frontiers(free, unknown, GRID, config, traversable) == []


def test_no_unknown_means_no_frontiers():
    free = np.ones(GRID.shape, dtype=bool)
    assert find_frontiers(free, np.zeros(GRID.shape, dtype=bool), GRID) == []


def split_by_sorted_rows(clusters, grid, max_extent):
    """The first ``_split_long_clusters``: tiles numbered by ``np.unique`` over their rows."""
    tile = max(1, int(round(max_extent / grid.resolution)))
    pieces = []
    for cells in clusters:
        if np.ptp(cells, axis=0).max() < tile:
            pieces.append(cells)
            continue
        _, ids = np.unique(cells // tile, axis=0, return_inverse=True)
        pieces += [cells[ids.reshape(-1) == i] for i in range(ids.max() + 1)]
    return pieces


def partly_known(seed, shape=(41, 37)):
    """Free, occupied and unknown cells; the known part touches the grid's edges or not."""
    rng = np.random.default_rng(seed)
    state = np.full(shape, 2)  # unknown
    top, left = [(0, 0), (5, 7), (9, 0), (3, 12)][seed % 4]
    state[top: top + 28, left: left + 25] = rng.choice(3, size=(28, 25), p=[0.88, 0.08, 0.04])[
        : shape[0] - top, : shape[1] - left]
    return state == 0, state == 2


@pytest.mark.parametrize("neighbourhood", [4, 8])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_clusters_over_the_free_window_are_the_whole_grids(seed, neighbourhood):
    """Frontier clusters found over the window of the free cells (widened by one) are those
    of the whole grid's mask, cell for cell and in the same order; splitting long clusters
    by one key per tile gives the pieces of splitting by sorted tile rows."""
    free, unknown = partly_known(seed)
    windowed = _frontier_clusters(free, unknown, neighbourhood)
    whole = _clusters(frontier_mask(free, unknown, neighbourhood))
    assert len(whole) > 3
    assert len(windowed) == len(whole)
    for got, expected in zip(windowed, whole):
        np.testing.assert_array_equal(got, expected)
    grid = GridSpec((0.0, 0.0), 0.1, free.shape)
    pieces, expected_pieces = _split_long_clusters(whole, grid, 0.6), split_by_sorted_rows(whole, grid, 0.6)
    assert len(pieces) > len(whole)  # some clusters were cut
    assert len(pieces) == len(expected_pieces)
    for got, expected in zip(pieces, expected_pieces):
        np.testing.assert_array_equal(got, expected)
    assert _frontier_clusters(np.zeros_like(free), unknown, neighbourhood) == []


def test_frontiers_of_real_explorations_are_the_whole_grids():
    """Street and office after a few decisions: the windowed clusters are the whole grid's."""
    from explore_rl.config import load_config
    from explore_rl.runner import Explorer

    for scene in ("street", "office"):
        explorer = Explorer(load_config([f"scene={scene}", "policy=nearest", "explore.progress_bar=false"]))
        for _ in range(3):
            explorer.step()
        occupancy, config = explorer.session.occupancy, explorer.config.mapping.frontiers
        windowed = _frontier_clusters(occupancy.known_free, occupancy.unknown, config.neighbourhood)
        whole = _clusters(frontier_mask(occupancy.known_free, occupancy.unknown, config.neighbourhood))
        assert len(whole) >= 3 and len(windowed) == len(whole)
        for got, expected in zip(windowed, whole):
            np.testing.assert_array_equal(got, expected)
