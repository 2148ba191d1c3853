"""``scene=building``: a seeded family of single-floor indoor plans whose seed changes the structure.

Unlike ``office`` (fixed walls, the seed moves objects), every seed draws a new plan, on a
raster of ``module`` cells (every wall lies on a raster line), in one *attempt*:

1. size: each side in ``[size_min, size_max]``;
2. corridors: bands drawn by kind (straight, L, loop, tree with dead-end branches), each
   band one region; touching bands are joined without a wall;
3. rooms: the rest is cut into rectangles; thin slivers join a neighbour; the largest
   rectangle may stay whole as an open hall, the others are cut (BSP) into rooms;
4. doors: a random spanning tree of the region adjacency (biased to doors onto corridors)
   plus, in some plans, extra doors that close loops through rooms;
5. walls: region borders except corridor joins, merged along each raster line, door gaps
   cut out (few long walls = few geoms);
6. starts: the first in a corridor, the others in distinct rooms, clear of walls;
7. clutter: tables, boxes and pillars placed with the office's clearance rules;
8. check on the true free space (``scene/truth.py``): every start and every region is
   reachable for the robot's footprint.

With ``lot_probability`` a plan is instead a parking lot (the garage's kind of space): one
open floor, rows of parked cars with drive lanes between them and aisles around their ends,
some spaces empty, the starts in the lanes; the same reachability check.

An attempt that fails (no room for a corridor kind, an unconnectable region, clutter that
does not fit, a disconnected check) is re-drawn with ``default_rng([seed, attempt])``, so
a seed always gives the same plan; after ``max_attempts`` a clear error names the knobs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from explore_rl.scene.config import BuildingConfig, SceneConfig, validate_building
from explore_rl.scene.layout import Box, Cylinder, Layout, Wall
from explore_rl.scene.procedural import place_random_objects
from explore_rl.scene.truth import free_space, layout_grid

CORRIDOR, ROOM, HALL = "corridor", "room", "hall"
LOT = "lot"  # BuildingPlan.corridor of a parking lot (no corridors: one open region)
Rect = tuple[int, int, int, int]  # y0, y1, x0, x1 in raster cells, half-open


class Redraw(Exception):
    """This attempt cannot give a valid plan; draw the next one."""


@dataclass(frozen=True)
class Door:
    """A gap in the wall between two regions: on the line ``x = line`` (``axis`` 1, the wall
    runs along y) or ``y = line`` (``axis`` 0), from ``low`` to ``high`` along it."""

    regions: tuple[int, int]
    axis: int
    line: float
    low: float
    high: float

    @property
    def width(self) -> float:
        return self.high - self.low

    @property
    def center(self) -> tuple[float, float]:
        mid = (self.low + self.high) / 2
        return (mid, self.line) if self.axis == 0 else (self.line, mid)


@dataclass(frozen=True, eq=False)  # holds an array: compare plans by their layouts
class BuildingPlan:
    """One generated plan: the layout plus the structure it was drawn from (for statistics)."""

    layout: Layout
    labels: np.ndarray  # [iy, ix] region id of every raster cell
    kinds: tuple[str, ...]  # per region: corridor, room or hall
    corridor: str  # the corridor kind
    doors: tuple[Door, ...]
    joins: tuple[tuple[int, int], ...]  # corridor regions that meet without a wall
    attempt: int  # which attempt gave it (0 = the first draw)
    free_fraction: float  # reachable free cells / all cells of the truth grid

    def edges(self) -> list[tuple[int, int]]:
        """Edges of the region graph: doors and corridor joins."""
        return [d.regions for d in self.doors] + list(self.joins)

    def stats(self) -> dict:
        """Structure statistics: size, rooms, halls, corridors, doors, loops (independent cycles
        of the region graph; ``corridor_loops``: of the corridors alone), dead ends (regions
        with one door or join), clutter, starts, free fraction, the attempt that passed."""
        n = len(self.kinds)
        degree = np.bincount(np.array(self.edges(), dtype=int).ravel(), minlength=n)
        sx, sy = self.layout.size
        return {
            "size_x": sx, "size_y": sy, "area": sx * sy, "corridor": self.corridor,
            "rooms": self.kinds.count(ROOM), "halls": self.kinds.count(HALL),
            "corridors": self.kinds.count(CORRIDOR), "doors": len(self.doors),
            "loops": graph_cycles(n, self.edges()), "corridor_loops": graph_cycles(n, list(self.joins)),
            "dead_ends": int(np.sum(degree == 1)),
            "objects": len(self.layout.boxes) + len(self.layout.cylinders),
            "starts": len(self.layout.starts), "free_fraction": self.free_fraction,
            "attempt": self.attempt,
        }


def building_layout(config: SceneConfig, robot_radius: float) -> Layout:
    """The :class:`Layout` of ``scene=building`` for ``config.seed`` (see :func:`generate_building`)."""
    return generate_building(config, robot_radius).layout


def generate_building(config: SceneConfig, robot_radius: float) -> BuildingPlan:
    """Draw the plan of ``config.seed``; re-draw deterministically until it passes the checks."""
    b = config.building
    validate_building(config, robot_radius)
    reasons: list[str] = []
    for attempt in range(b.max_attempts):
        rng = np.random.default_rng([config.seed, attempt])
        try:
            return draw_plan(rng, config, robot_radius, attempt)
        except Redraw as why:
            reasons.append(str(why))
    raise RuntimeError(
        f"scene=building seed={config.seed}: no valid plan in scene.building.max_attempts={b.max_attempts} "
        f"draws (last: {reasons[-1]}); raise max_attempts, scene.building.size_min or lower "
        "room_min_side / clutter_density"
    )


def draw_plan(rng: np.random.Generator, config: SceneConfig, robot_radius: float, attempt: int) -> BuildingPlan:
    """One attempt of the pipeline in the module docstring; raises :class:`Redraw`."""
    b, m = config.building, config.building.module
    low = cells(b.size_min, m)
    sides = np.clip(np.round(rng.uniform(b.size_min, b.size_max, size=2) / m), low, max(low, cells(b.size_max, m, False)))
    size = tuple(float(v) for v in sides * m)
    shape = (int(round(size[1] / m)), int(round(size[0] / m)))
    if b.lot_probability > 0 and rng.uniform() < b.lot_probability:  # no draw at 0: the family unchanged
        return draw_lot(rng, config, robot_radius, attempt, size, shape)
    kind = str(rng.choice(b.corridor_kinds, p=np.asarray(b.corridor_weights) / sum(b.corridor_weights)))
    labels, kinds = corridor_raster(rng, shape, kind, b)
    labels, kinds = fill_rooms(rng, labels, kinds, b)
    joins = sorted({pair for pair in boundary_runs(labels) if kinds[pair[0]] == kinds[pair[1]] == CORRIDOR})
    doors = choose_doors(rng, boundary_runs(labels, door_depth(b)), kinds, joins, b)
    walls = merged_walls(labels, kinds, doors, m, config.wall_thickness)
    base = Layout("building", size, walls=tuple(walls), wall_height=config.wall_height,
                  perimeter_thickness=config.wall_thickness)
    base = replace(base, starts=choose_starts(rng, base, labels, kinds, robot_radius + b.footprint_margin, b))
    layout = add_clutter(rng, base, config)
    free_fraction = check_reachable(layout, labels, config, robot_radius)
    return BuildingPlan(layout, labels, tuple(kinds), kind, tuple(doors), tuple(joins), attempt, free_fraction)


# --- a parking lot instead ------------------------------------------------------------


def draw_lot(rng: np.random.Generator, config: SceneConfig, robot_radius: float, attempt: int,
             size: tuple[float, float], shape: tuple[int, int]) -> BuildingPlan:
    """A parking lot of ``size``: one open region, rows of cars, starts in the lanes."""
    b = config.building
    base = Layout("building", size, wall_height=config.wall_height, perimeter_thickness=config.wall_thickness)
    cars = parked_cars(rng, size, config)
    if not cars:
        raise Redraw("no car fits the lot")
    layout = replace(base, boxes=tuple(cars))
    layout = replace(layout, starts=lot_starts(rng, layout, shape, robot_radius + b.footprint_margin, b))
    labels = np.zeros(shape, dtype=int)
    free_fraction = check_reachable(layout, labels, config, robot_radius)
    return BuildingPlan(layout, labels, (HALL,), LOT, (), (), attempt, free_fraction)


def parked_cars(rng: np.random.Generator, size: tuple[float, float], config: SceneConfig) -> list[Box]:
    """Rows of cars along x (each car's long side along y), a lane before every row and an
    aisle of the narrowest lane's width at both ends of it (so every lane connects), every
    space empty with ``lot_gap_probability``."""
    b = config.building
    across, along, height = config.car_size
    sx, sy = size
    cars: list[Box] = []
    y = rng.uniform(*b.lot_lane_width) + along / 2
    while y + along / 2 + b.lot_lane_width[0] <= sy:  # a lane stays behind the last row too
        pitch, aisle = rng.uniform(*b.lot_car_pitch), b.lot_lane_width[0]
        count = int((sx - 2 * aisle) // pitch)
        xs = aisle + (np.arange(count) + 0.5) * pitch + (sx - 2 * aisle - count * pitch) / 2
        for x in xs:
            if rng.uniform() >= b.lot_gap_probability:
                jitter = rng.uniform(-config.car_jitter, config.car_jitter, size=3)
                cars.append(Box((float(x + jitter[0]), float(y + jitter[1])), (across, along, height),
                                float(jitter[2])))
        y += along + rng.uniform(*b.lot_lane_width)
    return cars


def lot_starts(rng: np.random.Generator, layout: Layout, shape: tuple[int, int], clearance: float,
               b: BuildingConfig) -> tuple[tuple[float, float, float], ...]:
    """``num_starts`` distinct centres of the lot's raster cells (``shape``) at least
    ``clearance`` from every wall and car, random yaw."""
    centers = clear_centers(np.ones(shape, dtype=bool), layout.geometry(), clearance, b.module)
    if not len(centers):
        raise Redraw("no start position clear of the cars")
    chosen = rng.choice(len(centers), size=min(b.num_starts, len(centers)), replace=False)
    return tuple((float(x), float(y), float(rng.uniform(-np.pi, np.pi))) for x, y in centers[chosen])


# --- 2. corridors ------------------------------------------------------------------------


def corridor_raster(rng: np.random.Generator, shape: tuple[int, int], kind: str,
                    b: BuildingConfig) -> tuple[np.ndarray, list[str]]:
    """Raster of corridor bands (region ids 0..k-1, the rest -1) for corridor ``kind``.

    Bands are drawn with the spine along the first axis of a randomly transposed and
    flipped frame, so every kind appears in every orientation.
    """
    transpose = bool(rng.random() < 0.5)
    ny, nx = shape[::-1] if transpose else shape
    m = b.module
    cw = int(rng.integers(cells(b.corridor_min_width, m), cells(b.corridor_max_width, m, up=False) + 1))
    rmin = cells(b.room_min_side, m)
    bands = {"straight": straight_bands, "L": l_bands, "loop": loop_bands, "tree": tree_bands}[kind](
        rng, ny, nx, cw, rmin, b)
    labels = np.full((ny, nx), -1, dtype=int)
    for region, (y0, y1, x0, x1) in enumerate(bands):
        block = labels[y0:y1, x0:x1]
        block[block < 0] = region
    if rng.random() < 0.5:
        labels = labels[::-1]
    if rng.random() < 0.5:
        labels = labels[:, ::-1]
    labels = np.ascontiguousarray(labels.T if transpose else labels)
    return labels, [CORRIDOR] * len(bands)


def between(rng: np.random.Generator, low: int, high: int) -> int:
    """A uniform integer in ``[low, high]``; :class:`Redraw` if the range is empty."""
    if low > high:
        raise Redraw(f"no room for a corridor: {low} > {high} cells")
    return int(rng.integers(low, high + 1))


def spine_ends(rng: np.random.Generator, nx: int, rmin: int, b: BuildingConfig) -> tuple[int, int]:
    """Columns where a spine starts and ends: at the outer walls, or stopped short (an inset)."""
    inset = [between(rng, rmin, 2 * rmin) if rng.random() < b.end_inset_probability else 0 for _ in range(2)]
    if nx - sum(inset) < nx // 2:
        inset = [0, 0]
    return inset[0], nx - inset[1]


def straight_bands(rng: np.random.Generator, ny: int, nx: int, cw: int, rmin: int, b: BuildingConfig) -> list[Rect]:
    """One corridor across the building."""
    y0 = between(rng, rmin, ny - rmin - cw)
    xa, xe = spine_ends(rng, nx, rmin, b)
    return [(y0, y0 + cw, xa, xe)]


def l_bands(rng: np.random.Generator, ny: int, nx: int, cw: int, rmin: int, b: BuildingConfig) -> list[Rect]:
    """A corridor that turns once: along x to a corner, then along y."""
    y0 = between(rng, rmin, ny - cw - 2 * rmin)
    xc = between(rng, rmin, nx - rmin - cw)
    xa = between(rng, rmin, 2 * rmin) if rng.random() < b.end_inset_probability and xc >= 3 * rmin else 0
    top = ny
    if rng.random() < b.end_inset_probability and ny - (y0 + cw) >= 3 * rmin:
        top = ny - between(rng, rmin, min(2 * rmin, ny - y0 - cw - rmin))
    return [(y0, y0 + cw, xa, xc + cw), (y0 + cw, top, xc, xc + cw)]


def loop_bands(rng: np.random.Generator, ny: int, nx: int, cw: int, rmin: int, b: BuildingConfig) -> list[Rect]:
    """A ring corridor with rooms inside and outside it: two long bands, two short ones."""
    x0 = between(rng, rmin, nx - 2 * cw - 2 * rmin)
    x1 = between(rng, x0 + cw + rmin, nx - cw - rmin)
    y0 = between(rng, rmin, ny - 2 * cw - 2 * rmin)
    y1 = between(rng, y0 + cw + rmin, ny - cw - rmin)
    return [(y0, y0 + cw, x0, x1 + cw), (y1, y1 + cw, x0, x1 + cw),
            (y0 + cw, y1, x0, x0 + cw), (y0 + cw, y1, x1, x1 + cw)]


def tree_bands(rng: np.random.Generator, ny: int, nx: int, cw: int, rmin: int, b: BuildingConfig) -> list[Rect]:
    """A spine with 1..max_branches perpendicular branches that end before the outer wall."""
    y0 = between(rng, rmin, ny - rmin - cw)
    if max(y0, ny - y0 - cw) < 2 * rmin:
        y0 = rmin
    xa, xe = spine_ends(rng, nx, rmin, b)
    bands = [(y0, y0 + cw, xa, xe)]
    sides = [s for s, depth in ((-1, y0), (1, ny - y0 - cw)) if depth >= 2 * rmin]
    if not sides:
        raise Redraw("no side of the spine deep enough for a branch")
    columns: list[int] = []
    for _ in range(int(rng.integers(1, b.max_branches + 1))):
        xb = int(rng.integers(xa + rmin, max(xa + rmin, xe - rmin - cw) + 1))
        if xb + cw > xe - rmin or any(abs(xb - c) < cw + rmin for c in columns):
            continue  # no place for this branch; fewer branches
        columns.append(xb)
        side = int(rng.choice(sides))
        depth = y0 if side < 0 else ny - y0 - cw
        length = between(rng, rmin, depth - rmin)
        bands.append((y0 - length, y0, xb, xb + cw) if side < 0 else (y0 + cw, y0 + cw + length, xb, xb + cw))
    if len(bands) == 1:
        raise Redraw("tree corridor without a branch")
    return bands


# --- 3. rooms ----------------------------------------------------------------------------


def fill_rooms(rng: np.random.Generator, labels: np.ndarray, kinds: list[str],
               b: BuildingConfig) -> tuple[np.ndarray, list[str]]:
    """Give every non-corridor cell a room (or hall) region; see the module docstring, step 3."""
    labels, kinds = labels.copy(), list(kinds)
    rmin, rmax = cells(b.room_min_side, b.module), cells(b.room_max_side, b.module, up=False)
    hall_min, hall_max = cells(b.hall_min_side, b.module), cells(b.hall_max_side, b.module, up=False)
    rects = rectangles(labels < 0)
    whole = [r for r in rects if min_side(r) >= rmin]
    slivers = [r for r in rects if r not in whole]
    hall = None
    candidates = [r for r in whole if min_side(r) >= hall_min]
    if candidates and rng.random() < b.hall_probability:
        largest = max(candidates, key=area)
        pieces = bsp(rng, largest, rmin, hall_max)  # no hall side above hall_max_side
        hall = max(pieces, key=area)
        if min_side(hall) >= hall_min:
            whole.remove(largest)
            whole += pieces
        else:
            hall = None
    for rect in whole:
        for y0, y1, x0, x1 in ([rect] if rect == hall else bsp(rng, rect, rmin, rmax)):
            labels[y0:y1, x0:x1] = len(kinds)
            kinds.append(HALL if rect == hall else ROOM)
    merge_slivers(labels, slivers)
    return labels, kinds


def cells(length: float, module: float, up: bool = True) -> int:
    """``length`` in raster cells, rounded up (a minimum) or down (a maximum)."""
    return int(np.ceil(length / module - 1e-9)) if up else int(np.floor(length / module + 1e-9))


def min_side(rect: Rect) -> int:
    return min(rect[1] - rect[0], rect[3] - rect[2])


def area(rect: Rect) -> int:
    return (rect[1] - rect[0]) * (rect[3] - rect[2])


def rectangles(mask: np.ndarray) -> list[Rect]:
    """Cover ``mask`` with disjoint rectangles, greedily: grow right, then down."""
    todo = mask.copy()
    rects = []
    for y0, x0 in zip(*np.nonzero(mask)):
        if not todo[y0, x0]:
            continue
        x1 = x0
        while x1 < todo.shape[1] and todo[y0, x1]:
            x1 += 1
        y1 = y0 + 1
        while y1 < todo.shape[0] and todo[y1, x0:x1].all():
            y1 += 1
        todo[y0:y1, x0:x1] = False
        rects.append((int(y0), int(y1), int(x0), int(x1)))
    return rects


def bsp(rng: np.random.Generator, rect: Rect, rmin: int, rmax: int) -> list[Rect]:
    """Cut ``rect`` across its longer side at a random place until no side exceeds ``rmax``."""
    y0, y1, x0, x1 = rect
    if max(y1 - y0, x1 - x0) <= rmax:
        return [rect]
    if y1 - y0 >= x1 - x0:
        cut = int(rng.integers(y0 + rmin, y1 - rmin + 1))
        return bsp(rng, (y0, cut, x0, x1), rmin, rmax) + bsp(rng, (cut, y1, x0, x1), rmin, rmax)
    cut = int(rng.integers(x0 + rmin, x1 - rmin + 1))
    return bsp(rng, (y0, y1, x0, cut), rmin, rmax) + bsp(rng, (y0, y1, cut, x1), rmin, rmax)


def merge_slivers(labels: np.ndarray, slivers: list[Rect]) -> None:
    """Give each too-thin rectangle to the neighbour region it shares the longest border with."""
    pending = list(slivers)
    while pending:
        progress = False
        for rect in list(pending):
            y0, y1, x0, x1 = rect
            ring = np.concatenate([
                labels[y0:y1, x0 - 1] if x0 > 0 else [], labels[y0:y1, x1] if x1 < labels.shape[1] else [],
                labels[y0 - 1, x0:x1] if y0 > 0 else [], labels[y1, x0:x1] if y1 < labels.shape[0] else [],
            ]).astype(int)
            ring = ring[ring >= 0]
            if len(ring):
                labels[y0:y1, x0:x1] = np.bincount(ring).argmax()
                pending.remove(rect)
                progress = True
        if not progress:
            raise Redraw("a sliver of floor with no neighbouring region")


# --- 4. doors and 5. walls ---------------------------------------------------------------

# A run of one region border along one raster line: (axis, line index, first, last + 1).
Run = tuple[int, int, int, int]


def boundary_runs(labels: np.ndarray, depth: int = 1) -> dict[tuple[int, int], list[Run]]:
    """Every border between two regions, as maximal straight runs, keyed by the region pair.

    Axis 1: the vertical line ``x = line`` between columns ``line - 1`` and ``line``;
    axis 0: the horizontal line ``y = line``. ``first``/``last`` count cells along it.
    Only border cells with ``depth`` cells of the same region on both sides count (a door
    must not open into a nook thinner than the robot).
    """
    runs: dict[tuple[int, int], list[Run]] = {}
    for axis, grid in ((1, labels), (0, labels.T)):
        # grid[along, across]: the cells on either side of line `line` are columns line-1, line
        low, high = np.minimum(grid[:, :-1], grid[:, 1:]), np.maximum(grid[:, :-1], grid[:, 1:])
        for line in range(1, grid.shape[1]):
            if line < depth or line + depth > grid.shape[1]:
                continue
            near, far = grid[:, line - depth : line], grid[:, line : line + depth]
            deep = (near == near[:, -1:]).all(axis=1) & (far == far[:, :1]).all(axis=1)
            pair_low, pair_high = low[:, line - 1], high[:, line - 1]
            k = np.where((pair_low != pair_high) & deep, pair_low * (labels.max() + 1) + pair_high, -1)
            change = np.nonzero(np.diff(np.concatenate([[-2], k, [-2]])))[0]
            for first, last in zip(change[:-1], change[1:]):
                if k[first] >= 0:
                    pair = (int(pair_low[first]), int(pair_high[first]))
                    runs.setdefault(pair, []).append((axis, line, int(first), int(last)))
    return runs


def door_depth(b: BuildingConfig) -> int:
    """Cells of the same region a door needs on each side: the narrowest door's width."""
    return cells(b.door_min_width, b.module)


def choose_doors(rng: np.random.Generator, runs: dict[tuple[int, int], list[Run]], kinds: list[str],
                 joins: list[tuple[int, int]], b: BuildingConfig) -> list[Door]:
    """A random spanning tree of the door candidates (joins are free), then extra doors."""
    m = b.module
    longest = b.door_min_width + 2 * b.door_jamb
    candidates = [pair for pair, rs in runs.items() if pair not in joins
                  and max(r[3] - r[2] for r in rs) * m >= longest - 1e-9]
    weights = rng.random(len(candidates)) + [0.0 if CORRIDOR in (kinds[a], kinds[c]) else b.room_door_penalty
                                             for a, c in candidates]
    # joins first (they are open anyway), then the lightest candidates: a random spanning tree
    pairs = list(joins) + candidates
    weights = np.concatenate([np.full(len(joins), 1e-9), 1.0 + weights])
    tree_graph = minimum_spanning_tree(region_graph(len(kinds), pairs, weights))
    if connected_components(tree_graph, directed=False)[0] > 1:
        raise Redraw("a region with no wall long enough for a door")
    in_tree = {(int(min(a, c)), int(max(a, c))) for a, c in zip(*tree_graph.nonzero())}
    tree = [pair for pair in candidates if pair in in_tree]
    rest = [pair for pair in candidates if pair not in in_tree]
    extra: list[tuple[int, int]] = []
    if rest and b.max_extra_doors > 0 and rng.random() < b.room_loop_probability:
        count = min(len(rest), int(rng.integers(1, b.max_extra_doors + 1)))
        extra = [rest[i] for i in sorted(rng.choice(len(rest), size=count, replace=False))]
    return [place_door(rng, pair, runs[pair], b) for pair in tree + extra]


def place_door(rng: np.random.Generator, pair: tuple[int, int], runs: list[Run], b: BuildingConfig) -> Door:
    """A door of random width at a random place on one of the pair's long-enough runs."""
    m = b.module
    usable = [r for r in runs if (r[3] - r[2]) * m >= b.door_min_width + 2 * b.door_jamb - 1e-9]
    axis, line, first, last = usable[int(rng.integers(len(usable)))]
    room = (last - first) * m - 2 * b.door_jamb
    width = float(rng.uniform(b.door_min_width, min(b.door_max_width, room)))
    center = float(rng.uniform(first * m + b.door_jamb + width / 2, last * m - b.door_jamb - width / 2))
    return Door(pair, axis, line * m, center - width / 2, center + width / 2)


def merged_walls(labels: np.ndarray, kinds: list[str], doors: list[Door], m: float,
                 thickness: float) -> list[Wall]:
    """Walls on every region border but corridor joins, merged per raster line, doors cut out."""
    corridor = np.array([k == CORRIDOR for k in kinds])
    walls = []
    for axis, grid in ((1, labels), (0, labels.T)):
        a, c = grid[:, :-1], grid[:, 1:]
        solid = (a != c) & ~(corridor[a] & corridor[c])
        for line in range(1, grid.shape[1]):
            gaps = [(d.low, d.high) for d in doors if d.axis == axis and abs(d.line - line * m) < 1e-9]
            for low, high in wall_intervals(solid[:, line - 1], m, gaps):
                ends = ((line * m, low), (line * m, high)) if axis == 1 else ((low, line * m), (high, line * m))
                walls.append(Wall(ends[0], ends[1], thickness))
    return walls


def wall_intervals(solid: np.ndarray, m: float, gaps: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Contiguous runs of ``solid`` cells (in metres along the line) minus the door ``gaps``."""
    edges = np.diff(np.concatenate([[0], solid.astype(int), [0]]))
    intervals = list(zip(np.nonzero(edges == 1)[0] * m, np.nonzero(edges == -1)[0] * m))
    for low, high in sorted(gaps):
        cut = []
        for a, c in intervals:
            if high <= a or low >= c:
                cut.append((a, c))
                continue
            cut += [piece for piece in ((a, low), (high, c)) if piece[1] - piece[0] > 1e-6]
        intervals = cut
    return [(float(a), float(c)) for a, c in intervals]


# --- 6. starts, 7. clutter, 8. check -----------------------------------------------------


def choose_starts(rng: np.random.Generator, base: Layout, labels: np.ndarray, kinds: list[str],
                  clearance: float, b: BuildingConfig) -> tuple[tuple[float, float, float], ...]:
    """The first start in a corridor, the others in distinct rooms (then corridors), random yaw.

    Candidates are raster cell centres at least ``clearance`` from every wall.
    """
    m = b.module
    geometry = base.geometry()
    corridors = [r for r, k in enumerate(kinds) if k == CORRIDOR]
    others = [r for r in rng.permutation(len(kinds)) if kinds[r] != CORRIDOR]
    order = [corridors[int(rng.integers(len(corridors)))]] + others + [r for r in rng.permutation(corridors)]
    starts: list[tuple[float, float, float]] = []
    used: set[int] = set()
    for region in order:
        if region in used:
            continue
        centers = clear_centers(labels == region, geometry, clearance, m)
        if not len(centers):
            continue
        x, y = centers[int(rng.integers(len(centers)))]
        starts.append((float(x), float(y), float(rng.uniform(-np.pi, np.pi))))
        used.add(int(region))
        if len(starts) == b.num_starts:
            break
    if not starts:
        raise Redraw("no start position clear of the walls")
    return tuple(starts)


def clear_centers(cells: np.ndarray, geometry, clearance: float, module: float) -> np.ndarray:
    """``(x, y)`` centres of the raster ``cells`` (a ``[iy, ix]`` mask) at least ``clearance``
    from every solid of ``geometry``."""
    centers = (np.argwhere(cells)[:, ::-1] + 0.5) * module
    return centers[geometry.signed_distance(centers) >= clearance]


def random_building_object(rng: np.random.Generator, config: SceneConfig) -> Box | Cylinder:
    """A table (low, long), a box (low to tall) or a pillar (wall height)."""
    b = config.building
    kind = rng.choice(b.object_kinds, p=np.asarray(b.object_weights) / sum(b.object_weights))
    yaw = float(rng.uniform(-np.pi, np.pi))
    if kind == "table":
        size = (float(rng.uniform(*b.table_length)), float(rng.uniform(*b.table_width)), b.table_height)
        return Box((0.0, 0.0), size, yaw)
    if kind == "pillar":
        return Cylinder((0.0, 0.0), float(rng.uniform(*b.pillar_radius)), config.wall_height)
    sx, sy = rng.uniform(config.object_min_size, config.object_max_size, size=2)
    height = float(rng.uniform(config.object_min_height, config.object_max_height))
    return Box((0.0, 0.0), (float(sx), float(sy), height), yaw)


def add_clutter(rng: np.random.Generator, base: Layout, config: SceneConfig) -> Layout:
    """``clutter_density`` objects per 100 m2 (at most ``clutter_max``), office clearance rules."""
    b = config.building
    count = min(b.clutter_max, int(round(b.clutter_density * base.size[0] * base.size[1] / 100.0)))
    placing = replace(config, seed=int(rng.integers(2**31)), num_objects=count)
    try:
        return place_random_objects(base, placing, random_building_object, max_attempts=50 * count + 100)
    except RuntimeError as error:
        raise Redraw(str(error)) from None


def check_reachable(layout: Layout, labels: np.ndarray, config: SceneConfig, robot_radius: float) -> float:
    """Every start and every region reachable from the first start for the footprint; the
    reachable free fraction. :class:`Redraw` otherwise."""
    grid = layout_grid(layout, config.grid_resolution)
    truth = free_space(layout, grid, robot_radius, layout.starts[0][:2])
    drivable = np.pad(truth.drivable, 1)
    for x, y, _ in layout.starts:
        iy, ix = grid.world_to_cell(np.array([x, y]))
        if not drivable[iy : iy + 3, ix : ix + 3].any():  # the start's cell or a neighbour
            raise Redraw(f"start ({x:.1f}, {y:.1f}) cannot be reached from the first")
    centers = grid.cell_centers()
    m = config.building.module
    cell_region = labels[np.minimum((centers[..., 1] / m).astype(int), labels.shape[0] - 1),
                         np.minimum((centers[..., 0] / m).astype(int), labels.shape[1] - 1)]
    reached = np.bincount(cell_region[truth.drivable], minlength=labels.max() + 1) > 0
    if not reached.all():
        raise Redraw(f"region {int(np.argmin(reached))} cannot be reached")
    return float(truth.reachable.mean())


def region_graph(nodes: int, edges: list[tuple[int, int]], weights: np.ndarray | None = None) -> csr_matrix:
    """Sparse (upper-triangular) adjacency of a graph with ``nodes`` nodes."""
    edges_array = np.array(edges, dtype=int).reshape(-1, 2)
    data = np.ones(len(edges_array)) if weights is None else np.asarray(weights, dtype=float)
    low, high = edges_array.min(axis=1), edges_array.max(axis=1)
    return csr_matrix((data, (low, high)), shape=(nodes, nodes))


def graph_cycles(nodes: int, edges: list[tuple[int, int]]) -> int:
    """Independent cycles of a graph (no repeated edges): E - V + (connected components)."""
    components = connected_components(region_graph(nodes, edges), directed=False)[0]
    return len(edges) - nodes + int(components)
