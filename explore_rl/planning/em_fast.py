"""EM's fast backend (``planning.em.backend=fast``): the same utilities as the reference
forward simulation (explore_rl/planning/em.py) without a graph copy per candidate.

Per decision, once (:class:`FastContext`):

* the live graph's information matrix at iSAM2's linearisation point, factorised once
  (:class:`~explore_rl.slam.marginals.SparseMarginals`; only its planar part, yaw/x/y in
  3x3 blocks, when no factor couples it to roll/pitch/z, as on planar robots): every
  keyframe's marginal by selected inversion (the decision context's and the graph
  features' covariances) and, on demand, the covariance columns of the few keyframes
  candidates revisit;
* which virtual-map observations each landmark has, in fusion rounds (:class:`FuseRounds`),
  shared by U0 and every candidate's re-fusion; the keyframes' observations themselves are
  carried over from the previous decision where nothing they depend on changed
  (:class:`~explore_rl.planning.em.ObservationCache`).

Per candidate with a predicted loop (:func:`loop_update`), instead of copying iSAM2:

1. the predicted keyframes hang off the last keyframe by odometry + scan-matching factors
   at their noise-free means: linear propagation gives their covariances and their
   cross-covariances with every old keyframe (through the last keyframe's column);
2. each predicted loop ``(r, k)`` is one more 6-dof factor: all loops together are a
   rank-``6m`` update of that joint (Woodbury), which needs only the covariance columns
   of the revisited keyframes ``r`` and of the last keyframe (rank ``3m`` and three
   columns each when planar and off-plane dofs are decoupled);
3. the virtual map is fused again from the prior, in the same order and by the same
   covariance intersection as the reference, but for all loop candidates at once
   (:func:`fuse_batched`: one compiled loop over the rounds for each set;
   :func:`fuse_batched_reference`, the same in numpy, a round ~20 numpy calls whatever
   its size, as many rounds as the most-seen landmark has observations, ~150-200 on
   office graphs). Candidates whose paths agree up to their last loop leave bitwise the
   same old covariances (about a third of them): each distinct set is fused once
   (:func:`distinct`). An observation's covariance ``noise + gain S gain^T`` is a linear
   function of the pose covariance ``S`` (gains ``[-I | lever]``: :func:`lever_terms`),
   evaluated as component arithmetic on ``(rows, sets)`` arrays. The new keyframes'
   line-of-sight tests run once for the distinct predicted poses of all candidates
   (:func:`batch_observations`; paths share their first stretch), and their observations
   are fused into every candidate's map by the same rounds.

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
import scipy.sparse as sp

from explore_rl.planning.compiled import fuse_rounds, round_layout
from explore_rl.slam.marginals import BLOCK, SparseMarginals, scalar_indices
from explore_rl.slam.pose_graph import PoseGraph, odometry_covariance
from explore_rl.sorting import stable_argsort

if TYPE_CHECKING:
    from explore_rl.planning.em import DecisionContext, Observations, PredictedPath
    from explore_rl.planning.virtual_map import VirtualMap

# Rows/columns (yaw, x, y) of gtsam's Pose3 tangent order (rx, ry, rz, tx, ty, tz): the
# ones the world-frame (x, y, yaw) covariance reads.
ROT_Z, TRANS_X, TRANS_Y = 2, 3, 4
PLANAR = (ROT_Z, TRANS_X, TRANS_Y)
OFF_PLANE = (0, 1, 5)  # roll, pitch, z


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
    """What the fast backend shares between the candidates of one decision.

    When no factor couples the planar dofs (yaw, x, y) with roll, pitch and z (planar
    poses, planar factors with diagonal noise: ``planar_decoupled``), only the planar part
    of the system is factorised (3x3 blocks: about half the cost); the off-plane blocks of
    ``tangent_covs`` are then zero, and nothing reads them (the planar rows of every
    product with a planar pose's adjoint involve only planar dofs).
    """

    marginals: SparseMarginals  # the 6-dof system, or its planar part (``decoupled``)
    tangent_covs: np.ndarray  # (N, 6, 6) every keyframe's marginal (Pose3 tangent, body frame)
    decoupled: bool  # ``marginals`` holds the planar system only
    information: sp.spmatrix  # the 6-dof system, for :meth:`full`
    rounds: FuseRounds | None = None  # the current observations in fusion rounds (set by the context)
    _full: FastContext | None = None

    @classmethod
    def of(cls, graph: PoseGraph, planar: bool = True) -> FastContext:
        """Factorise the live graph (its planar part when ``planar`` and decoupled)."""
        information = graph.information_matrix()
        if planar and planar_decoupled(information):
            scalar = scalar_indices(np.arange(information.shape[0] // BLOCK)).reshape(-1, BLOCK)[:, list(PLANAR)]
            marginals = SparseMarginals(information[scalar.ravel()][:, scalar.ravel()], block=len(PLANAR))
            covs = np.zeros((marginals.num_blocks, BLOCK, BLOCK))
            covs[:, 2:5, 2:5] = marginals.diagonal_blocks()  # PLANAR = (2, 3, 4)
            return cls(marginals, covs, True, information)
        marginals = SparseMarginals(information)
        return cls(marginals, marginals.diagonal_blocks(), False, information)

    def full(self) -> FastContext:
        """The 6-dof factorisation (built on demand if a planar context meets an update
        that couples the planar dofs with the others)."""
        if not self.decoupled:
            return self
        if self._full is None:
            marginals = SparseMarginals(self.information)
            self._full = FastContext(marginals, marginals.diagonal_blocks(), False, self.information)
        return self._full

    def cross(self, poses, dims: list[int], rows: list[int]) -> np.ndarray:
        """``(N, len(rows), k, len(dims))``: ``Cov(xi_a[rows], xi_p[dims])`` for every
        keyframe ``a`` and each of the ``k`` keyframes ``poses`` (tangent components)."""
        n, k = self.marginals.num_blocks, len(np.atleast_1d(poses))
        if self.decoupled:
            local = [PLANAR.index(d) for d in dims]
            columns = self.marginals.columns(poses, local).reshape(n, len(PLANAR), k, len(dims))
            return columns[:, [PLANAR.index(r) for r in rows]]
        return self.marginals.columns(poses, dims).reshape(n, BLOCK, k, len(dims))[:, rows]

    def rounds_of(self, observations: Observations) -> FuseRounds:
        """The fusion rounds of the current observations (built once per decision)."""
        if self.rounds is None:
            self.rounds = FuseRounds.of(observations)
        return self.rounds


def planar_decoupled(information) -> bool:
    """Whether the information matrix (Pose3 tangent order per pose) has no entry joining
    a planar dof of one pose to an off-plane dof of any pose (planar poses, planar factors
    with diagonal noise): then planar marginals and updates need only planar columns."""
    coo = information.tocoo()
    planar = np.isin(coo.row % BLOCK, PLANAR)
    return not np.any((planar != np.isin(coo.col % BLOCK, PLANAR)) & (coo.data != 0))


def _block_diagonal(matrices: np.ndarray) -> bool:
    """Whether 6x6 tangent matrices ``(..., 6, 6)`` join no planar dof to an off-plane one."""
    return not np.any(matrices[..., list(PLANAR), :][..., list(OFF_PLANE)])


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
    unique, index = np.unique(np.asarray(steps, dtype=int), return_inverse=True)
    odom = np.stack([odometry_covariance(graph.config, int(n)) for n in unique])
    if _diagonal(odom) and _diagonal(ssm_cov):  # the usual case: no 6x6 inverses
        fused = np.zeros_like(odom)
        diag = 1.0 / (1.0 / np.diagonal(odom, axis1=1, axis2=2) + 1.0 / np.diag(ssm_cov))
        fused[:, np.arange(6), np.arange(6)] = diag
    else:
        fused = np.linalg.inv(np.linalg.inv(odom) + np.linalg.inv(ssm_cov))
    return fused[index.ravel()]


def _diagonal(matrices: np.ndarray) -> bool:
    return not np.any(matrices - matrices * np.eye(matrices.shape[-1]))


@dataclass
class CandidateCovariances:
    """World-frame (x, y, yaw) covariances after a candidate's path (and loops)."""

    old: np.ndarray  # (N, 3, 3) the live keyframes
    new: np.ndarray  # (P, 3, 3) the predicted keyframes


def loop_update(context: DecisionContext, fast: FastContext, predicted: PredictedPath, steps: np.ndarray,
                loop_cov: np.ndarray) -> CandidateCovariances:
    """Every keyframe's covariance once the predicted keyframes and loops join the graph
    (module docstring, steps 1-2); ``steps (P, 6, 6)``: the predicted steps' noise
    (:func:`step_tangent_covariances`), ``loop_cov (6, 6)`` the loops'."""
    last = len(context.poses) - 1
    revisited = np.array([r.keyframe_index for r in predicted.revisits], dtype=int)
    at = np.array([r.path_index for r in predicted.revisits], dtype=int)
    m = len(revisited)
    poses_new = predicted.poses
    adj_new = planar_adjoint(poses_new)  # (P, 6, 6)
    adj_new_inv = planar_adjoint_inverse(poses_new)
    adj_last = planar_adjoint(context.poses[last])[0]
    if fast.decoupled and not (_block_diagonal(steps) and _block_diagonal(loop_cov)):
        fast = fast.full()  # predicted factors that couple the planar dofs with the others
    sigma_last = fast.tangent_covs[last]

    # 1. the chain: world-frame accumulated covariance W_k = Cov(eta_k)
    world_steps = adj_new @ steps @ np.swapaxes(adj_new, 1, 2)
    world = adj_last @ sigma_last @ adj_last.T + np.cumsum(world_steps, axis=0)  # (P, 6, 6)
    new = world_from_tangent(adj_new_inv @ world @ np.swapaxes(adj_new_inv, 1, 2), poses_new)
    if not m:
        return CandidateCovariances(context.pose_covs, new)
    # 2. the loops; planar poses and factors: the planar rows of every update involve only planar dofs
    dims = list(PLANAR) if fast.decoupled else list(range(BLOCK))
    u_old, u_new, gain = _woodbury(context, fast, revisited, at, world, adj_new, adj_new_inv, adj_last, loop_cov,
                                   dims)
    return CandidateCovariances(_downdate(context.pose_covs, context.poses, u_old, gain),
                                _downdate(new, poses_new, u_new, gain))


def _woodbury(context, fast, revisited, at, world, adj_new, adj_new_inv, adj_last, loop_cov,
              dims: list[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Condition the chain's joint on the ``m`` loops ``y_j = eta_k - eta_r ~ N(0, R)``:
    the cross-covariances ``U (n, 3, m d)`` of the planar tangent rows (yaw, x, y) of every
    old and every new keyframe with the loops, and ``gain = Cov(y)^-1``, for
    :func:`_downdate` (only the planar rows/columns of each marginal are needed).
    ``dims``: the tangent components of the loops that enter (all 6, or the planar 3 when
    nothing couples them to roll, pitch and z: the same planar result at a quarter of the
    cost, a rank-3m update from 3 covariance columns per revisited keyframe)."""
    n, m, d = len(context.poses), len(revisited), len(dims)
    planar = list(PLANAR)
    sub = np.ix_(dims, dims)
    adj_r = planar_adjoint(context.poses[revisited])[(slice(None),) + sub]  # (m, d, d)
    adj_last, world = adj_last[sub], world[(slice(None),) + sub]
    adj_new, adj_new_inv, loop_cov = adj_new[(slice(None),) + sub], adj_new_inv[(slice(None), planar)], loop_cov[sub]
    columns = fast.cross(np.r_[revisited, n - 1], dims, planar + [c for c in dims if c not in planar])
    # Cov(xi_a, y_j), y_j = eta_{k_j} - eta_{r_j}, planar rows of every old pose: (N, 3, m, d)
    rows = columns[:, :3]
    u_old = np.empty((n, 3, m, d))
    last = rows[:, :, m] @ adj_last.T
    for j in range(m):  # one product per loop (a stacked (1, d) @ (d, d) per row is slower)
        np.subtract(last, rows[:, :, j] @ adj_r[j].T, out=u_old[:, :, j])
    # the loops' own covariance S0 = Cov(y) and R (world-frame loop noise at k_j)
    by_dims = [(planar + [c for c in dims if c not in planar]).index(c) for c in dims]
    at_r = columns[revisited][:, by_dims].transpose(0, 2, 1, 3)  # (m, m + 1, d, d): Cov(xi_r, xi_j)
    eta_r_r = adj_r[:, None] @ at_r[:, :m] @ np.swapaxes(adj_r, 1, 2)[None]  # (m, m, d, d)
    eta_r_k = adj_r @ at_r[:, m] @ adj_last.T  # (m, d, d): Cov(eta_r, eta_k) for any new k
    eta_k_k = world[np.minimum(at[:, None], at[None, :])]  # (m, m, d, d)
    s0 = eta_k_k - np.swapaxes(eta_r_k, 1, 2)[None] - eta_r_k[:, None] + eta_r_r
    diag = np.arange(m)
    s0[diag, diag] += adj_new[at] @ loop_cov @ np.swapaxes(adj_new[at], 1, 2)
    gain = np.linalg.inv(s0.transpose(0, 2, 1, 3).reshape(d * m, d * m))
    gain = 0.5 * (gain + gain.T)
    # new keyframes: Cov(xi_k, y_j) = Ad(T_k^-1) [W_min(k, k_j) - Cov(eta_r_j, eta_k)^T], planar rows
    k = np.arange(len(world))
    inv_rows = adj_new_inv[..., dims] if d < BLOCK else adj_new_inv
    u_new = inv_rows[:, None] @ (world[np.minimum(k[:, None], at[None, :])] - np.swapaxes(eta_r_k, 1, 2)[None])
    return u_old.reshape(n, 3, m * d), u_new.transpose(0, 2, 1, 3).reshape(len(world), 3, -1), gain


def _downdate(world: np.ndarray, poses: np.ndarray, u_rows: np.ndarray, gain: np.ndarray) -> np.ndarray:
    """World-frame (x, y, yaw) covariances ``world (N, 3, 3)`` after the loops: ``world -
    (J U) gain (J U)^T``, with ``U = u_rows (N, 3, k)`` the cross-covariances of the planar
    tangent rows (yaw, x, y) with the loops and ``J`` their rotation to world (x, y, yaw)
    (:func:`world_from_tangent`)."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    u = np.stack([c * u_rows[:, 1] - s * u_rows[:, 2], s * u_rows[:, 1] + c * u_rows[:, 2], u_rows[:, 0]], axis=1)
    u_gain = (u.reshape(-1, u.shape[-1]) @ gain).reshape(u.shape)  # one product for all rows
    return world - u_gain @ np.swapaxes(u, 1, 2)


def distinct(arrays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bitwise-distinct ``arrays[k]`` (first occurrences, in order) and, for each
    ``k``, the position of its copy among them: ``distinct[inverse] == arrays``."""
    positions: dict[bytes, int] = {}
    inverse = np.array([positions.setdefault(a.tobytes(), len(positions)) for a in arrays], dtype=np.int64)
    first = np.unique(inverse, return_index=True)[1]
    return arrays[first], inverse


# ---------------------------------------------------------------------- landmarks


def information_components(covs: np.ndarray) -> np.ndarray:
    """``(3, ...)``: ``(i00, i01, i11)`` of the inverses of symmetric 2x2 ``covs (..., 2, 2)``
    (the expressions of ``virtual_map._information``, so the same floats)."""
    m00, m01, m11 = covs[..., 0, 0], covs[..., 0, 1], covs[..., 1, 1]
    det = m00 * m11 - m01 * m01
    return np.stack([m11 / det, -m01 / det, m00 / det])


def covariances_of(info: np.ndarray) -> np.ndarray:
    """``(..., 2, 2)`` covariances of information components ``info (3, ...)``."""
    i00, i01, i11 = info
    det = i00 * i11 - i01 * i01
    c00, c01, c11 = i11 / det, -i01 / det, i00 / det
    return np.stack([np.stack([c00, c01], axis=-1), np.stack([c01, c11], axis=-1)], axis=-2)


# The six components (row, column) of a symmetric 3x3 pose covariance, as
# :func:`observed_information` reads them.
COMPONENTS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def lever_terms(gain: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """``(10, M)``: each observation's ``noise + gain S gain^T`` as a linear function of
    the :data:`COMPONENTS` ``s..`` of its pose's covariance ``S``, for gains ``[-I | (a, b)]``
    (a range-bearing observation of a point: ``virtual_map.lever_and_noise``)::

        c00 = n00 + s00 - 2a s02 + a^2 s22
        c01 = n01 + s01 -  b s02 -   a s12 + ab s22
        c11 = n11 + s11 - 2b s12 + b^2 s22

    Rows: ``n00, -2a, a^2, n01, -b, -a, ab, n11, -2b, b^2``."""
    a, b = gain[:, 0, 2], gain[:, 1, 2]
    return np.stack([noise[:, 0, 0], -2.0 * a, a * a, noise[:, 0, 1], -b, -a, a * b, noise[:, 1, 1], -2.0 * b, b * b])


@dataclass
class FuseRounds:
    """The current observations arranged for covariance intersection in rounds: round
    ``j`` fuses the ``j``-th observation (pose order) of every landmark seen more than
    ``j`` times. Landmarks (columns) are sorted by observation count, most first, so a
    round touches a prefix of the columns and its rows are one contiguous slice. Built
    once per decision: U0 and every loop candidate fuse the same observations."""

    offsets: np.ndarray  # (R + 1,) where each round's rows start
    landmarks: np.ndarray  # (S,) the landmark of each column
    pose_idx: np.ndarray  # (M,) the pose of each row (round order)
    terms: np.ndarray  # (10, M) :func:`lever_terms` of each row (round order)

    @classmethod
    def of(cls, observations: Observations) -> FuseRounds:
        """``observations`` (gains ``[-I | lever]``: :meth:`Observations.closed_form`), laid
        out by counting (:func:`~explore_rl.planning.compiled.round_layout`): the same
        arrays as :meth:`of_reference`."""
        return cls(*round_layout(observations.landmark_idx, observations.pose_idx, observations.gain,
                                 observations.noise))

    @classmethod
    def of_reference(cls, observations: Observations) -> FuseRounds:
        """:meth:`of` by numpy sorts (the reference of the compiled layout)."""
        landmark_idx = observations.landmark_idx
        order = stable_argsort(landmark_idx)
        sorted_lm = landmark_idx[order]
        starts = np.flatnonzero(np.r_[True, sorted_lm[1:] != sorted_lm[:-1]]) if len(order) else order
        counts = np.diff(np.r_[starts, len(sorted_lm)])
        by_count = np.argsort(-counts, kind="stable")
        column = np.empty(len(starts), dtype=np.int64)
        column[by_count] = np.arange(len(starts))
        rank = np.arange(len(sorted_lm)) - np.repeat(starts, counts)
        slot = rank * max(len(starts), 1) + np.repeat(column, counts)
        rows = order[stable_argsort(slot)]  # distinct slots: any sort gives this order
        offsets = np.r_[0, np.cumsum(np.bincount(rank))] if len(order) else np.zeros(1, dtype=int)
        terms = lever_terms(observations.gain, observations.noise)[:, rows]
        return cls(offsets.astype(np.int64), sorted_lm[starts][by_count], observations.pose_idx[rows], terms)


def fuse_batched(rounds: FuseRounds, pose_covs: np.ndarray, initial: np.ndarray) -> np.ndarray:
    """``(C, S, 2, 2)``: the landmarks of ``rounds`` after fusing every observation into
    ``initial (S, 2, 2)``, for ``C`` sets of pose covariances ``pose_covs (C, N, 3, 3)`` at
    once -- :func:`~explore_rl.planning.virtual_map.fuse_in_order` per set (same order, the
    same covariance intersection). The compiled loop
    (:func:`~explore_rl.planning.compiled.fuse_rounds`): the same floats as
    :func:`fuse_batched_reference`."""
    return fuse_rounds(rounds.offsets, rounds.pose_idx, rounds.terms, pose_covs, information_components(initial))


def fuse_batched_reference(rounds: FuseRounds, pose_covs: np.ndarray, initial: np.ndarray) -> np.ndarray:
    """:func:`fuse_batched` in numpy: one pass of rounds for all sets (the reference of
    the compiled loop, and its equivalence test)."""
    observed = observed_information(rounds.terms, pose_covs, rounds.pose_idx)  # (4, M, C)
    info = np.repeat(information_components(initial)[:, :, None], len(pose_covs), axis=2)  # (3, S, C)
    with np.errstate(divide="ignore", invalid="ignore"):
        for begin, end in zip(rounds.offsets[:-1].tolist(), rounds.offsets[1:].tolist()):
            intersect(info[:, : end - begin], observed[:, begin:end])
    return covariances_of(np.moveaxis(info, 2, 1))


def intersect(info: np.ndarray, observed: np.ndarray) -> None:
    """One round of covariance intersection, in place: ``info (3, ...)`` (the running
    information components) becomes ``B + w (A - B)`` with ``B = observed[:3]`` and ``w``
    the maximiser over [0, 1] of ``det(B + w D) = det B + lin w + quad w^2`` (``D = A - B``),
    as :func:`~explore_rl.planning.virtual_map.ci_weight` -- the clamped stationary point
    where the quadratic is concave, else the endpoint with the larger determinant, found
    from ``det A - det B = lin + quad`` (an exact tie takes ``B``, where ``ci_weight``
    takes ``w = 0.5``: the same when ``A = B``) -- with fewer operations and temporaries.
    ``observed[3]`` holds ``2 b01``. Call under ``np.errstate(divide="ignore", invalid="ignore")``."""
    b = observed[:3]
    diff = info - b
    d00, d01, d11 = diff
    quad = d00 * d11
    quad -= d01 * d01
    lin = observed[0] * d11
    lin += observed[2] * d00
    lin -= observed[3] * d01
    stationary = lin / (-2.0 * quad)
    np.minimum(np.maximum(stationary, 0.0, out=stationary), 1.0, out=stationary)
    lin += quad
    diff *= np.where(quad < 0, stationary, lin > 0)
    np.add(diff, b, out=info)


def observed_information(terms: np.ndarray, pose_covs: np.ndarray, pose_idx: np.ndarray) -> np.ndarray:
    """``(4, M, C)``: ``(i00, i01, i11, 2 i01)`` of the information ``(noise + gain S
    gain^T)^-1`` of each observation (:func:`lever_terms` ``terms (10, M)``, pose
    ``pose_idx (M,)``) for each of ``C`` sets of pose covariances ``pose_covs (C, N, 3, 3)``:
    component arithmetic on ``(rows, C)`` arrays, ``OBSERVATION_CHUNK`` rows at a time
    (temporaries stay in cache)."""
    covs = np.stack([pose_covs[:, :, i, j].T for i, j in COMPONENTS])  # (6, N, C)
    out = np.empty((4, len(pose_idx), pose_covs.shape[0]))
    for begin in range(0, len(pose_idx), OBSERVATION_CHUNK):
        rows = slice(begin, begin + OBSERVATION_CHUNK)
        _observed_chunk(terms[:, rows, None], np.take(covs, pose_idx[rows], axis=1), out[:, rows])
    return out


OBSERVATION_CHUNK = 2048


def _observed_chunk(terms: np.ndarray, covs: np.ndarray, out: np.ndarray) -> None:
    """:func:`observed_information` of one chunk into ``out (4, rows, C)`` (``terms (10,
    rows, 1)``, ``covs (6, rows, C)``), in place where it can."""
    n00, a1, a2, n01, x1, x2, x3, n11, b1, b2 = terms
    s00, s01, s02, s11, s12, s22 = covs
    term = np.empty_like(s00)
    c00 = _affine(n00, s00, [(a1, s02), (a2, s22)], term)
    c01 = _affine(n01, s01, [(x1, s02), (x2, s12), (x3, s22)], term)
    c11 = _affine(n11, s11, [(b1, s12), (b2, s22)], term)
    det = c00 * c11
    np.multiply(c01, c01, out=term)
    det -= term
    np.divide(c11, det, out=out[0])
    np.divide(c01, det, out=out[1])
    np.negative(out[1], out=out[1])
    np.divide(c00, det, out=out[2])
    np.multiply(out[1], 2.0, out=out[3])


def _affine(constant: np.ndarray, component: np.ndarray, products: list[tuple[np.ndarray, np.ndarray]],
            scratch: np.ndarray) -> np.ndarray:
    """``constant + component + sum of coefficient * other`` over ``products`` (a new
    array; ``scratch`` holds each product)."""
    (coefficient, other), *rest = products
    out = coefficient * other
    out += constant
    out += component
    for coefficient, other in rest:
        np.multiply(coefficient, other, out=scratch)
        out += scratch
    return out


def batch_observations(vmap: VirtualMap, poses: list[np.ndarray], blocked: np.ndarray) -> list[tuple]:
    """``vmap.visible_pairs`` of each pose set in ``poses``, with one line-of-sight batch
    for the distinct poses of all sets: ``[(pose_idx, landmark_idx), ...]``, each as
    ``visible_pairs(poses[k], blocked)`` would return it (pose order, then window order)."""
    sizes = [len(p) for p in poses]
    if not sum(sizes):
        return [(np.zeros(0, dtype=int), np.zeros(0, dtype=int)) for _ in poses]
    stacked = np.concatenate([np.asarray(p, float).reshape(-1, 3) for p in poses])
    unique, inverse = np.unique(stacked, axis=0, return_inverse=True)
    pose_idx, landmark_idx = vmap.visible_pairs(unique, blocked, by_length=True)
    starts = np.searchsorted(pose_idx, np.arange(len(unique) + 1))
    out, offset = [], 0
    for size in sizes:
        ids = inverse.ravel()[offset: offset + size]
        offset += size
        spans = [np.arange(starts[u], starts[u + 1]) for u in ids]
        rows = np.concatenate(spans) if spans else np.zeros(0, dtype=int)
        out.append((np.repeat(np.arange(size), [len(x) for x in spans]), landmark_idx[rows]))
    return out
