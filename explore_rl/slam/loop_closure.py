"""Loop closures of the icp front end: pose matching and segment matching, gated and verified.

For each new keyframe ``j`` (:meth:`IcpLoopCloser.process`, after its odometry/SSM update):

**Pose matching** (factor kind ``pose_matching``)

1. *Candidates*: earlier keyframes whose current estimate lies within ``search_radius``
   of the estimate of ``j``, with more than ``min_travel_gap`` metres of travel and
   ``min_index_gap`` keyframes in between and line of sight on the 2D map; the closest
   of each run of nearby indices, at most ``max_candidates``.
2. *Gate* on the 12x12 joint marginal of (candidate, current), turned into the
   covariance of their relative pose (:func:`relative_covariance`): register only if
   the true distance could be within ``overlap_radius`` (one-sided chi-square at
   ``gate_probability``), the relative pose is certain enough for the starts to reach
   it, and uncertain enough for a closure to be worth its cost.
3. *Registration* (:class:`Verifier`) of the current cloud's structure points (walls,
   objects: the floor fits any horizontal shift) against the candidate and a few
   neighbours placed at their current estimates in the candidate's frame: kiss-icp
   point-to-point ICP from the estimate and, when uncertain, a few offsets; the distinct
   results are scored by inliers and the best gets the scan matcher's point-to-plane
   refinement and KD-tree quality measures.
4. *Acceptance* on measured quality: inlier fraction, point-to-plane residual, the
   planar information eigenvalues (how well constrained: one weak direction may keep
   the prior, with an inflated covariance), no comparable solution elsewhere (ambiguity)
   and a correction consistent with the joint marginal (chi-square). The factor is
   robust (Cauchy, ``pose_graph.loop_robust_*``).

**Segment matching** (factor kind ``segment_matching``, :mod:`explore_rl.slam.segments`):
every ``segment_every`` keyframes the structure points of a rolling submap (the last
``segment_submap_keyframes`` keyframes) are clustered into object-like segments
described by their shape and stored under that keyframe. Earlier submaps near the
current estimate (gated like pose matching) are matched with a ratio test; a 2D rigid
transform from matched centroids must be confirmed by RANSAC; the best consensus is
refined on the clouds (from the RANSAC transform, not the estimate) and accepted like
pose matching.

Every candidate that reaches the gate is logged as a :class:`LoopClosureAttempt` in
:attr:`IcpLoopCloser.attempts`, with the true error of the measurement (keyframes carry
``true_pose``); :func:`write_attempts_csv` exports them. These are the statistics
``scripts/calibrate_loop_closures.py`` fits ``r_lc`` and the acceptance rates from.
:meth:`IcpLoopCloser.process` never raises: failures are logged and skipped.
"""

from __future__ import annotations

import csv
import dataclasses
import logging
import time
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Iterable

import gtsam
import numpy as np
from kiss_icp.mapping import VoxelHashMap
from kiss_icp.registration import Registration
from kiss_icp.voxelization import voxel_down_sample
from scipy.stats import chi2

from explore_rl.geometry import matrix_to_se2, se2_between, se2_compose, se2_to_matrix, transform_points
from explore_rl.mapping.visibility import line_of_sight
from explore_rl.slam import segments as seg
from explore_rl.slam.config import LoopClosureConfig, ScanMatcherConfig

# Shared with the scan matcher on purpose (one implementation of the normals, the
# point-to-plane system, its refinement and its covariance).
from explore_rl.slam.frontend import PLANAR, Linearisation, LocalMap, ScanMatcher

if TYPE_CHECKING:
    from explore_rl.slam.session import SlamSession

log = logging.getLogger(__name__)

POSE_MATCHING = "pose_matching"
SEGMENT_MATCHING = "segment_matching"
SOURCES = (POSE_MATCHING, SEGMENT_MATCHING)

__all__ = [
    "LoopClosureConfig",
    "LoopClosureAttempt",
    "IcpLoopCloser",
    "Verifier",
    "POSE_MATCHING",
    "SEGMENT_MATCHING",
    "SOURCES",
    "relative_covariance",
    "write_attempts_csv",
    "read_attempts_csv",
]


# ---------------------------------------------------------------------------- records


