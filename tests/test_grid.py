import numpy as np
import pytest

from explore_rl.grid import GridSpec


def test_covering_and_round_trip():
    grid = GridSpec.covering((0.0, 0.0), (2.0, 1.0), 0.1)
    assert grid.shape == (10, 20)
    cells = np.array([[0, 0], [9, 19], [3, 7]])
    assert np.array_equal(grid.world_to_cell(grid.cell_to_world(cells)), cells)


def test_indexing_is_row_y_column_x():
    grid = GridSpec((1.0, 2.0), 0.5, (4, 6))
    assert grid.world_to_cell(np.array([1.0 + 0.5 * 5 + 0.1, 2.0 + 0.1])).tolist() == [0, 5]
    assert grid.extent == (1.0, 4.0, 2.0, 4.0)


def test_in_bounds_and_coarsened():
    grid = GridSpec((0.0, 0.0), 0.1, (10, 10))
    assert grid.in_bounds(np.array([[0, 0], [9, 9], [10, 0], [-1, 3]])).tolist() == [True, True, False, False]
    coarse = grid.coarsened(5)
    assert coarse.shape == (2, 2) and coarse.resolution == pytest.approx(0.5)


def test_bad_resolution_raises():
    with pytest.raises(ValueError, match="resolution"):
        GridSpec.covering((0, 0), (1, 1), 0.0)
