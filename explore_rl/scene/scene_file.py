"""Load a user scene from a YAML file into a :class:`Layout` (the DESIGN.md contract).

.. code-block:: yaml

    version: 1
    name: my_lab
    size: [20.0, 15.0]     # interior floor extent (m); perimeter walls stand outside it
    wall_height: 2.5       # optional, default 2.5
    perimeter: true        # optional, default true
    walls:                 # optional; thickness optional, default 0.2
      - {from: [0.0, 5.0], to: [8.0, 5.0], thickness: 0.2}
    boxes:                 # optional; size = full x, y, z extents; yaw optional (radians)
      - {center: [3.0, 3.0], size: [1.0, 0.6, 0.8], yaw: 0.3}
    cylinders:             # optional
      - {center: [10.0, 10.0], radius: 0.3, height: 1.5}
    starts:                # at least one [x, y, yaw_rad]; the first is the default start
      - [10.0, 7.5, 0.0]

Rules beyond the types: every footprint (walls *with* their thickness, boxes, cylinders)
lies inside ``[0, size_x] x [0, size_y]`` (touching the border is fine); every start has
at least ``robot_radius`` of clearance to every solid and to the scene border; every start
can be driven to from the first one (8-connected cells of a ``resolution`` grid where the
footprint disc fits, so a door must be wider than the robot's diameter plus about one
cell). Numbers must be YAML numbers: quoted numbers and booleans are rejected.

A bad file raises :class:`SceneFileError` with one message ``FILE: FIELD: PROBLEM``,
e.g. ``my.yaml: walls[2].thickness: must be a positive number, got -0.1``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from explore_rl.scene.layout import Box, Cylinder, Layout, Wall
from explore_rl.scene.truth import first_disconnected_start, layout_grid

SUPPORTED_VERSION = 1
CHECK_RESOLUTION = 0.05  # m; grid used to check that the starts are connected
TOLERANCE = 1e-6  # m; slack for footprints that touch the scene border

# Required keys with an example value (shown when one is missing), then the optional keys.
TOP_KEYS = (
    {"version": "1", "name": "my_lab", "size": "[20.0, 15.0]", "starts": "[[1.0, 1.0, 0.0]]"},
    ("wall_height", "perimeter", "walls", "boxes", "cylinders"),
)
WALL_KEYS = ({"from": "[x, y]", "to": "[x, y]"}, ("thickness",))
BOX_KEYS = ({"center": "[x, y]", "size": "[size_x, size_y, size_z]"}, ("yaw",))
CYLINDER_KEYS = ({"center": "[x, y]", "radius": "0.3", "height": "1.5"}, ())


class SceneFileError(ValueError):
    """A scene file that cannot be loaded; ``str(err)`` is ``FILE: FIELD: PROBLEM``."""

    def __init__(self, file: str, field: str, problem: str) -> None:
        self.file, self.field, self.problem = file, field, problem
        super().__init__(f"{file}: {field}: {problem}" if field else f"{file}: {problem}")


def load_scene_file(
    path: str | Path, robot_radius: float, resolution: float = CHECK_RESOLUTION
) -> Layout:
    """Parse, validate and build the :class:`Layout` of the scene file at ``path``.

    ``robot_radius`` is the footprint disc used for the start checks; ``resolution`` the
    grid on which start connectivity is checked. Raises :class:`SceneFileError`.
    """
    robot_radius = float(robot_radius)
    if not (math.isfinite(robot_radius) and robot_radius >= 0):
        raise ValueError(f"robot_radius must be a finite number >= 0, got {robot_radius!r}")
    checker = _Checker(str(path))
    data = checker.read_yaml(Path(path))
    layout = checker.layout(data)
    checker.check_placement(layout, robot_radius, resolution)
    return layout


class _DuplicateKeyLoader(yaml.SafeLoader):
    """``yaml.SafeLoader`` that rejects a key given twice in one mapping (YAML keeps the last)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=deep)
            if not isinstance(key, (str, int, float, bool)):
                continue  # unhashable keys: left to the SafeLoader's own error
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} appears twice in one mapping", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


