"""Configuration of the SLAM back end (pose graph) and the sequential scan matcher.

Plain dataclasses with plain field types so they can become Hydra structured configs.
Units are SI (metres, radians) unless the field name ends in ``_deg``.
``conf/slam/icp.yaml`` mirrors these defaults.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional


@dataclass
class PoseGraphConfig:
    """iSAM2 pose graph over Pose3 keyframes (kept planar by tight z/roll/pitch sigmas)."""

    # Prior on the first keyframe (the true start pose).
    prior_sigma_translation: float = 1e-4
    prior_sigma_rotation: float = 1e-4

    # Odometry factor noise per motion step; x, y and yaw scale with sqrt(motion_steps).
    odom_sigma_xy_per_step: float = 0.01
    odom_sigma_yaw_deg_per_step: float = 0.08
    # Tight, unscaled sigmas that keep the graph planar.
    odom_sigma_z: float = 1e-3
    odom_sigma_roll_pitch: float = 1e-3

    # Loop closures: robust kernel "cauchy", "huber" or "none"; width in whitened
    # (Mahalanobis) units. The residual of a *correct* closure includes the drift
    # accumulated since the revisited pose, so a narrow kernel (~1) also discounts good
    # closures; 3 keeps them while a 2 m-wrong closure (40 sigma) gets weight ~0.006.
    # Huber's bounded but non-vanishing influence still lets it pull 5-15 cm.
    loop_robust_kernel: str = "cauchy"
    loop_robust_width: float = 3.0
    # Extra iSAM2 update() calls after each loop closure (lets iSAM2 relinearise).
    loop_extra_updates: int = 2

    # iSAM2 parameters.
    relinearize_threshold: float = 0.01
    relinearize_skip: int = 1


@dataclass
class ScanMatcherConfig:
    """kiss-icp sequential scan matching plus a KD-tree quality/covariance check."""

    # kiss-icp: scan range filter; ``max_range`` also bounds the local map radius.
    max_range: float = 5.0
    min_range: float = 0.0
    # Map voxel; kiss-icp registers a 1.5x-voxel down-sample. Synthetic 3 m rooms,
    # ~11k points, with refinement: 0.1 -> ~70 ms/frame, 0.15 -> ~28 ms, 0.2 -> ~20 ms
    # (median step errors 1.0 / 1.2 / 1.8 mm).
    voxel_size: float = 0.2
    max_points_per_voxel: int = 3
    # Fixed ICP threshold sigma: correspondences gated at 3 sigma, Geman-McClure kernel
    # scale = kernel_ratio * sigma (1/3 as in kiss-icp's C++ pipeline; its Python
    # wrapper passes sigma, which gave ~2x worse tail errors here).
    fixed_threshold: float = 0.2
    kernel_ratio: float = 0.33
    max_iterations: int = 20
    convergence_criterion: float = 1e-4
    # 1 keeps kiss-icp single-threaded (the machine is shared); 0 = automatic.
    max_threads: int = 1

    # Sensor-frame z below which points are dropped before registration (None keeps
    # the floor).
    drop_ground_below_z: Optional[float] = None

    # Point-to-plane Gauss-Newton steps after kiss-icp (0 = pure kiss-icp); they
    # remove the pull of partially-overlapping surfaces towards the previous pose.
    refine_iterations: int = 2
    # If kiss-icp moved this far from the wheel prior, also refine from the prior and
    # keep the start with more inliers (kiss-icp can lock onto the far face of a wall).
    recheck_translation: float = 0.05
    recheck_rotation_deg: float = 2.0

    # Refinement and quality check run against the last few anchored keyframe clouds
    # (each point knows the sensor origin that saw it), not kiss-icp's voxel map.
    submap_keyframes: int = 5
    submap_voxel: float = 0.15  # each keyframe cloud is thinned to this before joining
    # After this many keyframes without a usable match the submap is stale (odometry
    # drift): it restarts at the current keyframe, with no factor.
    max_span: int = 5

    # Correspondences, refinement and quality check.
    inlier_distance: float = 0.15
    normal_neighbors: int = 8
    # Map points whose neighbourhood is not planar (PCA surface variation above this:
    # edges, corners, wall-floor junctions) are left out of refinement and Hessian.
    max_surface_variation: float = 0.02
    min_points: int = 50
    min_inliers: int = 50
    min_inlier_fraction: float = 0.3
    # A planar direction (in yaw, x, y; yaw in rad, so a point at r metres counts r^2)
    # is weak when the point-to-plane information J^T W J along it is below this many
    # perfectly aligned points. Absolute, not per point: floor points, which say
    # nothing about x, y, yaw, must not dilute it. More weak planar directions than
    # allowed -> degenerate (a floor-only scan has three).
    min_information: float = 10.0
    max_weak_directions: int = 2

    # Covariance: standard deviation along weak planar directions, floors added on the
    # planar diagonal, z/roll/pitch (left to odometry), and the isotropic standard
    # deviation of degenerate (unusable) scans.
    weak_sigma: float = 1.0
    min_sigma_translation: float = 0.01
    min_sigma_rotation_deg: float = 0.15
    off_plane_sigma: float = 1.0
    degenerate_sigma: float = 100.0


@dataclass
class SlamConfig:
    """The ``slam`` config group: keyframing, the front end and the back end."""

    # "icp": kiss-icp scan matching on the simulated clouds; "model": the calibrated model.
    frontend: str = "icp"
    keyframe_distance: float = 0.5
    keyframe_angle_deg: float = 15.0
    # Map error: this many seeded scan points per keyframe (DESIGN.md).
    map_error_points: int = 256
    # Keyframe clouds kept for maps/loop closures are voxel-down-sampled to this size.
    keyframe_cloud_voxel: float = 0.05
    pose_graph: PoseGraphConfig = field(default_factory=PoseGraphConfig)
    scan_matcher: ScanMatcherConfig = field(default_factory=ScanMatcherConfig)
