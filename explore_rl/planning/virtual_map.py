"""Virtual map and its utility (EM exploration, Wang et al.; paper Sec. II-B).

A grid of virtual landmarks at the centres of ``cell_size`` cells (a coarsening of the
occupancy grid), each with a 2x2 world-frame covariance that starts at
``prior_std^2 I``. Every pose that sees a landmark (within sensor range, line of sight on
the fine 2D grid) predicts a landmark covariance from its own (x, y, yaw) covariance via a
range-bearing measurement, and that prediction is fused into the landmark's running
covariance by covariance intersection. The utility is ``U = sum_l log det Sigma_l``
(smaller is better).

Everything is vectorised over (pose, landmark) pairs; see
:meth:`VirtualMap.predict_landmark_covariances` for the cost.
"""

from __future__ import annotations

import numpy as np

from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight, line_of_sight_by_length
from explore_rl.planning.config import VirtualMapConfig
from explore_rl.planning.compiled import window_pairs
from explore_rl.sorting import stable_argsort

# ---------------------------------------------------------------------------- 2x2 algebra


def _det2(m: np.ndarray) -> np.ndarray:
    """Determinants of a stack of 2x2 matrices ``(..., 2, 2)``."""
    return m[..., 0, 0] * m[..., 1, 1] - m[..., 0, 1] * m[..., 1, 0]


def _inv2(m: np.ndarray) -> np.ndarray:
    """Inverses of a stack of 2x2 matrices (closed form, much faster than LAPACK here)."""
    det = _det2(m)
    inv = np.empty_like(m, dtype=float)
    inv[..., 0, 0] = m[..., 1, 1]
    inv[..., 1, 1] = m[..., 0, 0]
    inv[..., 0, 1] = -m[..., 0, 1]
    inv[..., 1, 0] = -m[..., 1, 0]
    return inv / det[..., None, None]


