"""Scene files: the example loads; every kind of bad file gets one clear error."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import yaml

from explore_rl.scene.layout import Box, Cylinder, Wall
from explore_rl.scene.scene_file import SceneFileError, load_scene_file

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "lab.yaml"
ROBOT_RADIUS = 0.3

# A valid 6 m x 4 m scene: a wall at x = 3 with a 1 m door, one start in each half.
BASE = {
    "version": 1,
    "name": "base",
    "size": [6.0, 4.0],
    "walls": [
        {"from": [3.0, 0.0], "to": [3.0, 1.5], "thickness": 0.2},
        {"from": [3.0, 2.5], "to": [3.0, 4.0]},
    ],
    "boxes": [{"center": [1.5, 3.0], "size": [1.0, 0.6, 0.8], "yaw": 0.3}],
    "cylinders": [{"center": [4.5, 1.0], "radius": 0.3, "height": 1.5}],
    "starts": [[1.0, 1.0, 0.0], [5.0, 3.0, 1.57]],
}


def write(tmp_path: Path, content: dict | str, name: str = "my.yaml") -> Path:
    path = tmp_path / name
    path.write_text(content if isinstance(content, str) else yaml.safe_dump(content))
    return path


def edited(edit) -> dict:
    data = copy.deepcopy(BASE)
    edit(data)
    return data


def test_example_loads():
    layout = load_scene_file(EXAMPLE, robot_radius=ROBOT_RADIUS)
    assert layout.name == "lab"
    assert layout.size == (12.0, 10.0)
    assert layout.wall_height == 2.5 and layout.perimeter
    assert layout.walls[0] == Wall((6.0, 0.0), (6.0, 4.0), 0.2)
    assert layout.walls[1].thickness == 0.2  # default
    assert layout.boxes[0] == Box((3.0, 7.0), (1.6, 0.8, 0.75), 0.3)
    assert layout.boxes[1].yaw == 0.0  # default
    assert layout.cylinders == (Cylinder((9.0, 7.5), 0.25, 1.2),)
    assert layout.starts == ((2.0, 2.0, 0.0), (10.0, 5.0, 3.14159))


def test_base_loads_with_defaults(tmp_path):
    data = edited(lambda d: None)
    layout = load_scene_file(write(tmp_path, data), ROBOT_RADIUS)
    assert layout.wall_height == 2.5 and layout.perimeter is True
    assert all(isinstance(v, float) for v in layout.size)


def test_optional_lists_may_be_absent_or_null(tmp_path):
    data = edited(lambda d: (d.pop("walls"), d.update(boxes=None), d.pop("cylinders")))
    layout = load_scene_file(write(tmp_path, data), ROBOT_RADIUS)
    assert layout.walls == () and layout.boxes == () and layout.cylinders == ()


def test_exact_message_format(tmp_path):
    data = edited(lambda d: d["walls"][0].update(thickness=-0.1))
    with pytest.raises(SceneFileError) as info:
        load_scene_file(write(tmp_path, data), ROBOT_RADIUS)
    err = info.value
    assert str(err) == f"{tmp_path / 'my.yaml'}: walls[0].thickness: must be a positive number, got -0.1"
    assert isinstance(err, ValueError) and err.field == "walls[0].thickness"


def test_larger_robot_cannot_pass_the_example_door():
    with pytest.raises(SceneFileError, match=r"starts\[1\]: cannot be reached"):
        load_scene_file(EXAMPLE, robot_radius=0.65)


def _set(path: str, value):
    """An edit that sets ``BASE`` field ``path`` (dotted, with list indices) to ``value``."""

    def edit(data):
        *parents, last = path.split(".")
        node = data
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        node[int(last) if last.isdigit() else last] = value

    return edit


def _delete(path: str):
    def edit(data):
        *parents, last = path.split(".")
        node = data
        for key in parents:
            node = node[int(key)] if key.isdigit() else node[key]
        del node[last]

    return edit


BAD_EDITS = {
    # unknown keys, at every level
    "unknown_top_key": (_set("colour", "red"), "colour", "allowed keys"),
    "unknown_wall_key": (_set("walls.0.thikness", 0.2), "walls[0].thikness", "allowed keys"),
    "unknown_box_key": (_set("boxes.0.rotation", 0.2), "boxes[0].rotation", "allowed keys"),
    "unknown_cyl_key": (_set("cylinders.0.r", 0.2), "cylinders[0].r", "allowed keys"),
    # missing required keys
    "missing_version": (_delete("version"), "version", "missing"),
    "missing_name": (_delete("name"), "name", "missing"),
    "missing_size": (_delete("size"), "size", "missing"),
    "missing_starts": (_delete("starts"), "starts", "missing"),
    "missing_wall_to": (_delete("walls.0.to"), "walls[0].to", "e.g. 'to: [x, y]'"),
    "missing_box_size": (_delete("boxes.0.size"), "boxes[0].size", "missing"),
    "missing_cyl_height": (_delete("cylinders.0.height"), "cylinders[0].height", "missing"),
    # version, types
    "wrong_version": (_set("version", 2), "version", "version: 1"),
    "name_not_string": (_set("name", 12), "name", "string"),
    "nan_size": (_set("size.0", math.nan), "size[0]", "finite"),
    "inf_thickness": (_set("walls.0.thickness", math.inf), "walls[0].thickness", "finite"),
    "neg_inf_start": (_set("starts.0.2", -math.inf), "starts[0][2]", "finite"),
    "string_size": (_set("size.1", "4.0"), "size[1]", "remove the quotes"),
    "string_radius": (_set("cylinders.0.radius", "0.3"), "cylinders[0].radius", "string"),
    "word_for_number": (_set("boxes.0.yaw", "north"), "boxes[0].yaw", "must be a number"),
    "bool_yaw": (_set("boxes.0.yaw", True), "boxes[0].yaw", "boolean"),
    "bool_wall_height": (_set("wall_height", False), "wall_height", "boolean"),
    "perimeter_not_bool": (_set("perimeter", 1), "perimeter", "true or false"),
    "walls_not_list": (_set("walls", {"from": [0, 0]}), "walls", "must be a list"),
    "wall_not_mapping": (_set("walls.0", [0, 0, 1, 1]), "walls[0]", "mapping"),
    # list lengths
    "size_three": (_set("size", [6.0, 4.0, 2.0]), "size", "2 numbers"),
    "size_scalar": (_set("size", 6.0), "size", "2 numbers"),
    "start_two": (_set("starts.1", [5.0, 3.0]), "starts[1]", "3 numbers"),
    "box_size_two": (_set("boxes.0.size", [1.0, 0.6]), "boxes[0].size", "3 numbers"),
    "wall_from_three": (_set("walls.0.from", [3.0, 0.0, 0.0]), "walls[0].from", "2 numbers"),
    # non-positive extents
    "zero_size": (_set("size.1", 0), "size[1]", "positive"),
    "neg_wall_height": (_set("wall_height", -2.5), "wall_height", "positive"),
    "zero_thickness": (_set("walls.1.thickness", 0.0), "walls[1].thickness", "positive"),
    "neg_box_size": (_set("boxes.0.size.2", -0.8), "boxes[0].size[2]", "positive"),
    "zero_radius": (_set("cylinders.0.radius", 0), "cylinders[0].radius", "positive"),
    "zero_height": (_set("cylinders.0.height", 0.0), "cylinders[0].height", "positive"),
    "zero_length_wall": (_set("walls.1.to", [3.0, 2.5]), "walls[1]", "zero-length"),
    # geometry outside the scene
    "box_outside": (_set("boxes.0.center", [0.3, 3.0]), "boxes[0]", "outside the scene"),
    "cyl_outside": (_set("cylinders.0.center", [4.5, 3.9]), "cylinders[0]", "outside the scene"),
    "wall_end_outside": (_set("walls.1.to", [3.0, 4.5]), "walls[1]", "outside the scene"),
    "wall_thickness_pokes_out": (
        _set("walls.1", {"from": [0.0, 4.0], "to": [2.0, 4.0]}), "walls[1]", "thickness included"
    ),
    # starts
    "empty_starts": (_set("starts", []), "starts", "got an empty list"),
    "start_outside": (_set("starts.1", [6.5, 3.0, 0.0]), "starts[1]", "outside the scene"),
    "start_near_box": (_set("starts.0", [1.5, 2.5, 0.0]), "starts[0]", "robot radius"),
    "start_in_cylinder": (_set("starts.1", [4.5, 1.0, 0.0]), "starts[1]", "inside an obstacle"),
    "start_near_border": (_set("starts.0", [0.1, 1.0, 0.0]), "starts[0]", "robot radius"),
    "starts_disconnected": (
        _set("walls.1.from", [3.0, 1.5]), "starts[1]", "cannot be reached from starts[0]"
    ),
    "door_too_narrow": (_set("walls.1.from", [3.0, 2.0]), "starts[1]", "cannot be reached"),
}


@pytest.mark.parametrize("edit, field, hint", BAD_EDITS.values(), ids=BAD_EDITS.keys())
def test_bad_field_is_named(tmp_path, edit, field, hint):
    path = write(tmp_path, edited(edit))
    with pytest.raises(SceneFileError) as info:
        load_scene_file(path, ROBOT_RADIUS)
    message = str(info.value)
    assert f"my.yaml: {field}: " in message
    assert hint in message
    assert info.value.__cause__ is None


BAD_TEXTS = {
    "not_yaml": ("size: [1, 2\nname: x\n", "not valid YAML"),
    "not_mapping": ("- 1\n- 2\n", "must hold a YAML mapping"),
    "empty_file": ("", "must hold a YAML mapping"),
    "duplicate_key": (yaml.safe_dump(BASE) + "name: again\n", "appears twice"),
}


@pytest.mark.parametrize("text, hint", BAD_TEXTS.values(), ids=BAD_TEXTS.keys())
def test_bad_file_is_named(tmp_path, text, hint):
    with pytest.raises(SceneFileError) as info:
        load_scene_file(write(tmp_path, text), ROBOT_RADIUS)
    assert str(info.value).startswith(f"{tmp_path / 'my.yaml'}: ")
    assert hint in str(info.value)


def test_exponent_without_point_is_a_string_in_yaml(tmp_path):
    text = yaml.safe_dump(BASE).replace("- 6.0", "- 6e0", 1)
    with pytest.raises(SceneFileError, match=r"size\[0\]: must be a number.*1\.0e\+3"):
        load_scene_file(write(tmp_path, text), ROBOT_RADIUS)


def test_missing_file(tmp_path):
    with pytest.raises(SceneFileError, match="nowhere.yaml: file not found"):
        load_scene_file(tmp_path / "nowhere.yaml", ROBOT_RADIUS)


def test_bad_robot_radius_is_a_caller_error():
    with pytest.raises(ValueError, match="robot_radius"):
        load_scene_file(EXAMPLE, robot_radius=-0.3)
