"""Ground-truth free space: cell counts against analytic areas, and start connectivity."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.scene.layout import Box, Cylinder, Layout, Wall
from explore_rl.scene.truth import (
    first_disconnected_start,
    free_space,
    layout_grid,
    starts_connected,
)

RES = 0.1
RADIUS = 0.3
ROOM = (4.0, 4.0)
TWO_STARTS = ((1.0, 2.0, 0.0), (3.0, 2.0, 0.0))


def room(walls=(), boxes=(), cylinders=(), starts=TWO_STARTS, perimeter=True) -> Layout:
    return Layout("room", ROOM, tuple(walls), tuple(boxes), tuple(cylinders), starts,
                  perimeter=perimeter)


def split_room(door: float) -> Layout:
    """A wall at x = 2 with a door of width ``door`` centred at y = 2 (0: no door)."""
    if door == 0:
        return room([Wall((2.0, 0.0), (2.0, 4.0))])
    return room([Wall((2.0, 0.0), (2.0, 2.0 - door / 2)), Wall((2.0, 2.0 + door / 2), (2.0, 4.0))])


def truth(layout: Layout):
    return free_space(layout, layout_grid(layout, RES), RADIUS, layout.starts[0][:2])


def test_layout_grid_covers_the_interior():
    grid = layout_grid(Layout("r", (12.0, 10.0)), 0.05)
    assert grid.origin == (0.0, 0.0) and grid.shape == (200, 240)


@pytest.mark.parametrize("perimeter", [True, False])
def test_empty_room_is_all_free(perimeter):
    gt = truth(room(perimeter=perimeter))
    assert gt.free.sum() == gt.reachable.sum() == 1600
    # inflated by 0.3 m: centres from 0.35 to 3.65 m, 34 per axis
    assert gt.traversable.sum() == gt.drivable.sum() == 34 * 34


def test_box_removes_its_footprint():
    # edges at 1.5/2.5 and 1.7/2.3 fall between cell centres: exactly area / cell area
    gt = truth(room(boxes=[Box((2.0, 2.0), (1.0, 0.6, 0.5))]))
    assert 1600 - gt.free.sum() == round(1.0 * 0.6 / RES**2) == 60
    iy, ix = gt.grid.world_to_cell(np.array([2.0, 2.0]))
    assert not gt.free[iy, ix]


def test_rotated_box_and_cylinder_remove_about_their_area():
    box = Box((1.2, 2.8), (1.0, 0.6, 0.5), yaw=0.7)
    cyl = Cylinder((2.8, 1.2), 0.5, 1.0)
    gt = truth(room(boxes=[box], cylinders=[cyl], starts=((0.5, 0.5, 0.0),)))
    removed = 1600 - gt.free.sum()
    expected = (0.6 + np.pi * 0.25) / RES**2
    assert abs(removed - expected) < 0.08 * expected


def test_wall_without_door_disconnects_the_starts():
    layout = split_room(door=0)
    grid = layout_grid(layout, RES)
    assert not starts_connected(layout, grid, RADIUS)
    assert first_disconnected_start(layout, grid, RADIUS) == 1
    gt = truth(layout)
    assert gt.reachable.sum() == 19 * 40  # the west half, wall cells (x = 1.95, 2.05) excluded


def test_door_wider_than_the_robot_connects_the_starts():
    layout = split_room(door=2 * RADIUS + 0.4)
    assert starts_connected(layout, layout_grid(layout, RES), RADIUS)
    gt = truth(layout)
    iy, ix = gt.grid.world_to_cell(np.array(layout.starts[1][:2]))
    assert gt.drivable[iy, ix]


def test_narrow_gap_is_in_f_but_not_drivable():
    """F (``reachable``) uses the non-inflated mask: a 0.4 m gap joins it, not ``drivable``."""
    layout = split_room(door=0.4)
    assert not starts_connected(layout, layout_grid(layout, RES), RADIUS)
    gt = truth(layout)
    assert gt.reachable.sum() == gt.free.sum()
    iy, ix = gt.grid.world_to_cell(np.array([3.0, 2.0]))
    assert gt.reachable[iy, ix] and not gt.drivable[iy, ix]


def test_start_inside_a_solid_is_rejected():
    layout = room(boxes=[Box((1.0, 2.0), (1.0, 1.0, 1.0))])
    with pytest.raises(ValueError, match="inside a solid"):
        truth(layout)


def test_start_outside_the_grid_is_rejected():
    with pytest.raises(ValueError, match="outside the grid"):
        free_space(room(), layout_grid(room(), RES), RADIUS, (5.0, 1.0))


@pytest.mark.parametrize("seed", [0, 1])
def test_free_masks_equal_the_brute_force_clearance(seed):
    """free_masks evaluates each solid on its window only; the reference thresholds the
    clearance of every cell to every solid. Same masks, on a building and on the office."""
    from explore_rl.robot import RobotConfig
    from explore_rl.scene.build import make_layout
    from explore_rl.scene.config import SceneConfig
    from explore_rl.scene.truth import clearance, free_masks

    for name in ("building", "office"):
        layout = make_layout(SceneConfig(name=name, seed=seed), RobotConfig().radius)
        grid = layout_grid(layout, RES)
        free, traversable = free_masks(layout, grid, RADIUS)
        dist = clearance(layout, grid)
        assert np.array_equal(free, dist > 0.0) and np.array_equal(traversable, dist > RADIUS)
        assert 0 < traversable.sum() < free.sum() < free.size
