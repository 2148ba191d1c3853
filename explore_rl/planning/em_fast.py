"""EM's fast backend (``planning.em.backend=fast``): the same utilities as the reference
forward simulation (explore_rl/planning/em.py) without a graph copy per candidate.

Per decision, once (:class:`FastContext`):

* the live graph's information matrix at iSAM2's linearisation point, factorised once
  (:class:`~explore_rl.slam.marginals.SparseMarginals`): every keyframe's marginal by
  selected inversion (the decision context's and the graph features' covariances) and,
  on demand, the covariance columns of the few keyframes candidates revisit;
* which virtual-map observations each landmark has (to re-fuse only what changes).

Per candidate with a predicted loop (:func:`loop_update`), instead of copying iSAM2:

1. the predicted keyframes hang off the last keyframe by odometry + scan-matching factors
   at their noise-free means: linear propagation gives their covariances and their
   cross-covariances with every old keyframe (through the last keyframe's column);
2. each predicted loop ``(r, k)`` is one more 6-dof factor: all loops together are a
   rank-``6m`` update of that joint (Woodbury), which needs only the covariance columns
   of the revisited keyframes ``r`` and of the last keyframe;
3. only landmarks seen from a keyframe whose (x, y, yaw) covariance moved by more than
   ``planning.em.refuse_tolerance`` of its norm are re-fused from the prior (in the same
   pose order as the reference); the others keep the current map's fused covariance.

Computed in world-frame adjoint coordinates ``eta = Ad(T) xi`` (gtsam's right perturbation
``T Exp(xi)``): a chain keyframe then moves as ``eta_k = eta_last + sum of step noises``,
and a loop measures ``eta_k - eta_r``.

**Against the reference.** The reference updates a copy of iSAM2 (which may relinearise
variables whose estimate moved more than ``slam.pose_graph.relinearize_threshold``) and
linearises the predicted factors at the copy's linearisation point; this backend
linearises them at the planar estimates the reference measures them from (zero
residual, so robust kernels weigh 1). The two agree to linearisation differences
(DESIGN.md: iSAM2 marginals move by up to ~1 % with the linearisation point);
tests/planning/test_em_fast.py bounds the utility gap on recorded office, street and
garage states and the choice agreement; benchmarks/bench_env.py reports it over many
decisions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from explore_rl.planning.config import EMConfig
from explore_rl.slam.marginals import BLOCK, SparseMarginals
from explore_rl.slam.pose_graph import PoseGraph, odometry_covariance

if TYPE_CHECKING:
    from explore_rl.planning.em import DecisionContext, PredictedPath

# Rows/columns (yaw, x, y) of gtsam's Pose3 tangent order (rx, ry, rz, tx, ty, tz): the
# ones the world-frame (x, y, yaw) covariance reads.
ROT_Z, TRANS_X, TRANS_Y = 2, 3, 4


# ---------------------------------------------------------------------- SE(3) of planar poses


def planar_adjoint(poses: np.ndarray) -> np.ndarray:
    """``(P, 6, 6)`` gtsam ``Pose3.AdjointMap`` of planar poses ``[x, y, yaw]`` (z = 0,
    no roll/pitch): ``[[R, 0], [t^ R, R]]`` in tangent order (w, v)."""
    poses = np.asarray(poses, float).reshape(-1, 3)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    rot = np.zeros((len(poses), 3, 3))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
    skew = np.zeros((len(poses), 3, 3))
    x, y = poses[:, 0], poses[:, 1]
    skew[:, 0, 2], skew[:, 1, 2], skew[:, 2, 0], skew[:, 2, 1] = y, -x, -y, x
    adj = np.zeros((len(poses), 6, 6))
    adj[:, :3, :3] = rot
    adj[:, 3:, 3:] = rot
    adj[:, 3:, :3] = skew @ rot
    return adj


def planar_adjoint_inverse(poses: np.ndarray) -> np.ndarray:
    """``(P, 6, 6)``: ``Ad(T^-1) = Ad(T)^-1`` = ``[[R^T, 0], [-R^T t^, R^T]]``."""
    adj = planar_adjoint(poses)
    rot_t = np.swapaxes(adj[:, :3, :3], 1, 2)
    inv = np.zeros_like(adj)
    inv[:, :3, :3] = rot_t
    inv[:, 3:, 3:] = rot_t
    inv[:, 3:, :3] = -rot_t @ adj[:, 3:, :3] @ rot_t
    return inv


def world_from_tangent(covs: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """World-frame (x, y, yaw) covariances ``(N, 3, 3)`` of 6x6 tangent covariances at
    planar ``poses`` (the transform of :func:`explore_rl.planning.em.world_covariances`)."""
    jac = np.zeros((len(poses), 3, 6))
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    jac[:, 0, TRANS_X], jac[:, 0, TRANS_Y] = c, -s
    jac[:, 1, TRANS_X], jac[:, 1, TRANS_Y] = s, c
    jac[:, 2, ROT_Z] = 1.0
    return jac @ covs @ np.swapaxes(jac, 1, 2)


# ---------------------------------------------------------------------- per decision


@dataclass
class FastContext:
    """What the fast backend shares between the candidates of one decision."""

    marginals: SparseMarginals
    tangent_covs: np.ndarray  # (N, 6, 6) every keyframe's marginal (Pose3 tangent, body frame)
    # (M, 3) each current observation's landmark information (i00, i01, i11) just before
    # it was fused into the current map (fuse_in_order's ``before``)
    fused_before: np.ndarray | None = None

    @classmethod
    def of(cls, graph: PoseGraph) -> FastContext:
        marginals = SparseMarginals(graph.information_matrix())
        return cls(marginals, marginals.diagonal_blocks())


def fast_world_covariances(graph: PoseGraph, poses: np.ndarray) -> tuple[np.ndarray, FastContext]:
    """``(N, 3, 3)`` world-frame (x, y, yaw) marginals of every keyframe (as
    :func:`~explore_rl.planning.em.world_covariances`, from one factorisation) and the
    factorisation, for the candidates' updates."""
    fast = FastContext.of(graph)
    return world_from_tangent(fast.tangent_covs, poses), fast


