"""scene=building: determinism, structure that changes with the seed, reachability for the
footprint, doors and starts within the clearance rules, every knob's bad value rejected."""

from __future__ import annotations

import dataclasses
import pickle
from collections import Counter
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
import yaml
from scipy import ndimage

from explore_rl.config import load_config
from explore_rl.robot import RobotConfig
from explore_rl.scene import building as building_module
from explore_rl.scene.build import make_scene
from explore_rl.scene.building import Redraw, draw_plan, generate_building, graph_cycles
from explore_rl.scene.config import BuildingConfig, SceneConfig, validate_building
from explore_rl.scene.truth import clearance, first_disconnected_start, layout_grid
from explore_rl.sensors.lidar import LidarConfig

RADIUS = RobotConfig().radius
CONF = Path(__file__).resolve().parents[2] / "conf" / "scene" / "building.yaml"
MANY_SEEDS = range(200)


def config(seed: int = 0, **building) -> SceneConfig:
    return SceneConfig(name="building", seed=seed, building=BuildingConfig(**building))


@pytest.fixture(scope="module")
def plans() -> dict[int, building_module.BuildingPlan]:
    return {seed: generate_building(config(seed), RADIUS) for seed in MANY_SEEDS}


def test_conf_yaml_equals_the_dataclass_defaults():
    conf = yaml.safe_load(CONF.read_text())
    assert conf["name"] == "building"
    assert conf["building"] == dataclasses.asdict(BuildingConfig())


def test_hydra_composes_scene_building():
    cfg = load_config(["scene=building", "seed=7"])
    assert cfg.scene.name == "building" and cfg.scene.seed == 7
    assert cfg.scene.building == BuildingConfig()


def test_same_seed_same_plan_and_model():
    a, b = generate_building(config(5), RADIUS), generate_building(config(5), RADIUS)
    assert a.layout == b.layout and np.array_equal(a.labels, b.labels)
    scene_a = make_scene(config(5), RobotConfig(), LidarConfig())
    scene_b = pickle.loads(pickle.dumps(make_scene(config(5), RobotConfig(), LidarConfig())))
    assert scene_a.layout == a.layout
    assert np.array_equal(scene_a.model.geom_pos, scene_b.model.geom_pos)
    assert np.array_equal(scene_a.model.geom_size, scene_b.model.geom_size)
    assert np.array_equal(scene_a.truth.reachable, scene_b.truth.reachable)


def test_the_seed_changes_the_structure_not_only_the_objects(plans):
    """Across seeds: sizes, walls, every corridor kind, room counts, halls, loops and trees."""
    stats = [plan.stats() for plan in plans.values()]
    assert len({plan.layout.size for plan in plans.values()}) > 40
    assert len({plan.layout.walls for plan in plans.values()}) == len(plans)
    assert set(Counter(s["corridor"] for s in stats)) == {"straight", "L", "loop", "tree"}
    rooms = [s["rooms"] for s in stats]
    assert max(rooms) - min(rooms) >= 10
    assert any(s["halls"] for s in stats) and not all(s["halls"] for s in stats)
    b = BuildingConfig()
    for plan in plans.values():  # halls within [hall_min_side, hall_max_side] a side (+ a sliver merged in)
        for region in np.flatnonzero(np.array(plan.kinds) == "hall"):
            rows, cols = np.nonzero(plan.labels == region)
            sides = np.array([np.ptp(rows) + 1, np.ptp(cols) + 1]) * b.module
            assert b.hall_min_side - 1e-9 <= sides.min()
            assert sides.max() <= b.hall_max_side + b.room_min_side - b.module + 1e-9
    loops = np.array([s["loops"] for s in stats])
    assert 0.2 < np.mean(loops > 0) < 0.8  # both plans that close loops and tree-like plans
    sizes = np.array([plan.layout.size for plan in plans.values()])
    b = BuildingConfig()
    assert sizes.min() >= b.size_min and sizes.max() <= b.size_max


def test_every_start_and_region_reachable_for_the_footprint(plans):
    for seed, plan in plans.items():
        layout = plan.layout
        assert 2 <= len(layout.starts) <= BuildingConfig().num_starts
        grid = layout_grid(layout, 0.1)
        assert first_disconnected_start(layout, grid, RADIUS) is None, f"seed {seed}"
        xy = np.array([s[:2] for s in layout.starts])
        assert np.all(layout.geometry().signed_distance(xy) >= RADIUS + BuildingConfig().footprint_margin - 1e-9)
        assert np.all((xy > 0) & (xy < np.array(layout.size)))


