"""Sequential scan matching (the SSM factor): kiss-icp with a wheel-odometry prior.

Frame conventions: the caller passes each keyframe's cloud in the *sensor* frame
(x forward, y left, z up) and the wheel-odometry motion since the previous keyframe as
a *sensor-frame* 4x4 delta. The returned relative motion and covariance are in the
sensor frame too. With the sensor mounted at a fixed height above the base and no
rotation, a planar base motion and its sensor-frame delta are the same matrix, so the
result can be used directly as a base-frame factor; otherwise conjugate by the
extrinsic (``T_bs @ delta @ inv(T_bs)``) and the covariance by its adjoint.

One step (:meth:`ScanMatcher.register`) follows kiss-icp's ``register_frame``:

1. filter and voxelise the cloud (kiss-icp's preprocessor and voxeliser);
2. initial guess = previous pose x wheel delta (kiss-icp's constant-velocity guess
   fails on stop-and-turn motion);
3. kiss-icp point-to-point ICP against its local voxel map;
4. a few point-to-plane Gauss-Newton steps against a *submap*: the clouds of the last
   few anchored keyframes, each point tagged with the sensor origin that saw it (for
   oriented normals). Point-to-point ICP is pulled back towards the previous pose by
   surfaces that extend past the map's coverage (on synthetic 3 m rooms it
   under-estimated a 0.46 m step by 1-2 cm; two point-to-plane steps leave ~1 mm),
   and it locks onto the far face of a thin wall seen through a door (20 cm errors in
   the office); correspondences whose oriented normal faces away from the sensor are
   rejected. If kiss-icp moved far from the wheel prior, the prior is refined too and
   the start with more wall/object inliers wins;
5. a quality check at the solution (kiss-icp returns only the pose): inliers,
   point-to-plane residual variance and information ``J^T W J``. (The point-to-*point*
   Hessian has translation block ``N I`` whatever the geometry, so it cannot reveal a
   corridor; the point-to-plane one can.) Planar directions (yaw, x, y) with less
   information than ``min_information`` aligned points are *weak*: the estimate keeps
   the wheel prior along them and the covariance is inflated there. Too few points or
   inliers, or too many weak directions (a floor-only scan has three) make the match
   *degenerate*: the wheel delta is returned with a huge covariance and ``usable`` is
   false. z, roll and pitch are left to the odometry factors;
6. kiss-icp's update: add the frame to its voxel map at the chosen pose; anchored
   keyframes (usable, or starting a submap) also join the submap.

A match after degenerate keyframes is measured from the last anchored keyframe
(``ScanMatch.span`` keyframes back), not from the odometry-placed previous one; after
``max_span`` keyframes without a usable match the submap restarts.

Never raises on bad clouds (empty, NaN, floor only).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass

import gtsam
import numpy as np
from kiss_icp.config import KISSConfig
from kiss_icp.kiss_icp import KissICP
from kiss_icp.voxelization import voxel_down_sample
from scipy.spatial import cKDTree

from explore_rl.geometry import transform_points
from explore_rl.slam.config import ScanMatcherConfig

# Planar degrees of freedom (yaw, x, y) in gtsam's Pose3 tangent order.
PLANAR = [2, 3, 4]
# A plane is "steep" (a wall, an object side) when |n_z| is below cos(45 deg).
STEEP_NORMAL_Z = np.cos(np.pi / 4)


@dataclass
class ScanMatch:
    """Result of registering one keyframe against the local map.

    ``relative`` is the matcher's motion since the previous keyframe. After degenerate
    keyframes (placed by wheel odometry alone) it also carries their odometry error,
    so the factor should instead join the last *anchored* keyframe (registered, or the
    first) to this one: ``span`` keyframes back, measured by ``span_relative``.
    ``span == 1`` and ``span_relative == relative`` in the common case.
    """

    relative: np.ndarray  # 4x4 motion since the previous keyframe (sensor frame)
    covariance: np.ndarray  # 6x6, gtsam Pose3 tangent order (rx, ry, rz, tx, ty, tz)
    degenerate: bool
    weak_directions: int  # among the planar directions (yaw, x, y)
    n_points: int  # points used for registration (after voxel down-sampling)
    ms: float  # wall time of register()
    n_inliers: int = 0
    residual_rms: float = float("nan")  # point-to-plane, over inliers
    span: int = 1
    span_relative: np.ndarray | None = None  # None means ``relative``

    def __post_init__(self) -> None:
        if self.span_relative is None:
            self.span_relative = self.relative

    @property
    def usable(self) -> bool:
        """Whether to add this match as a factor (degenerate ones fall back to odometry)."""
        return not self.degenerate


@dataclass
class Linearisation:
    """Point-to-plane Gauss-Newton system at one pose (sums over the used points).

    Public because the loop closer (:mod:`explore_rl.slam.loop_closure`) reuses it.
    """

    n_inliers: int  # source points with a consistent map point within inlier_distance
    n_used: int  # of those, the ones on planar patches (they enter the system)
    n_structure: int  # of those, the ones on steep planes (walls, object sides)
    # J^T W J, tangent order (rx, ry, rz, tx, ty, tz); an eigenvalue along a unit
    # translation is the number of perfectly aligned points constraining it.
    information: np.ndarray
    gradient: np.ndarray  # J^T W r
    residual_var: float  # sum(w r^2) / (n_used - 6)


class LocalMap:
    """KD-tree over recent anchored keyframe clouds with cached, oriented PCA normals.

    Every point remembers the sensor origin that saw it, and its normal is oriented
    towards that origin. A correspondence is only valid if the current sensor is on the
    side its normal faces: otherwise the scan sees the other face of a thin wall (e.g.
    through a door) -- which kiss-icp's point-to-point matching happily locks onto.

    Public because the loop closer (:mod:`explore_rl.slam.loop_closure`) reuses it.
    """

    def __init__(self, points: np.ndarray, viewpoints: np.ndarray, config: ScanMatcherConfig):
        self.points = points
        self.tree = cKDTree(points, balanced_tree=False, compact_nodes=False)
        self._viewpoints = viewpoints
        self._config = config
        self._normals = np.full_like(points, np.nan)
        self._planar = np.zeros(len(points), dtype=bool)

    def normals(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Oriented unit normals at ``points[idx]`` and whether each patch is planar."""
        missing = np.unique(idx[np.isnan(self._normals[idx, 0])])
        if len(missing):
            _, neighbours = self.tree.query(self.points[missing], k=self._config.normal_neighbors)
            normals, variation = estimate_normals(self.points, neighbours)
            view = self._viewpoints[missing] - self.points[missing]
            flip = np.einsum("mi,mi->m", normals, view) < 0
            self._normals[missing] = np.where(flip[:, None], -normals, normals)
            self._planar[missing] = variation <= self._config.max_surface_variation
        return self._normals[idx], self._planar[idx]