class _Checker:
    """Validates one file's data; every ``fail`` names the file and the field path."""

    def __init__(self, file: str) -> None:
        self.file = file

    def fail(self, field: str, problem: str) -> SceneFileError:
        return SceneFileError(self.file, field, problem)

    # ---- reading ---------------------------------------------------------------------

    def read_yaml(self, path: Path) -> dict:
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            hint = "" if path.is_absolute() else f" (relative to {Path.cwd()})"
            raise self.fail("", f"file not found{hint}; check the path") from None
        except (OSError, UnicodeDecodeError) as err:
            raise self.fail("", f"cannot read the file ({err})") from None
        try:
            data = yaml.load(text, Loader=_DuplicateKeyLoader)  # noqa: S506 (a SafeLoader)
        except yaml.YAMLError as err:
            where = getattr(err, "problem_mark", None)
            line = f" at line {where.line + 1}, column {where.column + 1}" if where else ""
            problem = getattr(err, "problem", None) or str(err)
            raise self.fail("", f"not valid YAML{line}: {problem}") from None
        if not isinstance(data, dict):
            raise self.fail("", "the file must hold a YAML mapping with keys "
                            f"{', '.join(TOP_KEYS[0])}, got {_describe(data)}")
        return data

    # ---- structure and values --------------------------------------------------------

    def layout(self, data: dict) -> Layout:
        self.keys(data, "", *TOP_KEYS)
        version = data["version"]
        if isinstance(version, bool) or version != SUPPORTED_VERSION:
            raise self.fail("version", f"unsupported version {_show(version)}; "
                            f"this loader reads version: {SUPPORTED_VERSION}")
        name = data["name"]
        if not isinstance(name, str) or not name.strip():
            raise self.fail("name", f"must be a non-empty string, got {_describe(name)}")
        return Layout(
            name=name,
            size=self.vector(data["size"], "size", 2, "[size_x, size_y]", positive=True),
            walls=tuple(self.wall(w, p) for w, p in self.items(data, "walls")),
            boxes=tuple(self.box(b, p) for b, p in self.items(data, "boxes")),
            cylinders=tuple(self.cylinder(c, p) for c, p in self.items(data, "cylinders")),
            starts=self.starts(data["starts"]),
            wall_height=self.positive(data.get("wall_height", 2.5), "wall_height"),
            perimeter=self.boolean(data.get("perimeter", True), "perimeter"),
        )

    def keys(self, data: Any, field: str, required: dict[str, str], optional: tuple) -> None:
        if not isinstance(data, dict):
            raise self.fail(field, f"must be a mapping with keys {', '.join(required)}, "
                            f"got {_describe(data)}")
        allowed = tuple(required) + optional
        for key in data:
            if key not in allowed:
                raise self.fail(_join(field, str(key)), f"unknown key {str(key)!r}; "
                                f"allowed keys here: {', '.join(allowed)}")
        for key, example in required.items():
            if key not in data:
                raise self.fail(_join(field, key), f"required key is missing; add it, "
                                f"e.g. '{key}: {example}'")

    def items(self, data: dict, key: str) -> list[tuple[Any, str]]:
        """The entries of an optional list (absent or null = empty) with their field paths."""
        value = data.get(key)
        if value is None:
            return []
        if not isinstance(value, list):
            raise self.fail(key, f"must be a list, got {_describe(value)}")
        return [(item, f"{key}[{i}]") for i, item in enumerate(value)]

    def wall(self, data: Any, field: str) -> Wall:
        self.keys(data, field, *WALL_KEYS)
        start = self.vector(data["from"], f"{field}.from", 2, "[x, y]")
        end = self.vector(data["to"], f"{field}.to", 2, "[x, y]")
        if math.dist(start, end) <= TOLERANCE:
            raise self.fail(field, f"zero-length wall: from and to are both {list(start)}; "
                            "give two different end points")
        thickness = self.positive(data.get("thickness", 0.2), f"{field}.thickness")
        return Wall(start, end, thickness)

    def box(self, data: Any, field: str) -> Box:
        self.keys(data, field, *BOX_KEYS)
        center = self.vector(data["center"], f"{field}.center", 2, "[x, y]")
        size = self.vector(data["size"], f"{field}.size", 3, "[size_x, size_y, size_z]",
                           positive=True)
        return Box(center, size, self.number(data.get("yaw", 0.0), f"{field}.yaw"))

    def cylinder(self, data: Any, field: str) -> Cylinder:
        self.keys(data, field, *CYLINDER_KEYS)
        center = self.vector(data["center"], f"{field}.center", 2, "[x, y]")
        radius = self.positive(data["radius"], f"{field}.radius")
        return Cylinder(center, radius, self.positive(data["height"], f"{field}.height"))

    def starts(self, value: Any) -> tuple[tuple[float, float, float], ...]:
        if not isinstance(value, list) or not value:
            got = "an empty list" if value == [] else _describe(value)
            raise self.fail("starts", f"must be a non-empty list of [x, y, yaw_rad] starts, "
                            f"got {got}")
        return tuple(
            self.vector(s, f"starts[{i}]", 3, "[x, y, yaw_rad]") for i, s in enumerate(value)
        )

    def vector(self, value: Any, field: str, n: int, form: str, positive: bool = False) -> tuple:
        if not isinstance(value, list) or len(value) != n:
            got = f"{len(value)} items" if isinstance(value, list) else _describe(value)
            raise self.fail(field, f"must be a list of {n} numbers {form}, got {got}")
        check = self.positive if positive else self.number
        return tuple(check(v, f"{field}[{i}]") for i, v in enumerate(value))

    def number(self, value: Any, field: str) -> float:
        if isinstance(value, bool):
            raise self.fail(field, f"must be a number, got the boolean {_show(value)}")
        if isinstance(value, str) and _parses_as_float(value):
            raise self.fail(field, _number_as_text(value))
        if not isinstance(value, (int, float)):
            raise self.fail(field, f"must be a number, got {_describe(value)}")
        if not math.isfinite(value):
            raise self.fail(field, f"must be a finite number, got {_show(value)}")
        return float(value)

    def positive(self, value: Any, field: str) -> float:
        number = self.number(value, field)
        if number <= 0:
            raise self.fail(field, f"must be a positive number, got {_show(value)}")
        return number

    def boolean(self, value: Any, field: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(field, f"must be true or false, got {_describe(value)}")
        return value

    # ---- placement -------------------------------------------------------------------

    def check_placement(self, layout: Layout, robot_radius: float, resolution: float) -> None:
        """Footprints inside the scene; starts inside, clear of obstacles and connected."""
        for i, wall in enumerate(layout.walls):
            self.inside(wall.as_box(layout.wall_height).corners(), layout, f"walls[{i}]",
                        "wall (thickness included)")
        for i, box in enumerate(layout.boxes):
            self.inside(box.corners(), layout, f"boxes[{i}]", "box footprint")
        for i, cyl in enumerate(layout.cylinders):
            c, r = np.asarray(cyl.center), cyl.radius
            extremes = c + np.array([[-r, 0], [r, 0], [0, -r], [0, r]])
            self.inside(extremes, layout, f"cylinders[{i}]", "cylinder footprint")
        distances = layout.geometry().signed_distance(np.array([s[:2] for s in layout.starts]))
        for i, to_solid in enumerate(distances):
            self.start_clear(layout, i, float(to_solid), robot_radius)
        self.starts_connected(layout, robot_radius, resolution)

    def inside(self, points: np.ndarray, layout: Layout, field: str, what: str) -> None:
        sx, sy = layout.size
        outside = (
            (points[:, 0] < -TOLERANCE) | (points[:, 0] > sx + TOLERANCE)
            | (points[:, 1] < -TOLERANCE) | (points[:, 1] > sy + TOLERANCE)
        )
        if outside.any():
            x, y = points[np.argmax(outside)]
            raise self.fail(field, f"{what} reaches outside the scene [0, {sx:g}] x [0, {sy:g}] "
                            f"(point ({x:.3g}, {y:.3g})); move it inside or enlarge size")

    def start_clear(self, layout: Layout, index: int, to_solid: float, robot_radius: float) -> None:
        sx, sy = layout.size
        x, y, _ = layout.starts[index]
        field = f"starts[{index}]"
        if not (0 <= x <= sx and 0 <= y <= sy):
            raise self.fail(field, f"({x:g}, {y:g}) is outside the scene "
                            f"[0, {sx:g}] x [0, {sy:g}]")
        to_border = min(x, sx - x, y, sy - y)
        gap = min(to_solid, to_border)
        if to_solid <= 0:
            raise self.fail(field, f"({x:g}, {y:g}) lies inside an obstacle; "
                            "move the start into open space")
        if gap < robot_radius:
            near = "an obstacle" if to_solid <= to_border else "the scene border"
            raise self.fail(field, f"({x:g}, {y:g}) is {gap:.3g} m from {near}, "
                            f"closer than the robot radius {robot_radius:g} m; "
                            "move the start into open space")

    def starts_connected(self, layout: Layout, robot_radius: float, resolution: float) -> None:
        index = first_disconnected_start(layout, layout_grid(layout, resolution), robot_radius)
        if index is not None:
            raise self.fail(f"starts[{index}]", "cannot be reached from starts[0] by a robot "
                            f"of radius {robot_radius:g} m; open a gap wider than "
                            f"{2 * robot_radius + resolution:.2f} m or move the start")


def _join(field: str, key: str) -> str:
    return f"{field}.{key}" if field else key


def _parses_as_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _number_as_text(text: str) -> str:
    """Why a number arrived as a YAML string, and how to write it."""
    if not math.isfinite(float(text)):
        return f"must be a finite number, got {text!r}"
    if "e" in text.lower():
        return (f"must be a number, got the string {text!r}; YAML reads exponents without a "
                "decimal point and sign as text: write 1.0e+3, not 1e3")
    return f"must be a number, got the string {text!r}; remove the quotes"


def _show(value: Any) -> str:
    """A value as the user wrote it in YAML (true, null, .nan, ...)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    return repr(value) if isinstance(value, str) else str(value)


def _describe(value: Any) -> str:
    """A value with its YAML type, for 'got ...' messages."""
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if value is None:
        return "nothing (null)"
    if isinstance(value, str):
        return f"the string {value!r}"
    return _show(value)