# ---------------------------------------------------------------------- per candidate


def step_tangent_covariances(graph: PoseGraph, steps: np.ndarray, ssm_cov: np.ndarray) -> np.ndarray:
    """``(P, 6, 6)`` noise of each predicted step: odometry and scan matching join the same
    poses at the same mean, so they act as one factor with the summed information."""
    ssm_info = np.linalg.inv(ssm_cov)
    odom = np.stack([odometry_covariance(graph.config, int(n)) for n in steps])
    return np.linalg.inv(np.linalg.inv(odom) + ssm_info)


@dataclass
class CandidateCovariances:
    """World-frame (x, y, yaw) covariances after a candidate's path (and loops)."""

    old: np.ndarray  # (N, 3, 3) the live keyframes
    new: np.ndarray  # (P, 3, 3) the predicted keyframes


def loop_update(context: DecisionContext, fast: FastContext, predicted: PredictedPath,
                graph: PoseGraph, config: EMConfig, ssm_cov: np.ndarray,
                loop_cov: np.ndarray) -> CandidateCovariances:
    """Every keyframe's covariance once the predicted keyframes and loops join the graph
    (module docstring, steps 1-2)."""
    last = len(context.poses) - 1
    revisited = np.array([r.keyframe_index for r in predicted.revisits], dtype=int)
    at = np.array([r.path_index for r in predicted.revisits], dtype=int)
    m = len(revisited)
    poses_new = predicted.poses
    adj_new = planar_adjoint(poses_new)  # (P, 6, 6)
    adj_new_inv = planar_adjoint_inverse(poses_new)
    adj_last = planar_adjoint(context.poses[last])[0]
    sigma_last = fast.tangent_covs[last]

    # 1. the chain: world-frame accumulated covariance W_k = Cov(eta_k)
    steps = step_tangent_covariances(graph, predicted.steps, ssm_cov)
    world_steps = adj_new @ steps @ np.swapaxes(adj_new, 1, 2)
    world = adj_last @ sigma_last @ adj_last.T + np.cumsum(world_steps, axis=0)  # (P, 6, 6)
    new_tangent = adj_new_inv @ world @ np.swapaxes(adj_new_inv, 1, 2)
    old_tangent = fast.tangent_covs
    if m:
        old_tangent, new_tangent = _woodbury(context, fast, revisited, at, world, adj_new, adj_new_inv,
                                             adj_last, loop_cov, old_tangent, new_tangent)
    return CandidateCovariances(world_from_tangent(old_tangent, context.poses),
                                world_from_tangent(new_tangent, poses_new))


