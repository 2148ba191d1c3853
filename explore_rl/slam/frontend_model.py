"""The ``model`` SLAM front end: scan-matching and loop-closure factors sampled from noise
models fitted to the ``icp`` front end, with no point-cloud registration.

Same pose graph, same factor kinds and the same sequence structure as ``slam.frontend=icp``
(DESIGN.md, "Two front-end fidelities, one back end"); only how a measurement is made
differs. The LiDAR still runs: the 2D/3D maps and the map-error sample are built from the
same scans in both modes.

**Sequential scan matching** (:class:`ModelFrontend`, per keyframe, ~0.05 ms):

1. what the scan sees: :func:`obstacle_points`, the number of points in the obstacle
   height band (one vectorised comparison over the cloud);
2. degenerate or not: a draw with the fitted rate for that statistic's bin, after a usable
   or after a degenerate keyframe (degenerate keyframes come in runs), plus the icp
   front end's forced submap restart after ``max_span`` degenerate keyframes; a
   degenerate keyframe gets no factor (odometry only), like icp;
3. otherwise the number of weak planar directions (0, 1, 2) from its fitted
   distribution for the bin, and the condition (weak count x straight/turned);
4. the reported standard deviations (yaw, constrained translation), drawn at one random
   level from the condition's quantiles of the sigmas icp reported; the covariance is
   those along the constrained directions, ``weak_sigma`` along weak ones and
   ``off_plane_sigma`` off-plane;
5. the measurement of the motion since the last anchored keyframe (``span``, as icp):
   the true motion plus a yaw error (fully constrained matches: the drawn sigma times a
   standardised error from the fitted mixture, so errors scale with the reported sigma as
   in icp; otherwise the fitted raw yaw mixture) and an error along each constrained
   translation axis from the fitted mixture; along weak directions (a translation axis at
   the fitted angle from body x; for weak 2 also the yaw) the wheel-odometry prior is
   kept, so the error there is the odometry error, as in icp.

**Loop closures** (:class:`ModelLoopCloser`): the icp loop closer's candidate rules
(current estimates within ``search_radius``, travel and index gaps, one candidate per
run of indices, line of sight on the 2D map), then instead of gating on the joint
marginal and registering: a pair close (in keyframes) to an earlier accepted closure is
"not worth" a registration (its relative pose is already known to the icp gate's
``min_sigma_*``), else it is accepted with the fitted per-attempt rate at its estimated
distance; the measurement is the true relative pose plus a normal error with the fitted
RMS of accepted closures, with the icp loop factor's covariance floors. Segment matching:
once per revisit (a run of segmentation steps with a candidate within
``segment_search_radius``) with the fitted per-revisit rate.

**What was fitted, where, how well.** ``conf/calibration/scan_matching.yaml`` comes from
``scripts/calibrate_scan_matching.py``: the icp front end (kiss-icp + point-to-plane
refinement, floor dropped, voxel 0.1 m) with loop closures off on 8 office-tour seeds and
40-decision nearest-frontier explorations of the office, street and garage (2 seeds
each): 4,403 matches. Degenerate keyframes: 4.7 % (after a usable keyframe 1-5 % for scans
with >=100 obstacle-band points, 80 % below). Usable matches: yaw error std 0.12 deg --
per condition a 0.025-0.046 deg core with a 22-26 % tail of 0.09-0.39 deg (0 or 1 weak
direction), 0.42-0.47 deg with 2 weak directions; translation along constrained axes
1-2.4 mm core. How honest icp's own covariance is: Mahalanobis d^2 per dof 1.46, 4.2 %
beyond the chi-square 99 % quantile (the tail; the SSM factors are Cauchy-robust), median
p-value 0.66. ``tests/slam/test_frontend_model.py`` checks that the model's samples
reproduce these (std and quantiles of the yaw error within 20 %, degenerate and weak
rates within binomial noise). ``conf/calibration/loop_closures.yaml``
(``scripts/calibrate_loop_closures.py``, 8 office tours) gives the acceptance rates and
the error of accepted closures (pose matching: 3.2 cm, 0.19 deg RMS).

On the same office tours (``benchmarks/bench_frontends.py``, 5 seeds, 2 model draws
each; full numbers in benchmarks/RESULTS.md) the model's mean ATE, map error and
loop-closure count fall within the spread of icp's over the seeds, and its SLAM stage
(registration + iSAM2 + loop closures) is 21-22x cheaper (1.2 vs 25-27 ms per keyframe;
20.8x with the other core busy). Of the model's 1.2 ms, ~0.45 ms are iSAM2 updates (the
same in both modes); most of the rest is the cost of calls into gtsam and numpy on caches
the LiDAR stage has just flushed (20-40 us per call versus 1-6 us warm), which is why the
per-keyframe code here uses scalar ``math`` and as few such calls as it can. The LiDAR
stays (measured on an office tour, 183 keyframes): the 3D voxel map and the map-error sample need the 3D
scan anyway; a vectorised 2D ray cast on the true obstacle grid gave nearly the same
explored fraction (65.3 vs 65.2 %) but not the same grid (4 % of known-free and 70 % of
known-occupied cells differ: hits land on other wall cells) and was no cheaper in numpy
(6.7 vs 13 ms under load for the 3D scan and its collapse; mj_multiRay itself is ~4.3 ms
of that, a 900-ray horizontal ring ~0.3 ms but it sees one height only).
"""

