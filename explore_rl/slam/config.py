"""Configuration of the SLAM back end (pose graph) and the sequential scan matcher.

Plain dataclasses with plain field types so they can become Hydra structured configs.
Units are SI (metres, radians) unless the field name ends in ``_deg``.
``conf/slam/icp.yaml`` mirrors these defaults.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

from explore_rl.resources import conf_dir


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
    # Sequential scan-matching factors: same choices. Their errors have a heavy tail
    # (4 % beyond the 99 % chi-square quantile: kiss-icp sometimes turns a scan by
    # 0.5-5 deg on a short wall or one object while reporting a tight yaw; see
    # conf/calibration/scan_matching.yaml). Measured on 16 office-tour seeds without
    # loop closures: Cauchy 3 beat dead reckoning on 16/16 (ATE ratio mean 0.58, max
    # 0.95); no kernel on 9/10 seeds (mean 0.56, max 1.04).
    ssm_robust_kernel: str = "cauchy"
    ssm_robust_width: float = 3.0
    # Extra iSAM2 update() calls after each loop closure (lets iSAM2 relinearise).
    loop_extra_updates: int = 2

    # iSAM2 parameters.
    relinearize_threshold: float = 0.01
    relinearize_skip: int = 1
    # Check only the part of the Bayes tree an update touches for relinearisation (gtsam's
    # enablePartialRelinearizationCheck). On 8 office tours (slam=model) iSAM2 updates got
    # 15-25 % cheaper; mean ATE 0.0446 vs 0.0439 m, map error equal to 1 mm.
    partial_relinearization_check: bool = True


@dataclass
class ScanMatcherConfig:
    """kiss-icp sequential scan matching plus a KD-tree quality/covariance check."""

    # kiss-icp: scan range filter; ``max_range`` also bounds the local map radius.
    max_range: float = 5.0
    min_range: float = 0.0
    # Map voxel; kiss-icp registers a 1.5x-voxel down-sample. On the simulated scenes
    # without the floor 0.1 gave ~0.03 deg robust yaw error and 60 % fully constrained
    # matches (0.2: 0.06 deg, 35 %) at ~10-19 ms per frame. Synthetic 3 m rooms,
    # ~11k points, with refinement: 0.1 -> ~70 ms/frame, 0.15 -> ~28 ms, 0.2 -> ~20 ms
    # (median step errors 1.0 / 1.2 / 1.8 mm).
    voxel_size: float = 0.1
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
    # the floor). The floor only constrains z/roll/pitch but its rings (circles around
    # the sensor) pull kiss-icp towards the previous pose: dropping it (0.1 m above the
    # floor at the 0.4 m mount) cut the yaw-error std of usable matches 0.26 -> 0.12 deg
    # and the p99 0.74 -> 0.57 deg (scripts/calibrate_scan_matching.py).
    drop_ground_below_z: Optional[float] = -0.3

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
    # drift): it restarts at the current keyframe, with no factor. Entering a room
    # through a door, a well-structured scan overlaps the submap too little (degenerate);
    # it is not added to the submap, so the following scans overlap even less: with 5,
    # such runs lasted 6 keyframes (~15 % of all keyframes on pure odometry). 1 restarts
    # at the next keyframe (ATE vs dead reckoning 0.72 -> 0.54 on 10 tour seeds).
    max_span: int = 1

    # Correspondences, refinement and quality check.
    inlier_distance: float = 0.15
    normal_neighbors: int = 8
    # Map points whose neighbourhood is not planar (PCA surface variation above this:
    # edges, corners, wall-floor junctions) are left out of refinement and Hessian.
    max_surface_variation: float = 0.02
    # (Without the floor a scan keeps ~100-700 points after the 1.5-voxel down-sample.)
    min_points: int = 20
    min_inliers: int = 15
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
    # Multiplies the residual-variance x inverse-information part (alone it under-states
    # the errors ~1.7x in standard deviation; with the floors below the total is honest).
    covariance_scale: float = 1.0
    # Floors fitted so that the errors' Mahalanobis distances along constrained
    # directions are roughly chi-square: d^2 per dof 1.5, median p-value 0.66, 4 %
    # beyond the 99 % quantile (the heavy tail, left to ssm_robust_kernel). The old
    # 0.15 deg / 1 cm made d^2 per dof ~0.4 (the core 2.5x too cautious in variance).
    min_sigma_translation: float = 0.002
    min_sigma_rotation_deg: float = 0.03
    off_plane_sigma: float = 1.0
    degenerate_sigma: float = 100.0

    # The `model` front end's scan-matching error model (slam.frontend=model only): a file of
    # scripts/calibrate_scan_matching.py; empty = conf/calibration/scan_matching.yaml (office tours and
    # office/street/garage explorations), a bare file name = that file in conf/calibration/.
    calibration_file: str = ""


@dataclass
class LoopClosureConfig:
    """Loop closures of the icp front end (``explore_rl/slam/loop_closure.py``): pose
    matching and segment matching, gated on the joint marginal, verified by
    registration, added as robust factors (kernel: ``pose_graph.loop_robust_*``).

    Defaults were chosen from logged attempts on the office tour (8 seeds, every
    registration scored against ground truth; ``scripts/calibrate_loop_closures.py``).
    """

    enabled: bool = True
    # Never add factors (attempts are still logged): for calibration.
    dry_run: bool = False

    # Candidates: earlier keyframes whose estimate is within search_radius of the current
    # one, more than min_travel_gap metres of travel and min_index_gap keyframes back,
    # in line of sight on the 2D map; the closest of each run of candidate_separation
    # indices; at most max_candidates per keyframe.
    search_radius: float = 2.0
    min_travel_gap: float = 3.0
    min_index_gap: int = 10
    candidate_separation: int = 5
    max_candidates: int = 3
    line_of_sight: bool = True
    # Registrations (pose + segment matching) and accepted closures per keyframe.
    max_attempts_per_keyframe: int = 2
    max_closures_per_keyframe: int = 1

    # Gate on the pair's joint marginal: register only if the true distance could be
    # within overlap_radius (one-sided chi-square at gate_probability), the relative
    # pose is certain enough for the starts to reach it (max_sigma_*: pose matching
    # only) and uncertain enough for a closure to be worth it (either std above
    # min_sigma_*).
    gate_probability: float = 0.99
    overlap_radius: float = 1.5
    max_sigma_translation: float = 0.5
    max_sigma_rotation_deg: float = 10.0
    min_sigma_translation: float = 0.04
    min_sigma_rotation_deg: float = 0.6

    # Registration: the current cloud's points above ground_height (walls, objects;
    # base frame) thinned to source_voxel against the candidate and submap_keyframes
    # neighbours each side thinned to submap_voxel, in the candidate's frame. kiss-icp
    # (icp_threshold sigma: correspondences within 3 sigma, kernel sigma/3;
    # icp_iterations; icp_source_voxel / icp_voxel maps) from the estimate and, if the
    # relative std exceeds guess_offset_min_sigma (m) or _rotation_deg, from the
    # estimate composed with each guess_offsets [dx, dy, dyaw_deg]; distinct results
    # (duplicate_*) are scored by inliers, the best gets refine_iterations of the scan
    # matcher's point-to-plane steps.
    ground_height: float = 0.1
    source_voxel: float = 0.1
    submap_keyframes: int = 3
    submap_voxel: float = 0.1
    icp_threshold: float = 0.2
    icp_iterations: int = 10
    icp_source_voxel: float = 0.25
    icp_voxel: float = 0.3
    icp_points_per_voxel: int = 3
    guess_offsets: list[list[float]] = field(default_factory=lambda: [
        [0.3, 0.0, 0.0], [-0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, -0.3, 0.0],
        [0.0, 0.0, 3.0], [0.0, 0.0, -3.0]])
    guess_offset_min_sigma: float = 0.1
    guess_offset_min_sigma_rotation_deg: float = 2.0
    duplicate_translation: float = 0.02
    duplicate_rotation_deg: float = 0.3
    refine_iterations: int = 2
    inlier_distance: float = 0.15

    # Acceptance. Too few source points (min_structure_points) -> not attempted.
    # inlier fraction, point-to-plane residual (m); planar directions whose information
    # (J^T W J eigenvalue, in aligned points) is below min_information are weak: at most
    # max_weak_directions, along which the prior's std moves the position by at most
    # max_weak_prior_sigma and the yaw by max_weak_prior_sigma_rotation_deg (the factor
    # keeps the prior there, std weak_sigma); a clearly different start (ambiguity_*)
    # with at least ambiguity_ratio of the best's inliers -> ambiguous; the correction
    # must pass a chi-square (3 dof, consistency_probability) under joint marginal +
    # factor covariance. On the office tour: min_information 10 and ambiguity 0.9 kept
    # 171 of 448 otherwise-passing registrations, none wrong by > 0.3 m / 3 deg.
    min_structure_points: int = 100
    min_inliers: int = 50
    min_inlier_fraction: float = 0.6
    max_residual: float = 0.03
    min_information: float = 10.0
    max_weak_directions: int = 1
    max_weak_prior_sigma: float = 0.1
    max_weak_prior_sigma_rotation_deg: float = 1.0
    weak_sigma: float = 1.0
    ambiguity_ratio: float = 0.9
    ambiguity_translation: float = 0.1
    ambiguity_rotation_deg: float = 2.0
    consistency_probability: float = 0.999

    # Loop factor covariance: residual variance x inverse planar information plus these
    # floors (the submap's own placement errors dominate); z/roll/pitch left to odometry.
    sigma_translation: float = 0.03
    sigma_rotation_deg: float = 0.5
    off_plane_sigma: float = 1.0

    # Segment matching (explore_rl/slam/segments.py): every segment_every keyframes the
    # last segment_submap_keyframes clouds (rolling submap) are segmented: points between
    # ground_height and segment_max_height, thinned to segment_voxel, clustered at
    # segment_cluster_distance, clusters with segment_min_points points and a horizontal
    # extent in [segment_min_extent, segment_max_extent] (walls are longer). Descriptors
    # (major, minor, top, height, radius; m) divided by segment_descriptor_scale are
    # matched to earlier submaps' (anchors within segment_search_radius, gated with
    # segment_overlap_radius, the closest max_segment_candidates) with a ratio test
    # (segment_ratio, segment_max_descriptor_distance); RANSAC (segment_ransac_*) on
    # matched centroids needs min_segment_matches inliers; the best consensus is refined
    # submap to submap and accepted like pose matching (segment_min_inlier_fraction).
    segments_enabled: bool = True
    segment_every: int = 4
    segment_submap_keyframes: int = 10
    segment_voxel: float = 0.1
    segment_max_height: float = 2.0
    segment_cluster_distance: float = 0.25
    segment_min_points: int = 20
    segment_min_extent: float = 0.1
    segment_max_extent: float = 2.0
    segment_descriptor_scale: list[float] = field(default_factory=lambda: [0.15, 0.15, 0.1, 0.1, 0.05])
    segment_ratio: float = 0.8
    segment_max_descriptor_distance: float = 2.0
    segment_ransac_iterations: int = 50
    segment_ransac_inlier_distance: float = 0.3
    min_segment_matches: int = 2
    segment_search_radius: float = 8.0
    segment_overlap_radius: float = 5.0
    max_segment_candidates: int = 4
    segment_min_inlier_fraction: float = 0.4
    # The verification registers the last segment_source_keyframes clouds (not the whole
    # rolling submap: less odometry distortion, faster) against the candidate's submap.
    segment_source_keyframes: int = 3

    # The `model` front end's acceptance rates and closure errors (slam.frontend=model only):
    # a file of scripts/calibrate_loop_closures.py; empty = conf/calibration/loop_closures.yaml,
    # a bare file name = that file in conf/calibration/. A fit holds for the keyframe spacing
    # it was made at (recorded in the file): refit with --set slam.keyframe_angle_deg=... .
    calibration_file: str = ""
    # The model's stand-in for the gate's "worth it" test: the relative pose of a pair next to
    # an accepted closure grows this uncertain per keyframe of index distance. Chosen so that
    # the model's closure counts match icp's on the office tours (benchmarks/study_keyframes.py;
    # at 0.5 m / 15 deg icp 22-28 per tour, mean 24.8: 0.009/0.08 gave mean 24, 0.008/0.07
    # 19, 0.012/0.1 41). Wider keyframe spacing -> larger steps (slam=model_45deg: 0.012).
    model_step_sigma_translation: float = 0.009
    model_step_sigma_rotation_deg: float = 0.08


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
    loop_closure: LoopClosureConfig = field(default_factory=LoopClosureConfig)


def calibration_dir() -> Path:
    """The front ends' calibration files (``conf/calibration/``: the repository's or the wheel's)."""
    return conf_dir() / "calibration"


def calibration_path(name: str, default: str) -> Path:
    """A ``calibration_file`` config value as a path: empty = ``default`` in ``conf/calibration/``, a bare file
    name = that file in ``conf/calibration/``, anything else as given."""
    path = Path(name or default)
    return calibration_dir() / path if path.parent == Path(".") else path


def loop_closures_path(name: str) -> Path:
    """``slam.loop_closure.calibration_file`` as a path (default ``conf/calibration/loop_closures.yaml``)."""
    return calibration_path(name, "loop_closures.yaml")


def scan_matching_path(name: str) -> Path:
    """``slam.scan_matcher.calibration_file`` as a path (default ``conf/calibration/scan_matching.yaml``)."""
    return calibration_path(name, "scan_matching.yaml")
