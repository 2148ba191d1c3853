"""The EM planner (Wang et al.; paper Sec. II-B, III-C): the expert the learned policy imitates.

For every candidate frontier the planner forward-simulates SLAM along the candidate's
path and asks how much the virtual map's utility ``U = sum_l log det Sigma_l`` would drop:

1. predicted keyframes every ``slam.keyframe_distance`` along the path
   (:func:`~explore_rl.planning.revisits.sample_path`), chained to the last keyframe by
   odometry and scan-matching factors at their noise-free means with calibrated sigmas;
2. loop factors wherever :func:`~explore_rl.planning.revisits.predict_revisits` fires;
3. pose covariances: with a loop, on a copy of the live iSAM2 (``PoseGraph.copy``; the
   live graph is untouched) holding the predicted keyframes and loops; without one, old
   marginals are unchanged and the new ones follow from propagating the last keyframe's
   covariance along the chain (:func:`propagate_chain`) -- no copy needed;
4. the virtual map rebuilt from all poses gives ``U'``.

The choice is ``argmax U0 - U' - alpha * path_length``. Everything that does not depend
on the candidate -- old marginals, which landmarks each old pose sees and the Jacobians
of those observations (:class:`Observations`), ``U0`` -- is computed once per decision
(:class:`DecisionContext`); a loop candidate then only re-reads marginals and re-fuses.
The fast backend also carries each keyframe's observations over to the next decision
where its estimate and the walls near it did not change (:class:`ObservationCache`, exact).

Two backends (``planning.em.backend``): ``reference`` is the forward simulation above (an
iSAM2 copy per loop candidate, one ``marginalCovariance`` query per pose); ``fast`` (the
default) gets the same utilities from one factorisation of the live graph per decision,
loops as low-rank updates and one batched re-fusion for all candidates
(explore_rl/planning/em_fast.py; tolerance and evidence in tests/planning/test_em_fast.py).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from explore_rl.geometry import rotation_2d, se2_between, se2_to_matrix
from explore_rl.grid import GridSpec
from explore_rl.planning.actions import Action, PathPrediction, predict_path, select_actions
from explore_rl.planning.config import EMConfig, PlanningConfig
from explore_rl.planning.em_fast import (
    PLANAR,
    FastContext,
    FuseRounds,
    batch_observations,
    distinct,
    fast_world_covariances,
    fuse_batched,
    loop_update,
    step_tangent_covariances,
)
from explore_rl.planning.policies import PolicyConfig
from explore_rl.planning.reward import normalize_rewards, raw_reward
from explore_rl.planning.revisits import Revisit
from explore_rl.planning.virtual_map import (
    VirtualMap,
    fuse_in_order,
    lever_and_noise,
    measurement_noise,
    range_bearing_jacobians,
)
from explore_rl.robot import RobotConfig
from explore_rl.slam.frontend import ScanMatch
from explore_rl.slam.pose_graph import PoseGraph, key, odometry_covariance

if TYPE_CHECKING:
    from explore_rl.state import ExplorationState

log = logging.getLogger(__name__)

# Rows/columns (x, y, yaw) of gtsam's Pose3 tangent order (rx, ry, rz, tx, ty, tz).
PLANAR_TANGENT = [3, 4, 2]
# Slack when counting motion steps, so float error in a whole number of steps adds none.
STEP_SLACK = 1e-9


# ---------------------------------------------------------------------- noise models


def planar_pose3_covariance(sigma_translation: float, sigma_rotation_deg: float,
                            off_plane_sigma: float) -> np.ndarray:
    """6x6 diagonal covariance (Pose3 tangent order) from planar and off-plane sigmas."""
    yaw = np.deg2rad(sigma_rotation_deg)
    sigmas = [off_plane_sigma, off_plane_sigma, yaw, sigma_translation, sigma_translation, off_plane_sigma]
    return np.diag(np.square(sigmas))


def ssm_covariance(config: EMConfig) -> np.ndarray:
    return planar_pose3_covariance(config.ssm_sigma_translation, config.ssm_sigma_rotation_deg,
                                   config.off_plane_sigma)


def loop_covariance(config: EMConfig) -> np.ndarray:
    return planar_pose3_covariance(config.loop_sigma_translation, config.loop_sigma_rotation_deg,
                                   config.off_plane_sigma)


def predicted_ssm(relative_se2: np.ndarray, config: EMConfig) -> ScanMatch:
    """A noise-free scan-matching measurement of ``relative_se2`` with the predicted sigmas."""
    return ScanMatch(relative=se2_to_matrix(relative_se2), covariance=ssm_covariance(config),
                     degenerate=False, weak_directions=0, n_points=0, ms=0.0)


def step_covariances(graph: PoseGraph, steps: np.ndarray, config: EMConfig) -> np.ndarray:
    """``(P, 3, 3)`` body-frame (x, y, yaw) covariance of odometry and SSM fused per step.

    Both factors join the same poses at the same (noise-free) mean, so together they act
    as one factor with the summed information.
    """
    planar = np.ix_(PLANAR_TANGENT, PLANAR_TANGENT)
    ssm_info = np.linalg.inv(ssm_covariance(config)[planar])
    odom = np.stack([odometry_covariance(graph.config, int(n))[planar] for n in steps])
    return np.linalg.inv(np.linalg.inv(odom) + ssm_info)


def motion_steps(deltas: np.ndarray, robot: RobotConfig) -> np.ndarray:
    """Motion steps the robot needs for each relative motion ``(P, 3)``: distance steps
    plus in-place turn steps, at least one (the odometry sigmas scale with its sqrt)."""
    distance = np.hypot(deltas[:, 0], deltas[:, 1]) / robot.step_distance
    turn = np.abs(deltas[:, 2]) / np.deg2rad(robot.step_angle_deg)
    return np.maximum(np.ceil(distance - STEP_SLACK) + np.ceil(turn - STEP_SLACK), 1).astype(int)


def propagate_chain(start_cov: np.ndarray, start_pose: np.ndarray, poses: np.ndarray,
                    step_covs: np.ndarray) -> np.ndarray:
    """World-frame (x, y, yaw) covariances ``(P, 3, 3)`` of a chain of poses hanging off
    ``start_pose`` (covariance ``start_cov``) through relative-motion factors.

    Linearised SE(2) composition with the factor noise in the frame of each step's end
    pose (as gtsam's BetweenFactor): ``S_k = F S_{k-1} F^T + G Q_k G^T`` with ``F`` the
    lever of a yaw error at the previous pose and ``G = diag(R_k, 1)``. For a chain this
    is what the pose graph's marginals would be.
    """
    out = np.empty((len(poses), 3, 3))
    cov, previous = np.asarray(start_cov, float), np.asarray(start_pose, float)
    for k, pose in enumerate(poses):
        lever = np.eye(3)
        lever[0, 2] = -(pose[1] - previous[1])
        lever[1, 2] = pose[0] - previous[0]
        rotate = np.eye(3)
        rotate[:2, :2] = rotation_2d(float(pose[2]))
        cov = lever @ cov @ lever.T + rotate @ step_covs[k] @ rotate.T
        out[k], previous = cov, pose
    return out


# ---------------------------------------------------------------------- graph helpers


def world_covariances(graph: PoseGraph, poses: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` world-frame (x, y, yaw) marginals of keyframes at planar ``poses``.

    Same transform as ``PoseGraph.world_xy_yaw_covariance`` (world xy = R v, yaw = w_z
    for a planar pose), read straight from iSAM2 and rotated in one vectorised step
    (the per-pose wrapper's cache bookkeeping doubles the cost on graph copies).
    """
    marginals = np.stack([graph.isam.marginalCovariance(key(i)) for i in range(len(poses))])
    jac = np.zeros((len(poses), 3, 6))
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    jac[:, 0, 3], jac[:, 0, 4] = c, -s
    jac[:, 1, 3], jac[:, 1, 4] = s, c
    jac[:, 2, 2] = 1.0
    return jac @ marginals @ np.swapaxes(jac, 1, 2)


def pose_covariances(graph: PoseGraph, poses: np.ndarray, backend: str) -> tuple[np.ndarray, FastContext | None]:
    """``(N, 3, 3)`` world-frame (x, y, yaw) marginals of every keyframe: one iSAM2 query
    per pose (``reference``) or one factorisation of the graph (``fast``, which also
    returns the factorisation for EM's candidates). If the factorisation fails (a
    singular or unexpected system) this decision falls back to the reference, logged."""
    if backend == "fast":
        try:
            return fast_world_covariances(graph, poses)
        except (RuntimeError, ValueError, np.linalg.LinAlgError) as error:
            log.warning("fast EM marginals failed at %d poses (%s); this decision uses the reference backend",
                        len(poses), error)
    return world_covariances(graph, poses), None


@dataclass
class PredictedPath:
    """The keyframes a candidate's path would add, chained to the last live keyframe."""

    poses: np.ndarray  # (P, 3) predicted keyframe poses [x, y, yaw]
    travel: np.ndarray  # (P,) travel from the robot's current pose to each
    deltas: np.ndarray  # (P, 3) body-frame motion from the previous keyframe (live or predicted)
    steps: np.ndarray  # (P,) motion steps per delta
    revisits: list[Revisit]

    def __len__(self) -> int:
        return len(self.poses)


def simulate_graph(graph: PoseGraph, old_poses: np.ndarray, predicted: PredictedPath,
                   config: EMConfig) -> PoseGraph:
    """A copy of ``graph`` with the predicted keyframes and loop factors added."""
    copy = graph.copy()
    first = copy.num_poses
    for delta, steps in zip(predicted.deltas, predicted.steps):
        copy.add_keyframe(se2_to_matrix(delta), int(steps), predicted_ssm(delta, config))
    for revisit in predicted.revisits:
        relative = se2_between(old_poses[revisit.keyframe_index], predicted.poses[revisit.path_index])
        copy.add_loop_closure(revisit.keyframe_index, first + revisit.path_index,
                              se2_to_matrix(relative), loop_covariance(config), config.loop_kind)
    return copy


# ---------------------------------------------------------------------- virtual-map observations


@dataclass
class Observations:
    """Virtual-map observations of fixed (pose, landmark) pairs, Jacobians precomputed.

    A landmark seen from a pose with covariance ``S`` gets ``H_l^-1 (R + H_x S H_x^T)
    H_l^-T = noise + gain S gain^T`` (:func:`landmark_covariance_from_pose`), so only the
    pose covariances change between candidates.
    """

    pose_idx: np.ndarray  # (M,) in pose order
    landmark_idx: np.ndarray  # (M,)
    gain: np.ndarray  # (M, 2, 3) H_l^-1 H_x
    noise: np.ndarray  # (M, 2, 2) H_l^-1 R H_l^-T

    @classmethod
    def of(cls, vmap: VirtualMap, poses: np.ndarray, blocked: np.ndarray) -> Observations:
        return cls.of_pairs(vmap, poses, *vmap.visible_pairs(poses, blocked))

    @classmethod
    def of_pairs(cls, vmap: VirtualMap, poses: np.ndarray, pose_idx: np.ndarray,
                 landmark_idx: np.ndarray) -> Observations:
        """The observations of given (pose, landmark) pairs (in pose order)."""
        h_x, h_l = range_bearing_jacobians(poses[pose_idx], vmap.landmark_xy[landmark_idx],
                                           vmap.config.min_range)
        h_l_inv = np.linalg.inv(h_l)
        noise = h_l_inv @ measurement_noise(vmap.config) @ np.swapaxes(h_l_inv, 1, 2)
        return cls(pose_idx, landmark_idx, h_l_inv @ h_x, noise)

    @classmethod
    def closed_form(cls, vmap: VirtualMap, poses: np.ndarray, pose_idx: np.ndarray,
                    landmark_idx: np.ndarray) -> Observations:
        """:meth:`of_pairs` in closed form (``virtual_map.lever_and_noise``; equal to
        round-off): gains exactly ``[-I | lever]``, which the fast backend's fusion
        (:func:`~explore_rl.planning.em_fast.lever_terms`) relies on."""
        lever, noise = lever_and_noise(poses[pose_idx], vmap.landmark_xy[landmark_idx], vmap.config)
        gain = np.zeros((len(pose_idx), 2, 3))
        gain[:, 0, 0] = gain[:, 1, 1] = -1.0
        gain[:, :, 2] = lever
        n00, n01, n11 = noise
        return cls(pose_idx, landmark_idx, gain, np.stack([np.stack([n00, n01], -1), np.stack([n01, n11], -1)], -2))

    def subset(self, rows: np.ndarray) -> Observations:
        """The observations selected by ``rows`` (a mask or indices), order kept."""
        return Observations(self.pose_idx[rows], self.landmark_idx[rows], self.gain[rows], self.noise[rows])

    def shifted(self, offset: int) -> Observations:
        """The same observations with pose indices moved by ``offset``."""
        return Observations(self.pose_idx + offset, self.landmark_idx, self.gain, self.noise)

    def concatenated(self, other: Observations) -> Observations:
        return Observations(*(np.concatenate([a, b]) for a, b in zip(
            (self.pose_idx, self.landmark_idx, self.gain, self.noise),
            (other.pose_idx, other.landmark_idx, other.gain, other.noise))))

    def landmark_covariances(self, pose_covs: np.ndarray) -> np.ndarray:
        """``(M, 2, 2)`` observed landmark covariances given every pose's covariance."""
        gain = self.gain
        return self.noise + gain @ pose_covs[self.pose_idx] @ np.swapaxes(gain, 1, 2)

    def fuse(self, initial: np.ndarray, pose_covs: np.ndarray) -> np.ndarray:
        """Landmark covariances after fusing every observation into ``initial`` (a copy),
        in pose order, by covariance intersection (as ``VirtualMap``)."""
        covs = np.array(initial, float)
        if len(self.pose_idx):
            fuse_in_order(covs, self.landmark_idx, self.landmark_covariances(pose_covs))
        return covs


class ObservationCache:
    """Each keyframe's virtual-map observations carried from one decision to the next
    (``planning.em.backend=fast``; the reference recomputes them every decision), exactly.

    A keyframe whose (x, y) estimate is bitwise the one of the previous decision (no loop
    closure or relinearisation moved it: about half of them on office episodes) keeps its
    Jacobians and the visibility of every landmark whose segment passes no known-occupied
    cell that changed since; only the segments near a changed cell are tested again.
    Keyframes that moved are tested afresh. The result is :meth:`Observations.of`: what
    the line of sight and the Jacobians read did not change. (Keeping the visibility of
    keyframes that moved by a centimetre was tried: one flipped pair moves U0 by up to
    ~5 log-det units, beyond the documented tolerance.)
    """

    def __init__(self) -> None:
        self.grid: GridSpec | None = None
        self.blocked: np.ndarray | None = None
        self.xy = np.zeros((0, 2))  # (x, y) of each keyframe at the previous decision
        self.observations: Observations | None = None
        self.starts = np.zeros(1, dtype=np.int64)  # rows of keyframe i: starts[i]:starts[i + 1]

    def observations_of(self, vmap: VirtualMap, poses: np.ndarray, blocked: np.ndarray) -> Observations:
        """:meth:`Observations.of` ``(vmap, poses, blocked)``, reusing what still holds."""
        keep = self.unmoved(vmap, poses, blocked)
        fresh = np.flatnonzero(~keep)
        pose_idx, landmark_idx = vmap.visible_pairs(poses[fresh], blocked, by_length=True)
        fresh_pairs = (fresh[pose_idx], landmark_idx)
        kept_pairs = self.kept_pairs(vmap, np.flatnonzero(keep), blocked)
        pose_idx = np.concatenate([fresh_pairs[0], kept_pairs[0]])
        landmark_idx = np.concatenate([fresh_pairs[1], kept_pairs[1]])
        order = np.argsort(pose_idx, kind="stable")  # pose order; window order within a pose
        observations = self.jacobians(vmap, poses, pose_idx[order], landmark_idx[order], keep)
        self.grid, self.blocked, self.xy = vmap.grid, blocked.copy(), poses[:, :2].copy()
        self.observations = observations
        self.starts = np.searchsorted(observations.pose_idx, np.arange(len(poses) + 1)).astype(np.int64)
        return observations

    def unmoved(self, vmap: VirtualMap, poses: np.ndarray, blocked: np.ndarray) -> np.ndarray:
        """``(N,)``: the keyframes whose (x, y) is bitwise the previous decision's."""
        keep = np.zeros(len(poses), dtype=bool)
        if self.observations is None or self.grid != vmap.grid or self.blocked.shape != blocked.shape:
            return keep
        known = min(len(poses), len(self.xy))
        keep[:known] = np.all(poses[:known, :2] == self.xy[:known], axis=1)
        return keep

    def kept_pairs(self, vmap: VirtualMap, kept: np.ndarray, blocked: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The visible pairs of the unmoved keyframes ``kept``: the cached ones where no
        known-occupied cell changed within sensor reach, else every landmark in range with
        its cached visibility unless a changed cell lies near its segment (tested again)."""
        if not len(kept):
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        changed = changed_cells(self.blocked, blocked)
        xy = self.xy[kept]
        near = _any_in_boxes(changed, vmap.grid, xy, xy, vmap.config.sensor_range + vmap.grid.resolution)
        rows = _spans(self.starts[kept[~near]], self.starts[kept[~near] + 1])
        pose_idx = [self.observations.pose_idx[rows]]
        landmark_idx = [self.observations.landmark_idx[rows]]
        if near.any():
            retest = kept[near]
            slot, in_range = vmap.in_range_pairs(self.xy[retest])
            owner = retest[slot]
            visible = self.was_visible(vmap, retest, owner, in_range)
            touched = _any_in_boxes(changed, vmap.grid, self.xy[owner], vmap.landmark_xy[in_range],
                                  vmap.grid.resolution)
            visible[touched] = vmap.line_of_sight(self.xy[owner[touched]], in_range[touched], blocked, by_length=True)
            pose_idx.append(owner[visible])
            landmark_idx.append(in_range[visible])
        return np.concatenate(pose_idx), np.concatenate(landmark_idx)

    def was_visible(self, vmap: VirtualMap, poses: np.ndarray, pose_idx: np.ndarray,
                    landmark_idx: np.ndarray) -> np.ndarray:
        """Whether each pair (of keyframes ``poses``) was visible at the previous decision."""
        rows = _spans(self.starts[poses], self.starts[poses + 1])
        cached = np.sort(self.observations.pose_idx[rows] * vmap.num_landmarks + self.observations.landmark_idx[rows])
        keys = pose_idx * vmap.num_landmarks + landmark_idx
        if not len(cached):
            return np.zeros(len(keys), dtype=bool)
        return cached[np.minimum(np.searchsorted(cached, keys), len(cached) - 1)] == keys

    def jacobians(self, vmap: VirtualMap, poses: np.ndarray, pose_idx: np.ndarray, landmark_idx: np.ndarray,
                  keep: np.ndarray) -> Observations:
        """The observations of the pairs: Jacobians copied for the unmoved keyframes'
        previously visible pairs, computed (:meth:`Observations.closed_form`) for the rest."""
        gain = np.empty((len(pose_idx), 2, 3))
        noise = np.empty((len(pose_idx), 2, 2))
        copied = keep[pose_idx]
        if copied.any():
            old = self.observations
            keys = old.pose_idx * vmap.num_landmarks + old.landmark_idx
            order = np.argsort(keys, kind="stable")
            wanted = pose_idx[copied] * vmap.num_landmarks + landmark_idx[copied]
            found = order[np.minimum(np.searchsorted(keys[order], wanted), len(keys) - 1)]
            hit = keys[found] == wanted  # a pair that became visible (a wall went) has none
            rows = np.flatnonzero(copied)
            gain[rows[hit]], noise[rows[hit]] = old.gain[found[hit]], old.noise[found[hit]]
            copied[rows[~hit]] = False
        computed = Observations.closed_form(vmap, poses, pose_idx[~copied], landmark_idx[~copied])
        gain[~copied], noise[~copied] = computed.gain, computed.noise
        return Observations(pose_idx, landmark_idx, gain, noise)


def _spans(begins: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The concatenated index ranges ``begins[k]:ends[k]`` (in the given order)."""
    lengths = ends - begins
    if not lengths.sum():
        return np.zeros(0, dtype=np.int64)
    offsets = np.repeat(begins - np.r_[0, np.cumsum(lengths)[:-1]], lengths)
    return np.arange(lengths.sum()) + offsets


def changed_cells(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """Summed-area table ``(ny + 1, nx + 1)`` of the cells that differ between two masks."""
    table = np.zeros((before.shape[0] + 1, before.shape[1] + 1), dtype=np.int64)
    table[1:, 1:] = np.cumsum(np.cumsum(before != after, axis=0), axis=1)
    return table


def _any_in_boxes(table: np.ndarray, grid: GridSpec, a: np.ndarray, b: np.ndarray, margin: float) -> np.ndarray:
    """``(K,)``: whether the summed-area ``table`` counts any cell in the axis-aligned box
    spanning points ``a`` and ``b`` (``(K, 2)``) grown by ``margin`` (m) on every side."""
    if not table[-1, -1]:
        return np.zeros(len(a), dtype=bool)
    low = grid.world_to_cell(np.minimum(a, b) - margin)
    high = grid.world_to_cell(np.maximum(a, b) + margin) + 1
    lo_y, hi_y = np.clip(low[:, 0], 0, grid.ny), np.clip(high[:, 0], 0, grid.ny)
    lo_x, hi_x = np.clip(low[:, 1], 0, grid.nx), np.clip(high[:, 1], 0, grid.nx)
    return (table[hi_y, hi_x] - table[lo_y, hi_x] - table[hi_y, lo_x] + table[lo_y, lo_x]) > 0


def fused_map(fast: FastContext, observations: Observations, pose_covs: np.ndarray,
              prior: np.ndarray) -> np.ndarray:
    """``(C, L, 2, 2)``: the virtual map after fusing ``observations`` into ``prior`` for
    each of ``C`` sets of pose covariances ``(C, N, 3, 3)`` (:func:`fuse_batched` on the
    decision's fusion rounds: :meth:`Observations.fuse` for all sets in one pass)."""
    maps = np.repeat(prior[None], len(pose_covs), axis=0)
    if len(observations.pose_idx):
        rounds = fast.rounds_of(observations)
        maps[:, rounds.landmarks] = fuse_batched(rounds, pose_covs, prior[rounds.landmarks])
    return maps


# ---------------------------------------------------------------------- per-decision state


@dataclass
class DecisionContext:
    """Everything shared by the candidates of one decision (computed once)."""

    graph: PoseGraph
    vmap: VirtualMap
    blocked: np.ndarray  # known-occupied cells (break line of sight)
    travel: float  # cumulative travel now
    keyframe_spacing: float  # m between predicted keyframes (the session's keyframe distance)
    poses: np.ndarray  # (N, 3) keyframe estimates
    pose_covs: np.ndarray  # (N, 3, 3) their world-frame (x, y, yaw) marginals
    keyframe_travel: np.ndarray  # (N,)
    observations: Observations  # what the keyframes see on the virtual map
    landmark_covs: np.ndarray  # (L, 2, 2) the current virtual map
    u0: float
    fast: FastContext | None = None  # the factorised live graph (planning.em.backend=fast)

    @property
    def grid(self) -> GridSpec:
        return self.vmap.grid


@dataclass
class EMEvaluation:
    """Every evaluated candidate's utility terms (aligned arrays, nearest first)."""

    indices: np.ndarray  # (C,) index of each evaluated candidate in state.candidates
    u0: float  # utility of the current virtual map
    u_after: np.ndarray  # (C,) U' after driving each candidate's path
    lengths: np.ndarray  # (C,) path lengths (m)
    loops: np.ndarray  # (C,) predicted loop closures
    raw: np.ndarray  # (C,) U0 - U' - alpha * length
    nearest: int  # position of state.nearest in ``indices`` (-1 if not evaluated)
    ms: float  # wall time of the evaluation

    @property
    def best(self) -> int:
        """Position (in ``indices``) of the best raw reward; ties go to the nearer."""
        return int(np.argmax(self.raw))

    @property
    def chosen(self) -> int:
        """Index into ``state.candidates`` of EM's choice."""
        return int(self.indices[self.best])

    def rewards(self, planning: PlanningConfig) -> np.ndarray:
        """Paper Algorithm 1 rewards ``(C,)`` of the evaluated candidates."""
        if self.nearest < 0:
            raise ValueError("the nearest frontier was not evaluated; Algorithm 1 needs it")
        return normalize_rewards(self.raw, self.nearest, planning.reward)


def make_decision_context(state: ExplorationState, vmap: VirtualMap, backend: str = "reference",
                          cache: ObservationCache | None = None) -> DecisionContext:
    """Old marginals, what each keyframe sees on the virtual map and the map itself (U0):
    what every candidate of one decision shares (also the exploration graph's features).
    ``backend="fast"`` reads the marginals from one factorisation of the live graph and
    keeps it for the candidates (explore_rl/planning/em_fast.py); ``cache`` carries the
    keyframes' observations over from the previous decision (:class:`ObservationCache`)."""
    session = state.session
    graph = session.graph
    blocked = session.occupancy.known_occupied
    poses = graph.poses_se2()
    pose_covs, fast = pose_covariances(graph, poses, backend)
    if cache is not None:
        observations = cache.observations_of(vmap, poses, blocked)
    else:  # the fast fusion reads the closed form's exact [-I | lever] gains
        observe = Observations.of_pairs if fast is None else Observations.closed_form
        observations = observe(vmap, poses, *vmap.visible_pairs(poses, blocked, by_length=fast is not None))
    landmark_covs = (observations.fuse(vmap.prior_covariances(), pose_covs) if fast is None
                     else fused_map(fast, observations, pose_covs[None], vmap.prior_covariances())[0])
    keyframe_travel = np.array([k.travel for k in session.keyframes], dtype=float)
    return DecisionContext(graph, vmap, blocked, float(state.travel),
                           float(session.config.keyframe_distance), poses, pose_covs,
                           keyframe_travel, observations, landmark_covs, vmap.utility(landmark_covs), fast)


# ---------------------------------------------------------------------- the planner


class EMPlanner:
    """Expected-map planner: argmax over candidates of ``U0 - U' - alpha * length``."""

    name = "em"

    def __init__(self, config: PolicyConfig, planning: PlanningConfig, em: EMConfig | None = None,
                 robot: RobotConfig | None = None) -> None:
        """``em`` defaults to ``planning.em`` when the config has one, else :class:`EMConfig`;
        ``robot`` (motion-step size, for the odometry sigmas) to ``RobotConfig()``."""
        self.config = config
        self.planning = planning
        self.em = em or getattr(planning, "em", None) or EMConfig()
        self.robot = robot or RobotConfig()
        self._vmap: VirtualMap | None = None
        self._observations = ObservationCache() if self.em.backend == "fast" else None
        self.last_evaluation: EMEvaluation | None = None

    def choose(self, state: ExplorationState) -> int:
        self.last_evaluation = self.evaluate(state)
        return self.last_evaluation.chosen

    def evaluate(self, state: ExplorationState, actions: list[Action] | None = None,
                 context: DecisionContext | None = None) -> EMEvaluation:
        """Utility terms of every frontier in the action set (``planning.actions``).

        ``actions`` and ``context`` may be passed in when the caller already has them (the
        environment builds its exploration graph from the same ones).
        """
        start = time.perf_counter()
        actions = self.actions(state) if actions is None else actions
        context = self.decision_context(state) if context is None else context
        indices = np.array([a.candidate for a in actions], dtype=int)
        predicted = [self.predicted_keyframes(context, action.prediction) for action in actions]
        loops = np.array([len(p.revisits) for p in predicted], dtype=int)
        if context.fast is None:
            u_after = np.array([self.utility_after(context, p) for p in predicted], dtype=float)
        else:
            u_after = self.utilities_fast(context, predicted)
        lengths = np.array([state.candidates[i].length for i in indices], dtype=float)
        raw = raw_reward(context.u0, u_after, lengths, self.planning.reward.alpha)
        nearest = np.flatnonzero(indices == state.nearest)
        return EMEvaluation(indices, context.u0, u_after, lengths, loops, raw,
                            int(nearest[0]) if len(nearest) else -1,
                            1e3 * (time.perf_counter() - start))

    def actions(self, state: ExplorationState) -> list[Action]:
        """The decision's action set (nearest first; explore_rl/planning/actions.py)."""
        return select_actions(state, self.planning.actions, self.planning.revisits)

    def virtual_map(self, grid: GridSpec) -> VirtualMap:
        """The virtual map geometry on ``grid`` (built once; its state is never used)."""
        if self._vmap is None or self._vmap.grid != grid:
            self._vmap = VirtualMap(grid, self.planning.virtual_map)
        return self._vmap

    def decision_context(self, state: ExplorationState) -> DecisionContext:
        """Old marginals, their observations and the current virtual map (U0)."""
        return make_decision_context(state, self.virtual_map(state.session.occupancy.grid), self.em.backend,
                                     self._observations)

    # ------------------------------------------------------------ one candidate

    def predict_path(self, context: DecisionContext, path_xy: np.ndarray) -> PredictedPath:
        """Predicted keyframes along ``path_xy`` and the loops they would close."""
        prediction = predict_path(path_xy, context.poses[:, :2], context.keyframe_travel, context.travel,
                                  context.blocked, context.grid, self.planning.revisits,
                                  context.keyframe_spacing)
        return self.predicted_keyframes(context, prediction)

    def predicted_keyframes(self, context: DecisionContext, prediction: PathPrediction) -> PredictedPath:
        """A path prediction chained to the last live keyframe (relative motions, steps)."""
        anchors = np.vstack([context.poses[-1:], prediction.poses[:-1]])
        deltas = se2_between(anchors, prediction.poses)
        return PredictedPath(prediction.poses, prediction.travel, deltas, motion_steps(deltas, self.robot),
                             prediction.revisits)

    def utility_after(self, context: DecisionContext, predicted: PredictedPath) -> float:
        """``U'``: the virtual map after the predicted keyframes (and loops) join the graph."""
        if len(predicted) == 0:
            return context.u0
        if context.fast is not None:
            return float(self.utilities_fast(context, [predicted])[0])
        if predicted.revisits or not self.em.shortcut_without_loops:
            covs = self.map_with_graph_copy(context, predicted)
        else:
            covs = self.map_with_chain(context, predicted)
        return context.vmap.utility(covs)

    def map_with_chain(self, context: DecisionContext, predicted: PredictedPath) -> np.ndarray:
        """No loop: old marginals (and their map) stand; fuse the propagated new poses."""
        covs = propagate_chain(context.pose_covs[-1], context.poses[-1], predicted.poses,
                               step_covariances(context.graph, predicted.steps, self.em))
        new = Observations.of(context.vmap, predicted.poses, context.blocked)
        return new.fuse(context.landmark_covs, covs)

    def map_with_graph_copy(self, context: DecisionContext, predicted: PredictedPath) -> np.ndarray:
        """Loops: simulate on a copy of the live iSAM2; rebuild the map from all poses."""
        graph = simulate_graph(context.graph, context.poses, predicted, self.em)
        all_poses = np.vstack([context.poses, predicted.poses])
        all_covs = world_covariances(graph, all_poses)
        new = Observations.of(context.vmap, predicted.poses, context.blocked)
        observations = context.observations.concatenated(new.shifted(len(context.poses)))
        return observations.fuse(context.vmap.prior_covariances(), all_covs)

    # ------------------------------------------------------------ fast backend

    def utilities_fast(self, context: DecisionContext, predicted: list[PredictedPath]) -> np.ndarray:
        """``U'`` of every candidate with the fast backend (explore_rl/planning/em_fast.py):
        loop candidates by a low-rank update of the factorised live graph and one batched
        re-fusion of the virtual map, the others from the current map (as
        :meth:`map_with_chain`); then every candidate's new keyframes fused in one pass."""
        u_after = np.full(len(predicted), context.u0)
        moving = [k for k, p in enumerate(predicted) if len(p)]
        if not moving:
            return u_after
        paths = [predicted[k] for k in moving]
        loop = [i for i, p in enumerate(paths) if p.revisits or not self.em.shortcut_without_loops]
        maps = np.repeat(context.landmark_covs[None], len(paths), axis=0)
        new_covs = [None if i in loop else
                    propagate_chain(context.pose_covs[-1], context.poses[-1], p.poses,
                                    step_covariances(context.graph, p.steps, self.em))
                    for i, p in enumerate(paths)]
        if loop:
            maps[loop], loop_covs = self.loop_maps(context, [paths[i] for i in loop])
            for i, covs in zip(loop, loop_covs):
                new_covs[i] = covs
        fuse_each(maps, self.new_observations(context, paths), np.concatenate(new_covs))
        u_after[moving] = [context.vmap.utility(covs) for covs in maps]
        return u_after

    def new_observations(self, context: DecisionContext, predicted: list[PredictedPath]) -> Observations:
        """What the candidates' predicted keyframes see, all in one (one line-of-sight batch
        for the distinct poses of all candidates, one Jacobian batch for all pairs): pose
        ``i`` is row ``i`` of the candidates' poses stacked, landmark ``k L + l`` is
        landmark ``l`` of candidate ``k``'s map (``L`` landmarks)."""
        visible = batch_observations(context.vmap, [p.poses for p in predicted], context.blocked)
        offsets = np.r_[0, np.cumsum([len(p) for p in predicted])]
        poses = np.concatenate([p.poses for p in predicted])
        pose_idx = np.concatenate([pairs[0] + offset for pairs, offset in zip(visible, offsets)])
        landmark_idx = np.concatenate([pairs[1] for pairs in visible])
        observations = Observations.closed_form(context.vmap, poses, pose_idx, landmark_idx)
        candidate = np.repeat(np.arange(len(predicted)), [len(pairs[0]) for pairs in visible])
        return Observations(pose_idx, candidate * context.vmap.num_landmarks + landmark_idx, observations.gain,
                            observations.noise)

    def loop_maps(self, context: DecisionContext,
                  predicted: list[PredictedPath]) -> tuple[np.ndarray, list[np.ndarray]]:
        """Virtual maps ``(C, L, 2, 2)`` of the live keyframes after each loop candidate
        (every keyframe's covariance by the low-rank update, the observations re-fused for
        all candidates in one pass, ``fuse_batched``) and the predicted keyframes'
        covariances ``(P, 3, 3)`` of each."""
        ssm, loop = ssm_covariance(self.em), loop_covariance(self.em)
        revisited = {r.keyframe_index for p in predicted for r in p.revisits}
        dims = list(PLANAR) if context.fast.decoupled else list(range(6))
        context.fast.cross(sorted(revisited) + [len(context.poses) - 1], dims, dims)  # one solve for all
        steps = step_tangent_covariances(context.graph, np.concatenate([p.steps for p in predicted]), ssm)
        bounds = np.cumsum([len(p) for p in predicted])[:-1]
        covs = [loop_update(context, context.fast, p, s, loop) for p, s in zip(predicted, np.split(steps, bounds))]
        # candidates whose paths share everything up to their last loop leave the same old
        # covariances (about a third on office decisions): fuse each distinct set once
        unique, inverse = distinct(np.stack([c.old for c in covs]))
        maps = fused_map(context.fast, context.observations, unique, context.vmap.prior_covariances())
        return maps[inverse], [c.new for c in covs]


def fuse_each(maps: np.ndarray, observations: Observations, pose_covs: np.ndarray) -> None:
    """Fuse the candidates' new ``observations`` (:meth:`EMPlanner.new_observations`: pose
    covariances ``pose_covs (P, 3, 3)``, landmark ``k L + l`` of map ``k``) into ``maps (C,
    L, 2, 2)`` in place: :meth:`Observations.fuse` of each candidate's, in one pass of
    :func:`fuse_batched` rounds (a landmark of map ``k`` is its own sequence, same order)."""
    if not len(observations.landmark_idx):
        return
    rounds = FuseRounds.of(observations)
    candidate, landmark = np.divmod(rounds.landmarks, maps.shape[1])
    maps[candidate, landmark] = fuse_batched(rounds, pose_covs[None], maps[candidate, landmark])[0]