from __future__ import annotations

import bisect
import hashlib
import math
import time

import numpy as np

from explore_rl.geometry import (
    matrix_to_se2_tuple,
    se2_between,
    se2_between_tuple,
    se2_compose,
    se2_compose_tuple,
    se2_to_matrix,
)
from explore_rl.slam.calibration import (
    LoopClosureCalibration,
    ScanMatchingCalibration,
    cached_loop_closures,
    cached_scan_matching,
    draw_index,
)
from explore_rl.slam.config import LoopClosureConfig, SlamConfig, loop_closures_path, scan_matching_path
from explore_rl.slam.frontend import ScanMatch
from explore_rl.slam.loop_closure import closest_separated

POSE_MATCHING = "pose_matching"
SEGMENT_MATCHING = "segment_matching"


def obstacle_points(points_sensor: np.ndarray, mount_height: float, min_height: float = 0.15,
                    max_height: float = 0.6, stride: int = 1) -> int:
    """Number of scan points between ``min_height`` and ``max_height`` above the floor
    (sensor-frame z + ``mount_height``): the statistic the degenerate rate is fitted on.
    ``stride > 1`` estimates it from every ``stride``-th point (the scan's points come
    ring by ring, so a stride samples every ring evenly)."""
    z = np.asarray(points_sensor)[::stride, 2] if len(points_sensor) else np.zeros(0)
    return stride * int(np.count_nonzero((z >= min_height - mount_height) & (z <= max_height - mount_height)))


def seed_from_points(points: np.ndarray) -> int:
    """A reproducible seed from a scan (itself seeded by the run's seed)."""
    return int.from_bytes(hashlib.blake2b(np.ascontiguousarray(points).tobytes(), digest_size=8).digest(),
                          "little")


def covariance_6x6(yaw_var: float, xx: float, xy: float, yy: float, off_plane_var: float) -> np.ndarray:
    """6x6 Pose3 covariance (rx, ry, rz, tx, ty, tz) of a planar measurement: yaw variance
    ``yaw_var``, translation covariance ``[[xx, xy], [xy, yy]]``, ``off_plane_var`` on
    roll, pitch and z."""
    o = off_plane_var
    return np.array([[o, 0.0, 0.0, 0.0, 0.0, 0.0],
                     [0.0, o, 0.0, 0.0, 0.0, 0.0],
                     [0.0, 0.0, yaw_var, 0.0, 0.0, 0.0],
                     [0.0, 0.0, 0.0, xx, xy, 0.0],
                     [0.0, 0.0, 0.0, xy, yy, 0.0],
                     [0.0, 0.0, 0.0, 0.0, 0.0, o]])