@dataclass
class LoopClosureAttempt:
    """One loop-closure candidate that reached the gate, and what became of it.

    Distances are between the planar positions of the two keyframes. Errors compare a
    relative pose ``T_candidate^-1 T_query`` with the true one: ``prior_error_*`` the
    estimate before the attempt, ``error_*`` the measurement (the factor's, if accepted;
    nan if nothing was measured).
    """

    source: str  # pose_matching | segment_matching
    query: int  # the current keyframe
    candidate: int  # the earlier keyframe (segment matching: the earlier submap's anchor)
    distance: float  # m, between the current estimates (what predict_revisits sees)
    true_distance: float  # m, between the true poses
    travel_gap: float  # m of travel between them
    sigma_translation: float  # m, largest std of the estimated relative position
    sigma_rotation_deg: float  # std of the estimated relative yaw
    gate_d2: float  # one-sided chi-square statistic of the distance gate
    registered: bool  # whether a registration ran
    accepted: bool
    reason: str  # "accepted" or why not (see IcpLoopCloser.gate, Verifier.judge)
    prior_error_translation: float  # m
    prior_error_rotation_deg: float
    error_translation: float  # m
    error_rotation_deg: float
    inlier_fraction: float = float("nan")
    residual_rms: float = float("nan")  # m, point-to-plane
    min_information: float = float("nan")  # smallest planar information eigenvalue
    weak_directions: int = 0
    runner_up: float = 0.0  # inliers of the best clearly different start / the best's
    matches: int = 0  # segment matching: RANSAC-consistent segment matches
    ms: float = 0.0  # wall time spent on this candidate (gate, registration, factor)


ATTEMPT_FIELDS = [f.name for f in fields(LoopClosureAttempt)]


def write_attempts_csv(attempts: Iterable[LoopClosureAttempt], path: str | Path) -> Path:
    """Write attempt records as CSV (one row each, columns :data:`ATTEMPT_FIELDS`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=ATTEMPT_FIELDS)
        writer.writeheader()
        for attempt in attempts:
            writer.writerow(dataclasses.asdict(attempt))
    return path


def read_attempts_csv(path: str | Path) -> list[LoopClosureAttempt]:
    """Read records written by :func:`write_attempts_csv`."""
    convert = {"str": str, "int": int, "float": float, "bool": lambda s: s == "True"}
    types = {f.name: convert[f.type] for f in fields(LoopClosureAttempt)}
    with Path(path).open() as f:
        return [LoopClosureAttempt(**{k: types[k](v) for k, v in row.items()}) for row in csv.DictReader(f)]


# ---------------------------------------------------------------------------- geometry


def relative_covariance(joint: np.ndarray, relative: np.ndarray) -> np.ndarray:
    """6x6 covariance of ``T_i^-1 T_j`` (right perturbation, body frame of ``j``) from the
    12x12 joint marginal of ``(i, j)``: ``J Sigma J^T`` with ``J = [-Ad(T_ij^-1), I]``."""
    adjoint = gtsam.Pose3(np.linalg.inv(relative)).AdjointMap()
    J = np.hstack([-adjoint, np.eye(6)])
    return J @ joint @ J.T


def closest_separated(indices: np.ndarray, distance: np.ndarray, separation: int,
                      limit: int | None = None) -> list[int]:
    """Keyframe ``indices`` closest first (``distance`` of each, stable order), leaving out
    any within ``separation`` indices of one already taken: one candidate per run of
    neighbouring keyframes. Stops after ``limit`` (None: all)."""
    taken: list[int] = []
    if not len(indices):
        return taken
    near_taken = np.zeros(int(np.max(indices)) + 1, dtype=bool)
    for i in np.asarray(indices)[np.argsort(distance, kind="stable")].tolist():
        if near_taken[i]:
            continue
        taken.append(i)
        near_taken[max(i - separation + 1, 0): i + separation] = True
        if limit is not None and len(taken) >= limit:
            break
    return taken


def planar(T: np.ndarray) -> np.ndarray:
    """``[x, y, yaw]`` of a 4x4 transform."""
    return matrix_to_se2(T)


def planar_error(measured: np.ndarray, true: np.ndarray) -> tuple[float, float]:
    """Translation (m) and |yaw| (deg) of ``true^-1 measured`` (planar ``[x, y, yaw]``)."""
    d = se2_between(true, measured)
    return float(np.hypot(d[0], d[1])), float(np.rad2deg(abs(d[2])))


def tangent(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(yaw, x, y)`` of ``a^-1 b`` (planar poses): the planar block of Pose3's tangent."""
    d = se2_between(a, b)
    return np.array([d[2], d[0], d[1]])


