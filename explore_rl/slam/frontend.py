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
3. kiss-icp point-to-point ICP against the local voxel map;
4. a few point-to-plane Gauss-Newton steps on a KD-tree of the local map. Point-to-
   point ICP is pulled back towards the previous pose by surfaces (the floor, walls)
   that extend past the map's coverage: on synthetic 3 m rooms it under-estimated a
   0.46 m step by 1-2 cm; two point-to-plane steps cut that to ~1 mm;
5. a quality check at the solution (kiss-icp returns only the pose): inlier count,
   point-to-plane residual variance and the 6x6 Gauss-Newton Hessian. (The point-to-
   *point* Hessian has translation block ``N I`` whatever the geometry, so it cannot
   reveal a corridor; the point-to-plane one can.) Eigen-directions with little
   information are *weak*: the estimate keeps the wheel prior along them and the
   covariance is inflated there. Too few points, too few inliers or too many weak
   directions (a floor-only scan has three: x, y, yaw) make the match *degenerate*:
   the wheel delta is returned with a huge covariance and ``usable`` is false;
6. kiss-icp's update: add the frame to the local map at the chosen pose.

Never raises on bad clouds (empty, NaN, floor only).
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
class _Linearisation:
    """Point-to-plane system at one pose; ``hessian`` and ``gradient`` are per point."""

    n_inliers: int
    hessian: np.ndarray  # J^T W J / m, tangent order (rx, ry, rz, tx, ty, tz)
    gradient: np.ndarray  # J^T W r / m
    residual_var: float  # sum(w r^2) / (m - 6)


class _LocalMap:
    """KD-tree over the local map points with lazily computed, cached PCA normals."""

    def __init__(self, points: np.ndarray, normal_neighbors: int) -> None:
        self.points = points
        self.tree = cKDTree(points, balanced_tree=False, compact_nodes=False)
        self._k = normal_neighbors
        self._normals = np.full_like(points, np.nan)

    def normals(self, idx: np.ndarray) -> np.ndarray:
        """Unit normals at ``points[idx]``."""
        missing = np.unique(idx[np.isnan(self._normals[idx, 0])])
        if len(missing):
            _, neighbours = self.tree.query(self.points[missing], k=self._k)
            self._normals[missing] = estimate_normals(self.points, neighbours)
        return self._normals[idx]


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


def retract(pose: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """``pose @ Exp(xi)`` with gtsam's Pose3 tangent order (w, v)."""
    return pose @ gtsam.Pose3.Expmap(np.asarray(xi, dtype=float)).matrix()


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
        return self._odometry.local_map.point_cloud().reshape(-1, 3)

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
        if len(points):
            points = self._odometry.preprocessor.preprocess(points, np.empty(0), np.eye(4))
        if len(points) == 0:
            return np.empty((0, 3)), np.empty((0, 3))
        source, frame = self._odometry.voxelize(points)
        return np.asarray(source).reshape(-1, 3), np.asarray(frame).reshape(-1, 3)

    def _match(self, source: np.ndarray, guess: np.ndarray) -> tuple[np.ndarray, ScanMatch]:
        """ICP from ``guess``, refine, check; fall back to ``guess`` if degenerate."""
        cfg = self.config
        pose = self._align(source, guess)
        points = self.local_map_points
        if len(points) < cfg.normal_neighbors:
            return guess, self._degenerate(len(source))
        local = _LocalMap(points, cfg.normal_neighbors)

        system = self._linearise(local, source, pose)
        for _ in range(cfg.refine_iterations):
            if system is None:
                break
            pose = self._gauss_newton_step(system, pose)
            system = self._linearise(local, source, pose)
        if system is None:
            return guess, self._degenerate(len(source))

        eigenvalues, eigenvectors = np.linalg.eigh(system.hessian)
        weak = eigenvalues < cfg.weak_eigenvalue
        if weak.sum() > cfg.max_weak_directions:
            return guess, self._degenerate(len(source), int(weak.sum()), system)
        pose = self._keep_prior_along(eigenvectors[:, weak], guess, pose)
        match = ScanMatch(
            relative=np.eye(4),
            covariance=self._covariance(system, eigenvalues, eigenvectors, weak),
            degenerate=False,
            weak_directions=int(weak.sum()),
            n_points=len(source),
            ms=0.0,
            n_inliers=system.n_inliers,
            residual_rms=float(np.sqrt(system.residual_var)),
        )
        return pose, match

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

    def _linearise(
        self, local: _LocalMap, source: np.ndarray, pose: np.ndarray
    ) -> _Linearisation | None:
        """Point-to-plane system at ``pose`` (None if too few inliers)."""
        cfg = self.config
        registered = transform_points(pose, source)
        dist, idx = local.tree.query(registered, distance_upper_bound=cfg.inlier_distance)
        inlier = np.flatnonzero(np.isfinite(dist))
        n_inliers = len(inlier)
        if n_inliers < max(cfg.min_inliers, cfg.min_inlier_fraction * len(source)):
            return None

        # Per-point averages: a regular subsample bounds the cost.
        inlier = inlier[:: -(-n_inliers // cfg.max_quality_points)]
        target = local.points[idx[inlier]]
        normals = local.normals(idx[inlier])
        residuals = np.einsum("mi,mi->m", normals, registered[inlier] - target)
        J = point_to_plane_jacobian(source[inlier], normals @ pose[:3, :3])  # R^T n
        scale = cfg.kernel_ratio * cfg.fixed_threshold
        weights = 1.0 / (1.0 + (residuals / scale) ** 2)  # Cauchy
        m = len(inlier)
        return _Linearisation(
            n_inliers=n_inliers,
            hessian=J.T @ (J * weights[:, None]) / m,
            gradient=J.T @ (weights * residuals) / m,
            residual_var=float(weights @ residuals**2 / max(m - 6, 1)),
        )

    def _gauss_newton_step(self, system: _Linearisation, pose: np.ndarray) -> np.ndarray:
        """One Gauss-Newton step restricted to the well-constrained directions."""
        eigenvalues, eigenvectors = np.linalg.eigh(system.hessian)
        strong = eigenvalues >= self.config.weak_eigenvalue
        basis = eigenvectors[:, strong]
        xi = -basis @ ((basis.T @ system.gradient) / eigenvalues[strong])
        return retract(pose, xi)

    # ----------------------------------------------------------- covariance

    def _covariance(
        self,
        system: _Linearisation,
        eigenvalues: np.ndarray,
        eigenvectors: np.ndarray,
        weak: np.ndarray,
    ) -> np.ndarray:
        """residual variance x inverse Hessian, inflated along weak directions, floored."""
        cfg = self.config
        safe = np.where(weak, 1.0, eigenvalues)
        variances = np.where(
            weak, cfg.weak_sigma**2, system.residual_var / (safe * system.n_inliers)
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
        return retract(guess, xi - weak_basis @ (weak_basis.T @ xi))

    def _degenerate(
        self, n_points: int, weak_directions: int = 6, system: _Linearisation | None = None
    ) -> ScanMatch:
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
