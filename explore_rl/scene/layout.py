"""Floor plans as plain data, and their analytic 2D geometry.

A :class:`Layout` is what every scene (procedural or from a YAML file) reduces to:
walls, boxes and cylinders standing on the floor, plus start poses. It knows nothing
about MuJoCo (``scene/build.py`` turns it into a model), so it pickles cheaply and the
2D geometry used for collision checks and ground truth is computed from it directly.

Frame: origin at the lower-left interior corner, x east, y north; the interior floor is
``[0, size_x] x [0, size_y]``; perimeter walls stand outside it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from explore_rl.grid import GridSpec


@dataclass(frozen=True)
class Wall:
    """A wall box centred on the segment ``start -> end``; no end caps."""

    start: tuple[float, float]
    end: tuple[float, float]
    thickness: float = 0.2

    @property
    def length(self) -> float:
        return float(np.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1]))

    def as_box(self, height: float) -> "Box":
        center = ((self.start[0] + self.end[0]) / 2, (self.start[1] + self.end[1]) / 2)
        yaw = float(np.arctan2(self.end[1] - self.start[1], self.end[0] - self.start[0]))
        return Box(center, (self.length, self.thickness, height), yaw)


@dataclass(frozen=True)
class Box:
    """A box standing on the floor: ``size`` = full (x, y, z) extents, ``yaw`` in radians."""

    center: tuple[float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0

    def corners(self) -> np.ndarray:
        """The four ground-plane corners, counter-clockwise, shape (4, 2)."""
        hx, hy = self.size[0] / 2, self.size[1] / 2
        local = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.center)


@dataclass(frozen=True)
class Cylinder:
    """An upright cylinder standing on the floor."""

    center: tuple[float, float]
    radius: float
    height: float


@dataclass(frozen=True)
class Layout:
    """A whole scene as plain data (see the scene-file contract in DESIGN.md)."""

    name: str
    size: tuple[float, float]
    walls: tuple[Wall, ...] = ()
    boxes: tuple[Box, ...] = ()
    cylinders: tuple[Cylinder, ...] = ()
    starts: tuple[tuple[float, float, float], ...] = ()
    wall_height: float = 2.5
    perimeter: bool = True
    perimeter_thickness: float = 0.2

    def wall_boxes(self) -> list[Box]:
        """Every wall (interior and perimeter) as a box; perimeter walls stand outside."""
        boxes = [wall.as_box(self.wall_height) for wall in self.walls]
        if self.perimeter:
            boxes += perimeter_walls(self.size, self.perimeter_thickness, self.wall_height)
        return boxes

    def solid_boxes(self) -> list[Box]:
        """Walls and objects: every box-shaped solid in the scene."""
        return self.wall_boxes() + list(self.boxes)

    def geometry(self) -> "Geometry2D":
        return Geometry2D.from_layout(self)


def perimeter_walls(size: tuple[float, float], thickness: float, height: float) -> list[Box]:
    """Four boxes enclosing ``[0, sx] x [0, sy]`` from outside, corners included."""
    sx, sy = size
    t = thickness
    return [
        Box((sx / 2, -t / 2), (sx + 2 * t, t, height)),
        Box((sx / 2, sy + t / 2), (sx + 2 * t, t, height)),
        Box((-t / 2, sy / 2), (t, sy, height)),
        Box((sx + t / 2, sy / 2), (t, sy, height)),
    ]


@dataclass
class Geometry2D:
    """Analytic ground-plane footprints: oriented rectangles and discs.

    Vectorised signed distance to the nearest solid, used for the robot's collision check
    (footprint disc), for ground-truth free cells and by the analytic ray caster.
    """

    rect_centers: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rect_half: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    rect_yaw: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rect_height: np.ndarray = field(default_factory=lambda: np.zeros(0))
    disc_centers: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    disc_radius: np.ndarray = field(default_factory=lambda: np.zeros(0))
    disc_height: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def from_layout(cls, layout: Layout) -> "Geometry2D":
        boxes = layout.solid_boxes()
        cyl = layout.cylinders
        return cls(
            rect_centers=np.array([b.center for b in boxes], dtype=float).reshape(-1, 2),
            rect_half=np.array([b.size[:2] for b in boxes], dtype=float).reshape(-1, 2) / 2,
            rect_yaw=np.array([b.yaw for b in boxes], dtype=float),
            rect_height=np.array([b.size[2] for b in boxes], dtype=float),
            disc_centers=np.array([c.center for c in cyl], dtype=float).reshape(-1, 2),
            disc_radius=np.array([c.radius for c in cyl], dtype=float),
            disc_height=np.array([c.height for c in cyl], dtype=float),
        )

    def signed_distance(self, xy: np.ndarray, chunk: int = 65536) -> np.ndarray:
        """Distance from points ``(..., 2)`` to the nearest solid; negative inside one.

        Works in chunks of ``chunk`` points to bound the (points x solids) temporaries.
        """
        xy = np.asarray(xy, dtype=float)
        flat = xy.reshape(-1, 2)
        if len(flat) > chunk:
            parts = [self.signed_distance(flat[i : i + chunk]) for i in range(0, len(flat), chunk)]
            return np.concatenate(parts).reshape(xy.shape[:-1])
        best = np.full(len(flat), np.inf)
        if len(self.rect_centers):
            best = np.minimum(best, self._rect_distance(flat).min(axis=1))
        if len(self.disc_centers):
            d = np.linalg.norm(flat[:, None, :] - self.disc_centers[None], axis=-1)
            best = np.minimum(best, (d - self.disc_radius[None]).min(axis=1))
        return best.reshape(xy.shape[:-1])

    def _rect_distance(self, flat: np.ndarray) -> np.ndarray:
        """Signed distance of each point to each rectangle, shape (N, R)."""
        rel = flat[:, None, :] - self.rect_centers[None]
        c, s = np.cos(self.rect_yaw), np.sin(self.rect_yaw)
        local_x = c * rel[..., 0] + s * rel[..., 1]
        local_y = -s * rel[..., 0] + c * rel[..., 1]
        qx = np.abs(local_x) - self.rect_half[:, 0]
        qy = np.abs(local_y) - self.rect_half[:, 1]
        outside = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0))
        inside = np.minimum(np.maximum(qx, qy), 0)
        return outside + inside

    def subset(self, rects: np.ndarray | slice, discs: np.ndarray | slice) -> "Geometry2D":
        """The solids ``rects`` (indices of rectangles) and ``discs`` (of discs) only."""
        return Geometry2D(self.rect_centers[rects], self.rect_half[rects], self.rect_yaw[rects],
                          self.rect_height[rects], self.disc_centers[discs], self.disc_radius[discs],
                          self.disc_height[discs])

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounding box ``[xmin, ymin, xmax, ymax]`` of every solid: rectangles
        first, then discs, shape (R + D, 4)."""
        c, s = np.abs(np.cos(self.rect_yaw)), np.abs(np.sin(self.rect_yaw))
        half = np.stack([c * self.rect_half[:, 0] + s * self.rect_half[:, 1],
                         s * self.rect_half[:, 0] + c * self.rect_half[:, 1]], axis=1)
        half = np.concatenate([half, np.repeat(self.disc_radius[:, None], 2, axis=1)])
        centers = np.concatenate([self.rect_centers, self.disc_centers])
        return np.concatenate([centers - half, centers + half], axis=1)

    def occupied_cells(self, grid: GridSpec, inflate: float = 0.0) -> np.ndarray:
        """Boolean ``[iy, ix]`` mask of cells whose centre lies within ``inflate`` of a solid."""
        return self.signed_distance(grid.cell_centers()) <= inflate
