"""Sequential scan matching (the SSM factor): kiss-icp with a wheel-odometry prior.

Frame conventions: the caller passes each keyframe's cloud in the *sensor* frame
(x forward, y left, z up) and the wheel-odometry motion since the previous keyframe as
a *sensor-frame* 4x4 delta. The returned relative motion and covariance are in the
sensor frame too. With the sensor mounted at a fixed height above the base and no
rotation, a planar base motion and its sensor-frame delta are the same matrix, so the
result can be used directly as a base-frame factor; otherwise conjugate by the
extrinsic (``T_bs @ delta @ inv(T_bs)``) and the covariance by its adjoint.

One step (:meth:`ScanMatcher.register`) reads like kiss-icp's own ``register_frame``,
with two changes: the initial guess is the previous pose composed with the wheel delta
(kiss-icp's constant-velocity guess fails on stop-and-turn motion), and the result is
checked against the local map with a KD-tree because kiss-icp returns only the pose:
inlier count, point-to-plane residual and the 6x6 Gauss-Newton Hessian at the solution.
(The point-to-*point* Hessian has translation block ``N I`` whatever the geometry, so it
cannot reveal a corridor; the point-to-plane one can.) Eigen-directions with little
information are *weak*: the estimate keeps the wheel prior along them and the
covariance is inflated there. Too few points, too few inliers or too many weak
directions (a floor-only scan has three: x, y, yaw) make the match *degenerate*: the
wheel delta is returned with a huge covariance and ``usable`` is false. Never raises
on bad clouds.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import gtsam
import numpy as np
from kiss_icp.config import KISSConfig
from kiss_icp.kiss_icp import KissICP
from scipy.spatial import cKDTree

from explore_rl.geometry import transform_points
from explore_rl.slam.config import ScanMatcherConfig


@dataclass
class ScanMatch:
    """Result of registering one keyframe against the local map."""

    relative: np.ndarray  # 4x4 motion since the previous keyframe (sensor frame)
    covariance: np.ndarray  # 6x6, gtsam Pose3 tangent order (rx, ry, rz, tx, ty, tz)
    degenerate: bool
    weak_directions: int
    n_points: int  # points used for registration (after voxel down-sampling)
    ms: float  # wall time of register()
    n_inliers: int = 0
    residual_rms: float = float("nan")  # point-to-plane, over inliers

    @property
    def usable(self) -> bool:
        """Whether to add this match as a factor (degenerate ones fall back to odometry)."""
        return not self.degenerate


@dataclass
class _Quality:
    """Local-map check of a registered frame (``hessian`` is per inlier)."""

    n_inliers: int
    residual_var: float
    hessian: np.ndarray


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


def estimate_normals(points: np.ndarray, neighbours: np.ndarray) -> np.ndarray:
    """Unit normals ``(M, 3)`` by PCA over ``points[neighbours]`` (``neighbours`` is (M, k))."""
    patches = points[neighbours]
    centred = patches - patches.mean(axis=1, keepdims=True)
    scatter = np.einsum("mki,mkj->mij", centred, centred)
    _, vectors = np.linalg.eigh(scatter)
    return vectors[:, :, 0]


def point_to_plane_jacobian(points_body: np.ndarray, normals_body: np.ndarray) -> np.ndarray:
    """``(M, 6)`` Jacobian of ``n . (T Exp(xi) p - q)`` w.r.t. ``xi = (w, v)`` at xi = 0."""
    return np.hstack([np.cross(points_body, normals_body), normals_body])


class ScanMatcher:
    """Registers each keyframe's cloud against a kiss-icp local map.

    Pickling keeps only the config: a restored matcher starts with an empty map, so
    its first registration is degenerate (falls back to odometry).
    """

    def __init__(self, config: ScanMatcherConfig) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Forget the local map and the trajectory."""
        self._odometry = KissICP(make_kiss_config(self.config))

    def __getstate__(self) -> dict:
        return {"config": self.config}

    def __setstate__(self, state: dict) -> None:
        self.config = state["config"]
        self.reset()

    @property
    def local_map_points(self) -> np.ndarray:
        """``(M, 3)`` points of the local map, in the matcher's odometry frame."""
        return self._odometry.local_map.point_cloud()

    # ------------------------------------------------------------------ the step

    def register(self, points_sensor: np.ndarray, wheel_delta: np.ndarray) -> ScanMatch:
        """Register a keyframe's sensor-frame cloud ``(N, 3)`` given the wheel delta (4x4)."""
        start = time.perf_counter()
        odo = self._odometry
        source, frame = self._prepare(points_sensor)
        guess = odo.last_pose @ np.asarray(wheel_delta, dtype=float)

        if odo.local_map.empty() or len(source) < self.config.min_points:
            pose, match = guess, self._degenerate(len(source))
        else:
            pose, match = self._match(source, guess)

        self._advance(frame, pose)
        match.relative = odo.last_delta.copy()
        match.ms = (time.perf_counter() - start) * 1e3
        return match

    def _prepare(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Filter the cloud; return (registration source, map-update frame)."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        points = points[np.all(np.isfinite(points), axis=1)]
        if self.config.drop_ground_below_z is not None:
            points = points[points[:, 2] >= self.config.drop_ground_below_z]
        if len(points) == 0:
            return points, points
        odo = self._odometry
        points = odo.preprocessor.preprocess(points, np.empty(0), np.eye(4))
        if len(points) == 0:
            return points, points
        source, frame = odo.voxelize(points)
        return np.asarray(source).reshape(-1, 3), np.asarray(frame).reshape(-1, 3)

    def _match(self, source: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, ScanMatch]:
        """ICP from ``guess``; check and fall back to ``guess`` if degenerate."""
        odo = self._odometry
        sigma = odo.adaptive_threshold.get_threshold()
        pose = odo.registration.align_points_to_map(
            points=source,
            voxel_map=odo.local_map,
            initial_guess=guess,
            max_correspondance_distance=3.0 * sigma,
            kernel=sigma,
        )
        quality = self._assess(source, pose)
        if quality is None:
            return guess, self._degenerate(len(source))
        eigenvalues, eigenvectors = np.linalg.eigh(quality.hessian)
        weak = eigenvalues < self.config.weak_eigenvalue
        if weak.sum() > self.config.max_weak_directions:
            return guess, self._degenerate(len(source), int(weak.sum()), quality)
        pose = self._keep_prior_along(eigenvectors[:, weak], guess, pose)
        covariance = self._covariance(quality, eigenvalues, eigenvectors, weak)
        match = ScanMatch(
            relative=np.eye(4),
            covariance=covariance,
            degenerate=False,
            weak_directions=int(weak.sum()),
            n_points=len(source),
            ms=0.0,
            n_inliers=quality.n_inliers,
            residual_rms=float(np.sqrt(quality.residual_var)),
        )
        return pose, match

    def _advance(self, frame: np.ndarray, pose: np.ndarray) -> None:
        """kiss-icp's update step: grow the local map, move last pose and delta."""
        odo = self._odometry
        if len(frame):
            odo.local_map.update(frame, pose)
        odo.last_delta = np.linalg.inv(odo.last_pose) @ pose
        odo.last_pose = pose

    # ------------------------------------------------------------ quality check

    def _assess(self, source: np.ndarray, pose: np.ndarray) -> _Quality | None:
        """Inliers, point-to-plane residual variance and per-inlier Hessian, or None."""
        cfg = self.config
        map_points = self.local_map_points
        if len(map_points) < cfg.normal_neighbors:
            return None
        tree = cKDTree(map_points, balanced_tree=False, compact_nodes=False)
        registered = transform_points(pose, source)
        dist, idx = tree.query(registered, distance_upper_bound=cfg.inlier_distance)
        inlier = np.flatnonzero(np.isfinite(dist))
        n_inliers = len(inlier)
        if n_inliers < max(cfg.min_inliers, cfg.min_inlier_fraction * len(source)):
            return None

        # Hessian and residual are per-inlier averages: a regular subsample suffices.
        inlier = inlier[:: -(-n_inliers // cfg.max_quality_points)]
        target = map_points[idx[inlier]]
        _, neighbours = tree.query(target, k=cfg.normal_neighbors)
        normals_world = estimate_normals(map_points, neighbours)
        residuals = np.einsum("mi,mi->m", normals_world, registered[inlier] - target)
        normals_body = normals_world @ pose[:3, :3]  # rows of R^T n
        J = point_to_plane_jacobian(source[inlier], normals_body)
        dof = max(len(inlier) - 6, 1)
        return _Quality(n_inliers, float(residuals @ residuals / dof), J.T @ J / len(inlier))

    def _covariance(
        self,
        quality: _Quality,
        eigenvalues: np.ndarray,
        eigenvectors: np.ndarray,
        weak: np.ndarray,
    ) -> np.ndarray:
        """residual variance x inverse Hessian, inflated along weak directions, floored."""
        cfg = self.config
        safe = np.where(weak, 1.0, eigenvalues)
        variances = np.where(
            weak, cfg.weak_sigma**2, quality.residual_var / (safe * quality.n_inliers)
        )
        covariance = eigenvectors @ np.diag(variances) @ eigenvectors.T
        floor = [np.deg2rad(cfg.min_sigma_rotation_deg) ** 2] * 3 + [
            cfg.min_sigma_translation**2
        ] * 3
        return covariance + np.diag(floor)

    @staticmethod
    def _keep_prior_along(weak_basis: np.ndarray, guess: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Remove the ICP correction along weak directions (keep the wheel prior there)."""
        if weak_basis.shape[1] == 0:
            return pose
        xi = gtsam.Pose3.Logmap(gtsam.Pose3(np.linalg.inv(guess) @ pose))
        xi = xi - weak_basis @ (weak_basis.T @ xi)
        return guess @ gtsam.Pose3.Expmap(xi).matrix()

    def _degenerate(
        self, n_points: int, weak_directions: int = 6, quality: _Quality | None = None
    ) -> ScanMatch:
        return ScanMatch(
            relative=np.eye(4),
            covariance=np.eye(6) * self.config.degenerate_sigma**2,
            degenerate=True,
            weak_directions=weak_directions,
            n_points=n_points,
            ms=0.0,
            n_inliers=0 if quality is None else quality.n_inliers,
            residual_rms=float("nan") if quality is None else float(np.sqrt(quality.residual_var)),
        )