class ModelFrontend:
    """Sequential scan matches sampled from the fitted icp error model (module docstring).

    ``register(points_sensor, wheel_delta, true_delta) -> ScanMatch`` like the icp front
    end; deltas are planar 4x4 transforms. ``rng``: the generator of the draws; by default
    it is seeded from the first scan (reproducible for a given run seed).
    """

    # The statistic from every 4th point: 4x cheaper, within a few % of the full count
    # (the fitted bins are 1.5-4x wide).
    stride = 4

    def __init__(self, config: SlamConfig, calibration: ScanMatchingCalibration | None = None,
                 rng: np.random.Generator | None = None, mount_height: float | None = None):
        self.config = config
        if calibration is None:
            calibration = cached_scan_matching(str(scan_matching_path(config.scan_matcher.calibration_file)))
        self.calibration = calibration
        self.rng = rng
        cal = self.calibration
        self.mount_height = cal.mount_height if mount_height is None else mount_height
        self._band = (cal.statistic_min_height, cal.statistic_max_height)
        self._turn = np.deg2rad(cal.turn_threshold_deg)
        self._degenerate_covariance = np.eye(6) * config.scan_matcher.degenerate_sigma**2
        self._edges = list(cal.bin_edges)
        # Cumulative planar true and wheel-odometry poses (x, y, yaw) of the keyframes.
        self._true: list[tuple[float, float, float]] = []
        self._wheel: list[tuple[float, float, float]] = []
        self._since_anchor = 0
        self._previous_degenerate = False

    def register(self, points_sensor: np.ndarray, wheel_delta: np.ndarray,
                 true_delta: np.ndarray) -> ScanMatch:
        start = time.perf_counter()
        cal = self.calibration
        points = np.asarray(points_sensor, dtype=float).reshape(-1, 3)
        if self.rng is None:
            self.rng = np.random.default_rng(seed_from_points(points))
        statistic = obstacle_points(points, self.mount_height, *self._band, stride=self.stride)
        wheel = matrix_to_se2_tuple(wheel_delta)
        if not self._true:  # the first keyframe starts the submap: no factor (as icp)
            self._true.append((0.0, 0.0, 0.0))
            self._wheel.append((0.0, 0.0, 0.0))
            return self._degenerate(wheel_delta, statistic, start)
        self._true.append(se2_compose_tuple(self._true[-1], matrix_to_se2_tuple(true_delta)))
        self._wheel.append(se2_compose_tuple(self._wheel[-1], wheel))

        forced = self._since_anchor >= cal.max_span
        k = min(max(bisect.bisect_right(self._edges, statistic) - 1, 0), len(cal.degenerate_rate) - 1)
        rate = cal.degenerate_rate_after_degenerate[k] if self._previous_degenerate else cal.degenerate_rate[k]
        if forced or self.rng.random() < rate:
            self._since_anchor = 0 if forced else self._since_anchor + 1
            self._previous_degenerate = True
            return self._degenerate(wheel_delta, statistic, start)

        weak = draw_index(cal.weak_probabilities[k], self.rng)
        match = self._measure(weak, abs(wheel[2]) > self._turn, statistic)
        self._since_anchor, self._previous_degenerate = 0, False
        match.ms = (time.perf_counter() - start) * 1e3
        return match

    def _measure(self, weak: int, turned: bool, statistic: int) -> ScanMatch:
        # Scalar math throughout: this runs per keyframe, where numpy's per-call overhead
        # (on cold caches, after the LiDAR stage) would cost several times the arithmetic.
        cal, rng = self.calibration, self.rng
        condition = cal.condition(weak, turned)
        span = self._since_anchor + 1
        j = len(self._true) - 1
        truth = se2_between_tuple(self._true[j - span], self._true[j])
        wheel_span = se2_between_tuple(self._wheel[j - span], self._wheel[j])
        wheel_error = se2_between_tuple(truth, wheel_span)  # (x, y, yaw)
        sigma_yaw_deg, sigma_t = condition.draw_sigmas(rng)
        sigma_yaw = math.radians(sigma_yaw_deg)
        # The yaw error of a fully constrained match scales with its reported sigma, as in
        # icp (sigma x standardised error keeps the weighting the graph sees). Elsewhere
        # the fitted raw mixtures: with a weak direction the reported yaw sigma mostly
        # measures how much the weak direction leaks into yaw; and sigma x z drawn
        # independently under-states the translation tail (~25 %: large errors come
        # with large sigmas).
        if condition.yaw_z is not None and weak == 0:
            yaw_error = sigma_yaw * condition.yaw_z.sample(rng)
        else:
            yaw_error = math.radians(condition.yaw_deg.sample(rng))
        yaw_var, t_var, weak_var = sigma_yaw**2, sigma_t**2, cal.weak_sigma**2
        if weak == 0:
            error_x, error_y = condition.translation.sample_pair(rng)
            xx, xy, yy = t_var, 0.0, t_var
        else:
            # u: the weak translation direction (keeps the odometry error), v: the
            # constrained one (error from the fitted mixture); weak 2 swaps the roles of
            # the drawn axis and its perpendicular.
            angle = math.radians(condition.weak_angle_deg.sample(rng))
            axis = (math.cos(angle), math.sin(angle) * (1.0 if rng.random() < 0.5 else -1.0))
            normal = (-axis[1], axis[0])
            (ux, uy), (vx, vy) = (axis, normal) if weak == 1 else (normal, axis)
            along_u = wheel_error[0] * ux + wheel_error[1] * uy
            along_v = condition.translation.sample(rng)
            error_x, error_y = along_u * ux + along_v * vx, along_u * uy + along_v * vy
            xx = t_var * vx * vx + weak_var * ux * ux
            xy = t_var * vx * vy + weak_var * ux * uy
            yy = t_var * vy * vy + weak_var * uy * uy
            if weak == 2:  # the yaw is weak too: it keeps the prior
                yaw_error, yaw_var = wheel_error[2], weak_var
        measured = se2_compose_tuple(truth, (error_x, error_y, yaw_error))
        previous = se2_between_tuple(self._wheel[j - span], self._wheel[j - 1])
        return ScanMatch(
            relative=se2_to_matrix(se2_between_tuple(previous, measured)),
            covariance=covariance_6x6(yaw_var, xx, xy, yy, cal.off_plane_sigma**2),
            degenerate=False, weak_directions=weak, n_points=statistic, ms=0.0, n_inliers=0,
            span=span, span_relative=se2_to_matrix(measured))

    def _degenerate(self, wheel_delta: np.ndarray, statistic: int, start: float) -> ScanMatch:
        return ScanMatch(relative=np.array(wheel_delta, dtype=float), covariance=self._degenerate_covariance.copy(),
                         degenerate=True, weak_directions=3, n_points=statistic,
                         ms=(time.perf_counter() - start) * 1e3)


