"""Traversability and shortest paths on the 2D grid.

Obstacles (known-occupied cells) are inflated by the robot radius; unknown cells are not
traversable. One ``scipy.sparse.csgraph.dijkstra`` from the robot's cell gives the
distance to, and the path to, every cell (:class:`DistanceField`). The 8-connected
grid graph is built once per map with vectorised numpy, over the smallest window of the
grid that holds every traversable cell (edges join traversable cells only, so the
window's graph has the same edges in the same order as the whole grid's, and Dijkstra
the same distances and predecessors: ``PathPlanner(..., reference=True)`` builds the
whole grid's, tests/mapping/test_paths.py compares them).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from explore_rl.grid import GridSpec
from explore_rl.mapping.config import PathConfig

# The 8 neighbours (dy, dx) in increasing flat-index order, so CSR rows come out sorted.
_NEIGHBOURS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def traversability(
    known_free: np.ndarray,
    known_occupied: np.ndarray,
    grid: GridSpec,
    robot_radius: float,
    config: PathConfig | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Traversable mask and per-cell cost (``inf`` where not traversable).

    A cell is traversable if known free and its clearance exceeds ``robot_radius +
    inflation_margin``; its cost is ``1 + clearance_weight * exp(-c / clearance_scale)``,
    ``c`` = clearance beyond that radius, so paths keep away from walls. See
    :func:`obstacle_clearance` for how clearance is measured.

    Computed over the smallest window holding every known cell: every occupied cell lies
    in it and no free cell outside it, so the window's clearances (with the grid's border
    ring added by its distance, :func:`border_distance`) are the whole grid's, and the
    result is :func:`traversability_reference`'s bit for bit (tests/mapping/test_paths.py).
    """
    config = config or PathConfig()
    known_free = np.asarray(known_free, dtype=bool)
    known_occupied = np.asarray(known_occupied, dtype=bool)
    traversable = np.zeros(grid.shape, dtype=bool)
    cost = np.full(grid.shape, np.inf)
    low, high = traversable_window(known_free | known_occupied)
    window = tuple(slice(lo, hi) for lo, hi in zip(low, high))
    occupied = known_occupied[window]
    centre_distance = np.full(occupied.shape, np.inf)  # in cells
    if occupied.any():
        centre_distance = ndimage.distance_transform_edt(~occupied)
    if config.grid_border_is_obstacle:
        centre_distance = np.minimum(centre_distance, border_distance(grid.shape, low, high))
    clearance = (centre_distance - 0.5) * grid.resolution
    traversable[window], cost[window] = _traversable_and_cost(known_free[window], occupied, clearance,
                                                              robot_radius, config)
    return traversable, cost