def covariance_intersection(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fuse 2x2 covariances ``a`` and ``b`` (``(..., 2, 2)``) by covariance intersection.

    The fused information is ``w A^-1 + (1 - w) B^-1`` with ``w in [0, 1]`` maximising its
    determinant (= minimising the fused covariance's determinant). For 2x2 matrices
    ``det(IB + w (IA - IB)) = c + b w + a w^2`` is quadratic in ``w``: the optimum is the
    clamped stationary point when the quadratic is concave, else the better endpoint.
    Returns ``(fused covariance, w)``; symmetric: swapping the inputs maps ``w -> 1 - w``.
    """
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    fused, w = _ci_fuse(_information(a), _information(b))
    return _matrix(*_inverse_components(*fused)), w


def _components(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(m00, m01, m11)`` of symmetric 2x2 matrices ``(..., 2, 2)``."""
    return m[..., 0, 0], m[..., 0, 1], m[..., 1, 1]


def _matrix(m00, m01, m11) -> np.ndarray:
    """Symmetric 2x2 matrices ``(..., 2, 2)`` from their components."""
    return np.stack([np.stack([m00, m01], axis=-1), np.stack([m01, m11], axis=-1)], axis=-2)


def _inverse_components(m00, m01, m11) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Components of the inverses of symmetric 2x2 matrices given by their components."""
    det = m00 * m11 - m01 * m01
    return m11 / det, -m01 / det, m00 / det


def _information(covs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Components of the information matrices (inverses) of 2x2 covariances."""
    return _inverse_components(*_components(covs))


def _ci_fuse(info_a, info_b) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """Covariance intersection of information matrices given as components ``(i00, i01,
    i11)``: the fused information ``IB + w (IA - IB)`` and ``w``, the maximiser over [0, 1]
    of its determinant."""
    b00, b01, b11 = info_b
    d00, d01, d11 = (a - b for a, b in zip(info_a, info_b))
    with np.errstate(divide="ignore", invalid="ignore"):
        w = ci_weight(info_a, info_b, (d00, d01, d11))
    return (b00 + w * d00, b01 + w * d01, b11 + w * d11), w


def ci_weight(info_a, info_b, diff) -> np.ndarray:
    """The covariance-intersection weight ``w`` of :func:`_ci_fuse` for information
    components ``info_a``, ``info_b`` and ``diff = info_a - info_b`` (each indexable by
    component 0, 1, 2: tuples of arrays or ``(3, ...)`` arrays). Call it under
    ``np.errstate(divide="ignore", invalid="ignore")`` (the stationary point is only
    used where the quadratic is concave)."""
    a00, a01, a11 = info_a[0], info_a[1], info_a[2]
    b00, b01, b11 = info_b[0], info_b[1], info_b[2]
    d00, d01, d11 = diff[0], diff[1], diff[2]
    quad = d00 * d11 - d01 * d01
    lin = b00 * d11 + b11 * d00 - 2.0 * b01 * d01
    det_a, det_b = a00 * a11 - a01 * a01, b00 * b11 - b01 * b01  # the quadratic at w = 1 and 0
    endpoint = np.where(det_a > det_b, 1.0, np.where(det_a < det_b, 0.0, 0.5))
    concave = quad < 0
    stationary = np.clip(-lin / (2.0 * np.where(concave, quad, 1.0)), 0.0, 1.0)
    return np.where(concave, stationary, endpoint)


def log_det_utility(covs: np.ndarray) -> float:
    """``U = sum_l log det Sigma_l`` over a stack of landmark covariances ``(L, 2, 2)``."""
    return float(np.sum(np.log(_det2(covs))))


# ----------------------------------------------------------------- range-bearing measurement


def range_bearing(pose: np.ndarray, landmark_xy: np.ndarray) -> np.ndarray:
    """Measurement ``[bearing, range]`` of landmarks ``(..., 2)`` from poses ``(..., 3)``."""
    pose, landmark_xy = np.asarray(pose, float), np.asarray(landmark_xy, float)
    d = landmark_xy - pose[..., :2]
    bearing = np.arctan2(d[..., 1], d[..., 0]) - pose[..., 2]
    bearing = (bearing + np.pi) % (2.0 * np.pi) - np.pi
    return np.stack([bearing, np.hypot(d[..., 0], d[..., 1])], axis=-1)


def range_bearing_jacobians(
    pose: np.ndarray, landmark_xy: np.ndarray, min_range: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`range_bearing`: ``H_x (..., 2, 3)`` w.r.t. pose (x, y, yaw) and
    ``H_l (..., 2, 2)`` w.r.t. the landmark; rows (bearing, range).

    The range is clamped below at ``min_range`` (the landmark is moved out along its
    bearing; a landmark exactly at the pose gets bearing +x) so nothing blows up at zero.
    """
    pose, landmark_xy = np.asarray(pose, float), np.asarray(landmark_xy, float)
    ux, uy, dx, dy, r_eff = _clamped_offsets(pose, landmark_xy, min_range)
    r2 = r_eff * r_eff
    shape = np.broadcast_shapes(pose.shape[:-1], landmark_xy.shape[:-1])
    h_x = np.zeros(shape + (2, 3))
    h_x[..., 0, 0] = dy / r2
    h_x[..., 0, 1] = -dx / r2
    h_x[..., 0, 2] = -1.0
    h_x[..., 1, 0] = -ux
    h_x[..., 1, 1] = -uy
    h_l = np.empty(shape + (2, 2))
    h_l[..., 0, 0] = -dy / r2
    h_l[..., 0, 1] = dx / r2
    h_l[..., 1, 0] = ux
    h_l[..., 1, 1] = uy
    return h_x, h_l


def _clamped_offsets(pose: np.ndarray, landmark_xy: np.ndarray, min_range: float) -> tuple[np.ndarray, ...]:
    """``(ux, uy, dx, dy, r_eff)``: the direction from each pose to its landmark and the
    offset ``(dx, dy) = r_eff u`` with the range clamped below at ``min_range`` (a landmark
    exactly at the pose gets direction +x)."""
    d = landmark_xy - pose[..., :2]
    r = np.hypot(d[..., 0], d[..., 1])
    r_eff = np.maximum(r, min_range)
    safe_r = np.where(r > 0, r, 1.0)
    ux = np.where(r > 0, d[..., 0] / safe_r, 1.0)
    uy = np.where(r > 0, d[..., 1] / safe_r, 0.0)
    return ux, uy, ux * r_eff, uy * r_eff, r_eff


def lever_and_noise(pose: np.ndarray, landmark_xy: np.ndarray,
                    config: VirtualMapConfig) -> tuple[np.ndarray, np.ndarray]:
    """The observation of :func:`landmark_covariance_from_pose` in closed form:
    ``H_l^-1 H_x = [-I | lever]`` (the landmark moves with the pose's position, and by
    ``lever = (dy, -dx)`` per radian of yaw) and ``H_l^-1 R H_l^-T`` as its components
    ``(n00, n01, n11)`` (``H_l^-1 = [[-dy, ux], [dx, uy]]``). Returns ``lever (..., 2)``
    and ``noise (3, ...)``: the same as the batched inverse and products, to round-off,
    for a fraction of their cost."""
    ux, uy, dx, dy, _ = _clamped_offsets(np.asarray(pose, float), np.asarray(landmark_xy, float), config.min_range)
    r = measurement_noise(config)
    s_b, s_r = r[0, 0], r[1, 1]
    noise = np.stack([s_b * dy * dy + s_r * ux * ux, s_r * ux * uy - s_b * dx * dy, s_b * dx * dx + s_r * uy * uy])
    return np.stack([dy, -dx], axis=-1), noise


def measurement_noise(config: VirtualMapConfig) -> np.ndarray:
    """``R = diag(sigma_bearing^2, sigma_range^2)`` (row order of the Jacobians)."""
    return np.diag([np.deg2rad(config.sigma_bearing_deg) ** 2, config.sigma_range**2])


def landmark_covariance_from_pose(
    landmark_xy: np.ndarray,
    pose: np.ndarray,
    pose_cov: np.ndarray,
    config: VirtualMapConfig,
) -> np.ndarray:
    """Predicted landmark covariances ``(L, 2, 2)`` seen from a pose.

    ``Sigma_l = H_l^+ (R + H_x Sigma_x H_x^T) H_l^+^T`` with ``Sigma_x`` the world-frame
    (x, y, yaw) pose covariance. ``pose (3,)``/``pose_cov (3, 3)`` may also be stacks
    ``(L, 3)``/``(L, 3, 3)`` (one pose per landmark). ``H_l`` is invertible once the range
    is clamped, so its pseudo-inverse is its inverse.
    """
    h_x, h_l = range_bearing_jacobians(pose, landmark_xy, config.min_range)
    h_l_inv = _inv2(h_l)
    innovation = measurement_noise(config) + h_x @ np.asarray(pose_cov, float) @ np.swapaxes(
        h_x, -1, -2
    )
    return h_l_inv @ innovation @ np.swapaxes(h_l_inv, -1, -2)


# ---------------------------------------------------------------------------- virtual map


class VirtualMap:
    """Virtual landmarks on ``grid`` coarsened to ``config.cell_size`` cells.

    ``covariances (L, 2, 2)`` is the current state (landmark ``l = iy * nx + ix`` of
    :attr:`landmark_grid`); :meth:`predict_landmark_covariances` is pure, so a planner can
    evaluate many candidate trajectories against one map.
    """

    def __init__(self, grid: GridSpec, config: VirtualMapConfig | None = None) -> None:
        self.config = config or VirtualMapConfig()
        factor = self.config.cell_size / grid.resolution
        if factor < 1 or not np.isclose(factor, round(factor)):
            raise ValueError(
                f"virtual map cell_size {self.config.cell_size} must be an integer multiple "
                f"of the grid resolution {grid.resolution}"
            )
        self.grid = grid
        self.factor = int(round(factor))
        self.landmark_grid = grid.coarsened(self.factor)
        self.landmark_xy = self.landmark_grid.cell_centers().reshape(-1, 2)
        self._window = self._window_offsets()
        self.covariances = self.prior_covariances()

    @property
    def num_landmarks(self) -> int:
        return len(self.landmark_xy)

    def prior_covariances(self) -> np.ndarray:
        """``(L, 2, 2)`` prior covariances ``prior_std^2 I``."""
        prior = self.config.prior_std**2 * np.eye(2)
        return np.repeat(prior[None], self.num_landmarks, axis=0)

    def _window_offsets(self) -> np.ndarray:
        """``[diy, dix]`` offsets of every landmark cell that can lie within sensor range."""
        half = int(np.ceil(self.config.sensor_range / self.config.cell_size + 0.5))
        d = np.arange(-half, half + 1)
        diy, dix = np.meshgrid(d, d, indexing="ij")
        return np.stack([diy.ravel(), dix.ravel()], axis=-1)

    def visible_pairs(
        self, poses: np.ndarray, blocked: np.ndarray, by_length: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(pose_index, landmark_index)`` of every landmark a pose observes, in pose order.

        Observed = within ``sensor_range`` and in line of sight (known-occupied cells of
        ``blocked`` block, except inside the landmark's own cell; unknown cells do not).
        ``by_length``: see :meth:`line_of_sight`.
        """
        poses = np.asarray(poses, float).reshape(-1, 3)
        pose_idx, landmark_idx = self.in_range_pairs(poses)
        visible = self.line_of_sight(poses[pose_idx], landmark_idx, blocked, by_length)
        return pose_idx[visible], landmark_idx[visible]

    def in_range_pairs(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(pose_index, landmark_index)`` of every landmark within ``sensor_range`` of a
        pose (``(K, 2)`` or ``(K, 3)``), in pose order, then window order: one compiled
        loop over each pose's window (:func:`~explore_rl.planning.compiled.window_pairs`),
        the same pairs as :meth:`in_range_pairs_reference`."""
        xy = np.ascontiguousarray(np.asarray(poses, float)[:, :2])
        lg = self.landmark_grid
        return window_pairs(xy, float(lg.origin[0]), float(lg.origin[1]), float(lg.resolution), int(lg.nx),
                            int(lg.ny), self._window, self.landmark_xy, float(self.config.sensor_range))

    def in_range_pairs_reference(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`in_range_pairs` by numpy over every pose's whole window."""
        xy = np.asarray(poses, float)[:, :2]
        lg = self.landmark_grid
        cells = lg.world_to_cell(xy)[:, None, :] + self._window[None]
        inside = lg.in_bounds(cells)
        index = np.where(inside, cells[..., 0] * lg.nx + cells[..., 1], 0)
        dist = np.linalg.norm(self.landmark_xy[index] - xy[:, None], axis=-1)
        pose_idx, slot = np.nonzero(inside & (dist <= self.config.sensor_range))
        return pose_idx, index[pose_idx, slot]

    def line_of_sight(self, poses: np.ndarray, landmark_idx: np.ndarray, blocked: np.ndarray,
                      by_length: bool = False) -> np.ndarray:
        """``(M,)``: whether each pose (``(M, 2)`` or ``(M, 3)``) sees its landmark past the
        known-occupied cells of ``blocked`` (:meth:`visible_pairs`). ``by_length``: the same
        answers from :func:`~explore_rl.mapping.visibility.line_of_sight_by_length` (segments
        far from any blocked cell unsampled, the others walked by a compiled loop; EM's fast
        backend), else from ``line_of_sight``."""
        visibility = line_of_sight_by_length if by_length else line_of_sight
        return visibility(
            np.asarray(poses, float)[:, :2],
            self.landmark_xy[landmark_idx],
            blocked,
            self.grid,
            self.config.los_step_fraction,
            end_box=self.config.cell_size,
            max_batch_samples=self.config.max_batch_samples,
        )

    def predict_landmark_covariances(
        self,
        poses: np.ndarray,
        pose_covs: np.ndarray,
        blocked: np.ndarray,
        initial: np.ndarray | None = None,
        pairs: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """Landmark covariances ``(L, 2, 2)`` after ``poses (K, 3)`` with world-frame
        covariances ``pose_covs (K, 3, 3)`` observe the map; the map is not modified.

        Starts from ``initial`` (default: the prior; pass the current map to add only new
        poses whose predecessors' covariances are unchanged) and fuses each pose's predicted
        landmark covariance by covariance intersection, poses in the given order.
        ``pairs`` may pass precomputed :meth:`visible_pairs` (in pose order) to skip the
        line-of-sight tests, e.g. for past poses shared by every EM candidate (their
        visibility barely changes when their estimates shift by a few centimetres).

        Cost: O(K x landmarks in range) pairs (about 113 per pose at 3 m / 0.5 m), each with
        one line-of-sight test of ``sensor_range / (step_fraction * resolution)`` samples
        (60 at 0.1 m), plus one vectorised CI per "round" (the largest number of
        observations of one landmark), independent of the map size otherwise.
        """
        covs = self.prior_covariances() if initial is None else np.array(initial, float)
        poses = np.asarray(poses, float).reshape(-1, 3)
        pose_covs = np.asarray(pose_covs, float).reshape(-1, 3, 3)
        pose_idx, landmark_idx = self.visible_pairs(poses, blocked) if pairs is None else pairs
        if len(pose_idx) == 0:
            return covs
        observed = landmark_covariance_from_pose(
            self.landmark_xy[landmark_idx], poses[pose_idx], pose_covs[pose_idx], self.config
        )
        fuse_in_order(covs, landmark_idx, observed)
        return covs

    def update(self, poses: np.ndarray, pose_covs: np.ndarray, blocked: np.ndarray) -> None:
        """Rebuild :attr:`covariances` from the prior with all ``poses``."""
        self.covariances = self.predict_landmark_covariances(poses, pose_covs, blocked)

    def utility(self, covs: np.ndarray | None = None) -> float:
        """``sum_l log det Sigma_l`` of ``covs`` (default: the current map)."""
        return log_det_utility(self.covariances if covs is None else covs)

    def landmark_index(self, xy: np.ndarray) -> np.ndarray:
        """Landmark index of the cell containing each point ``(..., 2)``; -1 outside."""
        cells = self.landmark_grid.world_to_cell(xy)
        inside = self.landmark_grid.in_bounds(cells)
        return np.where(inside, cells[..., 0] * self.landmark_grid.nx + cells[..., 1], -1)

    def frontier_landmark_covariance(
        self, xy: np.ndarray, covs: np.ndarray | None = None
    ) -> np.ndarray:
        """Covariance ``(..., 2, 2)`` of the landmark cell containing each point (prior if
        the point lies outside the map)."""
        covs = self.covariances if covs is None else covs
        index = self.landmark_index(xy)
        prior = self.config.prior_std**2 * np.eye(2)
        return np.where((index >= 0)[..., None, None], covs[np.maximum(index, 0)], prior)

    def trace_map(self, covs: np.ndarray | None = None) -> np.ndarray:
        """Trace of each landmark covariance as a ``landmark_grid.shape`` image."""
        covs = self.covariances if covs is None else covs
        return np.trace(covs, axis1=-2, axis2=-1).reshape(self.landmark_grid.shape)


def fuse_in_order(covs: np.ndarray, landmark_idx: np.ndarray, observed: np.ndarray) -> None:
    """Fuse ``observed[i]`` into ``covs[landmark_idx[i]]`` in place, in index order, by
    covariance intersection (:func:`covariance_intersection`).

    The j-th observation of every landmark is fused in round j, all landmarks at once.
    The rounds run on information components (three flat arrays), inverting each
    observation once and each landmark twice, instead of every matrix in every round.
    """
    if not len(landmark_idx):
        return
    order = stable_argsort(landmark_idx)
    sorted_lm = landmark_idx[order]
    starts = np.flatnonzero(np.r_[True, sorted_lm[1:] != sorted_lm[:-1]])
    group_sizes = np.diff(np.r_[starts, len(sorted_lm)])
    rank = np.arange(len(sorted_lm)) - np.repeat(starts, group_sizes)
    by_round = order[stable_argsort(rank)]
    seen = sorted_lm[starts]
    info = [np.array(c) for c in _information(covs[seen])]
    slot = np.empty(len(covs), dtype=np.int64)  # landmark -> row of ``info``
    slot[seen] = np.arange(len(seen))
    observed_info = _information(observed)
    begin = 0
    for count in np.bincount(rank):
        sel = by_round[begin : begin + count]
        begin += count
        rows = slot[landmark_idx[sel]]
        fused, _ = _ci_fuse([c[rows] for c in info], [c[sel] for c in observed_info])
        for component, value in zip(info, fused):
            component[rows] = value
    covs[seen] = _matrix(*_inverse_components(*info))