def keep_prior_along(weak: np.ndarray, prior: np.ndarray, solution: np.ndarray) -> np.ndarray:
    """``solution`` with its difference from ``prior`` removed along the columns of
    ``weak`` (unit ``(yaw, x, y)`` tangent directions)."""
    xi = tangent(prior, solution)
    xi = xi - weak @ (weak.T @ xi)
    return se2_compose(prior, np.array([xi[1], xi[2], xi[0]]))


# ---------------------------------------------------------------------------- verification


@dataclass
class Solution:
    """One registration result; the best one also carries its refined system."""

    relative: np.ndarray  # planar [x, y, yaw] of T_target^-1 T_source
    n_source: int
    score: int  # source points with a target point within inlier_distance (after ICP)
    system: Linearisation | None = None  # point-to-plane system after refinement
    weak: np.ndarray | None = None  # set by Verifier.judge: weak planar directions (mask)
    eigen: tuple[np.ndarray, np.ndarray] | None = None  # planar information eigenpairs

    @property
    def inlier_fraction(self) -> float:
        return self.system.n_inliers / max(self.n_source, 1) if self.system else 0.0

    @property
    def residual_rms(self) -> float:
        return float(np.sqrt(self.system.residual_var)) if self.system else float("nan")


@dataclass
class Verdict:
    """What :meth:`Verifier.judge` concluded."""

    solution: Solution | None  # the best solution (None: nothing registered)
    reason: str  # "ok" or why the solution is refused
    min_information: float = float("nan")
    weak_directions: int = 0
    runner_up: float = 0.0  # score ratio of the best clearly different solution

    @property
    def ok(self) -> bool:
        return self.reason == "ok"


class Target:
    """Keyframe clouds joined in one frame: a kiss-icp voxel map (point-to-point ICP) and
    the scan matcher's KD-tree with oriented normals (refinement, quality)."""

    def __init__(self, clouds: list[np.ndarray], origins: list[np.ndarray], config: LoopClosureConfig,
                 matcher_config: ScanMatcherConfig):
        clouds = [c for c in clouds if len(c)]
        points = np.vstack(clouds) if clouds else np.zeros((0, 3))
        self.n_points = len(points)
        self.voxels = VoxelHashMap(config.icp_voxel, 1e3, config.icp_points_per_voxel)
        self.local: LocalMap | None = None
        if len(points) >= matcher_config.normal_neighbors:
            viewpoints = np.vstack([np.broadcast_to(o, c.shape) for c, o in zip(clouds, origins)])
            self.voxels.add_points(points)
            self.local = LocalMap(points, viewpoints, matcher_config)