def border_distance(shape: tuple[int, int], low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Distance (cells, centre to centre) from each cell of the window ``[low, high)`` of a
    grid of ``shape`` to the nearest cell of the ring just outside the grid (the nearest
    lies straight across: the ring holds whole rows and columns)."""
    rows = np.arange(low[0], high[0])
    cols = np.arange(low[1], high[1])
    to_row = np.minimum(rows + 1, shape[0] - rows).astype(float)
    to_col = np.minimum(cols + 1, shape[1] - cols).astype(float)
    return np.minimum(to_row[:, None], to_col[None, :])


def _traversable_and_cost(known_free: np.ndarray, known_occupied: np.ndarray, clearance: np.ndarray,
                          robot_radius: float, config: PathConfig) -> tuple[np.ndarray, np.ndarray]:
    """The traversable mask and cost of :func:`traversability` from the clearances (m)."""
    inflated_radius = robot_radius + config.inflation_margin
    traversable = known_free & ~known_occupied & (clearance > inflated_radius)
    extra = np.maximum(clearance - inflated_radius, 0.0)
    cost = 1.0 + config.clearance_weight * np.exp(-extra / config.clearance_scale)
    return traversable, np.where(traversable, cost, np.inf)


def traversability_reference(
    known_free: np.ndarray,
    known_occupied: np.ndarray,
    grid: GridSpec,
    robot_radius: float,
    config: PathConfig | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`traversability` as first written, over the whole grid (the reference it must
    equal)."""
    config = config or PathConfig()
    known_free = np.asarray(known_free, dtype=bool)
    known_occupied = np.asarray(known_occupied, dtype=bool)
    clearance = obstacle_clearance(known_occupied, grid, config.grid_border_is_obstacle)
    return _traversable_and_cost(known_free, known_occupied, clearance, robot_radius, config)


def obstacle_clearance(
    occupied: np.ndarray, grid: GridSpec, border_is_obstacle: bool = True
) -> np.ndarray:
    """Distance (m) from each cell centre to the nearest occupied cell's edge.

    An occupied cell only says the surface lies somewhere inside it, so the distance is
    the centre-to-centre distance minus half a cell. With ``border_is_obstacle`` the
    ring of cells just outside the grid counts as occupied (the scene grid covers the
    interior only; its perimeter walls lie outside it).
    """
    blocked = np.pad(occupied, 1, constant_values=border_is_obstacle)
    if not blocked.any():
        return np.full(grid.shape, np.inf)
    centre_distance = ndimage.distance_transform_edt(~blocked)[1:-1, 1:-1]  # in cells
    return (centre_distance - 0.5) * grid.resolution


def grid_graph(
    traversable: np.ndarray, cost: np.ndarray, resolution: float, allow_corner_cutting: bool = False
) -> sparse.csr_matrix:
    """8-connected graph over all cells (flat index), edges between traversable cells only.

    Edge weight = step length x mean of the two cell costs. Without corner cutting a
    diagonal step also needs both cells beside it traversable. Both directions are
    stored; the CSR arrays are assembled directly (no COO sort), from the traversable
    cells alone (the other rows are empty): the same matrix as :func:`grid_graph_reference`,
    which works on every cell, bit for bit.
    """
    ny, nx = traversable.shape
    width = nx + 2  # the padded grid's row: a neighbour's padded flat index never wraps
    padded = np.pad(traversable, 1, constant_values=False).reshape(-1)
    padded_cost = np.pad(cost, 1, constant_values=np.inf).reshape(-1)
    cells = np.flatnonzero(traversable)  # ascending: the CSR rows in order
    rows, cols = np.divmod(cells, nx)
    centre = (rows + 1) * width + cols + 1  # each traversable cell in the padded grid
    own_cost = padded_cost[centre]
    valid = np.empty((len(cells), len(_NEIGHBOURS)), dtype=bool)
    weights = np.empty((len(cells), len(_NEIGHBOURS)))
    for k, (dy, dx) in enumerate(_NEIGHBOURS):
        neighbour = centre + dy * width + dx
        ok = padded[neighbour]
        diagonal = dy != 0 and dx != 0
        if diagonal and not allow_corner_cutting:
            ok &= padded[centre + dy * width] & padded[centre + dx]
        step = resolution * (np.sqrt(2.0) if diagonal else 1.0)
        valid[:, k] = ok
        weights[:, k] = step * 0.5 * (own_cost + padded_cost[neighbour])
    n = ny * nx
    offsets = np.array([dy * nx + dx for dy, dx in _NEIGHBOURS])
    counts = np.zeros(n, dtype=np.int64)
    counts[cells] = valid.sum(axis=1)
    indptr = np.concatenate([[0], np.cumsum(counts)])
    targets = cells[:, None] + offsets[None, :]
    return sparse.csr_matrix((weights[valid], targets[valid], indptr), shape=(n, n))


def grid_graph_reference(
    traversable: np.ndarray, cost: np.ndarray, resolution: float, allow_corner_cutting: bool = False
) -> sparse.csr_matrix:
    """:func:`grid_graph` as first written, over every cell of the grid (the reference it must
    equal; ``PathPlanner(..., reference=True)`` builds with it)."""
    ny, nx = traversable.shape
    padded = np.pad(traversable, 1, constant_values=False)
    padded_cost = np.pad(cost, 1, constant_values=np.inf)

    def shifted(array: np.ndarray, dy: int, dx: int) -> np.ndarray:
        return array[1 + dy : 1 + dy + ny, 1 + dx : 1 + dx + nx]

    valid = np.empty((ny, nx, len(_NEIGHBOURS)), dtype=bool)
    weights = np.empty((ny, nx, len(_NEIGHBOURS)))
    for k, (dy, dx) in enumerate(_NEIGHBOURS):
        ok = traversable & shifted(padded, dy, dx)
        diagonal = dy != 0 and dx != 0
        if diagonal and not allow_corner_cutting:
            ok &= shifted(padded, dy, 0) & shifted(padded, 0, dx)
        step = resolution * (np.sqrt(2.0) if diagonal else 1.0)
        valid[..., k] = ok
        weights[..., k] = step * 0.5 * (cost + shifted(padded_cost, dy, dx))

    n = ny * nx
    offsets = np.array([dy * nx + dx for dy, dx in _NEIGHBOURS])
    targets = np.arange(n)[:, None] + offsets[None, :]
    valid = valid.reshape(n, -1)
    indptr = np.concatenate([[0], np.cumsum(valid.sum(axis=1))])
    return sparse.csr_matrix(
        (weights.reshape(n, -1)[valid], targets[valid], indptr), shape=(n, n)
    )


@dataclass
class DistanceField:
    """Single-source shortest paths from ``start_cell`` over the grid graph."""

    grid: GridSpec
    start_cell: np.ndarray | None  # [iy, ix], None if the start was blocked
    distances: np.ndarray  # (ny, nx) path cost, inf where unreachable
    predecessors: np.ndarray  # (ny, nx) flat index of the previous cell, < 0 if none
    _predecessor_list: list[int] | None = field(default=None, repr=False, compare=False)

    @property
    def reachable(self) -> np.ndarray:
        return np.isfinite(self.distances)

    def cost_to(self, cells: np.ndarray) -> np.ndarray:
        """Path cost to each ``[..., (iy, ix)]`` cell (inf if unreachable or out of bounds)."""
        cells = np.asarray(cells, dtype=np.int64)
        inside = self.grid.in_bounds(cells)
        safe = np.where(inside[..., None], cells, 0)
        return np.where(inside, self.distances[safe[..., 0], safe[..., 1]], np.inf)

    def path_cells(self, cell: np.ndarray) -> np.ndarray | None:
        """Cells ``(K, 2)`` from the start to ``cell``, or None if unreachable."""
        cell = np.asarray(cell, dtype=np.int64).reshape(2)
        if not np.isfinite(self.cost_to(cell)):
            return None
        start = int(np.ravel_multi_index(tuple(self.start_cell), self.grid.shape))
        if self._predecessor_list is None:  # Python ints: a chain walk is ~10x faster than on the array
            self._predecessor_list = self.predecessors.reshape(-1).tolist()
        flat_pred = self._predecessor_list
        node = int(np.ravel_multi_index(tuple(cell), self.grid.shape))
        chain = [node]
        while node != start:
            node = flat_pred[node]
            chain.append(node)
        return np.stack(np.unravel_index(np.array(chain[::-1]), self.grid.shape), axis=-1)

    def path_to(self, cell: np.ndarray) -> np.ndarray | None:
        """World xy waypoints ``(K, 2)`` (cell centres) from the start to ``cell``, or None."""
        cells = self.path_cells(cell)
        return None if cells is None else self.grid.cell_to_world(cells)

    def paths_to(self, cells: np.ndarray) -> list[np.ndarray | None]:
        """:meth:`path_to` of each ``(M, 2)`` cell, the same arrays: the predecessor chains
        of all of them walked in step (one array lookup per step for every path still
        walking, instead of a Python walk per path: ~1.8x cheaper for a decision's
        frontiers on the garage, and no list copy of the whole grid's predecessors)."""
        cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        paths: list[np.ndarray | None] = [None] * len(cells)
        rows = np.flatnonzero(np.isfinite(self.cost_to(cells)))
        if not len(rows):
            return paths
        chains = self._walk_to_start(np.ravel_multi_index(tuple(cells[rows].T), self.grid.shape))
        lengths = (chains != chains[-1]).sum(axis=0) + 1  # every chain ends on the start
        xy = self.grid.cell_to_world(np.stack(np.unravel_index(chains, self.grid.shape), axis=-1))
        for k, row in enumerate(rows):
            paths[row] = np.ascontiguousarray(xy[lengths[k] - 1:: -1, k])
        return paths

    def _walk_to_start(self, nodes: np.ndarray) -> np.ndarray:
        """``(L, M)`` flat cells: row ``s`` holds each node's ``s``-th predecessor, or the
        start once its chain has reached it (the last row is the start throughout).
        Raises if a chain breaks off (a node without a predecessor that is not the start)."""
        start = int(np.ravel_multi_index(tuple(self.start_cell), self.grid.shape))
        flat_pred = self.predecessors.reshape(-1)
        steps = [nodes]
        walking = np.flatnonzero(nodes != start)
        for _ in range(flat_pred.size):  # a chain visits every cell at most once
            if not len(walking):
                return np.stack(steps)
            nodes = nodes.copy()
            nodes[walking] = flat_pred[nodes[walking]]
            if (nodes[walking] < 0).any():
                raise RuntimeError("a reachable cell's predecessor chain does not reach the start")
            steps.append(nodes)
            walking = walking[nodes[walking] != start]
        raise RuntimeError("predecessor chains longer than the grid: the predecessors hold a cycle")

    def path_to_xy(self, xy: np.ndarray) -> np.ndarray | None:
        """:meth:`path_to` the cell holding world point ``xy``."""
        return self.path_to(self.grid.world_to_cell(np.asarray(xy, dtype=float)))


class PathPlanner:
    """Dijkstra on one traversability map; build once per map, query from many starts.
    The graph covers the window of the grid that holds every traversable cell
    (``reference``: the whole grid, the first code; the same distances and paths)."""

    def __init__(
        self,
        grid: GridSpec,
        traversable: np.ndarray,
        cost: np.ndarray,
        config: PathConfig | None = None,
        reference: bool = False,
    ) -> None:
        self.grid = grid
        self.config = config or PathConfig()
        self.traversable = np.asarray(traversable, dtype=bool)
        if self.traversable.shape != grid.shape or np.shape(cost) != grid.shape:
            raise ValueError(f"traversable/cost shapes must equal the grid shape {grid.shape}")
        self.cost = np.asarray(cost, dtype=float)
        self.low, self.high = (np.zeros(2, dtype=int), np.array(grid.shape)) if reference else \
            traversable_window(self.traversable)
        window = tuple(slice(lo, hi) for lo, hi in zip(self.low, self.high))
        self.graph = (grid_graph_reference if reference else grid_graph)(
            self.traversable[window], self.cost[window], grid.resolution, self.config.allow_corner_cutting
        )

    def start_cell(self, start_xy: np.ndarray) -> np.ndarray | None:
        """The start's cell, or the nearest traversable cell within ``start_snap_radius``."""
        start_xy = np.asarray(start_xy, dtype=float)[:2]
        cell = self.grid.world_to_cell(start_xy)
        if self.grid.in_bounds(cell) and self.traversable[cell[0], cell[1]]:
            return cell
        radius = self.config.start_snap_radius
        pad = int(np.ceil(radius / self.grid.resolution)) + 1
        lo = np.maximum(cell - pad, 0)
        hi = np.minimum(cell + pad + 1, self.grid.shape)
        if np.any(hi <= lo):
            return None
        candidates = np.argwhere(self.traversable[lo[0] : hi[0], lo[1] : hi[1]]) + lo
        if len(candidates) == 0:
            return None
        gaps = np.linalg.norm(self.grid.cell_to_world(candidates) - start_xy, axis=1)
        best = int(np.argmin(gaps))
        return candidates[best] if gaps[best] <= radius else None

    def from_start(self, start_xy: np.ndarray) -> DistanceField:
        """Shortest paths from the robot at ``start_xy`` to every cell (one Dijkstra over
        the window, read back into the whole grid)."""
        cell = self.start_cell(start_xy)
        distances = np.full(self.grid.shape, np.inf)
        predecessors = np.full(self.grid.shape, -9999, dtype=np.int32)  # scipy's "no predecessor"
        if cell is None:
            return DistanceField(self.grid, None, distances, predecessors)
        shape = tuple(self.high - self.low)
        source = int(np.ravel_multi_index(tuple(cell - self.low), shape))
        window_distances, window_predecessors = csgraph.dijkstra(
            self.graph, directed=True, indices=source, return_predecessors=True
        )
        window = tuple(slice(lo, hi) for lo, hi in zip(self.low, self.high))
        distances[window] = window_distances.reshape(shape)
        found = window_predecessors >= 0
        rows, cols = np.divmod(window_predecessors[found], shape[1])
        window_predecessors[found] = np.ravel_multi_index((rows + self.low[0], cols + self.low[1]), self.grid.shape)
        predecessors[window] = window_predecessors.reshape(shape)
        return DistanceField(self.grid, cell, distances, predecessors)


def traversable_window(traversable: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` cell bounds of the smallest window holding every traversable cell (of
    any mask: every true cell), a 1x1 window at the origin when there is none (a graph of
    one isolated cell)."""
    rows, cols = np.flatnonzero(traversable.any(axis=1)), np.flatnonzero(traversable.any(axis=0))
    if not len(rows):
        return np.zeros(2, dtype=int), np.ones(2, dtype=int)
    return np.array([rows[0], cols[0]]), np.array([rows[-1] + 1, cols[-1] + 1])


def path_length(path: np.ndarray | None) -> float:
    """Euclidean length of a polyline ``(K, 2)`` in metres (inf for None)."""
    if path is None:
        return float("inf")
    path = np.asarray(path, dtype=float)
    if len(path) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def simplify_path(path: np.ndarray, tolerance: float = 1e-9) -> np.ndarray:
    """Drop interior waypoints that lie on a straight segment between their neighbours."""
    path = np.asarray(path, dtype=float)
    if len(path) < 3:
        return path
    before = path[1:-1] - path[:-2]
    after = path[2:] - path[1:-1]
    cross = before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]
    same_way = (before * after).sum(axis=1) > 0
    scale = np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1)
    straight = (np.abs(cross) <= tolerance * np.maximum(scale, tolerance)) & same_way
    keep = np.concatenate([[True], ~straight, [True]])
    return path[keep]