def make_kiss_config(config: ScanMatcherConfig) -> KISSConfig:
    """kiss-icp configuration: no deskew, fixed threshold, small voxel maps."""
    return KISSConfig(
        data={"max_range": config.max_range, "min_range": config.min_range, "deskew": False},
        mapping={
            "voxel_size": config.voxel_size,
            "max_points_per_voxel": config.max_points_per_voxel,
        },
        registration={
            "max_num_iterations": config.max_iterations,
            "convergence_criterion": config.convergence_criterion,
            "max_num_threads": config.max_threads,
        },
        adaptive_threshold={"fixed_threshold": config.fixed_threshold},
    )


def estimate_normals(points: np.ndarray, neighbours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PCA over ``points[neighbours]`` ((M, k) indices): unit normals ``(M, 3)`` and the
    surface variation ``l0 / (l0 + l1 + l2)`` (0 on a plane, ~1/3 for isotropic
    scatter; high at edges and corners, whose normals are meaningless)."""
    patches = points[neighbours]
    centred = patches - patches.mean(axis=1, keepdims=True)
    scatter = np.einsum("mki,mkj->mij", centred, centred)
    values, vectors = np.linalg.eigh(scatter)
    variation = values[:, 0] / np.maximum(values.sum(axis=1), np.finfo(float).tiny)
    return vectors[:, :, 0], variation


def point_to_plane_jacobian(points_body: np.ndarray, normals_body: np.ndarray) -> np.ndarray:
    """``(M, 6)`` Jacobian of ``n . (T Exp(xi) p - q)`` w.r.t. ``xi = (w, v)`` at xi = 0."""
    return np.hstack([np.cross(points_body, normals_body), normals_body])


def retract(pose: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """``pose @ Exp(xi)`` with gtsam's Pose3 tangent order (w, v)."""
    return pose @ gtsam.Pose3.Expmap(np.asarray(xi, dtype=float)).matrix()


class ScanMatcher:
    """Registers each keyframe's cloud against the recent ones (kiss-icp + refinement).

    Pickling keeps only the config: a restored matcher starts with an empty map, so
    its first registration is degenerate (falls back to odometry).
    """

    def __init__(self, config: ScanMatcherConfig) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Forget the local map and the trajectory."""
        self._odometry = KissICP(make_kiss_config(self.config))
        self._anchor = np.eye(4)  # pose of the last keyframe anchored to the map
        self._since_anchor = 0
        # (points, sensor origin) of recent anchored keyframes, odometry frame.
        self._submap: deque[tuple[np.ndarray, np.ndarray]] = deque(
            maxlen=self.config.submap_keyframes
        )

    def __getstate__(self) -> dict:
        return {"config": self.config}

    def __setstate__(self, state: dict) -> None:
        self.config = state["config"]
        self.reset()

    @property
    def local_map_points(self) -> np.ndarray:
        """``(M, 3)`` points of the local map, in the matcher's odometry frame."""
        return self._odometry.local_map.point_cloud().reshape(-1, 3)

    # ------------------------------------------------------------------ the step

    def register(self, points_sensor: np.ndarray, wheel_delta: np.ndarray) -> ScanMatch:
        """Register a keyframe's sensor-frame cloud ``(N, 3)`` given the wheel delta (4x4)."""
        start = time.perf_counter()
        odo = self._odometry
        source, frame = self._prepare(points_sensor)
        guess = odo.last_pose @ np.asarray(wheel_delta, dtype=float)

        if self._since_anchor >= self.config.max_span:
            self._submap.clear()  # too long on odometry alone: start a new submap
        starts_submap = not self._submap
        if starts_submap or len(source) < self.config.min_points:
            pose, match = guess, self._degenerate(len(source))
        else:
            pose, match = self._match(source, guess)

        self._advance(frame, pose)
        match.relative = odo.last_delta.copy()
        match.span_relative = match.relative
        self._since_anchor += 1
        if match.usable:
            match.span = self._since_anchor
            match.span_relative = np.linalg.inv(self._anchor) @ pose
        if match.usable or starts_submap:
            self._anchor, self._since_anchor = pose, 0
            if len(frame):
                thinned = voxel_down_sample(frame, self.config.submap_voxel)
                self._submap.append((transform_points(pose, thinned), pose[:3, 3].copy()))
        match.ms = (time.perf_counter() - start) * 1e3
        return match

    def _prepare(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Filter the cloud; return (registration source, map-update frame)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        points = points[np.all(np.isfinite(points), axis=1)]
        if self.config.drop_ground_below_z is not None:
            points = points[points[:, 2] >= self.config.drop_ground_below_z]
        if len(points):
            points = self._odometry.preprocessor.preprocess(points, np.empty(0), np.eye(4))
        if len(points) == 0:
            return np.empty((0, 3)), np.empty((0, 3))
        source, frame = self._odometry.voxelize(points)
        return np.asarray(source).reshape(-1, 3), np.asarray(frame).reshape(-1, 3)

    def _match(self, source: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, ScanMatch]:
        """ICP from ``guess``, refine, check; fall back to ``guess`` if degenerate."""
        cfg = self.config
        local = self._local_map()
        if local is None:
            return guess, self._degenerate(len(source))

        # kiss-icp can lock onto the wrong face of a thin wall; if it moved far from
        # the wheel prior, also refine from the prior and keep the start with more
        # inliers on steep planes (the floor fits any horizontal shift, and rewards
        # sliding the scan back onto already-mapped floor).
        kiss_pose = self._align(source, guess)
        starts = [kiss_pose]
        if self._far_apart(guess, kiss_pose):
            starts.append(guess)
        refined = [self.refine(local, source, start) for start in starts]
        pose, system = max(refined, key=lambda r: -1 if r[1] is None else r[1].n_structure)
        if system is None:
            return guess, self._degenerate(len(source))

        eigenvalues, eigenvectors = np.linalg.eigh(system.information[np.ix_(PLANAR, PLANAR)])
        weak = eigenvalues < cfg.min_information
        if weak.sum() > cfg.max_weak_directions:
            return guess, self._degenerate(len(source), int(weak.sum()), system)
        weak_basis = np.zeros((6, int(weak.sum())))
        weak_basis[PLANAR] = eigenvectors[:, weak]
        match = ScanMatch(
            relative=np.eye(4),
            covariance=self.covariance(system, eigenvalues, eigenvectors, weak),
            degenerate=False,
            weak_directions=int(weak.sum()),
            n_points=len(source),
            ms=0.0,
            n_inliers=system.n_inliers,
            residual_rms=float(np.sqrt(system.residual_var)),
        )
        return self._keep_prior_along(weak_basis, guess, pose), match

    def _local_map(self) -> LocalMap | None:
        """The submap of recent anchored keyframes (None if too small for normals)."""
        if not self._submap:
            return None
        points = np.vstack([p for p, _ in self._submap])
        if len(points) < self.config.normal_neighbors:
            return None
        viewpoints = np.vstack([np.broadcast_to(o, p.shape) for p, o in self._submap])
        return LocalMap(points, viewpoints, self.config)

    def _far_apart(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether two poses differ by more than the recheck thresholds."""
        delta = np.linalg.inv(a) @ b
        angle = np.arccos(np.clip((np.trace(delta[:3, :3]) - 1.0) / 2.0, -1.0, 1.0))
        return bool(
            np.linalg.norm(delta[:3, 3]) > self.config.recheck_translation
            or np.rad2deg(angle) > self.config.recheck_rotation_deg
        )

    def _align(self, source: np.ndarray, guess: np.ndarray) -> np.ndarray:
        """kiss-icp's point-to-point ICP against its voxel map."""
        odo = self._odometry
        sigma = odo.adaptive_threshold.get_threshold()
        return odo.registration.align_points_to_map(
            points=source,
            voxel_map=odo.local_map,
            initial_guess=guess,
            max_correspondance_distance=3.0 * sigma,
            kernel=self.config.kernel_ratio * sigma,
        )

    def _advance(self, frame: np.ndarray, pose: np.ndarray) -> None:
        """kiss-icp's update step: grow the local map, move last pose and delta."""
        odo = self._odometry
        if len(frame):
            odo.local_map.update(frame, pose)
        odo.last_delta = np.linalg.inv(odo.last_pose) @ pose
        odo.last_pose = pose

    # ----------------------------------------------- point-to-plane refinement

    def refine(
        self, local: LocalMap, source: np.ndarray, pose: np.ndarray
    ) -> tuple[np.ndarray, Linearisation | None]:
        """Point-to-plane Gauss-Newton from ``pose``; the system at the result.

        Public because the loop closer reuses it to refine its matches.
        """
        system = self._linearise(local, source, pose)
        for _ in range(self.config.refine_iterations):
            if system is None:
                break
            pose = self._gauss_newton_step(system, pose)
            system = self._linearise(local, source, pose)
        return pose, system

    def _linearise(
        self, local: LocalMap, source: np.ndarray, pose: np.ndarray
    ) -> Linearisation | None:
        """Point-to-plane system at ``pose`` (None if too few inliers)."""
        cfg = self.config
        registered = transform_points(pose, source)
        dist, idx = local.tree.query(registered, distance_upper_bound=cfg.inlier_distance)
        near = np.flatnonzero(np.isfinite(dist))
        normals, planar = local.normals(idx[near])
        target = local.points[idx[near]]
        # The sensor must be on the side of the plane its normal faces (edges: no test).
        facing = np.einsum("mi,mi->m", normals, pose[:3, 3] - target) > 0
        inlier = facing | ~planar
        used = facing & planar
        n_inliers, n_used = int(inlier.sum()), int(used.sum())
        if n_inliers < max(cfg.min_inliers, cfg.min_inlier_fraction * len(source)):
            return None
        if n_used < cfg.min_inliers:
            return None

        near, normals, target = near[used], normals[used], target[used]
        residuals = np.einsum("mi,mi->m", normals, registered[near] - target)
        J = point_to_plane_jacobian(source[near], normals @ pose[:3, :3])  # R^T n
        scale = cfg.kernel_ratio * cfg.fixed_threshold
        weights = 1.0 / (1.0 + (residuals / scale) ** 2)  # Cauchy
        steep = np.abs(normals[:, 2]) < STEEP_NORMAL_Z
        return Linearisation(
            n_inliers=n_inliers,
            n_used=n_used,
            n_structure=int(steep.sum()),
            information=J.T @ (J * weights[:, None]),
            gradient=J.T @ (weights * residuals),
            residual_var=float(weights @ residuals**2 / max(n_used - 6, 1)),
        )

    def _gauss_newton_step(self, system: Linearisation, pose: np.ndarray) -> np.ndarray:
        """One Gauss-Newton step restricted to the well-constrained directions."""
        eigenvalues, eigenvectors = np.linalg.eigh(system.information)
        strong = eigenvalues >= self.config.min_information
        basis = eigenvectors[:, strong]
        xi = -basis @ ((basis.T @ system.gradient) / eigenvalues[strong])
        return retract(pose, xi)

    # ----------------------------------------------------------- covariance

    def covariance(
        self,
        system: Linearisation,
        eigenvalues: np.ndarray,
        eigenvectors: np.ndarray,
        weak: np.ndarray,
    ) -> np.ndarray:
        """6x6 covariance: planar block (yaw, x, y) = residual variance x inverse planar
        information, inflated along weak directions and floored; z, roll and pitch are
        left to the odometry factors (``off_plane_sigma``).

        Public because the loop closer reuses it for its matches' covariances."""
        cfg = self.config
        safe = np.where(weak, 1.0, eigenvalues)
        variances = np.where(
            weak, cfg.weak_sigma**2, cfg.covariance_scale * system.residual_var / safe
        )
        rotation, translation = np.deg2rad(cfg.min_sigma_rotation_deg), cfg.min_sigma_translation
        floor = np.array([rotation, translation, translation])
        covariance = np.eye(6) * cfg.off_plane_sigma**2
        covariance[np.ix_(PLANAR, PLANAR)] = (
            eigenvectors @ np.diag(variances) @ eigenvectors.T + np.diag(floor**2)
        )
        return covariance

    @staticmethod
    def _keep_prior_along(
        weak_basis: np.ndarray, guess: np.ndarray, pose: np.ndarray
    ) -> np.ndarray:
        """Remove the ICP correction along weak directions (keep the wheel prior there)."""
        if weak_basis.shape[1] == 0:
            return pose
        xi = gtsam.Pose3.Logmap(gtsam.Pose3(np.linalg.inv(guess) @ pose))
        return retract(guess, xi - weak_basis @ (weak_basis.T @ xi))

    def _degenerate(
        self,
        n_points: int,
        weak_directions: int = len(PLANAR),
        system: Linearisation | None = None,
    ) -> ScanMatch:
        """A fall-back-to-odometry result (``usable`` is false)."""
        return ScanMatch(
            relative=np.eye(4),
            covariance=np.eye(6) * self.config.degenerate_sigma**2,
            degenerate=True,
            weak_directions=weak_directions,
            n_points=n_points,
            ms=0.0,
            n_inliers=0 if system is None else system.n_inliers,
            residual_rms=float("nan") if system is None else float(np.sqrt(system.residual_var)),
        )