class Verifier:
    """Registers a source cloud against a :class:`Target` from several starts and judges
    the result (shared by pose and segment matching). Poses are planar ``[x, y, yaw]``."""

    def __init__(self, config: LoopClosureConfig, matcher_config: ScanMatcherConfig):
        self.config = config
        # The scan matcher's refinement, quality measures and covariance, with the
        # loop-closure thresholds (the quality gates themselves are applied in judge()).
        loop = dict(
            inlier_distance=config.inlier_distance,
            min_inlier_fraction=0.0,
            min_inliers=config.min_inliers,
            refine_iterations=config.refine_iterations,
            min_information=config.min_information,
            weak_sigma=config.weak_sigma,
            min_sigma_translation=config.sigma_translation,
            min_sigma_rotation_deg=config.sigma_rotation_deg,
            off_plane_sigma=config.off_plane_sigma,
        )
        self.matcher_config = dataclasses.replace(matcher_config, **loop)
        self.matcher = ScanMatcher(self.matcher_config)
        self.registration = Registration(config.icp_iterations, 1e-4, 1)

    def target(self, clouds: list[np.ndarray], origins: list[np.ndarray]) -> Target:
        """A target from sensor-frame-height clouds already placed in the target frame."""
        thinned = [voxel_down_sample(c, self.config.submap_voxel) if len(c) else c for c in clouds]
        return Target(thinned, origins, self.config, self.matcher_config)

    def register(self, source: np.ndarray, target: Target, starts: list[np.ndarray]) -> list[Solution]:
        """kiss-icp from each start; distinct results scored by inliers, best first; the
        best one refined (point-to-plane) with its system. Empty if nothing to match."""
        cfg = self.config
        if target.local is None or len(source) == 0:
            return []
        coarse = voxel_down_sample(source, cfg.icp_source_voxel)
        sigma = cfg.icp_threshold
        aligned: list[np.ndarray] = []
        for start in starts:
            pose = self.registration.align_points_to_map(
                points=coarse, voxel_map=target.voxels, initial_guess=se2_to_matrix(start),
                max_correspondance_distance=3.0 * sigma, kernel=sigma / 3.0)
            if not np.all(np.isfinite(pose)):
                continue
            pose = planar(pose)  # the graph is planar
            if not any(self._same(pose, other) for other in aligned):
                aligned.append(pose)
        solutions = [Solution(pose, len(source), self._count_inliers(target, source, pose))
                     for pose in aligned]
        solutions.sort(key=lambda s: -s.score)
        if solutions:
            best = solutions[0]
            refined, best.system = self.matcher.refine(target.local, source, se2_to_matrix(best.relative))
            best.relative = planar(refined)
        return solutions

    def judge(self, solutions: list[Solution], prior: np.ndarray, prior_covariance: np.ndarray,
              min_inlier_fraction: float | None = None) -> Verdict:
        """Whether the best solution is acceptable (``reason == "ok"``), else why not.

        ``prior`` is the relative pose the match started from and ``prior_covariance``
        its 3x3 ``(yaw, x, y)`` covariance. Planar directions with less information than
        ``min_information`` are *weak*: at most ``max_weak_directions``, along which the
        prior's std moves the position by at most ``max_weak_prior_sigma`` and the yaw by
        at most ``max_weak_prior_sigma_rotation_deg``; the solution then keeps the prior
        along them (its covariance is ``weak_sigma`` there). Another start's result that
        differs along the strong directions and has at least ``ambiguity_ratio`` of the
        best's inliers makes the match ambiguous.
        """
        cfg = self.config
        if not solutions or solutions[0].system is None:
            return Verdict(solutions[0] if solutions else None, "no_overlap")
        best = solutions[0]
        values, vectors = np.linalg.eigh(best.system.information[np.ix_(PLANAR, PLANAR)])
        weak = values < cfg.min_information
        best.weak, best.eigen = weak, (values, vectors)
        verdict = Verdict(best, "ok", float(values[0]), int(weak.sum()))
        strong = vectors[:, ~weak]
        for other in solutions[1:]:
            d = strong @ (strong.T @ tangent(best.relative, other.relative))
            if np.hypot(d[1], d[2]) > cfg.ambiguity_translation or \
                    np.rad2deg(abs(d[0])) > cfg.ambiguity_rotation_deg:
                verdict.runner_up = max(verdict.runner_up, other.score / max(best.score, 1))
        limit = cfg.min_inlier_fraction if min_inlier_fraction is None else min_inlier_fraction
        if verdict.runner_up >= cfg.ambiguity_ratio:
            verdict.reason = "ambiguous"
        elif best.inlier_fraction < limit:
            verdict.reason = "inlier_fraction"
        elif best.residual_rms > cfg.max_residual:
            verdict.reason = "residual"
        elif weak.sum() > cfg.max_weak_directions:
            verdict.reason = "weakly_constrained"
        elif weak.any():
            # Keeping the prior along w leaves its error there: std sigma_w along the unit
            # (yaw, x, y) vector w, i.e. sigma_w |w_yaw| of yaw, sigma_w |w_xy| of position.
            w = vectors[:, weak]
            sigma_w = np.sqrt(np.einsum("ik,ij,jk->k", w, prior_covariance, w))
            yaw = sigma_w * np.abs(w[0])
            position = sigma_w * np.hypot(w[1], w[2])
            if np.any(position > cfg.max_weak_prior_sigma) or \
                    np.any(yaw > np.deg2rad(cfg.max_weak_prior_sigma_rotation_deg)):
                verdict.reason = "weak_and_uncertain"
            else:
                best.relative = keep_prior_along(w, prior, best.relative)
        return verdict

    def covariance(self, solution: Solution) -> np.ndarray:
        """6x6 factor covariance: the scan matcher's (residual variance x inverse planar
        information, ``weak_sigma`` along weak directions) plus the loop-factor floors."""
        values, vectors = solution.eigen
        return self.matcher.covariance(solution.system, values, vectors, solution.weak)

    def _same(self, a: np.ndarray, b: np.ndarray) -> bool:
        t, r = planar_error(a, b)
        return t <= self.config.duplicate_translation and r <= self.config.duplicate_rotation_deg

    def _count_inliers(self, target: Target, source: np.ndarray, pose: np.ndarray) -> int:
        dist, _ = target.local.tree.query(transform_points(se2_to_matrix(pose), source),
                                          distance_upper_bound=self.config.inlier_distance)
        return int(np.isfinite(dist).sum())


# ---------------------------------------------------------------------------- the loop closer