def _woodbury(context, fast, revisited, at, world, adj_new, adj_new_inv, adj_last, loop_cov,
              old_tangent, new_tangent) -> tuple[np.ndarray, np.ndarray]:
    """Condition the chain's joint on the ``m`` loops ``eta_k - eta_r ~ N(0, R)``; only the
    planar rows/columns (yaw, x, y) of each updated marginal are needed, the rest are kept."""
    last = len(context.poses) - 1
    m = len(revisited)
    adj_r = planar_adjoint(context.poses[revisited])  # (m, 6, 6)
    cross = fast.marginals.cross_blocks(np.r_[revisited, last])  # (N, m + 1, 6, 6): Cov(xi_a, xi_j)
    cross_r, cross_last = cross[:, :m], cross[:, m]
    # Cov(xi_a, y_j), y_j = eta_{k_j} - eta_{r_j}: (N, m, 6, 6)
    u_old = (cross_last @ adj_last.T)[:, None] - cross_r @ np.swapaxes(adj_r, 1, 2)[None]
    # the loops' own covariance S0 = Cov(y) and R (world-frame loop noise at k_j)
    eta_r_r = adj_r[:, None] @ cross_r[revisited] @ np.swapaxes(adj_r, 1, 2)[None]  # (m, m, 6, 6)
    eta_r_k = adj_r @ cross_last[revisited] @ adj_last.T  # (m, 6, 6): Cov(eta_r, eta_k) for any k
    eta_k_k = world[np.minimum(at[:, None], at[None, :])]  # (m, m, 6, 6)
    s0 = eta_k_k - np.swapaxes(eta_r_k, 1, 2)[None] - eta_r_k[:, None] + eta_r_r
    diag = np.arange(m)
    s0[diag, diag] += adj_new[at] @ loop_cov @ np.swapaxes(adj_new[at], 1, 2)
    gain = np.linalg.inv(s0.transpose(0, 2, 1, 3).reshape(6 * m, 6 * m))
    gain = 0.5 * (gain + gain.T)
    # new keyframes: Cov(xi_k, y_j) = Ad(T_k^-1) [W_min(k, k_j) - Cov(eta_r_j, eta_k)^T]
    k = np.arange(len(world))
    u_new = adj_new_inv[:, None] @ (world[np.minimum(k[:, None], at[None, :])] - np.swapaxes(eta_r_k, 1, 2)[None])
    planar = [ROT_Z, TRANS_X, TRANS_Y]
    old_tangent = _downdate(old_tangent, u_old, gain, planar)
    new_tangent = _downdate(new_tangent, u_new, gain, planar)
    return old_tangent, new_tangent


def _downdate(covs: np.ndarray, u: np.ndarray, gain: np.ndarray, rows: list[int]) -> np.ndarray:
    """``covs - U gain U^T`` on the ``rows`` block of each covariance (``u (N, m, 6, 6)``)."""
    n, m = u.shape[:2]
    u_rows = u[:, :, rows, :].transpose(0, 2, 1, 3).reshape(n, len(rows), m * BLOCK)
    out = covs.copy()
    block = np.ix_(rows, rows)
    out[:, block[0], block[1]] = covs[:, block[0], block[1]] - u_rows @ gain @ np.swapaxes(u_rows, 1, 2)
    return out


# ---------------------------------------------------------------------- landmarks


def congruence(gain: np.ndarray, covs: np.ndarray) -> np.ndarray:
    """``(M, 2, 2)``: ``gain @ covs @ gain^T`` for ``gain (M, 2, 3)`` and symmetric
    ``covs (M, 3, 3)``, written out (batched 2x3 matmuls cost ~10x more in numpy)."""
    g0, g1 = gain[:, 0], gain[:, 1]  # (M, 3) rows
    t0 = np.einsum("mj,mjk->mk", g0, covs)  # row 0 of gain @ covs
    t1 = np.einsum("mj,mjk->mk", g1, covs)
    out = np.empty((len(gain), 2, 2))
    out[:, 0, 0] = np.einsum("mk,mk->m", t0, g0)
    out[:, 1, 1] = np.einsum("mk,mk->m", t1, g1)
    out[:, 0, 1] = out[:, 1, 0] = np.einsum("mk,mk->m", t0, g1)
    return out



def changed_poses(before: np.ndarray, after: np.ndarray, tolerance: float) -> np.ndarray:
    """``(N,)`` whether each covariance moved by more than ``tolerance`` of its norm."""
    diff = np.linalg.norm((after - before).reshape(len(before), -1), axis=1)
    return diff > tolerance * np.linalg.norm(before.reshape(len(before), -1), axis=1)


def refuse_selection(context: DecisionContext, old_covs: np.ndarray,
                     tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """``(first (L,), rows (M,))``: for every landmark the first of its current
    observations (in pose order) made from a keyframe whose covariance moved by more than
    ``tolerance`` (``M`` if none), and the observations from there on, which are fused
    again (from the landmark's recorded state just before ``first``)."""
    old = context.observations
    count = len(old.pose_idx)
    moved = np.flatnonzero(changed_poses(context.pose_covs, old_covs, tolerance)[old.pose_idx])
    first = np.full(len(context.landmark_covs), count)
    landmarks, at = np.unique(old.landmark_idx[moved], return_index=True)  # rows ascend: the first
    first[landmarks] = moved[at]
    return first, np.arange(count) >= first[old.landmark_idx]
