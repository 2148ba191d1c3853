"""GridSpec: the one 2D grid geometry shared by every ground-plane grid.

Ground truth free space, the occupancy map, the virtual map and the planner all index
cells as ``[iy, ix]`` (row = y, column = x) on a grid whose lower-left corner sits at
``origin`` in the world frame (x east, y north).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GridSpec:
    """A regular 2D grid: ``shape = (ny, nx)`` cells of ``resolution`` metres."""

    origin: tuple[float, float]
    resolution: float
    shape: tuple[int, int]

    @classmethod
    def covering(
        cls, lower: tuple[float, float], upper: tuple[float, float], resolution: float
    ) -> "GridSpec":
        """The smallest grid of ``resolution`` cells that covers the box [lower, upper]."""
        if resolution <= 0:
            raise ValueError(f"grid resolution must be positive, got {resolution}")
        nx = int(np.ceil((upper[0] - lower[0]) / resolution - 1e-9))
        ny = int(np.ceil((upper[1] - lower[1]) / resolution - 1e-9))
        if nx <= 0 or ny <= 0:
            raise ValueError(f"empty grid for box {lower}..{upper}")
        return cls((float(lower[0]), float(lower[1])), float(resolution), (ny, nx))

    @property
    def ny(self) -> int:
        return self.shape[0]

    @property
    def nx(self) -> int:
        return self.shape[1]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax), handy for ``imshow(..., origin="lower")``."""
        x0, y0 = self.origin
        return (x0, x0 + self.nx * self.resolution, y0, y0 + self.ny * self.resolution)

    def world_to_cell(self, xy: np.ndarray) -> np.ndarray:
        """Integer ``[iy, ix]`` indices of world points ``xy[..., 2]`` (may be out of bounds)."""
        xy = np.asarray(xy, dtype=float)
        ix = np.floor((xy[..., 0] - self.origin[0]) / self.resolution).astype(np.int64)
        iy = np.floor((xy[..., 1] - self.origin[1]) / self.resolution).astype(np.int64)
        return np.stack([iy, ix], axis=-1)

    def cell_to_world(self, cells: np.ndarray) -> np.ndarray:
        """World ``xy`` of the centres of cells ``[..., (iy, ix)]``."""
        cells = np.asarray(cells)
        x = self.origin[0] + (cells[..., 1] + 0.5) * self.resolution
        y = self.origin[1] + (cells[..., 0] + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    def in_bounds(self, cells: np.ndarray) -> np.ndarray:
        """Boolean mask of the ``[iy, ix]`` cells that lie inside the grid."""
        cells = np.asarray(cells)
        return (
            (cells[..., 0] >= 0)
            & (cells[..., 0] < self.ny)
            & (cells[..., 1] >= 0)
            & (cells[..., 1] < self.nx)
        )

    def cell_centers(self) -> np.ndarray:
        """World ``xy`` of every cell centre, shape ``(ny, nx, 2)``."""
        iy, ix = np.meshgrid(np.arange(self.ny), np.arange(self.nx), indexing="ij")
        return self.cell_to_world(np.stack([iy, ix], axis=-1))

    def coarsened(self, factor: int) -> "GridSpec":
        """A grid with the same origin and ``factor`` times larger cells (e.g. the virtual map)."""
        ny = int(np.ceil(self.ny / factor))
        nx = int(np.ceil(self.nx / factor))
        return GridSpec(self.origin, self.resolution * factor, (ny, nx))
