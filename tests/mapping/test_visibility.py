"""Grid line of sight (shared by SLAM loop-closure candidates and the planner)."""

from __future__ import annotations

import numpy as np

from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight


def wall_grid() -> tuple[GridSpec, np.ndarray]:
    """10 m x 10 m at 0.1 m with a wall x in [4.0, 4.2) along the whole height."""
    grid = GridSpec((0.0, 0.0), 0.1, (100, 100))
    blocked = np.zeros(grid.shape, dtype=bool)
    blocked[:, 40:42] = True
    return grid, blocked


def test_line_of_sight_cases():
    grid, blocked = wall_grid()
    start = np.array([[3.0, 5.0], [3.0, 5.0], [3.0, 5.0], [-2.0, 5.0]])
    end = np.array([[5.0, 5.5], [3.9, 1.0], [4.1, 5.0], [-1.0, 5.0]])
    clear = line_of_sight(start, end, blocked, grid, 0.5)
    # across the wall; beside it; ending inside it; entirely outside the grid
    assert clear.tolist() == [False, True, False, True]
    # ignoring the end's own 0.5 m cell: the wall cell itself is seen
    assert line_of_sight(start[2:3], np.array([[4.25, 5.25]]), blocked, grid, 0.5, 0.5)[0]
    # tiny batches give the same answer
    small = line_of_sight(start, end, blocked, grid, 0.5, max_batch_samples=1)
    assert small.tolist() == clear.tolist()