@dataclass
class Pair:
    """The gate's view of a (candidate, query) pair."""

    candidate: int
    query: int
    relative: np.ndarray  # planar estimate of T_candidate^-1 T_query
    covariance: np.ndarray  # 3x3 (yaw, x, y) of the relative pose, body frame of the query
    travel_gap: float
    gate_d2: float = float("nan")

    @property
    def distance(self) -> float:
        return float(np.hypot(self.relative[0], self.relative[1]))

    @property
    def sigma_translation(self) -> float:
        return float(np.sqrt(np.linalg.eigvalsh(self.covariance[1:, 1:])[-1]))

    @property
    def sigma_rotation_deg(self) -> float:
        return float(np.rad2deg(np.sqrt(self.covariance[0, 0])))


class IcpLoopCloser:
    """Pose-matching and segment-matching loop closures for a :class:`SlamSession` (icp).

    ``process(session)`` reads ``session.keyframes`` (``travel``, ``cloud`` in the sensor
    frame, ``true_pose`` for the logs), ``session.graph`` and, with ``line_of_sight``,
    ``session.occupancy``/``session.scene``; ``mount_height`` defaults to the session's
    LiDAR mount height (clouds are in the sensor frame, ``mount_height`` above the floor).
    """

    def __init__(self, config: LoopClosureConfig, matcher_config: ScanMatcherConfig | None = None,
                 mount_height: float | None = None):
        self.config = config
        self.matcher_config = matcher_config or ScanMatcherConfig()
        self.mount_height = mount_height
        self.attempts: list[LoopClosureAttempt] = []
        self.closures: dict[str, int] = {s: 0 for s in SOURCES}
        self.failures = 0  # exceptions caught (and logged) by process()
        # Segment matching: the segments of each segmented rolling submap, by its anchor
        # (newest) keyframe, in the anchor's frame.
        self.segment_sets: dict[int, list[seg.Segment]] = {}
        self._setup()

    def _setup(self) -> None:
        self.verifier = Verifier(self.config, self.matcher_config)
        self._gate_chi2 = float(chi2.ppf(self.config.gate_probability, 1))
        self._consistency_chi2 = float(chi2.ppf(self.config.consistency_probability, 3))
        self._rng = np.random.default_rng(0)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        for name in ("verifier", "_gate_chi2", "_consistency_chi2", "_rng"):
            state.pop(name)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._setup()

    # ------------------------------------------------------------------ entry point

    def process(self, session: SlamSession) -> int:
        """Look for loop closures of the newest keyframe, add the accepted ones to the
        graph, return how many. Never raises (a failure is logged and counted)."""
        if not self.config.enabled:
            return 0
        try:
            return self._process(session)
        except Exception:  # noqa: BLE001 - a loop closure must never stop a run
            n = len(getattr(session, "keyframes", []))
            log.exception("loop closure failed at keyframe %d; skipped", n - 1)
            self.failures += 1
            return 0

    def _process(self, session: SlamSession) -> int:
        if len(session.keyframes) < 2:
            return 0
        if self.mount_height is None:
            self.mount_height = session.lidar.config.mount_height
        budget = [self.config.max_attempts_per_keyframe]  # registrations left (shared)
        added = self._pose_matching(session, budget)
        if self.config.segments_enabled and added < self.config.max_closures_per_keyframe:
            added += self._segment_matching(session, budget)
        return added

    # ------------------------------------------------------------------ candidates & gate

    def candidates(self, session: SlamSession) -> list[int]:
        """Earlier keyframes to gate for the newest one (closest estimate first)."""
        cfg = self.config
        j = len(session.keyframes) - 1
        poses = session.graph.poses_se2()
        travel = np.array([k.travel for k in session.keyframes])
        distance = np.hypot(*(poses[:, :2] - poses[j, :2]).T)
        ok = (distance <= cfg.search_radius) & (travel[j] - travel >= cfg.min_travel_gap)
        ok &= np.arange(len(poses)) <= j - cfg.min_index_gap
        indices = np.flatnonzero(ok)
        picked = closest_separated(indices, distance[indices], cfg.candidate_separation)
        if cfg.line_of_sight and picked:
            clear = self._line_of_sight(session, poses[j], poses[picked])
            picked = [i for i, c in zip(picked, clear) if c]
        return picked[: cfg.max_candidates]

    @staticmethod
    def _line_of_sight(session: SlamSession, here: np.ndarray, there: np.ndarray) -> np.ndarray:
        """No known-occupied cell between ``here`` and each of ``there`` (2D map)."""
        there = np.atleast_2d(there)
        return line_of_sight(np.broadcast_to(here[:2], (len(there), 2)), there[:, :2],
                             session.occupancy.known_occupied, session.scene.grid, 0.5)

    def pair(self, session: SlamSession, i: int, j: int) -> Pair:
        """Estimated relative pose of ``j`` from ``i`` and its planar covariance."""
        graph = session.graph
        relative = np.linalg.inv(graph.pose(i)) @ graph.pose(j)
        covariance = relative_covariance(graph.joint_marginal_covariance(i, j), relative)
        travel = session.keyframes[j].travel - session.keyframes[i].travel
        return Pair(i, j, planar(relative), covariance[np.ix_(PLANAR, PLANAR)], travel)

    def gate(self, pair: Pair, overlap_radius: float | None = None, starts: bool = True) -> str:
        """``"ok"``, or why the pair is not registered:

        * ``gate_far``: even at ``gate_probability`` the true distance cannot be within
          the overlap radius (one-sided chi-square along the estimated direction);
        * ``gate_uncertain`` (``starts``: the registration starts from the estimate):
          the relative pose is too uncertain for the starts to reach it;
        * ``not_worth``: it is already known better than a closure would tell.
        """
        cfg = self.config
        overlap = cfg.overlap_radius if overlap_radius is None else overlap_radius
        # Position of the query in the candidate's frame and its covariance.
        c, s = np.cos(pair.relative[2]), np.sin(pair.relative[2])
        R = np.array([[c, -s], [s, c]])
        covariance = R @ pair.covariance[1:, 1:] @ R.T
        distance = pair.distance
        pair.gate_d2 = 0.0
        if distance > overlap:
            u = pair.relative[:2] / distance
            pair.gate_d2 = (distance - overlap) ** 2 / float(u @ covariance @ u)
        if pair.gate_d2 > self._gate_chi2:
            return "gate_far"
        if starts and (pair.sigma_translation > cfg.max_sigma_translation
                       or pair.sigma_rotation_deg > cfg.max_sigma_rotation_deg):
            return "gate_uncertain"
        if (pair.sigma_translation < cfg.min_sigma_translation
                and pair.sigma_rotation_deg < cfg.min_sigma_rotation_deg):
            return "not_worth"
        return "ok"

    # ------------------------------------------------------------------ pose matching

    def _pose_matching(self, session: SlamSession, budget: list[int]) -> int:
        cfg = self.config
        j = len(session.keyframes) - 1
        candidates = self.candidates(session)
        if not candidates:
            return 0
        source = self._structure(session.keyframes[j].cloud)
        added = 0
        for i in candidates:
            if added >= cfg.max_closures_per_keyframe:
                break
            start = time.perf_counter()
            pair = self.pair(session, i, j)
            record = self._record(POSE_MATCHING, session, pair, self.gate(pair))
            if record.reason == "ok" and budget[0] <= 0:
                record.reason = "budget"
            elif record.reason == "ok" and len(source) < cfg.min_structure_points:
                record.reason = "no_structure"
            elif record.reason == "ok":
                budget[0] -= 1
                target = self.verifier.target(*self._clouds_around(session, i, j))
                solutions = self.verifier.register(source, target, self._starts(pair))
                added += self._conclude(session, record, pair, solutions)
            record.ms = (time.perf_counter() - start) * 1e3
            self.attempts.append(record)
        return added

    def _starts(self, pair: Pair) -> list[np.ndarray]:
        """The estimated relative pose and, if it is uncertain, ``guess_offsets`` around
        it (``[dx, dy, dyaw_deg]`` in the query's frame)."""
        cfg = self.config
        starts = [pair.relative]
        if (pair.sigma_translation >= cfg.guess_offset_min_sigma
                or pair.sigma_rotation_deg >= cfg.guess_offset_min_sigma_rotation_deg):
            starts += [se2_compose(pair.relative, np.array([dx, dy, np.deg2rad(dyaw)]))
                       for dx, dy, dyaw in cfg.guess_offsets]
        return starts

    def _structure(self, cloud: np.ndarray) -> np.ndarray:
        """Points of a sensor-frame cloud above ``ground_height`` (walls, objects), thinned."""
        points = np.asarray(cloud, float).reshape(-1, 3)
        points = points[np.all(np.isfinite(points), axis=1)]
        points = points[points[:, 2] + self.mount_height > self.config.ground_height]
        return voxel_down_sample(points, self.config.source_voxel) if len(points) else points

    def _clouds_around(self, session: SlamSession, i: int, j: int) -> tuple[list, list]:
        """Clouds of keyframe ``i`` and ``submap_keyframes`` neighbours each side (none
        within ``min_index_gap`` of ``j``) in the frame of ``i``, and their origins."""
        cfg = self.config
        lo = max(0, i - cfg.submap_keyframes)
        hi = min(j - cfg.min_index_gap, i + cfg.submap_keyframes)
        return self._clouds_in_frame_of(session, i, range(lo, hi + 1))

    @staticmethod
    def _clouds_in_frame_of(session: SlamSession, frame: int, indices: Iterable[int]) -> tuple[list, list]:
        poses = session.graph.poses_se2()
        clouds, origins = [], []
        for k in indices:
            cloud = session.keyframes[k].cloud
            if len(cloud):
                T = se2_to_matrix(se2_between(poses[frame], poses[k]))
                clouds.append(transform_points(T, cloud))
                origins.append(T[:3, 3].copy())
        return clouds, origins

    # ------------------------------------------------------------------ acceptance

    def _conclude(self, session: SlamSession, record: LoopClosureAttempt, pair: Pair,
                  solutions: list[Solution], prior: np.ndarray | None = None,
                  prior_covariance: np.ndarray | None = None,
                  min_inlier_fraction: float | None = None) -> int:
        """Judge a registration, fill ``record``, add the factor if accepted (1) or not (0).

        ``prior``/``prior_covariance`` (default: the graph's estimate of the pair) are
        what the registration started from (weak directions fall back to it)."""
        record.registered = True
        verdict = self.verifier.judge(
            solutions, pair.relative if prior is None else prior,
            pair.covariance if prior_covariance is None else prior_covariance, min_inlier_fraction)
        best, reason = verdict.solution, verdict.reason
        record.min_information, record.weak_directions = verdict.min_information, verdict.weak_directions
        record.runner_up = verdict.runner_up
        if best is not None and best.system is not None:
            record.inlier_fraction, record.residual_rms = best.inlier_fraction, best.residual_rms
            truth = se2_between(session.keyframes[pair.candidate].true_pose,
                                session.keyframes[pair.query].true_pose)
            record.error_translation, record.error_rotation_deg = planar_error(best.relative, truth)
        if reason == "ok":
            covariance = self.verifier.covariance(best)
            if not self._consistent(pair, best.relative, covariance):
                reason = "inconsistent"
        record.reason = reason
        if reason != "ok" or self.config.dry_run:
            return 0
        session.graph.add_loop_closure(pair.candidate, pair.query, se2_to_matrix(best.relative),
                                       covariance, record.source)
        record.accepted, record.reason = True, "accepted"
        self.closures[record.source] += 1
        return 1

    def _consistent(self, pair: Pair, measured: np.ndarray, covariance: np.ndarray) -> bool:
        """Chi-square (3 dof, ``consistency_probability``) of the correction from the
        estimate to the measurement under joint marginal + factor covariance."""
        xi = tangent(pair.relative, measured)
        total = pair.covariance + covariance[np.ix_(PLANAR, PLANAR)]
        return float(xi @ np.linalg.solve(total, xi)) <= self._consistency_chi2

    def _record(self, source: str, session: SlamSession, pair: Pair, reason: str) -> LoopClosureAttempt:
        truth = se2_between(session.keyframes[pair.candidate].true_pose, session.keyframes[pair.query].true_pose)
        prior_t, prior_r = planar_error(pair.relative, truth)
        return LoopClosureAttempt(
            source=source, query=pair.query, candidate=pair.candidate, distance=pair.distance,
            true_distance=float(np.hypot(truth[0], truth[1])), travel_gap=pair.travel_gap,
            sigma_translation=pair.sigma_translation, sigma_rotation_deg=pair.sigma_rotation_deg,
            gate_d2=pair.gate_d2, registered=False, accepted=False, reason=reason,
            prior_error_translation=prior_t, prior_error_rotation_deg=prior_r,
            error_translation=float("nan"), error_rotation_deg=float("nan"),
        )

    # ------------------------------------------------------------------ segment matching

    def _segment_matching(self, session: SlamSession, budget: list[int]) -> int:
        """Every ``segment_every`` keyframes: segment the rolling submap, match it against
        earlier submaps, register the best RANSAC consensus, judge it like pose matching."""
        cfg = self.config
        j = len(session.keyframes) - 1
        if j % cfg.segment_every or j + 1 < cfg.segment_submap_keyframes:
            return 0
        segments = self.segment(session, j)
        self.segment_sets[j] = segments
        if len(segments) < cfg.min_segment_matches:
            return 0
        consensus = []
        for i in self._segment_candidates(session, j):
            start = time.perf_counter()
            pair = self.pair(session, i, j)
            record = self._record(SEGMENT_MATCHING, session, pair,
                                  self.gate(pair, cfg.segment_overlap_radius, starts=False))
            if record.reason == "ok":
                transform, record.matches = self._match_segments(segments, self.segment_sets[i])
                if transform is None:
                    record.reason = "no_consensus"
                else:
                    consensus.append((record, pair, transform))
            record.ms = (time.perf_counter() - start) * 1e3
            self.attempts.append(record)
        if not consensus:
            return 0
        # Register only the largest consensus (ties: the closest).
        consensus.sort(key=lambda c: (-c[0].matches, c[1].distance))
        for record, _, _ in consensus[1:]:
            record.reason = "outscored"
        record, pair, transform = consensus[0]
        if budget[0] <= 0:
            record.reason = "budget"
            return 0
        budget[0] -= 1
        start = time.perf_counter()
        recent = range(max(0, j - cfg.segment_source_keyframes + 1), j + 1)
        clouds, _ = self._clouds_in_frame_of(session, j, recent)
        source = self._structure(np.vstack(clouds)) if clouds else np.zeros((0, 3))
        target = self.verifier.target(*self._clouds_in_frame_of(session, pair.candidate,
                                                                self._rolling(pair.candidate)))
        solutions = self.verifier.register(source, target, [transform])
        spread = cfg.segment_ransac_inlier_distance
        added = self._conclude(session, record, pair, solutions, prior=transform,
                               prior_covariance=np.diag([np.deg2rad(5.0), spread, spread]) ** 2,
                               min_inlier_fraction=cfg.segment_min_inlier_fraction)
        record.ms += (time.perf_counter() - start) * 1e3
        return added

    def segment(self, session: SlamSession, j: int) -> list[seg.Segment]:
        """Object-like segments of the rolling submap of ``j`` (in its frame)."""
        cfg = self.config
        clouds, _ = self._clouds_in_frame_of(session, j, self._rolling(j))
        points = np.vstack(clouds) if clouds else np.zeros((0, 3))
        points = points + np.array([0.0, 0.0, self.mount_height])  # z above the floor
        return seg.segment_submap(points, cfg.ground_height, cfg.segment_max_height, cfg.segment_voxel,
                                  cfg.segment_cluster_distance, cfg.segment_min_points,
                                  cfg.segment_max_extent, cfg.segment_min_extent)

    def _rolling(self, j: int) -> range:
        return range(max(0, j - self.config.segment_submap_keyframes + 1), j + 1)

    def _match_segments(self, query: list[seg.Segment],
                        reference: list[seg.Segment]) -> tuple[np.ndarray | None, int]:
        """RANSAC transform (query frame -> reference frame) of descriptor matches and its
        number of inliers; ``None`` below ``min_segment_matches``."""
        cfg = self.config
        matches = seg.match_descriptors(query, reference, np.asarray(cfg.segment_descriptor_scale),
                                        cfg.segment_ratio, cfg.segment_max_descriptor_distance)
        if len(matches) < cfg.min_segment_matches:
            return None, 0
        q = np.array([query[a].centroid for a, _ in matches])
        r = np.array([reference[b].centroid for _, b in matches])
        transform, inliers = seg.ransac_rigid_2d(q, r, cfg.segment_ransac_inlier_distance,
                                                 cfg.segment_ransac_iterations, self._rng)
        count = int(inliers.sum())
        return (transform if count >= cfg.min_segment_matches else None), count

    def _segment_candidates(self, session: SlamSession, j: int) -> list[int]:
        """Earlier anchors near the current estimate, with enough travel between and no
        keyframe shared by the two submaps (closest first)."""
        cfg = self.config
        anchors = np.array([i for i in self.segment_sets
                            if i <= j - cfg.segment_submap_keyframes - cfg.min_index_gap], dtype=int)
        if len(anchors) == 0:
            return []
        poses = session.graph.poses_se2()
        gap = session.keyframes[j].travel - np.array([session.keyframes[i].travel for i in anchors])
        distance = np.hypot(*(poses[anchors, :2] - poses[j, :2]).T)
        ok = (distance <= cfg.segment_search_radius) & (gap >= cfg.min_travel_gap)
        anchors = anchors[ok][np.argsort(distance[ok], kind="stable")]
        return [int(i) for i in anchors[: cfg.max_segment_candidates]]
