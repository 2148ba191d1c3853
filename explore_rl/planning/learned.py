"""The learned policy in the plain runner: the trained actor picks the frontier.

At a decision: the action set (:func:`~explore_rl.planning.actions.select_actions`, the
one EM and the environment use), the exploration graph, its padded encoding, the actor's
logits, the most probable frontier (greedy), and back from the encoded row to the graph
node, the action and the candidate -- what the environment does with the actor, minus
the reward.

**Cheaper features, same graph.** The environment builds its graph from EM's decision
context, which fuses *every* keyframe's observations into the whole virtual map (the
EM utility needs all of it; its cost grows with poses x landmarks in range, plus a
line-of-sight test per pair). The graph needs less: every keyframe's xy covariance
(all pose marginals, read at once by :func:`~explore_rl.planning.em.pose_covariances`)
and the virtual landmark of each action frontier -- a handful of cells. :func:`graph_features`
fuses only the observations of those landmarks, from the keyframes within sensor range,
in keyframe order and with the same observation model and covariance-intersection kernel
as the full map (:class:`~explore_rl.planning.em.Observations`), so the graph is the same
(tests/planning/test_learned.py compares it with the environment's on real states). An actor of
``graph.features=no_covariance`` needs neither: :func:`graph_without_covariances` skips the pose
marginals and the fusion altogether.

**Fast path** (issue 24: decide >= 5x faster than EM; ``benchmarks/bench_decision_real.py``):
every candidate's revisits predicted at once (:func:`~explore_rl.planning.actions.predict_candidate_paths`),
the pose marginals by depth levels with loop-free chains halved (:func:`pose_marginals`),
one fusion for the frontiers' landmarks and the extended set's, the pairs within sensor
range from a KD-tree (:func:`pairs_in_range`), their line of sight by length (as EM's
decision context), the observations in closed form and fused by EM's fast rounds
(:func:`fuse_observations`: the same code as EM's fast backend), and the encoding padded
only to the graph's nodes (the g-U-Net packs the real nodes: padding changes no logit).
The first implementation stays as ``LearnedPolicy(reference=True)``; tests and the
benchmark compare both on real states by :class:`Equivalence` (round-off only: the same
frontier, features, logits and probabilities within tolerances far below any real change).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import torch
from scipy.spatial import cKDTree

from explore_rl.graph.config import GraphConfig
from explore_rl.graph.encode import EncodedGraph, encode, loop_length_rows
from explore_rl.graph.exploration_graph import (
    ExplorationGraph,
    action_frontiers,
    factor_edges,
    graph_from_estimates,
    select_features,
)
from explore_rl.graph.features import (
    frontier_extras,
    has_frontier_extras,
    has_loop_length,
    reads_covariances,
)
from explore_rl.grid import GridSpec
from explore_rl.models.actor_critic import GraphActor, greedy_row
from explore_rl.models.actor_file import ActorFile, load_actor
from explore_rl.planning.actions import Action, select_actions
from explore_rl.planning.config import PlanningConfig
from explore_rl.planning.em import EMEvaluation, EMPlanner, Observations, pose_covariances
from explore_rl.planning.em_fast import PLANAR, FuseRounds, fuse_batched, world_from_tangent
from explore_rl.planning.policies import PolicyConfig
from explore_rl.planning.virtual_map import VirtualMap
from explore_rl.robot_config import RobotConfig
from explore_rl.slam.marginals import (
    BLOCK,
    DepthMarginals,
    SparseMarginals,
    information_from_jacobian,
    planar_blocks,
)

if TYPE_CHECKING:
    from explore_rl.slam.pose_graph import PoseGraph
    from explore_rl.state import ExplorationState

log = logging.getLogger(__name__)


# relative and absolute slack of the KD-tree's radius over the exact test (which is applied after)
KD_MARGIN = 1e-9


def visible_pairs_of(vmap: VirtualMap, poses: np.ndarray, blocked: np.ndarray, landmarks: np.ndarray,
                     reference: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """``(pose, landmark)`` index pairs of the observations of ``landmarks`` only, exactly
    as ``vmap.visible_pairs`` would list them among all pairs: within ``sensor_range``
    (same distance expression) and in line of sight (:meth:`VirtualMap.line_of_sight`), in
    pose order. ``reference``: the pairs from the full distance matrix and one line-of-sight
    batch (the first code); else a KD-tree (:func:`pairs_in_range`) and the segments
    grouped by length (``by_length``, as EM's decision context)."""
    pairs = pairs_in_range_reference if reference else pairs_in_range
    pose_idx, slot = pairs(poses[:, :2], vmap.landmark_xy[landmarks], vmap.config.sensor_range)
    landmark_idx = landmarks[slot]
    visible = vmap.line_of_sight(poses[pose_idx], landmark_idx, blocked, by_length=not reference)
    return pose_idx[visible], landmark_idx[visible]


def pairs_in_range(pose_xy: np.ndarray, landmark_xy: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(pose, landmark)`` index pairs with ``|landmark - pose| <= radius``, pose-major
    then landmark order -- ``np.nonzero`` of the full distance matrix, same expression --
    from the pairs a KD-tree finds within a slightly larger radius (the full ``poses x
    landmarks`` matrix costs ~10 ms at 500 poses and 1000 landmarks; few pairs are near)."""
    if len(pose_xy) == 0 or len(landmark_xy) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    near = cKDTree(pose_xy).sparse_distance_matrix(cKDTree(landmark_xy), radius * (1 + KD_MARGIN) + KD_MARGIN,
                                                   output_type="ndarray")
    pose_idx, slot = near["i"].astype(np.int64), near["j"].astype(np.int64)
    offset = landmark_xy[slot] - pose_xy[pose_idx]
    dx, dy = offset[:, 0], offset[:, 1]
    keep = np.sqrt(dx * dx + dy * dy) <= radius  # np.linalg.norm's sum of squares, without its reduction
    # pose-major, then landmark order: the pairs as a sparse pattern, its rows' columns sorted
    # (a counting sort by pose and short per-row sorts: half a lexsort of the pairs)
    pairs = sp.csr_matrix((np.ones(int(keep.sum()), dtype=bool), (pose_idx[keep], slot[keep])),
                          shape=(len(pose_xy), len(landmark_xy)))
    pairs.sort_indices()
    return np.repeat(np.arange(len(pose_xy), dtype=np.int64), np.diff(pairs.indptr)), pairs.indices.astype(np.int64)


def pairs_in_range_reference(pose_xy: np.ndarray, landmark_xy: np.ndarray,
                             radius: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`pairs_in_range` from the full distance matrix (the reference it must equal)."""
    dist = np.linalg.norm(landmark_xy[None, :, :] - pose_xy[:, None, :], axis=-1)
    pose_idx, slot = np.nonzero(dist <= radius)
    return pose_idx.astype(np.int64), slot.astype(np.int64)


def landmark_covariances(vmap: VirtualMap, poses: np.ndarray, pose_covs: np.ndarray, blocked: np.ndarray,
                         landmarks: np.ndarray, reference: bool = False) -> np.ndarray:
    """``(L, 2, 2)``: the fused covariances of the virtual landmarks ``landmarks`` (unique
    indices, ascending) after every keyframe's observations -- as in the fully fused map
    (each landmark is fused on its own), from their observations alone. ``reference``:
    as first written (:func:`visible_pairs_of`'s reference, EM's
    :class:`~explore_rl.planning.em.Observations` and ``fuse_in_order``); else EM's fast
    fusion (:func:`fuse_observations`), equal up to round-off."""
    prior = vmap.config.prior_std**2 * np.eye(2)  # as VirtualMap.prior_covariances
    fused = np.repeat(prior[None], len(landmarks), axis=0)
    if len(landmarks):
        pose_idx, landmark_idx = visible_pairs_of(vmap, poses, blocked, landmarks, reference)
        slot = np.searchsorted(landmarks, landmark_idx)
        if reference:
            observations = Observations.of_pairs(vmap, poses, pose_idx, landmark_idx)
            fused = Observations(pose_idx, slot, observations.gain, observations.noise).fuse(fused, pose_covs)
        else:
            observations = Observations.closed_form(vmap, poses, pose_idx, landmark_idx)
            fuse_observations(fused, Observations(pose_idx, slot, observations.gain, observations.noise), pose_covs)
    return fused


def fuse_observations(covs: np.ndarray, observations: Observations, pose_covs: np.ndarray) -> None:
    """Fuse ``observations`` (closed form, landmark indices into ``covs``) into ``covs``
    in place, as :meth:`Observations.fuse` does (pose order, covariance intersection), by
    EM's fast backend's rounds (:class:`~explore_rl.planning.em_fast.FuseRounds`,
    :func:`~explore_rl.planning.em_fast.fuse_batched`: in-place intersection rounds on
    information components; equal up to round-off)."""
    if not len(observations.pose_idx):
        return
    rounds = FuseRounds.of(observations)
    covs[rounds.landmarks] = fuse_batched(rounds, pose_covs[None], covs[rounds.landmarks])[0]


def frontier_covariances(vmap: VirtualMap, poses: np.ndarray, pose_covs: np.ndarray, blocked: np.ndarray,
                         frontier_xy: np.ndarray, reference: bool = False) -> np.ndarray:
    """``(F, 2, 2)``: the virtual-landmark covariance of each frontier's cell after every
    keyframe's observations -- ``vmap.frontier_landmark_covariance`` of the fully fused
    map, computed from the frontiers' landmarks alone (the prior outside the map)."""
    index = vmap.landmark_index(np.asarray(frontier_xy, float).reshape(-1, 2))
    landmarks = np.unique(index[index >= 0])
    return covariances_of(vmap, index, landmarks, landmark_covariances(vmap, poses, pose_covs, blocked, landmarks,
                                                                       reference))


def covariances_of(vmap: VirtualMap, index: np.ndarray, landmarks: np.ndarray, fused: np.ndarray) -> np.ndarray:
    """``(F, 2, 2)``: the covariance of landmark ``index[f]`` among the ``fused`` ones of
    ``landmarks`` (ascending, holding every index >= 0); the prior for -1 (outside the map)."""
    covs = np.repeat((vmap.config.prior_std**2 * np.eye(2))[None], len(index), axis=0)
    inside = index >= 0
    covs[inside] = fused[np.searchsorted(landmarks, index[inside])]
    return covs


def landmarks_near(vmap: VirtualMap, points: np.ndarray, radius: float) -> np.ndarray:
    """Indices (ascending) of the virtual landmarks within ``radius`` of any of ``points``:
    :func:`landmarks_near_reference` (the same distance expression) over the landmark
    cells around each point only, not the whole map once per point."""
    points = np.asarray(points, float).reshape(-1, 2)
    grid = vmap.landmark_grid
    half = int(np.ceil(radius / grid.resolution)) + 1  # a centre within radius lies this many cells away at most
    offsets = np.arange(-half, half + 1)
    cells = grid.world_to_cell(points)
    rows = cells[:, 0, None, None] + offsets[None, :, None]
    cols = cells[:, 1, None, None] + offsets[None, None, :]
    inside = (rows >= 0) & (rows < grid.ny) & (cols >= 0) & (cols < grid.nx)
    index = (rows * grid.nx + cols)[inside]
    point = np.broadcast_to(points[:, None, None, :], inside.shape + (2,))[inside]
    near = np.linalg.norm(vmap.landmark_xy[index] - point, axis=1) <= radius
    return np.unique(index[near])


def landmarks_near_reference(vmap: VirtualMap, points: np.ndarray, radius: float) -> np.ndarray:
    """:func:`landmarks_near` as first written: every landmark's distance to each point."""
    points = np.asarray(points, float).reshape(-1, 2)
    near = np.zeros(vmap.num_landmarks, dtype=bool)
    for point in points:
        near |= np.linalg.norm(vmap.landmark_xy - point, axis=1) <= radius
    return np.flatnonzero(near)


def graph_features(state: ExplorationState, actions: list[Action], vmap: VirtualMap,
                   backend: str = "fast", features: str = "paper") -> ExplorationGraph:
    """The exploration graph of ``state`` (equal to ``graph_from_state`` with EM's decision
    context; see the module docstring for what is skipped). ``backend`` reads the pose
    marginals as EM's (``planning.em.backend``): one factorisation or one query per pose.
    ``features=extended`` also needs the landmarks within sensor range of each frontier
    (their mean uncertainty is a column), still a small part of the map: one fusion of the
    frontiers' landmarks and those together (each landmark is fused on its own, so a
    frontier's covariance is the same whatever else is fused with it)."""
    if not reads_covariances(features):
        return graph_without_covariances(state, actions, vmap, features)
    poses, pose_covs, blocked, frontier_xy = decision_estimates(state, actions, backend, fast=True)
    index = vmap.landmark_index(frontier_xy)
    near = (landmarks_near(vmap, frontier_xy, vmap.config.sensor_range) if has_frontier_extras(features)
            else np.zeros(0, dtype=np.int64))
    landmarks = np.union1d(index[index >= 0], near)
    fused = landmark_covariances(vmap, poses, pose_covs, blocked, landmarks)
    frontier_covs = covariances_of(vmap, index, landmarks, fused)
    extra = None
    if has_frontier_extras(features):
        extra = frontier_extras(state, actions, pose_covs, vmap.landmark_xy[near],
                                fused[np.searchsorted(landmarks, near)], vmap.config.sensor_range)
    return graph_of(state, actions, poses, pose_covs, frontier_covs, extra, features)


def graph_without_covariances(state: ExplorationState, actions: list[Action], vmap: VirtualMap,
                              features: str) -> ExplorationGraph:
    """The graph of a feature set that reads no covariance (``graph.features=no_covariance``): no pose marginals,
    no virtual-map fusion. The columns it leaves out are built from zero covariances and dropped by
    :func:`~explore_rl.graph.exploration_graph.select_features`; the others are the covariance-reading graph's."""
    poses = state.session.graph.poses_se2()
    pose_covs = np.zeros((len(poses), 3, 3))
    frontier_covs = np.zeros((len(actions), 2, 2))
    extra = None
    if has_frontier_extras(features):
        extra = frontier_extras(state, actions, pose_covs, np.zeros((0, 2)), np.zeros((0, 2, 2)),
                                vmap.config.sensor_range)
    return graph_of(state, actions, poses, pose_covs, frontier_covs, extra, features)


def graph_of(state: ExplorationState, actions: list[Action], poses: np.ndarray, pose_covs: np.ndarray,
             frontier_covs: np.ndarray, extra: np.ndarray | None, features: str) -> ExplorationGraph:
    """The exploration graph of these estimates with the columns ``features`` reads (the fast paths and the
    reference end here alike)."""
    graph = graph_from_estimates(state, actions, poses, pose_covs, frontier_covs,
                                 factor_edges(state.session.graph.edges), extra, has_loop_length(features))
    return select_features(graph, features)


def graph_features_reference(state: ExplorationState, actions: list[Action], vmap: VirtualMap,
                             backend: str = "fast", features: str = "paper") -> ExplorationGraph:
    """:func:`graph_features` as first written (the reference the fast path must equal):
    the frontiers' landmarks and the extended set's landmarks fused separately, pairs
    in range from the full distance matrix."""
    poses, pose_covs, blocked, frontier_xy = decision_estimates(state, actions, backend)
    frontier_covs = frontier_covariances(vmap, poses, pose_covs, blocked, frontier_xy, reference=True)
    extra = None
    if has_frontier_extras(features):
        landmarks = landmarks_near_reference(vmap, frontier_xy, vmap.config.sensor_range)
        covs = landmark_covariances(vmap, poses, pose_covs, blocked, landmarks, reference=True)
        extra = frontier_extras(state, actions, pose_covs, vmap.landmark_xy[landmarks], covs,
                                vmap.config.sensor_range)
    return graph_of(state, actions, poses, pose_covs, frontier_covs, extra, features)


def decision_estimates(state: ExplorationState, actions: list[Action], backend: str,
                       fast: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Keyframe estimates ``(K, 3)``, their world-frame marginals ``(K, 3, 3)``, the
    known-occupied cells and the action frontiers' waypoints ``(F, 2)``. ``fast``: the
    marginals by :func:`pose_marginals` (else EM's :func:`~explore_rl.planning.em.pose_covariances`)."""
    session = state.session
    poses = session.graph.poses_se2()
    if fast:
        pose_covs = pose_marginals(session.graph, poses, backend)
    else:
        pose_covs, _ = pose_covariances(session.graph, poses, backend)
    return poses, pose_covs, session.occupancy.known_occupied, action_frontiers(state, actions)


def pose_marginals(graph: PoseGraph, poses: np.ndarray, backend: str) -> np.ndarray:
    """``(K, 3, 3)`` world-frame marginals of every keyframe, as EM's
    :func:`~explore_rl.planning.em.pose_covariances`: with ``backend=fast`` from the same
    factorisation and recurrences, the elimination-tree levels built at once
    (:class:`~explore_rl.slam.marginals.DepthMarginals`; EM keeps its factorisation for
    its candidates, the graph needs only the diagonal). If that fails, EM's own route
    (which falls back to iSAM2's queries, logged)."""
    if backend == "fast":
        try:
            return world_from_tangent(_tangent_marginals(linearised_information(graph)), poses)
        except (RuntimeError, ValueError, np.linalg.LinAlgError) as error:
            log.debug("depth-level marginals failed at %d poses (%s); EM's route instead", len(poses), error)
    return pose_covariances(graph, poses, backend)[0]


def _tangent_marginals(information) -> np.ndarray:
    """``(K, 6, 6)`` tangent marginals for :func:`world_from_tangent`, which reads only
    their planar components (yaw, x, y): from the planar system alone when nothing joins
    it to roll, pitch and z (planar poses and factors, as EM's fast backend checks), else
    from the whole one. The off-plane blocks of the planar route are left zero."""
    planar = planar_blocks(information, PLANAR)
    if planar is None:
        return DepthMarginals(information).diagonal_blocks()
    rows = np.array(PLANAR)
    covs = np.zeros((information.shape[0] // BLOCK, BLOCK, BLOCK))
    covs[:, rows[:, None], rows] = DepthMarginals(planar, block=len(rows)).diagonal_blocks()
    return covs


def actor_logits(actor: GraphActor, encoded: EncodedGraph) -> torch.Tensor:
    """The actor's logit of every row of ``encoded`` (0 on padding), no gradients; the
    adjacency's nonzero entries from the encoding's edges when it has them (no scan)."""
    entries = None
    if encoded.entries is not None:
        entries = torch.from_numpy(np.pad(encoded.entries, ((0, 0), (1, 0))))  # graph 0
    with torch.no_grad():
        return actor(torch.from_numpy(encoded.x)[None], torch.from_numpy(encoded.adj)[None],
                     torch.from_numpy(encoded.node_mask)[None], entries)[0]


def revisit_counts(graph: ExplorationGraph, encoded: EncodedGraph, actions: list[Action]) -> np.ndarray:
    """``(N,)``: keyframes the path of each encoded frontier row revisits (its predicted loop
    closures, the ``revisits`` node feature of the extended set); 0 on pose and padding rows."""
    return action_rows(np.array([len(action.prediction.revisits) for action in actions]), actions, graph, encoded)


def closure_gains(graph: PoseGraph, poses: np.ndarray, actions: list[Action], loop_sigma: float) -> np.ndarray:
    """``(A,)``: for each action, the largest over the keyframes its path revisits of the
    relative position uncertainty (m) a loop factor would remove between the current
    (latest) keyframe and that keyframe: ``sqrt(tr(S (S + R)^-1 S))``, ``S`` the world-frame
    covariance of their position difference (joint marginals of the linearised system),
    ``R = loop_sigma^2 I`` (EM's predicted loop factor, ``planning.em.loop_sigma_translation``).
    Large where the drift between the two is large, ~0 where a closure is already there
    or the factor's own noise dominates: what a closure pays. 0 for an action that revisits
    none; all 0 (logged) if the system cannot be factorised."""
    gains = np.zeros(len(actions))
    revisited = sorted({r.keyframe_index for action in actions for r in action.prediction.revisits})
    if not revisited:
        return gains
    current = graph.num_poses - 1
    try:
        relative = relative_position_covariances(linearised_information(graph), poses, current,
                                                 np.asarray(revisited))
    except (RuntimeError, ValueError, np.linalg.LinAlgError) as error:
        log.warning("closure gains: the pose graph of %d keyframes cannot be factorised (%s); prior off this decision",
                    graph.num_poses, error)
        return gains
    noise = loop_sigma ** 2 * np.eye(2)
    removed = relative @ np.linalg.solve(relative + noise, relative)
    gain_of = dict(zip(revisited, np.sqrt(np.clip(np.trace(removed, axis1=1, axis2=2), 0.0, None))))
    for i, action in enumerate(actions):
        gains[i] = max((gain_of[r.keyframe_index] for r in action.prediction.revisits), default=0.0)
    return gains


def closure_gain_rows(state: ExplorationState, actions: list[Action], graph: ExplorationGraph,
                      encoded: EncodedGraph, loop_sigma: float) -> np.ndarray:
    """``(N,)``: :func:`closure_gains` of ``state``'s pose graph on the encoded frontier rows
    (0 on pose and padding rows): the column ``policy.closure_bias`` adds."""
    session_graph = state.session.graph
    gains = closure_gains(session_graph, session_graph.poses_se2(), actions, loop_sigma)
    return action_rows(gains, actions, graph, encoded)


def relative_position_covariances(information: sp.spmatrix, poses: np.ndarray, current: int,
                                  keyframes: np.ndarray) -> np.ndarray:
    """``(k, 2, 2)`` world-frame covariance of ``p_k - p_current`` for each of ``keyframes``, from
    the pose graph's information matrix ``(6K, 6K)`` (Pose3 tangents in pose order) at planar
    ``poses (K, 3)``: ``W_kk + W_cc - W_kc - W_kc^T`` with ``W_ij = R_i Cov(t_i, t_j) R_j^T`` (a
    tangent's translation is in its body frame); the covariance columns of those poses by sparse
    solves of one factorisation (of the planar system when nothing joins it to the rest)."""
    information = sp.bsr_matrix(information, blocksize=(BLOCK, BLOCK))
    planar = planar_blocks(information, PLANAR)
    if planar is None:
        marginals, translation = SparseMarginals(information), (PLANAR[1], PLANAR[2])
    else:
        marginals, translation = SparseMarginals(planar, block=len(PLANAR)), (1, 2)
    wanted = np.r_[current, np.asarray(keyframes, dtype=np.int64)]
    columns = marginals.columns(wanted, translation)  # (bK, 2 (1 + k))
    rows = (marginals.block * wanted[:, None] + np.asarray(translation)).ravel()
    joint = columns[rows].reshape(len(wanted), 2, len(wanted), 2).transpose(0, 2, 1, 3)  # [i, j] = Cov(t_i, t_j)
    c, s = np.cos(poses[wanted, 2]), np.sin(poses[wanted, 2])
    rotation = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (1 + k, 2, 2)
    world = rotation[:, None] @ joint @ np.swapaxes(rotation, 1, 2)[None]  # W_ij
    cross, own = world[1:, 0], world[np.arange(1, len(wanted)), np.arange(1, len(wanted))]
    return own + world[0, 0] - cross - np.swapaxes(cross, 1, 2)


def linearised_information(graph: PoseGraph) -> sp.bsr_matrix:
    """The pose graph's information matrix at iSAM2's linearisation point, in 6x6 blocks (the
    system of ``PoseGraph.information_matrix``, formed block by block)."""
    linear = graph.isam.getFactorsUnsafe().linearize(graph.isam.getLinearizationPoint())
    return information_from_jacobian(*linear.sparseJacobian_(), graph.num_poses)


def action_rows(values: np.ndarray, actions: list[Action], graph: ExplorationGraph, encoded: EncodedGraph) -> np.ndarray:
    """``(N,)``: the per-action ``values`` on the encoded frontier rows (0 on pose and padding rows)."""
    of_candidate = {action.candidate: value for action, value in zip(actions, values)}
    rows = np.zeros(len(encoded.action_mask), dtype=np.float32)
    for row in np.flatnonzero(encoded.action_mask):
        rows[row] = of_candidate[int(graph.candidate[encoded.nodes[row]])]
    return rows


def shortlist_rows(logits: torch.Tensor, action_mask: torch.Tensor, k: int) -> np.ndarray:
    """Rows of the ``k`` largest logits among the ``action_mask`` rows (all of them if fewer),
    most probable first; the first is :func:`greedy_row`'s."""
    valid = int(action_mask.sum())
    order = torch.argsort(logits.masked_fill(~action_mask, float("-inf")), descending=True, stable=True)
    return order[:min(k, valid)].numpy()


def shortlist(actions: list[Action], graph: ExplorationGraph, encoded: EncodedGraph, rows: np.ndarray) -> list[Action]:
    """The actions of the frontier ``rows`` of ``encoded``, in the action set's order (nearest
    first, as EM evaluates them: its ties go to the nearer)."""
    chosen = {int(graph.candidate[encoded.nodes[row]]) for row in rows}
    return [action for action in actions if action.candidate in chosen]


def top_probability(logits: torch.Tensor, action_mask: torch.Tensor) -> float:
    """The largest probability of the actor's distribution over the ``action_mask`` rows."""
    return float(torch.softmax(logits.masked_fill(~action_mask, float("-inf")), -1).max())


def choose_row(actor: GraphActor, encoded: EncodedGraph) -> int:
    """Row of the most probable action of ``encoded`` (:func:`greedy_row`)."""
    return greedy_row(actor_logits(actor, encoded), torch.from_numpy(encoded.action_mask))


@dataclass(frozen=True)
class Equivalence:
    """When a decision counts as the reference's: differences of round-off only (another
    summation or elimination order), never an approximation. Asking for bit-identical
    logits asks for bit-identical float32 features; across implementations that is luck,
    not a property (scaling every pose marginal by 1 + 1e-9 moves a logit of a few hundred
    by one float32 step, 3e-5). Real changes are orders of magnitude above
    these bounds: the planar approximation of the marginals under icp (ruled out) moves
    them by 1e-7 to 2e-5 relative and the logits by up to 7e-3.

    * ``feature_rtol``: every node feature within this of the reference's, relative to
      it (double precision; another elimination order of the marginals gives ~1e-11);
    * ``logit_rtol``: every real row's logit within this times the largest reference
      logit (a float32 step is 6e-8 to 1.2e-7 of it: some 8-16 steps);
    * ``probability_atol``: the actor's action probabilities (softmax over the frontier
      rows, in double) within this;
    * and the same edges and the same chosen frontier.
    """

    feature_rtol: float = 1e-9
    logit_rtol: float = 1e-6
    probability_atol: float = 1e-6


@dataclass(frozen=True)
class DecisionDifference:
    """How far a decision is from the reference's on the same state (:func:`decision_difference`)."""

    same_choice: bool
    same_edges: bool
    feature_rel: float  # largest |a - b| / |b| over the node features and edge weights
    logit_rel: float  # largest |a - b| over the real rows / largest |b|
    probability: float  # largest |p_a - p_b| over the frontier rows

    def within(self, equivalence: Equivalence) -> bool:
        """Whether the decision is the reference's under ``equivalence``."""
        return (self.same_choice and self.same_edges and self.feature_rel <= equivalence.feature_rtol
                and self.logit_rel <= equivalence.logit_rtol and self.probability <= equivalence.probability_atol)


def decision_difference(policy: LearnedPolicy, reference: LearnedPolicy) -> DecisionDifference:
    """Compare the last decisions of ``policy`` and ``reference`` (made on the same state):
    the encodings hold the same graph nodes in their first rows (the reference may pad)."""
    graph, expected = policy.last_graph, reference.last_graph
    n = len(policy.last_encoded.nodes)
    logits, reference_logits = policy.last_logits[:n].double(), reference.last_logits[:n].double()
    action_mask = torch.from_numpy(policy.last_encoded.action_mask[:n])
    same_rows = (np.array_equal(policy.last_encoded.nodes, reference.last_encoded.nodes[:n])
                 and torch.equal(action_mask, torch.from_numpy(reference.last_encoded.action_mask[:n])))
    same_edges = (graph.features.shape == expected.features.shape and np.array_equal(graph.edges, expected.edges)
                  and same_rows)
    feature_rel = (max(_relative(graph.features, expected.features), _relative(graph.weights, expected.weights))
                   if same_edges else float("inf"))
    scale = float(reference_logits.abs().max()) if n else 0.0
    difference = float((logits - reference_logits).abs().max()) if n else 0.0
    logit_rel = difference / scale if scale > 0 else (0.0 if difference == 0 else float("inf"))
    probability = float((_probabilities(logits, action_mask) - _probabilities(reference_logits, action_mask))
                        .abs().max()) if bool(action_mask.any()) else 0.0
    return DecisionDifference(policy.last_choice == reference.last_choice, same_edges, feature_rel, logit_rel,
                              probability)


def _relative(values: np.ndarray, expected: np.ndarray) -> float:
    """Largest ``|values - expected| / |expected|`` (0 where they are equal, inf where
    ``expected`` is 0 and ``values`` is not)."""
    differ = values != expected
    if not differ.any():
        return 0.0
    with np.errstate(divide="ignore"):
        return float(np.max(np.abs(values[differ] - expected[differ]) / np.abs(expected[differ])))


def _probabilities(logits: torch.Tensor, action_mask: torch.Tensor) -> torch.Tensor:
    """The actor's distribution over the ``action_mask`` rows (``MaskedCategorical``'s)."""
    return torch.softmax(logits.masked_fill(~action_mask, float("-inf")), 0)


class LearnedPolicy:
    """The trained actor, greedy, behind the :class:`~explore_rl.planning.policies.Policy` protocol.

    ``config.checkpoint``: an actor file (explore_rl/models/actor_file.py) or a training
    checkpoint; by default the shipped policy. A missing or unusable file raises
    ``CheckpointError`` (a ValueError) with one line naming it. ``reference``: decide by
    the first implementation (the candidates' paths predicted one at a time,
    :func:`graph_features_reference`, the encoding padded to ``graph.max_nodes``) -- the
    same choices, kept to check and time the fast path against.

    ``config.em_top_k`` > 0: the actor shortlists its ``k`` most probable frontiers and the
    EM planner (``planning.em``, ``robot`` for its odometry sigmas) picks among them by its
    Algorithm 1 utility -- not the learned policy alone: it pays EM's decision context and
    ``k`` candidates' utilities (:attr:`last_evaluation`); ``k`` >= the action set is EM.
    ``config.em_below_confidence`` > 0: EM decides over the whole action set when the actor's
    top probability is below it (:attr:`em_decisions` counts them), the actor elsewhere.
    """

    name = "learned"

    def __init__(self, config: PolicyConfig, planning: PlanningConfig, graph: GraphConfig | None = None,
                 actor: GraphActor | None = None, reference: bool = False, robot: RobotConfig | None = None):
        self.config = config
        self.reference = reference
        self.planning = planning
        self.actor_file: ActorFile | None = None
        if actor is None:
            actor, self.actor_file = load_actor(config.checkpoint)
        self.actor = actor.eval()
        self.max_nodes = int((graph or GraphConfig()).max_nodes)
        # what the actor reads: its file says so; an actor handed in reads graph.features
        self.features = (self.actor_file.feature_set if self.actor_file is not None
                         else (graph or GraphConfig()).features)
        self._vmap: VirtualMap | None = None
        self.last_actions: list[Action] = []  # the action set of the last decision
        self.last_graph: ExplorationGraph | None = None
        self.last_encoded: EncodedGraph | None = None
        self.last_logits: torch.Tensor | None = None
        self.last_choice: int | None = None
        self.last_ms: dict[str, float] = {}
        self.robot = robot
        self._em: EMPlanner | None = None
        self.last_evaluation: EMEvaluation | None = None
        self.decisions = self.em_decisions = 0  # choices made, and those EM made (em_below_confidence)

    def virtual_map(self, grid: GridSpec) -> VirtualMap:
        """The virtual map geometry on ``grid`` (built once; its state is never used)."""
        if self._vmap is None or self._vmap.grid != grid:
            self._vmap = VirtualMap(grid, self.planning.virtual_map)
        return self._vmap

    def choose(self, state: ExplorationState) -> int:
        start = time.perf_counter()
        actions = select_actions(state, self.planning.actions, self.planning.revisits, self.reference)
        after_actions = time.perf_counter()
        features = graph_features_reference if self.reference else graph_features
        graph = features(state, actions, self.virtual_map(state.session.occupancy.grid),
                         self.planning.em.backend, self.features)
        encoded = encode(graph, self.max_nodes, compact=not self.reference)
        after_graph = time.perf_counter()
        logits = actor_logits(self.actor, encoded)
        biased = self.biased(logits, graph, encoded, actions, state)
        action_mask = torch.from_numpy(encoded.action_mask)
        after_forward = time.perf_counter()
        self.last_actions, self.last_graph, self.last_encoded, self.last_logits = actions, graph, encoded, logits
        self.last_evaluation = None
        self.decisions += 1
        gate = self.config.em_below_confidence
        unsure = gate > 0 and top_probability(biased, action_mask) < gate
        if self.config.em_top_k > 0:  # EM decides among the actor's shortlist
            rows = shortlist_rows(biased, action_mask, self.config.em_top_k)
            self.last_evaluation = self.em_planner().evaluate(state, shortlist(actions, graph, encoded, rows))
            self.last_choice = self.last_evaluation.chosen
        elif unsure:  # EM decides over the whole action set
            self.last_evaluation = self.em_planner().evaluate(state, actions)
            self.last_choice = self.last_evaluation.chosen
            self.em_decisions += 1
        else:
            self.last_choice = int(graph.candidate[encoded.nodes[greedy_row(biased, action_mask)]])
        end = time.perf_counter()
        self.last_ms = {"actions": 1e3 * (after_actions - start), "graph": 1e3 * (after_graph - after_actions),
                        "forward": 1e3 * (end - after_graph)}
        if self.last_evaluation is not None:  # the shortlist's EM evaluation apart from the forward pass
            self.last_ms.update(forward=1e3 * (after_forward - after_graph), em=1e3 * (end - after_forward))
        return self.last_choice

    def em_planner(self) -> EMPlanner:
        """The EM planner of the hybrids (``policy.em_top_k``, ``policy.em_below_confidence``; built once: its
        observation cache carries over between decisions, as EM's own does)."""
        if self._em is None:
            self._em = EMPlanner(self.config, self.planning, robot=self.robot)
        return self._em

    def loop_prior_applies(self, travel: float) -> bool:
        """Whether ``policy.loop_bias`` applies after ``travel`` metres: from
        ``loop_bias_from_m`` (0: from the start) to before ``loop_bias_until_m`` (0: no end)."""
        start, until = float(self.config.loop_bias_from_m), float(self.config.loop_bias_until_m)
        return travel >= start and not (until > 0 and travel >= until)

    def biased(self, logits: torch.Tensor, graph: ExplorationGraph, encoded: EncodedGraph,
               actions: list[Action], state: ExplorationState) -> torch.Tensor:
        """The logits the greedy choice reads: the actor's, plus ``policy.revisit_bias`` per
        keyframe a frontier's path revisits, ``policy.loop_bias`` per metre of its
        ``loop_length`` (priors towards closing loops, long ones for the second; 0: the actor's)
        and ``policy.closure_bias`` per metre of its :func:`closure_gains` (towards closures
        that remove drift); the second only within its travel window, from
        ``policy.loop_bias_from_m`` to before ``policy.loop_bias_until_m`` metres (each if set)."""
        revisit_bias, closure_bias = float(self.config.revisit_bias), float(self.config.closure_bias)
        loop_bias = float(self.config.loop_bias) if self.loop_prior_applies(state.travel) else 0.0
        if revisit_bias:
            logits = logits + revisit_bias * torch.from_numpy(revisit_counts(graph, encoded, actions))
        if loop_bias:
            logits = logits + loop_bias * torch.from_numpy(loop_length_rows(graph, encoded))
        if closure_bias:
            rows = closure_gain_rows(state, actions, graph, encoded, self.planning.em.loop_sigma_translation)
            logits = logits + closure_bias * torch.from_numpy(rows)
        return logits
