"""Pose graph: a thin, readable wrapper over ``gtsam.ISAM2`` with ``Pose3`` keyframes.

Keyframe ``i`` is the gtsam key ``symbol('x', i)``; keyframes are numbered 0..N-1 in the
order they are added. Poses are the robot base in the world frame. Measurements
(odometry, scan matching, loop closures) are 4x4 relative transforms ``T_i^-1 T_j``;
their covariances are 6x6 in gtsam's Pose3 tangent order ``(rx, ry, rz, tx, ty, tz)``,
expressed in the body frame of ``j`` (right perturbation ``T Exp(xi)``).

Every change goes through :meth:`PoseGraph._apply`, which turns plain-numpy factor
records into gtsam factors, runs the iSAM2 update(s) and logs the batch. The log makes
the graph picklable (``__setstate__`` replays it, reproducing the same iSAM2 state) and
:meth:`copy` uses the iSAM2 copy constructor (``copy.deepcopy`` of an ISAM2 fails).

Estimates are read once per update and only where they can have changed (a keyframe's
iSAM2 delta or linearisation point): bit for bit ``calculateEstimate()``, without
retracting the whole trajectory at every keyframe.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING

import gtsam
import numpy as np
import scipy.sparse as sp

from explore_rl.geometry import se2_to_matrix
from explore_rl.slam.config import PoseGraphConfig

if TYPE_CHECKING:
    from explore_rl.slam.frontend import ScanMatch

ODOMETRY = "odometry"
SCAN_MATCHING = "scan_matching"
PRIOR = "prior"


_KEY_BASE = ord("x") << 56  # gtsam.Symbol layout: the character in the top byte
_INDEX_MASK = (1 << 56) - 1

# Above this fraction of changed poses, one full ``calculateEstimate`` beats per-key reads
# (~0.6 vs ~3 us per pose, measured on office episodes; the same values either way, see
# PoseGraph._read_estimates).
_FULL_READ_FRACTION = 0.2


def key(i: int) -> int:
    """gtsam key of keyframe ``i``: ``gtsam.symbol("x", i)`` in plain integer arithmetic
    (a call into gtsam costs ~10x more on the per-keyframe path)."""
    i = int(i)
    if i < 0:
        raise IndexError(f"keyframe index must be >= 0, got {i}")
    return _KEY_BASE | i


@dataclass(frozen=True)
class FactorRecord:
    """One factor as plain data: a prior (``j is None``) or a between factor ``i -> j``."""

    kind: str
    i: int
    j: int | None
    measurement: np.ndarray  # 4x4: the prior pose, or the relative pose T_i^-1 T_j
    covariance: np.ndarray  # 6x6, Pose3 tangent order (rx, ry, rz, tx, ty, tz)
    robust: bool = False

    def __post_init__(self) -> None:
        # Own read-only copies: the log must not change if the caller reuses its arrays.
        object.__setattr__(self, "measurement", frozen_array(self.measurement))
        object.__setattr__(self, "covariance", frozen_array(self.covariance))


def frozen_array(values) -> np.ndarray:
    """A read-only float copy of ``values`` (an array that is one already is kept)."""
    if isinstance(values, np.ndarray) and values.dtype == np.float64 and not values.flags.writeable:
        return values
    array = np.array(values, dtype=float)
    array.flags.writeable = False
    return array


@dataclass
class _Batch:
    """Everything passed to one ``PoseGraph._apply`` call (the unit of replay)."""

    factors: list[FactorRecord]
    new_poses: dict[int, np.ndarray] = field(default_factory=dict)
    extra_updates: int = 0


def as_matrix(pose: np.ndarray) -> np.ndarray:
    """A 4x4 transform from a 4x4 or a planar ``[x, y, yaw]``."""
    pose = np.asarray(pose, dtype=float)
    if pose.shape == (3,):
        return se2_to_matrix(pose)
    if pose.shape == (4, 4):
        return pose
    raise ValueError(f"expected a 4x4 transform or [x, y, yaw], got shape {pose.shape}")


def odometry_covariance(config: PoseGraphConfig, motion_steps: int) -> np.ndarray:
    """6x6 odometry covariance over ``motion_steps`` steps (x, y, yaw scale with sqrt)."""
    scale = np.sqrt(max(int(motion_steps), 1))
    sigmas = np.array(
        [
            config.odom_sigma_roll_pitch,
            config.odom_sigma_roll_pitch,
            np.deg2rad(config.odom_sigma_yaw_deg_per_step) * scale,
            config.odom_sigma_xy_per_step * scale,
            config.odom_sigma_xy_per_step * scale,
            config.odom_sigma_z,
        ]
    )
    return np.diag(sigmas**2)


def _gaussian(covariance: np.ndarray) -> gtsam.noiseModel.Base:
    covariance = np.asarray(covariance, dtype=float)
    variances = covariance.diagonal()
    if np.count_nonzero(covariance) == np.count_nonzero(variances):  # diagonal
        return gtsam.noiseModel.Diagonal.Variances(variances.copy())
    return gtsam.noiseModel.Gaussian.Covariance(covariance)


@lru_cache(maxsize=None)
def _m_estimator(kernel: str, width: float) -> gtsam.noiseModel.mEstimator.Base:
    """The robust kernel (immutable, so one per kind and width is shared by all factors)."""
    estimators = {
        "cauchy": gtsam.noiseModel.mEstimator.Cauchy,
        "huber": gtsam.noiseModel.mEstimator.Huber,
    }
    if kernel not in estimators:
        choices = ", ".join(sorted(estimators) + ["none"])
        raise ValueError(f"unknown robust kernel {kernel!r}; use one of {choices}")
    return estimators[kernel].Create(width)


def _robust(base: gtsam.noiseModel.Base, kernel: str, width: float) -> gtsam.noiseModel.Base:
    if kernel == "none":
        return base
    return gtsam.noiseModel.Robust.Create(_m_estimator(kernel, width), base)


class PoseGraph:
    """iSAM2 pose graph of keyframes with cached marginal covariances."""

    def __init__(self, config: PoseGraphConfig, start_pose: np.ndarray) -> None:
        """Start a graph with keyframe 0 at ``start_pose`` (``[x, y, yaw]`` or 4x4)."""
        self.config = config
        self._reset_state()
        start = as_matrix(start_pose)
        prior_cov = np.diag(
            [config.prior_sigma_rotation**2] * 3 + [config.prior_sigma_translation**2] * 3
        )
        self._apply(_Batch([FactorRecord(PRIOR, 0, None, start, prior_cov)], {0: start}))

    def _reset_state(self) -> None:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(self.config.relinearize_threshold)
        params.relinearizeSkip = self.config.relinearize_skip
        params.enablePartialRelinearizationCheck = self.config.partial_relinearization_check
        self._isam = gtsam.ISAM2(params)
        self._log: list[_Batch] = []
        self._edges: list[tuple[int, int, str]] = []
        self.factor_counts: dict[str, int] = {ODOMETRY: 0, SCAN_MATCHING: 0}
        self.version = 0
        self._num_poses = 0
        self._cache: dict[tuple, np.ndarray] = {}
        # The last estimates read and the iSAM2 delta they were read at (read-only arrays,
        # never changed in place, so copies share them), the keys in order, and the
        # keyframes whose linearisation point may have moved since (see _read_estimates).
        self._estimates = np.zeros((0, 4, 4))
        self._delta = np.zeros(0)
        self._keys = gtsam.KeyVector()
        self._marked: set[int] = set()
        # Odometry covariances by motion-step count and noise models by covariance: a
        # handful of distinct ones per run, and building them was a third of the Python
        # cost of a keyframe.
        self._odometry_covariances: dict[int, np.ndarray] = {}
        self._odometry_noise: dict[bytes, gtsam.noiseModel.Base] = {}

    # ------------------------------------------------------------------ updates

    def add_keyframe(
        self, odom_delta: np.ndarray, motion_steps: int, ssm: ScanMatch | None = None
    ) -> int:
        """Add the next keyframe; return its index.

        ``odom_delta`` is the wheel-odometry motion since the previous keyframe (4x4 or
        ``[x, y, yaw]``), ``motion_steps`` the number of motion steps it spans (odometry
        sigmas scale with its square root; at least 1). ``ssm`` adds a scan-matching
        factor with the match's own covariance, unless ``ssm.usable`` is false; it joins
        keyframe ``j - ssm.span`` to the new one ``j`` (``span > 1`` after degenerate
        keyframes, see :class:`ScanMatch`). Noise-free measurements are fine (the EM
        planner forward-simulates on copies).
        """
        i, j = self._num_poses - 1, self._num_poses
        delta = as_matrix(odom_delta)
        guess = self.pose(i) @ delta
        factors = [FactorRecord(ODOMETRY, i, j, delta, self._odometry_covariance(motion_steps))]
        if ssm is not None and ssm.usable:
            ref = j - int(ssm.span)
            if ref < 0:
                raise ValueError(f"scan match spans {ssm.span} keyframes; only {j} exist")
            robust = self.config.ssm_robust_kernel != "none"
            factors.append(
                FactorRecord(SCAN_MATCHING, ref, j, as_matrix(ssm.span_relative), ssm.covariance,
                             robust)
            )
        self._apply(_Batch(factors, {j: guess}))
        return j

    def _odometry_covariance(self, motion_steps: int) -> np.ndarray:
        steps = max(int(motion_steps), 1)
        covariance = self._odometry_covariances.get(steps)
        if covariance is None:
            covariance = self._odometry_covariances[steps] = frozen_array(
                odometry_covariance(self.config, steps))
        return covariance

    def add_loop_closure(
        self, i: int, j: int, relative: np.ndarray, covariance: np.ndarray, kind: str
    ) -> None:
        """Add a robust loop-closure factor ``T_i^-1 T_j = relative`` of the given kind."""
        for k in (i, j):
            if not 0 <= k < self._num_poses:
                raise IndexError(f"keyframe {k} does not exist (graph has {self._num_poses})")
        if kind in (PRIOR, ODOMETRY, SCAN_MATCHING):
            raise ValueError(f"{kind!r} is not a loop-closure kind")
        robust = self.config.loop_robust_kernel != "none"
        record = FactorRecord(kind, int(i), int(j), as_matrix(relative), covariance, robust)
        self._apply(_Batch([record], extra_updates=self.config.loop_extra_updates))

    def _apply(self, batch: _Batch) -> None:
        """Run one iSAM2 update (plus extra ones) for ``batch`` and log it."""
        graph = gtsam.NonlinearFactorGraph()
        for record in batch.factors:
            graph.add(self._make_factor(record))
        values = gtsam.Values()
        for j, T in batch.new_poses.items():
            values.insert(key(j), gtsam.Pose3(T))
            self._keys.append(key(j))
        self._mark(self._isam.update(graph, values))
        for _ in range(batch.extra_updates):
            self._mark(self._isam.update())
        self._bookkeep(batch)

    def _mark(self, result: gtsam.ISAM2Result) -> None:
        """Remember the keyframes an update may have relinearised: iSAM2 moves the
        linearisation point only of keys it also reports as marked."""
        self._marked.update(k & _INDEX_MASK for k in result.getMarkedKeys())

    def _make_factor(self, record: FactorRecord) -> gtsam.NonlinearFactor:
        if record.kind == ODOMETRY:
            noise = self._odometry_noise.get(record.covariance.tobytes())
            if noise is None:
                noise = self._odometry_noise[record.covariance.tobytes()] = _gaussian(record.covariance)
        else:
            noise = _gaussian(record.covariance)
        pose = gtsam.Pose3(record.measurement)
        if record.j is None:
            return gtsam.PriorFactorPose3(key(record.i), pose, noise)
        if record.robust and record.kind == SCAN_MATCHING:
            noise = _robust(noise, self.config.ssm_robust_kernel, self.config.ssm_robust_width)
        elif record.robust:
            noise = _robust(noise, self.config.loop_robust_kernel, self.config.loop_robust_width)
        return gtsam.BetweenFactorPose3(key(record.i), key(record.j), pose, noise)

    def _bookkeep(self, batch: _Batch) -> None:
        self._log.append(batch)
        self._num_poses += len(batch.new_poses)
        for record in batch.factors:
            if record.j is not None:
                self._edges.append((record.i, record.j, record.kind))
                self.factor_counts[record.kind] = self.factor_counts.get(record.kind, 0) + 1
        self.version += 1
        self._cache.clear()

    # ---------------------------------------------------------------- estimates

    @property
    def num_poses(self) -> int:
        return self._num_poses

    def __len__(self) -> int:
        return self._num_poses

    @property
    def isam(self) -> gtsam.ISAM2:
        """The live iSAM2 object (read it; change the graph only through this class)."""
        return self._isam

    @property
    def edges(self) -> list[tuple[int, int, str]]:
        """``(i, j, kind)`` of every between factor, in insertion order."""
        return list(self._edges)

    def pose(self, i: int) -> np.ndarray:
        """Current 4x4 estimate of keyframe ``i`` (from the cached estimates if there are)."""
        cached = self._cache.get(("poses",))
        if cached is not None:
            return cached[i].copy()
        return self._isam.calculateEstimatePose3(key(i)).matrix()

    def poses_matrix(self) -> np.ndarray:
        """``(N, 4, 4)`` current estimates."""
        if ("poses",) not in self._cache:
            self._cache[("poses",)] = self._read_estimates()
        return self._cache[("poses",)].copy()

    def _read_estimates(self) -> np.ndarray:
        """``(N, 4, 4)`` current estimates, bit for bit those of ``calculateEstimate()``,
        computed again only for the keyframes whose estimate can have changed.

        An estimate is ``Retract(theta_i, delta_i)``: it changes only where the delta
        changed (compared with the delta of the last read) or the linearisation point
        did (keys iSAM2 marked since, :meth:`_mark`). Between loop closures that is the
        newest few keyframes, not the whole trajectory that ``calculateEstimate`` retracts.
        """
        n, old = self._num_poses, len(self._estimates)
        delta = self._isam.getDelta().vector(self._keys)
        moved = (delta[: 6 * old].reshape(old, 6) != self._delta.reshape(old, 6)).any(axis=1)
        moved[[i for i in self._marked if i < old]] = True
        changed = [*np.flatnonzero(moved).tolist(), *range(old, n)]
        if len(changed) > _FULL_READ_FRACTION * n:
            T = self._all_estimates()
        else:
            T = np.empty((n, 4, 4))
            T[:old] = self._estimates
            for i in changed:
                T[i] = self._isam.calculateEstimatePose3(key(i)).matrix()
        T.flags.writeable = False
        delta.flags.writeable = False
        self._estimates, self._delta, self._marked = T, delta, set()
        return T

    def _all_estimates(self) -> np.ndarray:
        """``(N, 4, 4)`` estimates of every keyframe from one ``calculateEstimate``."""
        # extractPose3: (N, 12) rows [R row-major, t] in key order (x0, x1, ...);
        # ~3x faster than a Python loop over atPose3 at a few hundred poses.
        flat = gtsam.utilities.extractPose3(self._isam.calculateEstimate())
        T = np.tile(np.eye(4), (len(flat), 1, 1))
        T[:, :3, :3] = flat[:, :9].reshape(-1, 3, 3)
        T[:, :3, 3] = flat[:, 9:]
        return T

    def poses_se2(self) -> np.ndarray:
        """``(N, 3)`` current planar estimates ``[x, y, yaw]`` (cached until the next update:
        the session reads them several times per keyframe)."""
        if ("se2",) not in self._cache:
            T = self._cache[("poses",)] if ("poses",) in self._cache else self.poses_matrix()
            self._cache[("se2",)] = np.stack([T[:, 0, 3], T[:, 1, 3], np.arctan2(T[:, 1, 0], T[:, 0, 0])], axis=-1)
        return self._cache[("se2",)].copy()

    # -------------------------------------------------------------- covariances

    def marginal_covariance(self, i: int) -> np.ndarray:
        """6x6 marginal of keyframe ``i`` (tangent order rx, ry, rz, tx, ty, tz; body frame).

        iSAM2 marginals are linearised at ``isam.getLinearizationPoint()``.
        """
        return self._cached(("marginal", i), lambda: self._isam.marginalCovariance(key(i)))

    def world_xy_yaw_covariance(self, i: int) -> np.ndarray:
        """3x3 covariance of (x, y) in the world frame and yaw.

        With ``T Exp(xi)`` the world translation moves by ``R v`` and the world rotation
        by ``R w``, so the Jacobian picks rows 0-1 of ``R`` on ``v`` and row 2 on ``w``;
        for a planar pose this is ``R2 Sigma_t R2^T`` plus the yaw row/column.
        """

        def compute() -> np.ndarray:
            R = self.pose(i)[:3, :3]
            J = np.zeros((3, 6))
            J[:2, 3:] = R[:2, :]
            J[2, :3] = R[2, :]
            return J @ self.marginal_covariance(i) @ J.T

        return self._cached(("xy_yaw", i), compute)

    def world_xy_covariance(self, i: int) -> np.ndarray:
        """2x2 world-frame covariance of the position of keyframe ``i``."""
        return self.world_xy_yaw_covariance(i)[:2, :2]

    def all_world_xy_covariances(self) -> np.ndarray:
        """``(N, 2, 2)`` world-frame position covariances of every keyframe."""

        def compute() -> np.ndarray:
            return np.stack([self.world_xy_covariance(i) for i in range(self._num_poses)])

        return self._cached(("all_xy",), compute)

    def joint_marginal_covariance(self, i: int, j: int) -> np.ndarray:
        """12x12 joint marginal of keyframes ``i`` then ``j`` (for loop-closure gating)."""

        def compute() -> np.ndarray:
            joint = self._isam.jointMarginalCovariance([key(i), key(j)])
            ki, kj = key(i), key(j)
            return np.block(
                [[joint.at(ki, ki), joint.at(ki, kj)], [joint.at(kj, ki), joint.at(kj, kj)]]
            )

        return self._cached(("joint", i, j), compute)

    def information_matrix(self) -> sp.csr_matrix:
        """``(6N, 6N)`` information matrix ``A^T A`` of the whitened linearised system at
        ``isam.getLinearizationPoint()`` (variables in keyframe order, Pose3 tangent order
        each): the system whose inverse holds iSAM2's marginals (robust weights included)."""
        size = 6 * self._num_poses
        linear = self._isam.getFactorsUnsafe().linearize(self._isam.getLinearizationPoint())
        rows, cols, values = linear.sparseJacobian_()  # 1-based; the last column is b
        rows, cols = rows.astype(np.int64) - 1, cols.astype(np.int64) - 1
        keep = cols < size
        jacobian = sp.csr_matrix((values[keep], (rows[keep], cols[keep])), shape=(int(rows.max()) + 1, size))
        return (jacobian.T @ jacobian).tocsr()

    def _cached(self, name: tuple, compute) -> np.ndarray:
        if name not in self._cache:
            self._cache[name] = np.asarray(compute(), dtype=float)
        return self._cache[name].copy()

    # ------------------------------------------------------- copying & pickling

    def copy(self) -> PoseGraph:
        """An independent graph: updating the copy leaves this one untouched (~1 ms)."""
        other = PoseGraph.__new__(PoseGraph)
        other.config = self.config
        other._isam = gtsam.ISAM2(self._isam)
        other._log = list(self._log)
        other._edges = list(self._edges)
        other.factor_counts = dict(self.factor_counts)
        other.version = self.version
        other._num_poses = self._num_poses
        other._cache = dict(self._cache)
        other._estimates, other._delta = self._estimates, self._delta  # read-only, shared
        other._keys = gtsam.KeyVector(self._keys)
        other._marked = set(self._marked)
        other._odometry_covariances = self._odometry_covariances
        other._odometry_noise = self._odometry_noise
        return other

    def __getstate__(self) -> dict:
        """Pickle the config and the update log (plain numpy), not the iSAM2 object."""
        return {"config": self.config, "log": self._log, "version": self.version}

    def __setstate__(self, state: dict) -> None:
        """Rebuild iSAM2 by replaying the logged updates in order (same result)."""
        self.config = state["config"]
        self._reset_state()
        for batch in state["log"]:
            self._apply(batch)
        self.version = state["version"]
