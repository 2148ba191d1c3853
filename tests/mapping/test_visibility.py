"""Grid line of sight (shared by SLAM loop-closure candidates and the planner)."""

from __future__ import annotations

import numpy as np

from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight, line_of_sight_by_length


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


def test_line_of_sight_by_length_gives_the_same_answers():
    """Random segments of all lengths (inside, across and outside the grid, some degenerate)
    on a room with walls and clutter: the same answer as :func:`line_of_sight` for every
    segment, with and without an end box, at two sample steps, compiled and in numpy (also in
    tiny batches)."""
    grid, blocked = wall_grid()
    rng = np.random.default_rng(3)
    blocked[70:72, 10:60] = True
    blocked[rng.random(grid.shape) < 0.004] = True  # isolated cells: many boxes hold one
    start = rng.uniform(-2.0, 12.0, (4000, 2))
    end = start + rng.normal(0.0, 2.0, (4000, 2))
    end[:50] = start[:50]  # zero length
    for step in (0.5, 0.3):
        for end_box in (0.0, 0.5):
            expected = line_of_sight(start, end, blocked, grid, step, end_box)
            assert 0.2 < expected.mean() < 0.95  # both answers are common
            for compiled in (True, False):
                np.testing.assert_array_equal(
                    line_of_sight_by_length(start, end, blocked, grid, step, end_box, compiled=compiled), expected)
    small = line_of_sight_by_length(start[:300], end[:300], blocked, grid, 0.5, 0.5, max_batch_samples=1,
                                    compiled=False)
    np.testing.assert_array_equal(small, line_of_sight(start[:300], end[:300], blocked, grid, 0.5, 0.5))
    assert line_of_sight_by_length(start[:0], end[:0], blocked, grid, 0.5).shape == (0,)
