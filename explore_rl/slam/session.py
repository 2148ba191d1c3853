"""A SLAM session: what the robot believes about its trajectory and map, and how wrong it is.

Feed it the robot's motion steps; every ``keyframe_distance`` metres or
``keyframe_angle_deg`` of odometry it takes a keyframe: a LiDAR scan at the *true* pose,
a sequential scan-matching factor from the front end (seeded with the wheel-odometry
delta), an odometry factor, one iSAM2 update, then the 2D occupancy grid and the 3D
voxel map at the *estimated* poses. When loop closures move estimates by more than a
cell the maps follow: with ``mapping.updates=incremental`` only the keyframes that moved
that far are traced again in 2D (the kept beam cells of all keyframes are then replayed:
the grid clamps after each scan, so a scan cannot be subtracted), and the 3D clouds of
those more than ``mapping.voxels.reproject_shift`` off are taken out of the voxel counts
and put back; with ``rebuild`` (the reference) every keyframe is re-projected whenever
any moved. Both give the maps :func:`reference_maps` builds from scratch at the poses
each map was built at. Metrics follow DESIGN.md: map error, ATE, 3D
volume, explored %, degenerate scans.

Poses in the graph are the robot base at z = 0; the sensor sits ``mount_height`` above it.
A pure-z mount offset commutes with planar motion, so sensor-frame and base-frame deltas
are the same transform.
"""

from __future__ import annotations

import logging
import time
from collections import defaultdict
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterator, Protocol

import numpy as np
from kiss_icp.voxelization import voxel_down_sample

from explore_rl.geometry import se2_between, se2_compose, se2_matrices, se2_to_matrix, transform_points
from explore_rl.mapping.config import MappingConfig
from explore_rl.mapping.occupancy import (
    OccupancyGrid,
    RayGridCollapse,
    Scan2D,
    collapse_scan,
    explored_fraction,
    moved_poses,
)
from explore_rl.mapping.voxels import VoxelCounts, VoxelMap
from explore_rl.robot import MotionStep
from explore_rl.scene.build import Scene
from explore_rl.sensors.lidar import Lidar
from explore_rl.slam.config import SlamConfig
from explore_rl.slam.frontend import ScanMatch, ScanMatcher
from explore_rl.slam.pose_graph import PoseGraph

if TYPE_CHECKING:
    from explore_rl.slam.calibration import LoopClosureCalibration

log = logging.getLogger(__name__)


@dataclass
class Keyframe:
    """What the session keeps of one keyframe."""

    index: int
    true_pose: np.ndarray
    odom_pose: np.ndarray
    travel: float
    cloud: np.ndarray  # down-sampled scan, sensor frame
    scan2d: Scan2D
    error_points: np.ndarray  # the fixed sample of scan points for the map error
    match: ScanMatch | None


@dataclass
class SlamMetrics:
    keyframes: int
    map_error_m: float
    ate_m: float
    volume_m3: float
    explored: float
    degenerate_registrations: int
    loop_closures: int


