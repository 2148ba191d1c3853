"""Top-down matplotlib drawings of scenes, scans, maps and trajectories (PNG output).

Drawing functions take an ``Axes`` and plain arrays so every stage (viewer, SLAM session,
runner) composes the same pieces.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Ellipse, Polygon  # noqa: E402

from explore_rl.geometry import se2_to_matrix, transform_points  # noqa: E402
from explore_rl.grid import GridSpec  # noqa: E402
from explore_rl.scene.layout import Layout  # noqa: E402


def new_figure(layout: Layout, size_inches: float = 7.0):
    fig, ax = plt.subplots(figsize=(size_inches, size_inches * layout.size[1] / layout.size[0]))
    ax.set_aspect("equal")
    t = layout.perimeter_thickness
    ax.set_xlim(-t - 0.2, layout.size[0] + t + 0.2)
    ax.set_ylim(-t - 0.2, layout.size[1] + t + 0.2)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    return fig, ax


def draw_mask(ax, grid: GridSpec, mask: np.ndarray, color: str, alpha: float = 0.3, zorder=0) -> None:
    rgba = np.zeros((*mask.shape, 4))
    rgba[mask] = matplotlib.colors.to_rgba(color, alpha)
    ax.imshow(rgba, origin="lower", extent=grid.extent, interpolation="nearest", zorder=zorder)


def draw_layout(ax, layout: Layout, color: str = "0.25") -> None:
    """Walls and objects as filled footprints."""
    for box in layout.solid_boxes():
        ax.add_patch(Polygon(box.corners(), closed=True, color=color, zorder=2))
    for cyl in layout.cylinders:
        ax.add_patch(Circle(cyl.center, cyl.radius, color=color, zorder=2))


def draw_robot(ax, pose: np.ndarray, radius: float, color: str = "tab:red") -> None:
    ax.add_patch(Circle(pose[:2], radius, fill=False, color=color, lw=1.5, zorder=5))
    tip = pose[:2] + radius * np.array([np.cos(pose[2]), np.sin(pose[2])])
    ax.plot([pose[0], tip[0]], [pose[1], tip[1]], color=color, lw=1.5, zorder=5)


def draw_scan(ax, pose: np.ndarray, points_sensor: np.ndarray, mount_height: float) -> None:
    """Scan points in the world frame, coloured by height above the floor."""
    world = transform_points(se2_to_matrix(pose, mount_height), points_sensor)
    sc = ax.scatter(world[:, 0], world[:, 1], c=world[:, 2], s=0.5, cmap="viridis", zorder=4)
    plt.colorbar(sc, ax=ax, fraction=0.046, pad=0.04, label="point height [m]")


def draw_trajectory(ax, poses: np.ndarray, color: str, label: str, lw: float = 1.2) -> None:
    poses = np.asarray(poses).reshape(-1, 3)
    ax.plot(poses[:, 0], poses[:, 1], color=color, lw=lw, label=label, zorder=6)


def draw_ellipses(ax, xy: np.ndarray, covs: np.ndarray, scale: float = 3.0, color="tab:orange", every: int = 1) -> None:
    """Uncertainty ellipses (``scale`` sigma) of 2x2 world-frame xy covariances."""
    for p, cov in list(zip(xy, covs))[::every]:
        vals, vecs = np.linalg.eigh(cov)
        vals = np.clip(vals, 0, None)
        angle = np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1]))
        ax.add_patch(Ellipse(p, 2 * scale * np.sqrt(vals[1]), 2 * scale * np.sqrt(vals[0]),
                             angle=angle, fill=False, color=color, lw=0.8, zorder=7))


def save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(fig)
    return path


def draw_candidates(ax, paths: list[np.ndarray], chosen: int) -> None:
    """Candidate frontier paths in grey, the chosen one highlighted (paper Fig. 7)."""
    for i, path in enumerate(paths):
        if i != chosen:
            ax.plot(path[:, 0], path[:, 1], color="0.55", lw=0.8, zorder=8)
            ax.plot(*path[-1], "o", color="0.55", ms=3, zorder=8)
    if 0 <= chosen < len(paths):
        path = paths[chosen]
        ax.plot(path[:, 0], path[:, 1], color="deepskyblue", lw=2.0, zorder=9, label="chosen path")
        ax.plot(*path[-1], "*", color="deepskyblue", ms=10, zorder=9)


def figure_to_array(fig) -> np.ndarray:
    """RGB pixels of a figure (for animations)."""
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