# Scalar SE(2) helpers: the vectorised ones in explore_rl.geometry cost ~40 us per call
# on single poses, more than everything else the model does per keyframe.


def segments_clear(start_xy, ends_xy: np.ndarray, occupancy, step_fraction: float = 0.5) -> np.ndarray:
    """Whether each segment ``start_xy -> ends_xy[k]`` misses every known-occupied cell of
    ``occupancy`` (an :class:`~explore_rl.mapping.occupancy.OccupancyGrid`; samples every
    ``step_fraction`` cells, start excluded; cells outside the grid do not block). The same
    test as ``mapping.visibility.line_of_sight`` for one start point, reading only the
    sampled cells."""
    delta = ends_xy - np.asarray(start_xy)
    length = np.hypot(delta[:, 0], delta[:, 1])
    step = step_fraction * occupancy.grid.resolution
    n = max(int(np.ceil(length.max() / step)), 1) if len(length) else 1
    t = np.minimum(np.arange(1, n + 1)[None, :] * step, length[:, None])  # (K, n)
    unit = delta / np.where(length > 0, length, 1.0)[:, None]
    xy = np.asarray(start_xy) + t[..., None] * unit[:, None, :]
    return ~occupancy.occupied_at(occupancy.grid.world_to_cell(xy)).any(axis=1)