@pytest.mark.parametrize("seed", [0, 4, 17])
def test_reachability_against_the_brute_force_clearance(plans, seed):
    """Independent of the generator's own check: the analytic clearance of every cell
    (truth.clearance, every solid at every cell), 8-connected components, and the region
    each cell centre falls in."""
    plan = plans[seed]
    grid = layout_grid(plan.layout, 0.1)
    dist = clearance(plan.layout, grid)
    labels, _ = ndimage.label(dist > RADIUS, structure=np.ones((3, 3), bool))
    iy, ix = grid.world_to_cell(np.array(plan.layout.starts[0][:2]))
    home = labels[iy - 1 : iy + 2, ix - 1 : ix + 2]
    home = labels == np.bincount(home[home > 0]).argmax()
    centers = grid.cell_centers()
    m = BuildingConfig().module
    region = plan.labels[(centers[..., 1] // m).astype(int), (centers[..., 0] // m).astype(int)]
    assert set(np.unique(region[home])) == set(range(len(plan.kinds)))


def test_doors_within_the_clearance_rules_and_open(plans):
    b = BuildingConfig()
    for plan in plans.values():
        assert plan.doors
        walls = dataclasses.replace(plan.layout, boxes=(), cylinders=()).geometry()
        solids = plan.layout.geometry()
        for door in plan.doors:
            assert b.door_min_width - 1e-9 <= door.width <= b.door_max_width + 1e-9
            assert door.width > 2 * RADIUS
            # the gap is open: the nearest wall is a jamb (width / 2 away) or farther ...
            assert walls.signed_distance(np.array(door.center)) >= door.width / 2 - 1e-6
            # ... and no object blocks it (the footprint fits at its centre)
            assert solids.signed_distance(np.array(door.center)) > RADIUS
            along = plan.layout.size[0] if door.axis == 0 else plan.layout.size[1]
            assert b.door_jamb - 1e-9 <= door.low and door.high <= along - b.door_jamb + 1e-9


def test_objects_inside_clear_of_starts_and_under_the_cap(plans):
    b, scene = BuildingConfig(), SceneConfig()
    for plan in plans.values():
        layout = plan.layout
        sx, sy = layout.size
        assert len(layout.boxes) + len(layout.cylinders) <= b.clutter_max
        starts = np.array([s[:2] for s in layout.starts])
        for box in layout.boxes:
            corners = box.corners()
            assert corners.min() >= 0 and corners[:, 0].max() <= sx and corners[:, 1].max() <= sy
            reach = np.hypot(*box.size[:2]) / 2
            assert np.linalg.norm(starts - box.center, axis=1).min() >= reach + scene.start_clearance - 1e-9
            assert box.size[2] >= scene.object_min_height
        for cyl in layout.cylinders:
            assert cyl.radius <= cyl.center[0] <= sx - cyl.radius and cyl.radius <= cyl.center[1] <= sy - cyl.radius
            assert np.linalg.norm(starts - cyl.center, axis=1).min() >= cyl.radius + scene.start_clearance - 1e-9


def test_walls_stay_inside_and_on_the_raster(plans):
    m = BuildingConfig().module
    for plan in plans.values():
        for wall in plan.layout.walls:
            ends = np.array([wall.start, wall.end])
            assert ends.min() >= 0 and np.all(ends <= np.array(plan.layout.size) + 1e-9)
            assert wall.start[0] == wall.end[0] or wall.start[1] == wall.end[1]  # axis-aligned
            line = wall.start[0] if wall.start[0] == wall.end[0] else wall.start[1]
            assert abs(line / m - round(line / m)) < 1e-9


def test_loops_count_matches_networkx_and_the_corridor_kind(plans):
    for plan in plans.values():
        graph = nx.MultiGraph()
        graph.add_nodes_from(range(len(plan.kinds)))
        graph.add_edges_from(plan.edges())
        assert nx.is_connected(graph)
        assert plan.stats()["loops"] == len(nx.cycle_basis(nx.Graph(graph))) + (
            graph.number_of_edges() - nx.Graph(graph).number_of_edges())
        if plan.corridor == "loop":
            assert plan.stats()["loops"] >= 1


def test_graph_cycles_on_known_graphs():
    assert graph_cycles(3, [(0, 1), (1, 2), (0, 2)]) == 1
    assert graph_cycles(4, [(0, 1), (1, 2), (1, 3)]) == 0
    assert graph_cycles(5, [(0, 1), (1, 2), (0, 2), (3, 4)]) == 1
    assert graph_cycles(4, [(0, 1), (1, 2), (2, 3), (3, 0), (0, 2)]) == 2


def test_a_failed_draw_is_redrawn_deterministically(monkeypatch):
    """Attempt 0 fails the check -> the plan of attempt 1, i.e. of default_rng([seed, 1])."""
    real = building_module.check_reachable
    calls = []

    def fail_first(*args, **kwargs):
        calls.append(1)
        if len(calls) == 1:
            raise Redraw("stand-in failure")
        return real(*args, **kwargs)

    monkeypatch.setattr(building_module, "check_reachable", fail_first)
    plan = generate_building(config(3), RADIUS)
    monkeypatch.undo()
    expected = draw_plan(np.random.default_rng([3, 1]), config(3), RADIUS, 1)
    assert plan.attempt == 1 and plan.layout == expected.layout
    assert plan.layout != generate_building(config(3), RADIUS).layout


def test_a_seed_that_cannot_be_drawn_is_a_clear_error():
    with pytest.raises(RuntimeError, match=r"scene=building seed=2: no valid plan in scene.building.max_attempts=2"):
        # no room of at most 9 m (no hall) leaves 5 m around an object
        scene = dataclasses.replace(config(2, clutter_max=1, hall_probability=0.0, max_attempts=2), object_clearance=5.0)
        generate_building(scene, RADIUS)


def test_starts_index_into_the_plan():
    scene = make_scene(dataclasses.replace(config(1), start_index=2), RobotConfig(), LidarConfig())
    assert np.allclose(scene.start_pose, scene.layout.starts[2])
    assert scene.truth.reachable[scene.truth.start_cell]


# --- every knob's bad value is rejected, in one line naming it ----------------------------

BAD_VALUES = [
    ("size_min", 0.0, "size_min must be positive"),
    ("size_min", 10.0, "size_min=10.0 must be >= 3 scene.building.room_min_side"),
    ("size_max", 14.0, "size_max=14.0 must be >= scene.building.size_min"),
    ("size_max", float("inf"), "size_max must be positive \\(finite\\)"),
    ("module", -0.5, "module must be positive"),
    ("module", 2.0, "room_min_side=3.0 must be >= 2 scene.building.module"),
    ("corridor_kinds", ["straight", "spiral"], "corridor_kinds=\\['straight', 'spiral'\\]: choose"),
    ("corridor_kinds", [], "corridor_kinds=\\[\\]: choose a non-empty list"),
    ("corridor_weights", [1.0, 1.0], "corridor_weights=\\[1.0, 1.0\\] needs one finite weight"),
    ("corridor_weights", [0.0, 0.0, 0.0, 0.0], "not all zero"),
    ("corridor_weights", [1.0, -1.0, 1.0, 1.0], "corridor_weights"),
    ("corridor_min_width", 1.0, "corridor_min_width=1.0 must be >= scene.building.door_min_width"),
    ("corridor_max_width", 1.4, "corridor_max_width=1.4 must be >= scene.building.corridor_min_width"),
    ("max_branches", 0, "max_branches must be >= 1"),
    ("end_inset_probability", 1.5, "end_inset_probability must be in \\[0, 1\\]"),
    ("room_min_side", 1.5, "room_min_side=1.5 must be >= scene.building.door_min_width"),
    ("room_max_side", 5.0, "room_max_side=5.0 must be >= 2 scene.building.room_min_side"),
    ("hall_probability", -0.1, "hall_probability must be in \\[0, 1\\]"),
    ("hall_min_side", 2.0, "hall_min_side=2.0 must be >= scene.building.room_min_side"),
    ("hall_max_side", 5.0, "hall_max_side=5.0 must be >= scene.building.hall_min_side and 2"),
    ("door_min_width", 0.9, "door_min_width=0.9 must be >= 2 \\(robot.radius"),
    ("door_max_width", 0.95, "door_max_width=0.95 must be >= scene.building.door_min_width"),
    ("door_jamb", 0.05, "door_jamb=0.05 must be >= scene.wall_thickness / 2"),
    ("footprint_margin", -0.1, "footprint_margin must be >= 0"),
    ("footprint_margin", 0.3, "door_min_width=1.0 must be >= 2 \\(robot.radius"),
    ("room_loop_probability", 2.0, "room_loop_probability must be in \\[0, 1\\]"),
    ("max_extra_doors", -1, "max_extra_doors must be >= 0"),
    ("room_door_penalty", -1.0, "room_door_penalty must be >= 0"),
    ("clutter_density", -1.0, "clutter_density must be >= 0"),
    ("clutter_max", -2, "clutter_max must be >= 0"),
    ("object_kinds", ["sofa"], "object_kinds=\\['sofa'\\]: choose"),
    ("object_weights", [1.0], "object_weights=\\[1.0\\] needs one finite weight"),
    ("table_length", [2.0, 1.0], "table_length must be \\[min, max\\]"),
    ("table_length", [30.0, 40.0], "table_length: objects of footprint radius 20.0062 m"),
    ("table_width", [0.0, 1.0], "table_width must be \\[min, max\\]"),
    ("table_height", 0.0, "table_height must be positive"),
    ("pillar_radius", [0.2], "pillar_radius must be \\[min, max\\]"),
    ("num_starts", 0, "num_starts must be >= 1"),
    ("max_attempts", 0, "max_attempts must be >= 1"),
    ("lot_probability", 1.5, "lot_probability must be in \\[0, 1\\]"),
    ("lot_lane_width", [0.5, 3.0], "lot_lane_width=\\[0.5, 3.0\\]: its min must be >= 2 \\(robot.radius"),
    ("lot_lane_width", [3.0], "lot_lane_width must be \\[min, max\\]"),
    ("lot_car_pitch", [1.0, 3.0], "lot_car_pitch=\\[1.0, 3.0\\]: its min must be >= the car's width"),
    ("lot_gap_probability", -0.5, "lot_gap_probability must be in \\[0, 1\\]"),
]


def test_every_knob_has_a_bad_value_case():
    assert {key for key, _, _ in BAD_VALUES} == {f.name for f in dataclasses.fields(BuildingConfig)}


@pytest.mark.parametrize(("key", "value", "message"), BAD_VALUES, ids=[f"{k}={v}" for k, v, _ in BAD_VALUES])
def test_bad_value_rejected_in_one_line(key, value, message):
    with pytest.raises(ValueError, match=message) as error:
        validate_building(config(**{key: value}), RADIUS)
    assert "\n" not in str(error.value) and "scene.building." in str(error.value)


def test_a_lot_that_cannot_hold_a_row_is_rejected_only_when_lots_are_drawn():
    with pytest.raises(ValueError, match="size_min=15 must be >= a car's length \\+ 2 narrowest lanes"):
        validate_building(config(lot_probability=0.2, lot_lane_width=[6.0, 8.0]), RADIUS)
    validate_building(config(lot_lane_width=[6.0, 8.0]), RADIUS)  # no lots drawn: no constraint
    with pytest.raises(ValueError, match="scene.car_size must be"):
        validate_building(dataclasses.replace(config(), car_size=[1.9, 4.5]), RADIUS)


def test_bad_value_rejected_before_anything_runs():
    with pytest.raises(ValueError, match="scene.building.door_min_width=0.5 must be >= 2 \\(robot.radius"):
        load_config(["scene=building", "scene.building.door_min_width=0.5"])
    with pytest.raises(ValueError, match="door_min_width=1.0 must be >= 2 \\(robot.radius"):
        load_config(["scene=building", "robot.radius=0.45"])  # a wider robot needs wider doors
    load_config(["scene=office", "scene.building.door_min_width=0.5"])  # not checked for another scene
    with pytest.raises(ValueError, match="door_min_width"):
        make_scene(config(0, door_min_width=0.5), RobotConfig(), LidarConfig())  # the API checks too


def test_explore_rl_view_draws_a_building(tmp_path):
    """``explore-rl-view scene=building seed=S`` as a user runs it."""
    import subprocess
    import sys

    out = tmp_path / "b.png"
    view = [sys.executable, "-c", "from explore_rl.cli import view; view()"]
    result = subprocess.run(view + ["scene=building", "seed=5", f"out={out}"], capture_output=True, text=True,
                            cwd=tmp_path, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert out.stat().st_size > 10_000 and f"wrote {out}" in result.stdout


@pytest.mark.parametrize("knobs", [
    {"module": 0.25}, {"room_min_side": 3.2, "size_min": 16.0}, {"corridor_kinds": ["tree"], "corridor_weights": [1.0]},
    {"corridor_kinds": ["loop"], "corridor_weights": [1.0], "size_max": 16.0}, {"hall_probability": 1.0},
    {"clutter_density": 0.0, "room_loop_probability": 0.0, "corridor_kinds": ["straight", "L", "tree"],
     "corridor_weights": [1.0, 1.0, 1.0]},
], ids=["module", "room_min", "tree", "small_loop", "hall", "no_loops"])
def test_other_knobs_give_valid_plans(knobs):
    for seed in range(8):
        plan = generate_building(config(seed, **knobs), RADIUS)
        assert first_disconnected_start(plan.layout, layout_grid(plan.layout, 0.1), RADIUS) is None
        stats = plan.stats()
        if knobs.get("hall_probability") == 1.0:
            assert stats["halls"] == 1
        if knobs.get("room_loop_probability") == 0.0:
            assert stats["loops"] == 0 and stats["objects"] == 0  # trees only: no ring, no extra doors
        if knobs.get("corridor_kinds") == ["loop"]:
            assert stats["corridor_loops"] == 1 and stats["loops"] >= 1


# --- parking lots (lot_probability) ---------------------------------------------------------

LOT_SEEDS = range(12)


def test_lots_are_open_floors_with_rows_of_cars_and_reachable_starts():
    b = BuildingConfig(lot_probability=1.0)
    scene = SceneConfig(name="building", building=b)
    across, along, height = scene.car_size
    for seed in LOT_SEEDS:
        plan = generate_building(config(seed, lot_probability=1.0), RADIUS)
        assert plan.corridor == building_module.LOT and plan.kinds == (building_module.HALL,)
        assert not plan.layout.walls and not plan.doors and not plan.layout.cylinders
        assert plan.layout.boxes and all(box.size == (across, along, height) for box in plan.layout.boxes)
        ys = sorted({round(box.center[1]) for box in plan.layout.boxes})
        xs = np.array([box.center[0] for box in plan.layout.boxes])
        # every car inside, with an aisle of the narrowest lane between its row's ends and the walls
        assert np.all(xs - across / 2 >= b.lot_lane_width[0] - 2 * scene.car_jitter)
        assert np.all(xs + across / 2 <= plan.layout.size[0] - b.lot_lane_width[0] + 2 * scene.car_jitter)
        assert all(y + along / 2 < plan.layout.size[1] for y in ys)
        assert len(plan.layout.starts) == b.num_starts
        assert first_disconnected_start(plan.layout, layout_grid(plan.layout, 0.1), RADIUS) is None
        grid = layout_grid(plan.layout, 0.1)
        distance = clearance(plan.layout, grid)
        for x, y, _ in plan.layout.starts:  # clear of every car and wall by the footprint (to a cell)
            iy, ix = grid.world_to_cell(np.array([x, y]))
            assert distance[iy, ix] >= RADIUS + b.footprint_margin - grid.resolution


def test_lots_are_deterministic_and_the_default_family_draws_no_lot():
    a, b = generate_building(config(3, lot_probability=1.0), RADIUS), generate_building(config(3, lot_probability=1.0),
                                                                                        RADIUS)
    assert a.layout == b.layout
    for seed in range(6):  # at 0 no draw is made: the lot knobs cannot change a plan
        plain = generate_building(config(seed), RADIUS)
        other = generate_building(config(seed, lot_lane_width=[4.0, 8.0], lot_car_pitch=[3.0, 7.0],
                                         lot_gap_probability=0.9), RADIUS)
        assert plain.corridor != building_module.LOT and plain.layout == other.layout


def test_some_plans_are_lots_at_an_intermediate_probability():
    kinds = Counter(generate_building(config(seed, lot_probability=0.5), RADIUS).corridor for seed in range(16))
    assert 0 < kinds[building_module.LOT] < 16


def test_a_scene_of_a_lot_builds_and_is_explorable():
    scene = make_scene(config(2, lot_probability=1.0), RobotConfig(), LidarConfig())
    assert scene.truth.reachable[scene.truth.start_cell] and scene.model.ngeom > 4