class StageTimer:
    """Accumulated wall time per named stage."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)

    @contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        start = time.perf_counter()
        yield
        self.seconds[stage] += time.perf_counter() - start


class SequentialFrontend(Protocol):
    """Produces the sequential scan-matching measurement of each new keyframe."""

    def register(self, points_sensor: np.ndarray, wheel_delta: np.ndarray,
                 true_delta: np.ndarray) -> ScanMatch: ...


class LoopCloser(Protocol):
    """Looks for loop closures for the newest keyframe; adds accepted ones to the graph."""

    def process(self, session: "SlamSession") -> int: ...


class IcpFrontend:
    """kiss-icp scan matching on the simulated cloud (the true motion is not used)."""

    def __init__(self, config: SlamConfig):
        self.matcher = ScanMatcher(config.scan_matcher)

    def register(self, points_sensor: np.ndarray, wheel_delta: np.ndarray,
                 true_delta: np.ndarray) -> ScanMatch:
        return self.matcher.register(points_sensor, wheel_delta)


class NoLoopClosures:
    """Sequential factors only (``slam.loop_closure.enabled=false``)."""

    def process(self, session: "SlamSession") -> int:
        return 0


def make_frontend(config: SlamConfig) -> SequentialFrontend:
    """The sequential front end named by ``config.frontend``."""
    if config.frontend == "icp":
        return IcpFrontend(config)
    if config.frontend == "model":
        from explore_rl.slam.frontend_model import ModelFrontend

        return ModelFrontend(config)
    raise ValueError(f"unknown slam.frontend={config.frontend!r}; choose icp or model")


def make_loop_closer(config: SlamConfig) -> LoopCloser:
    """The loop-closure front end matching ``config.frontend``: pose and segment matching
    for ``icp`` when ``config.loop_closure.enabled``, else none."""
    if config.frontend == "icp" and config.loop_closure.enabled:
        from explore_rl.slam.loop_closure import IcpLoopCloser

        return IcpLoopCloser(config.loop_closure, config.scan_matcher)
    if config.frontend == "model" and config.loop_closure.enabled:
        from explore_rl.slam.frontend_model import ModelLoopCloser

        closer = ModelLoopCloser(config.loop_closure)
        warn_if_fitted_at_another_spacing(closer.calibration, config)
        return closer
    return NoLoopClosures()


_SPACING_WARNED: set = set()


def warn_if_fitted_at_another_spacing(calibration: LoopClosureCalibration, config: SlamConfig) -> None:
    """Log once per file and spacing when the model's loop-closure fit was made with other
    keyframes: its rates are per attempt, one per keyframe, so they do not carry over."""
    fitted, spacing = calibration.keyframe_spacing, (config.keyframe_distance, config.keyframe_angle_deg)
    key = (calibration.path, spacing)
    if fitted is None or np.allclose(fitted, spacing) or key in _SPACING_WARNED:
        return
    _SPACING_WARNED.add(key)
    log.warning("slam=model at %g m / %g deg keyframes, but %s was fitted at %g m / %g deg: loop closures will not "
                "match icp's (refit: scripts/calibrate_loop_closures.py --set slam.keyframe_angle_deg=...; "
                "at 45 deg use slam=model_45deg)", *spacing, calibration.path, *fitted)


class ErrorSamples:
    """Every keyframe's map-error sample points, padded to one ``(K, P, 3)`` array (``P``: the
    largest sample) with their counts: what :func:`map_error` reads. The samples never
    change, so a session keeps one and extends it with the keyframes that came since."""

    def __init__(self) -> None:
        self.padded = np.zeros((0, 0, 3))
        self.counts = np.zeros(0, dtype=np.int64)

    def extend(self, points: list[np.ndarray]) -> "ErrorSamples":
        """Add the samples of ``points`` (every keyframe's, in order) beyond those held."""
        held, new = len(self.counts), points[len(self.counts):]
        if new:
            width = max(self.padded.shape[1], *(len(p) for p in new))
            grown = np.zeros((len(points), width, 3))
            grown[:held, :self.padded.shape[1]] = self.padded
            for row, sample in enumerate(new, held):
                grown[row, :len(sample)] = sample
            self.padded = grown
            self.counts = np.concatenate([self.counts, [len(p) for p in new]]).astype(np.int64)
        return self


def map_error(world_from_sensor_est: np.ndarray, world_from_sensor_true: np.ndarray,
              points: list[np.ndarray] | ErrorSamples) -> float:
    """Mean over keyframes of the mean ``|T_est p - T_true p|`` over their sample points
    (DESIGN.md), every keyframe at once: ``(T_est - T_true) p`` on the padded samples
    (:class:`ErrorSamples`), the padding masked out of the means. :func:`map_error_reference`
    up to round-off (~1e-16 relative); the runner and the environment read the metrics
    after every decision, and the reference's cost grows with the keyframes (~11 ms at 320)."""
    samples = points if isinstance(points, ErrorSamples) else ErrorSamples().extend(list(points))
    counts, padded = samples.counts, samples.padded
    kept = counts > 0
    if not kept.any():
        return 0.0
    difference = np.asarray(world_from_sensor_est, dtype=float) - np.asarray(world_from_sensor_true, dtype=float)
    squared = sum((difference[:, row, 0, None] * padded[..., 0] + difference[:, row, 1, None] * padded[..., 1]
                   + difference[:, row, 2, None] * padded[..., 2] + difference[:, row, 3, None]) ** 2
                  for row in range(3))
    valid = np.arange(padded.shape[1]) < counts[:, None]
    per_keyframe = np.where(valid, np.sqrt(squared), 0.0).sum(axis=1)[kept] / counts[kept]
    return float(per_keyframe.mean())


def map_error_reference(world_from_sensor_est: np.ndarray, world_from_sensor_true: np.ndarray,
                        points: list[np.ndarray]) -> float:
    """:func:`map_error` keyframe by keyframe, each transform applied on its own (the first
    code: the equivalence test's and ``benchmarks/bench_explore.py``'s baseline)."""
    per_keyframe = [
        np.linalg.norm(transform_points(t_est, p) - transform_points(t_true, p), axis=1).mean()
        for t_est, t_true, p in zip(world_from_sensor_est, world_from_sensor_true, points)
        if len(p)
    ]
    return float(np.mean(per_keyframe)) if per_keyframe else 0.0


def reference_maps(session: "SlamSession") -> tuple[OccupancyGrid, VoxelMap]:
    """Both maps built from scratch by the reference code (:meth:`OccupancyGrid.rebuild`,
    :meth:`VoxelMap.rebuild`) at the session's map poses (:attr:`SlamSession.map_poses`,
    :attr:`SlamSession.voxel_poses`): what either update mode must equal (tests,
    ``benchmarks/bench_drive.py``)."""
    occupancy = OccupancyGrid(session.scene.grid, session.mapping.occupancy, compiled=False)
    occupancy.rebuild([k.scan2d for k in session.keyframes], session.map_poses)
    voxels = VoxelMap(session.mapping.voxels)
    voxels.rebuild([k.cloud for k in session.keyframes], list(session.world_from_sensor(session.voxel_poses)))
    return occupancy, voxels


def absolute_trajectory_error(estimated: np.ndarray, true: np.ndarray) -> float:
    """RMSE of keyframe positions (no alignment: the graph's prior is the true start)."""
    return float(np.sqrt(np.mean(np.sum((estimated[:, :2] - true[:, :2]) ** 2, axis=1))))


class SlamSession:
    """Keyframes, pose graph, maps and metrics of one run (see the module docstring)."""

    def __init__(self, config: SlamConfig, mapping: MappingConfig, scene: Scene, lidar: Lidar,
                 start_pose: np.ndarray, rng: np.random.Generator):
        self.config = config
        self.mapping = mapping
        self.scene = scene
        self.lidar = lidar
        self.rng = rng
        self.graph = PoseGraph(config.pose_graph, start_pose)
        self.frontend = make_frontend(config)
        self.loop_closer = make_loop_closer(config)
        self.incremental = mapping.updates == "incremental"
        # the reference updates keep the numpy tracing (the same cells, see mapping.compiled)
        self.occupancy = OccupancyGrid(scene.grid, mapping.occupancy, compiled=self.incremental)
        self._collapse = self._ray_grid_collapse() if self.incremental else None
        self.voxels: VoxelCounts | VoxelMap = (VoxelCounts if self.incremental else VoxelMap)(mapping.voxels)
        self._cells: list[tuple[np.ndarray, np.ndarray]] = []  # per keyframe, at its map pose (incremental)
        self.keyframes: list[Keyframe] = []
        self._error_samples = ErrorSamples()  # the keyframes' map-error samples, padded (metrics)
        self.timer = StageTimer()
        self._map_poses = np.zeros((0, 3))
        self._voxel_poses = np.zeros((0, 3))  # incremental: the 3D map's own (see correct_maps)
        self._steps_since_keyframe = 0
        self._take_keyframe(np.asarray(start_pose, float), np.asarray(start_pose, float), 0.0)

    # ------------------------------------------------------------------ driving

    def observe(self, step: MotionStep) -> bool:
        """Account for one motion step; take a keyframe when odometry says so."""
        self._steps_since_keyframe += 1
        delta = se2_between(self.keyframes[-1].odom_pose, step.odom_pose)
        far = np.hypot(delta[0], delta[1]) >= self.config.keyframe_distance
        turned = abs(delta[2]) >= np.deg2rad(self.config.keyframe_angle_deg)
        if far or turned:
            self._take_keyframe(step.true_pose, step.odom_pose, step.travelled)
            return True
        return False

    def belief(self, odom_pose: np.ndarray) -> np.ndarray:
        """Best current pose estimate: the last keyframe's estimate plus odometry since."""
        last = self.keyframes[-1]
        return se2_compose(self.graph.poses_se2()[-1], se2_between(last.odom_pose, odom_pose))

    def _take_keyframe(self, true_pose: np.ndarray, odom_pose: np.ndarray, travel: float) -> None:
        with self.timer("lidar"):
            scan = self.lidar.scan(true_pose)
            cloud = voxel_down_sample(scan.points, self.config.keyframe_cloud_voxel)
            scan2d = self.collapse(scan)
        first = not self.keyframes
        wheel_delta = np.eye(4) if first else se2_to_matrix(
            se2_between(self.keyframes[-1].odom_pose, odom_pose))
        true_delta = np.eye(4) if first else se2_to_matrix(
            se2_between(self.keyframes[-1].true_pose, true_pose))
        with self.timer("registration"):
            match = self.frontend.register(scan.points, wheel_delta, true_delta)
        if not first:
            with self.timer("isam2"):
                self.graph.add_keyframe(wheel_delta, max(self._steps_since_keyframe, 1), match)
        sample = self.rng.choice(len(scan.points), min(len(scan.points), self.config.map_error_points),
                                 replace=False) if len(scan.points) else np.zeros(0, dtype=int)
        self.keyframes.append(Keyframe(len(self.keyframes), np.asarray(true_pose, float).copy(),
                                       np.asarray(odom_pose, float).copy(), travel, cloud, scan2d,
                                       scan.points[sample], None if first else match))
        self._steps_since_keyframe = 0
        with self.timer("loops"):
            self.loop_closer.process(self)
        with self.timer("maps"):
            self.update_maps()

    # ------------------------------------------------------------------ maps

    def _ray_grid_collapse(self) -> RayGridCollapse | None:
        """The cheap 2D collapse when the LiDAR's rays fall one azimuth per bin, else None."""
        directions, channels = self.lidar.directions, self.lidar.config.channels
        if not RayGridCollapse.aligned(directions, channels, self.mapping.occupancy.azimuth_bins):
            return None
        return RayGridCollapse(directions, channels, self.lidar.config.mount_height, self.mapping.occupancy)

    def collapse(self, scan) -> Scan2D:
        """A scan's :class:`Scan2D`: :class:`RayGridCollapse` when it applies (incremental
        updates, a LiDAR scan with its rays), else the reference :func:`collapse_scan`."""
        if self._collapse is not None and scan.hit_index is not None:
            return self._collapse(scan.points, scan.hit_index)
        return collapse_scan(scan.points, scan.no_return_dirs, self.lidar.config.mount_height,
                             self.mapping.occupancy)

    def world_from_sensor(self, poses_se2: np.ndarray) -> np.ndarray:
        h = self.lidar.config.mount_height
        return np.array([se2_to_matrix(p, h) for p in poses_se2])

    def update_maps(self) -> None:
        """Integrate the newest keyframe after moving the maps along with estimates that
        moved by more than a cell (see the module docstring)."""
        estimates = self.graph.poses_se2()
        if not self.incremental:
            if self.occupancy.needs_rebuild(self._map_poses, estimates):
                self.rebuild_maps(estimates)
                return
            keyframe = self.keyframes[-1]
            self.occupancy.integrate(keyframe.scan2d, estimates[-1])
        else:
            moved = self.occupancy.moved_poses(self._map_poses, estimates)
            if len(moved):
                self.correct_maps(moved, estimates)
            keyframe = self.keyframes[-1]
            self._cells.append(self._trace(keyframe, estimates[-1]))
            self.occupancy.integrate_cells(*self._cells[-1])
            self._voxel_poses = np.vstack([self._voxel_poses, estimates[-1:]])
        self.voxels.insert(self._cloud_world(keyframe, estimates[-1]))
        self._map_poses = np.vstack([self._map_poses, estimates[-1:]])

    def correct_maps(self, moved: np.ndarray, estimates: np.ndarray) -> None:
        """Re-project the 2D scans of keyframes ``moved`` at ``estimates``, and the 3D clouds
        of every keyframe more than ``mapping.voxels.reproject_shift`` off its estimate
        (``mapping.updates=incremental``)."""
        with self.timer("map_corrections"):
            for i in moved:
                self._cells[i] = self._trace(self.keyframes[i], estimates[i])
                self._map_poses[i] = estimates[i]
            self.occupancy.replay(self._cells)
            shift = self.mapping.voxels.reproject_shift
            for i in moved_poses(self._voxel_poses, estimates, shift, self.mapping.occupancy.max_range):
                self.voxels.remove(self._cloud_world(self.keyframes[i], self._voxel_poses[i]))
                self.voxels.insert(self._cloud_world(self.keyframes[i], estimates[i]))
                self._voxel_poses[i] = estimates[i]

    def _trace(self, keyframe: Keyframe, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A keyframe's 2D beam cells at a planar pose, kept as int32 (half the memory)."""
        free, occupied = self.occupancy.beam_cells(keyframe.scan2d, pose)
        return free.astype(np.int32), occupied.astype(np.int32)

    def _cloud_world(self, keyframe: Keyframe, pose: np.ndarray) -> np.ndarray:
        return transform_points(self.world_from_sensor(pose[None])[0], keyframe.cloud)

    @property
    def map_poses(self) -> np.ndarray:
        """``(N, 3)`` planar estimates the 2D map was last built at: each within a map cell
        of its current estimate (a keyframe is re-projected when it moves further)."""
        return self._map_poses

    @property
    def voxel_poses(self) -> np.ndarray:
        """``(N, 3)`` planar estimates the 3D voxel map was last built at."""
        return self._voxel_poses if self.incremental else self._map_poses

    def rebuild_maps(self, estimates: np.ndarray | None = None) -> None:
        """Re-project every keyframe at ``estimates`` (default: the current ones)."""
        estimates = self.graph.poses_se2() if estimates is None else estimates
        if self.incremental:
            self._cells = [self._trace(k, pose) for k, pose in zip(self.keyframes, estimates)]
            self.occupancy.replay(self._cells)
        else:
            self.occupancy.rebuild([k.scan2d for k in self.keyframes], estimates)
        self.voxels.rebuild([k.cloud for k in self.keyframes], list(self.world_from_sensor(estimates)))
        self._map_poses = np.array(estimates, dtype=float).copy()
        self._voxel_poses = self._map_poses.copy()

    # ------------------------------------------------------------------ metrics

    def true_poses(self) -> np.ndarray:
        return np.array([k.true_pose for k in self.keyframes])

    def odometry_poses(self) -> np.ndarray:
        return np.array([k.odom_pose for k in self.keyframes])

    def metrics(self, estimates: np.ndarray | None = None, reference: bool = False) -> SlamMetrics:
        """Metrics of the SLAM estimate, or of any other ``estimates`` (e.g. odometry).
        ``reference``: the map error by :func:`map_error_reference` and the transforms the
        maps use, keyframe by keyframe (the first code; ``benchmarks/bench_explore.py``)."""
        estimates = self.graph.poses_se2() if estimates is None else estimates
        truth = self.true_poses()
        points = [k.error_points for k in self.keyframes]
        if reference:
            error = map_error_reference(self.world_from_sensor(estimates), self.world_from_sensor(truth), points)
        else:
            height = self.lidar.config.mount_height
            error = map_error(se2_matrices(estimates, height), se2_matrices(truth, height),
                              self._error_samples.extend(points))
        return SlamMetrics(
            keyframes=len(self.keyframes),
            map_error_m=error,
            ate_m=absolute_trajectory_error(estimates, truth),
            volume_m3=self.voxels.occupied_volume(),
            explored=self.explored(),
            degenerate_registrations=self.degenerate_registrations,
            loop_closures=sum(n for kind, n in self.graph.factor_counts.items()
                              if kind not in ("odometry", "scan_matching")),
        )

    def explored(self) -> float:
        """The explored fraction alone (what a stop rule reads; :meth:`metrics` has it too)."""
        return explored_fraction(self.occupancy, self.scene.truth.reachable)

    @property
    def degenerate_registrations(self) -> int:
        return sum(1 for k in self.keyframes if k.match is not None and k.match.degenerate)

    # ------------------------------------------------------------------ drawing

    def draw(self, ax, ellipse_every: int = 5) -> None:
        """Estimated map, true and estimated trajectories, 3-sigma pose ellipses."""
        from explore_rl import viz

        viz.draw_mask(ax, self.scene.grid, self.occupancy.known_free, "tab:cyan", alpha=0.25)
        viz.draw_mask(ax, self.scene.grid, self.occupancy.known_occupied, "black", alpha=0.9, zorder=1)
        estimates = self.graph.poses_se2()
        viz.draw_trajectory(ax, self.true_poses(), "tab:green", "true")
        viz.draw_trajectory(ax, self.odometry_poses(), "tab:gray", "odometry", lw=0.8)
        viz.draw_trajectory(ax, estimates, "tab:blue", "SLAM estimate")
        viz.draw_ellipses(ax, estimates[:, :2], self.graph.all_world_xy_covariances(), every=ellipse_every)
        ax.legend(loc="upper right", fontsize=7)