class ModelLoopCloser:
    """Loop closures accepted where the icp candidate rules and the fitted acceptance
    rates say so; measurements drawn from the fitted loop error (module docstring).

    ``config`` is the icp loop closer's :class:`LoopClosureConfig` (candidate rules, factor
    floors, ``enabled``), with the model's own ``model_step_sigma_*``: how fast the relative
    pose of a pair next to an accepted closure becomes uncertain again, per keyframe of index
    distance -- the stand-in for the icp gate's joint marginal.
    """

    def __init__(self, config: LoopClosureConfig, calibration: LoopClosureCalibration | None = None,
                 rng: np.random.Generator | None = None):
        self.config = config
        if calibration is None:
            calibration = cached_loop_closures(str(loop_closures_path(config.calibration_file)))
        self.calibration = calibration
        self.rng = rng
        self.closures: dict[str, int] = {POSE_MATCHING: 0, SEGMENT_MATCHING: 0}
        self.accepted: list[tuple[int, int]] = []
        self._nodes: list[int] = []  # endpoints of accepted closures
        # _distance and _through (see _link) live in the top-left corner of square buffers
        # that double when full: a closure adds up to two endpoints, and reallocating the
        # tables for each was most of its cost.
        self._distance_buffer = np.zeros((0, 0))
        self._through_buffer = np.zeros((0, 0))
        self._through_minus_node = np.zeros(0)  # per endpoint p: min over q of _through[p, q] - q
        self._newest_node = -1
        self._segment_revisit: list[int] = []  # candidates of the previous segmentation step
        self._travel: list[float] = []  # keyframe travel, appended as keyframes arrive

    def process(self, session) -> int:
        cfg = self.config
        if not cfg.enabled or len(session.keyframes) < 2:
            return 0
        if self.rng is None:
            self.rng = np.random.default_rng(seed_from_points(session.keyframes[0].error_points))
        j = len(session.keyframes) - 1
        older, newest = self._estimates(session, j)
        self._travel.extend(k.travel for k in session.keyframes[len(self._travel):])
        added = self._pose_matching(session, older, newest, j)
        if (cfg.segments_enabled and added < cfg.max_closures_per_keyframe
                and SEGMENT_MATCHING in self.calibration.sources):
            added += self._segment_matching(session, older, newest, j)
        return added

    @staticmethod
    def _estimates(session, j: int) -> tuple[np.ndarray, tuple[float, float, float]]:
        """Planar estimates of keyframes 0..j-1 (``(j, 3)``) and of the newest one ``j``.
        The older ones are the poses the maps were last built at (within a map cell of the
        current estimates: the maps are rebuilt when any moves further). Avoids a full
        iSAM2 estimate per keyframe (the maps stage computes it anyway, after the loop
        closures)."""
        mapped = session.map_poses
        if len(mapped) != j:
            poses = session.graph.poses_se2()
            return poses[:j], tuple(poses[j])
        return mapped, matrix_to_se2_tuple(session.graph.pose(j))

    # ------------------------------------------------------------------ candidates

    def candidates(self, session, older: np.ndarray, newest: tuple, j: int, radius: float,
                   keep=None) -> tuple[list[int], list[int]]:
        """The icp loop closer's candidate rules, closest first: ``(picked, visible)``.

        ``older``/``newest``: planar estimates of keyframes 0..j-1 and j. ``picked``: within
        ``radius``, past the travel and index gaps, one per run of ``candidate_separation``
        indices. ``visible``: the first ``max_candidates`` of them that pass ``keep``
        (``keep(indices) -> bool array``, checked before the line-of-sight test, which is
        the costly part) and have line of sight on the 2D map."""
        cfg = self.config
        # Keyframes 0..last-1 may be candidates. Travel never decreases, so the ones at
        # least min_travel_gap of travel back are a prefix too.
        last = min(j - cfg.min_index_gap + 1,
                   bisect.bisect_right(self._travel, self._travel[j] - cfg.min_travel_gap))
        if last <= 0:
            return [], []
        distance = np.hypot(older[:last, 0] - newest[0], older[:last, 1] - newest[1])
        indices = np.flatnonzero(distance <= radius)
        if not len(indices):
            return [], []
        # 3x max_candidates: enough to survive the line-of-sight test
        picked = closest_separated(indices, distance[indices], cfg.candidate_separation,
                                   limit=3 * cfg.max_candidates)
        kept = picked if keep is None else [i for i, ok in zip(picked, keep(np.asarray(picked))) if ok]
        if not cfg.line_of_sight:
            return picked, kept[: cfg.max_candidates]
        visible: list[int] = []
        for start in range(0, len(kept), cfg.max_candidates):  # closest first, until enough
            batch = kept[start: start + cfg.max_candidates]
            clear = segments_clear(newest[:2], older[batch, :2], session.occupancy)
            visible += [i for i, c in zip(batch, clear) if c]
            if len(visible) >= cfg.max_candidates:
                break
        return picked, visible[: cfg.max_candidates]

    def worth(self, indices: np.ndarray, j: int) -> np.ndarray:
        """Per keyframe in ``indices``: false if accepted closures already pin the relative
        pose of (i, j) below the icp gate's ``min_sigma_*`` (icp would not register the
        pair). Stand-in for the joint marginal: the relative sigma is the loop factor floor
        plus ``model_step_sigma_*`` per keyframe along the shortest path from i to j that uses
        accepted closures as free links (:meth:`steps_via_closures`)."""
        cfg = self.config
        limit = min((cfg.min_sigma_translation**2 - cfg.sigma_translation**2) / cfg.model_step_sigma_translation**2,
                    (cfg.min_sigma_rotation_deg**2 - cfg.sigma_rotation_deg**2) / cfg.model_step_sigma_rotation_deg**2)
        return self.steps_via_closures(indices, j) >= limit

    def steps_via_closures(self, indices: np.ndarray, j: int) -> np.ndarray:
        """Per keyframe i in ``indices``: fewest keyframe steps from i to j on a path that
        uses at least one accepted closure (inf if none): ``min |i - p| + D[p, q] + |q - j|``
        over closure endpoints p, q, with ``D`` their all-pairs distances (kept up to date
        in :meth:`_link`; closures are zero-length links)."""
        indices = np.asarray(indices)
        if not self._nodes:
            return np.full(indices.shape, np.inf)
        nodes = np.asarray(self._nodes)
        if j >= self._newest_node:  # the newest keyframe: |q - j| = j - q for every endpoint
            to_j = self._through_minus_node + j  # per p, exact: whole numbers (or inf) in floats
        else:
            to_j = np.min(self._through + np.abs(nodes - j)[None, :], axis=1)  # per p, over q
        return np.min(np.abs(indices[:, None] - nodes[None, :]) + to_j[None, :], axis=1)

    @property
    def _distance(self) -> np.ndarray:
        n = len(self._nodes)
        return self._distance_buffer[:n, :n]

    @property
    def _through(self) -> np.ndarray:
        n = len(self._nodes)
        return self._through_buffer[:n, :n]

    def _link(self, a: int, b: int) -> None:
        """Add closure (a, b) to the endpoint distance tables.

        ``_distance[p, q]``: fewest steps between endpoints p and q (chain and closures);
        ``_through[p, q]``: the same restricted to paths that use at least one closure.
        Both are symmetric and hold whole numbers (or inf), so every sum and minimum below
        is exact whatever its order."""
        for x in (a, b):
            if x not in self._nodes:
                self._add_endpoint(x)
        ia, ib = self._nodes.index(a), self._nodes.index(b)
        D, through = self._distance, self._through  # views: updated in place
        via = np.add.outer(D[:, ia], D[ib])
        np.minimum(via, np.add.outer(D[:, ib], D[ia]), out=via)
        np.minimum(through, via, out=through)
        np.minimum(D, via, out=D)
        # For queries from a keyframe at or past every endpoint (the newest one, every call
        # of the loop closer): min over q of through[p, q] - q, so a query costs O(n), not O(n^2).
        self._through_minus_node = np.min(through - np.asarray(self._nodes, dtype=float)[None, :], axis=1)
        self._newest_node = max(self._nodes)

    def _add_endpoint(self, x: int) -> None:
        """A new closure endpoint ``x``: it reaches the others along the chain to some
        endpoint, then on (row and column ``n`` of both tables)."""
        n = len(self._nodes)
        if n == len(self._distance_buffer):
            size = max(2 * n, 16)
            for name in ("_distance_buffer", "_through_buffer"):
                grown = np.full((size, size), np.inf)
                grown[:n, :n] = getattr(self, name)[:n, :n]
                setattr(self, name, grown)
        chain = np.abs(np.asarray(self._nodes, dtype=float) - x)
        for buffer in (self._distance_buffer, self._through_buffer):
            if n:  # min over endpoints p of |p - x| + table[p, q], read along rows (symmetric)
                buffer[n, :n] = buffer[:n, n] = np.min(buffer[:n, :n] + chain[None, :], axis=1)
            buffer[n, n] = np.inf
        self._distance_buffer[n, n] = 0.0
        self._nodes.append(x)

    # ------------------------------------------------------------------ sources

    def _pose_matching(self, session, older, newest, j) -> int:
        cfg = self.config
        source = self.calibration.sources.get(POSE_MATCHING)
        if source is None:
            return 0
        _, candidates = self.candidates(session, older, newest, j, cfg.search_radius,
                                        keep=lambda indices: self.worth(indices, j))
        added = 0
        for i in candidates[: cfg.max_attempts_per_keyframe]:
            if added >= cfg.max_closures_per_keyframe:
                break
            distance = math.hypot(older[i, 0] - newest[0], older[i, 1] - newest[1])
            if self.rng.random() < source.rate(distance, "attempt"):
                added += self._add(session, i, j, POSE_MATCHING)
        return added

    def _segment_matching(self, session, older, newest, j) -> int:
        cfg = self.config
        if j % cfg.segment_every or j + 1 < cfg.segment_submap_keyframes:
            return 0
        source = self.calibration.sources[SEGMENT_MATCHING]
        previous = np.asarray(self._segment_revisit)

        def starts_revisit(indices: np.ndarray) -> np.ndarray:  # one draw per revisit
            near = (np.abs(indices[:, None] - previous[None, :]) < cfg.segment_submap_keyframes).any(axis=1)
            return ~near & self.worth(indices, j)

        picked, candidates = self.candidates(session, older, newest, j, cfg.segment_search_radius,
                                             keep=starts_revisit)
        self._segment_revisit = picked
        for i in candidates:
            distance = math.hypot(older[i, 0] - newest[0], older[i, 1] - newest[1])
            if self.rng.random() < source.rate(distance, "revisit"):
                return self._add(session, i, j, SEGMENT_MATCHING)
        return 0

    def _add(self, session, i: int, j: int, kind: str) -> int:
        cfg, rng = self.config, self.rng
        source = self.calibration.sources[kind]
        truth = se2_between(session.keyframes[i].true_pose, session.keyframes[j].true_pose)
        error = np.array([*rng.normal(0.0, source.rms_translation / np.sqrt(2.0), 2),
                          rng.normal(0.0, np.deg2rad(source.rms_rotation_deg))])
        t_var = cfg.sigma_translation**2
        covariance = covariance_6x6(math.radians(cfg.sigma_rotation_deg) ** 2, t_var, 0.0, t_var,
                                    cfg.off_plane_sigma**2)
        session.graph.add_loop_closure(i, j, se2_to_matrix(se2_compose(truth, error)), covariance, kind)
        self.closures[kind] += 1
        self.accepted.append((i, j))
        self._link(i, j)
        return 1
