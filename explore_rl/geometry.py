"""Small rigid-transform helpers shared by every stage.

Planar poses are ``np.array([x, y, yaw])`` (metres, radians, yaw counter-clockwise from
+x). 3D transforms are 4x4 homogeneous matrices. Functions accept single poses ``(3,)``
or stacks ``(N, 3)`` where noted.
"""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(angle: np.ndarray | float) -> np.ndarray | float:
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def wrap_angle_one(angle: float) -> float:
    """:func:`wrap_angle` of one Python float (the same float operations)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def se2_compose_tuple(a, b) -> tuple[float, float, float]:
    """:func:`se2_compose` of one pose and one motion (sequences of 3 floats) in scalar
    ``math``, as a tuple.

    For the per-step hot paths (every motion step composes a few poses; numpy's per-call
    overhead costs ~20x the arithmetic). The same operations in the same order as the
    vectorised code, so equal wherever ``math``'s and numpy's cos/sin agree; where numpy
    vectorises them they may differ in the last bit (``tests/test_geometry.py`` compares
    the two with a tolerance).
    """
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap_angle_one(a[2] + b[2])


def se2_between_tuple(a, b) -> tuple[float, float, float]:
    """:func:`se2_between` of two poses (sequences of 3 floats) in scalar ``math``, as a
    tuple (see :func:`se2_compose_tuple`)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return c * dx + s * dy, -s * dx + c * dy, wrap_angle_one(b[2] - a[2])


def _one_pose(a, b) -> bool:
    """Whether both arguments are single planar poses ``(3,)`` (the scalar paths)."""
    return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape == (3,)


def se2_compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a (+) b``: apply the body-frame motion ``b`` at pose ``a`` (both ``(..., 3)``)."""
    if _one_pose(a, b):
        return np.array(se2_compose_tuple(a.tolist(), b.tolist()))
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def se2_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a^-1 (+) b``: the motion from pose ``a`` to pose ``b`` in ``a``'s body frame."""
    if _one_pose(a, b):
        return np.array(se2_between_tuple(a.tolist(), b.tolist()))
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    return np.stack(
        [c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[..., 2] - a[..., 2])], axis=-1
    )


def se2_to_matrix(pose, z: float = 0.0) -> np.ndarray:
    """4x4 transform of a planar pose (array or ``(x, y, yaw)`` tuple) lifted to height ``z``.

    Scalar ``math`` on purpose: called per keyframe and per factor, where numpy's
    per-call overhead would cost several times the arithmetic.
    """
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]],
                    dtype=float)


def se2_matrices(poses: np.ndarray, z: float = 0.0) -> np.ndarray:
    """``(N, 4, 4)``: :func:`se2_to_matrix` of every planar pose ``(N, 3)`` at once (numpy's
    vectorised cos/sin may differ from ``math``'s in the last bit: for metrics, not for
    the maps, which keep the transforms they were built with)."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    out = np.zeros((len(poses), 4, 4))
    out[:, 0, 0], out[:, 0, 1], out[:, 1, 0], out[:, 1, 1] = c, -s, s, c
    out[:, 0, 3], out[:, 1, 3], out[:, 2, 3] = poses[:, 0], poses[:, 1], z
    out[:, 2, 2] = out[:, 3, 3] = 1.0
    return out


def matrix_to_se2(T: np.ndarray) -> np.ndarray:
    """Planar ``[x, y, yaw]`` of a 4x4 transform (drops z, roll, pitch)."""
    return np.array(matrix_to_se2_tuple(T))


def matrix_to_se2_tuple(T: np.ndarray) -> tuple[float, float, float]:
    """:func:`matrix_to_se2` as a tuple of floats (for the scalar hot paths)."""
    return float(T[0, 3]), float(T[1, 3]), math.atan2(T[1, 0], T[0, 0])


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to ``(N, 3)`` points."""
    return points @ T[:3, :3].T + T[:3, 3]


def rotation_2d(yaw: float) -> np.ndarray:
    """2x2 rotation matrix."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])
