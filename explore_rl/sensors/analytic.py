"""An independent, pure-numpy ray caster on a layout's analytic geometry.

A reference for tests and benchmarks only (the product LiDAR is ``sensors/lidar.py`` on
``mj_multiRay``): rays against the floor plane ``z = 0``, upright boxes (slab test in the
box frame) and upright finite cylinders, all vectorised over rays.
"""

from __future__ import annotations

import numpy as np

from explore_rl.scene.layout import Layout

NO_HIT = np.inf


def ray_floor(origin: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Distance along each ray to the plane z = 0 (inf if it points up or sideways)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -origin[2] / dirs[:, 2]
    return np.where((dirs[:, 2] < 0) & (t > 0), t, NO_HIT)


def ray_box(origin: np.ndarray, dirs: np.ndarray, center, size, yaw: float) -> np.ndarray:
    """Distance to an upright box standing on the floor (slab method in the box frame)."""
    c, s = np.cos(yaw), np.sin(yaw)
    rel = origin - np.array([center[0], center[1], size[2] / 2])
    o = np.array([c * rel[0] + s * rel[1], -s * rel[0] + c * rel[1], rel[2]])
    d = np.stack([c * dirs[:, 0] + s * dirs[:, 1], -s * dirs[:, 0] + c * dirs[:, 1], dirs[:, 2]], 1)
    half = np.asarray(size, dtype=float) / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-half - o) / d
        t2 = (half - o) / d
    t_near = np.nanmax(np.minimum(t1, t2), axis=1)
    t_far = np.nanmin(np.maximum(t1, t2), axis=1)
    hit = (t_near <= t_far) & (t_far > 0)
    return np.where(hit, np.where(t_near > 0, t_near, t_far), NO_HIT)


def ray_cylinder(origin: np.ndarray, dirs: np.ndarray, center, radius: float, height: float) -> np.ndarray:
    """Distance to an upright finite cylinder standing on the floor (side and top cap)."""
    ox, oy = origin[0] - center[0], origin[1] - center[1]
    a = dirs[:, 0] ** 2 + dirs[:, 1] ** 2
    b = 2 * (ox * dirs[:, 0] + oy * dirs[:, 1])
    cc = ox**2 + oy**2 - radius**2
    disc = b**2 - 4 * a * cc
    with np.errstate(divide="ignore", invalid="ignore"):
        t_side = (-b - np.sqrt(np.where(disc >= 0, disc, np.nan))) / (2 * a)
        z_side = origin[2] + t_side * dirs[:, 2]
        side_ok = (disc >= 0) & (t_side > 0) & (z_side >= 0) & (z_side <= height)
        t_top = (height - origin[2]) / dirs[:, 2]
        px = ox + t_top * dirs[:, 0]
        py = oy + t_top * dirs[:, 1]
        top_ok = (t_top > 0) & (px**2 + py**2 <= radius**2)
    return np.minimum(np.where(side_ok, t_side, NO_HIT), np.where(top_ok, t_top, NO_HIT))


def cast_rays(layout: Layout, origin: np.ndarray, dirs: np.ndarray, max_range: float) -> np.ndarray:
    """Nearest hit distance per ray, -1 where nothing lies within ``max_range``."""
    best = ray_floor(origin, dirs)
    for box in layout.solid_boxes():
        best = np.minimum(best, ray_box(origin, dirs, box.center, box.size, box.yaw))
    for cyl in layout.cylinders:
        best = np.minimum(best, ray_cylinder(origin, dirs, cyl.center, cyl.radius, cyl.height))
    return np.where(best <= max_range, best, -1.0)
