"""LiDAR throughput per procedural scene, against baselines in the same run.

For each scene: the median time of one full scan through the project's LiDAR (batched
``mj_multiRay``), a Python loop of ``mujoco.mj_ray`` over the same rays, the independent
numpy analytic caster (also the accuracy reference) and Open3D's RaycastingScene when it
is importable. Scan poses are seeded samples of reachable free space. The process is
pinned to one core (the target is quoted per core); `ms_per_scan_multiray_only` is the
`mj_multiRay` call alone, without the noise and point assembly of a scan, on the
LiDAR's tile models and (`..._full_model`, the baseline for the tiles) on the full scene.
Where the cast's time goes (issue 22's drive): `ms_per_scan_multiray_nothing_to_hit`, the
same rays on a model whose one geom is out of reach (MuJoCo's per-ray cost, the floor of
any scene model), and `ms_per_scan_multiray_by_wall_piece`, the cast on scenes whose walls
are cut into pieces of at most that many metres (`scene.max_geom_length`; 6 is the default).

    python benchmarks/bench_lidar.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args, pin_to_one_core, time_call  # noqa: E402

from explore_rl.geometry import rotation_2d  # noqa: E402
from explore_rl.robot import RobotConfig  # noqa: E402
from explore_rl.scene.build import ROBOT_GEOM_GROUP, Scene, make_scene  # noqa: E402
from explore_rl.scene.config import SceneConfig  # noqa: E402
from explore_rl.sensors.analytic import cast_rays  # noqa: E402
from explore_rl.sensors.lidar import Lidar, LidarConfig  # noqa: E402

SCENES = {
    "office": SceneConfig(name="office", size=[20.0, 20.0], num_objects=8),
    "street": SceneConfig(name="street", size=[20.0, 20.0], num_objects=5),
    "garage": SceneConfig(name="garage", size=[30.0, 30.0], num_objects=15,
                          car_rows_y=[4.0, 11.25, 22.5]),
}


def sample_poses(scene: Scene, count: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    cells = np.argwhere(scene.truth.traversable & scene.truth.reachable)
    xy = scene.grid.cell_to_world(cells[rng.choice(len(cells), count, replace=False)])
    return np.column_stack([xy, rng.uniform(-np.pi, np.pi, count)])


def world_directions(lidar: Lidar, pose: np.ndarray) -> np.ndarray:
    dirs = lidar.directions.copy()
    dirs[:, :2] = dirs[:, :2] @ rotation_2d(float(pose[2])).T
    return dirs


def mj_ray_loop(scene: Scene, lidar: Lidar, pose: np.ndarray) -> np.ndarray:
    """The baseline: one ``mj_ray`` call per ray from Python."""
    groups = np.ones(6, dtype=np.uint8)
    groups[ROBOT_GEOM_GROUP] = 0
    geomid = np.zeros(1, dtype=np.int32)
    origin = lidar.sensor_position(pose)
    out = np.empty(lidar.rays_per_scan)
    for i, d in enumerate(world_directions(lidar, pose)):
        out[i] = mujoco.mj_ray(scene.model, scene.data, origin, d, groups, 1, scene.robot_body_id, geomid)
    out[(out > lidar.config.max_range) | (out < lidar.config.min_range)] = -1.0
    return out


def open3d_caster(scene: Scene, cylinder_resolution: int = 128):
    """Open3D's Embree RaycastingScene of the same floor, boxes and (faceted) cylinders.

    Returns ``cast(origin, dirs) -> ranges`` or None when open3d is not importable
    (``pip install open3d``; it needs the system library libusb-1.0-0).
    """
    try:
        import open3d as o3d
    except Exception:
        return None
    raycaster = o3d.t.geometry.RaycastingScene()

    def add(mesh) -> None:
        raycaster.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))

    sx, sy = scene.layout.size
    floor = o3d.geometry.TriangleMesh.create_box(sx + 10, sy + 10, 0.01).translate((-5, -5, -0.01))
    add(floor)
    for box in scene.layout.solid_boxes():
        mesh = o3d.geometry.TriangleMesh.create_box(*box.size).translate(
            (-box.size[0] / 2, -box.size[1] / 2, 0.0))
        mesh.rotate(mesh.get_rotation_matrix_from_xyz((0, 0, box.yaw)), center=(0, 0, 0))
        add(mesh.translate((box.center[0], box.center[1], 0.0)))
    for cyl in scene.layout.cylinders:
        mesh = o3d.geometry.TriangleMesh.create_cylinder(cyl.radius, cyl.height, cylinder_resolution)
        add(mesh.translate((cyl.center[0], cyl.center[1], cyl.height / 2)))

    def cast(origin: np.ndarray, dirs: np.ndarray, max_range: float) -> np.ndarray:
        rays = np.hstack([np.broadcast_to(origin, dirs.shape), dirs]).astype(np.float32)
        hits = raycaster.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(float)
        return np.where(hits <= max_range, hits, -1.0)

    return cast


WALL_PIECES = (6.0, 3.0, 1.5)  # scene.max_geom_length values timed (metres)


def multiray_nothing_to_hit(lidar: Lidar, poses: np.ndarray) -> float:
    """Median seconds of the LiDAR's ``mj_multiRay`` on a model whose one geom (a small
    sphere far above the scene) no ray reaches: what the call costs with nothing to test."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.1, 0.0, 0.0], pos=[0.0, 0.0, 1e3])
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    n = lidar.rays_per_scan
    geomid, dist = np.empty(n, dtype=np.int32), np.empty(n)

    def cast(origin: np.ndarray, directions: np.ndarray) -> None:
        mujoco.mj_multiRay(model, data, origin, directions, None, 1, -1, geomid, dist, None, n,
                           lidar.config.max_range)
    rays = [(lidar.sensor_position(p), world_directions(lidar, p).reshape(-1)) for p in poses]
    return float(np.median([time_call(lambda r=r: cast(*r), repeats=5) for r in rays]))


def multiray_by_wall_piece(config: SceneConfig, poses: np.ndarray, rounds: int = 3) -> dict[str, float]:
    """Ms of the LiDAR's ``mj_multiRay`` (tile models) on the scene rebuilt with its walls
    cut into pieces of at most each of :data:`WALL_PIECES` metres, at the same poses: the
    median over the poses, the lengths interleaved for ``rounds`` rounds, the least round
    kept (the same cast varies by tens of percent between moments on a shared machine)."""
    lidars = {}
    for length in WALL_PIECES:
        scene = make_scene(replace(config, max_geom_length=length), RobotConfig(), LidarConfig())
        lidars[f"{length:g}"] = Lidar(scene, LidarConfig(), np.random.default_rng(0))
    best = {name: np.inf for name in lidars}
    for _ in range(rounds):
        for name, lidar in lidars.items():
            ms = 1e3 * float(np.median([time_call(lambda p=p: lidar.cast_raw(p), repeats=5) for p in poses]))
            best[name] = min(best[name], ms)
    return {name: round(ms, 3) for name, ms in best.items()}


def bench_scene(name: str, config: SceneConfig, poses_count: int, loop_count: int) -> dict:
    scene = make_scene(config, RobotConfig(), LidarConfig())
    lidar = Lidar(scene, LidarConfig(), np.random.default_rng(0))
    poses = sample_poses(scene, poses_count)
    scan_s = [time_call(lambda p=p: lidar.scan(p), repeats=5) for p in poses]
    multiray_s = [time_call(lambda p=p: lidar.cast_raw(p), repeats=5) for p in poses]
    full_model = Lidar(scene, replace(LidarConfig(), tile_size=0.0), np.random.default_rng(0))
    full_model_s = [time_call(lambda p=p: full_model.cast_raw(p), repeats=5) for p in poses]
    tile_geoms = [lidar.tiles.model_at(p)[0].ngeom for p in poses]
    analytic_s, diffs, mismatches = [], [], 0
    for pose in poses:
        dirs = world_directions(lidar, pose)
        origin = lidar.sensor_position(pose)
        analytic_s.append(time_call(lambda: cast_rays(scene.layout, origin, dirs, 3.0)))
        expected = cast_rays(scene.layout, origin, dirs, lidar.config.max_range)
        got = lidar.cast(pose)
        both = (got > 0) & (expected > 0)
        mismatches += int(((got > 0) != (expected > 0)).sum())
        diffs.append(float(np.abs(got[both] - expected[both]).max()) if both.any() else 0.0)
    loop_s = [time_call(lambda p=p: mj_ray_loop(scene, lidar, p)) for p in poses[:loop_count]]
    o3d_cast = open3d_caster(scene)
    o3d_s, o3d_diffs = [], []
    if o3d_cast is not None:
        for pose in poses:
            dirs, origin = world_directions(lidar, pose), lidar.sensor_position(pose)
            o3d_s.append(time_call(lambda: o3d_cast(origin, dirs, 3.0), repeats=3))
            got = o3d_cast(origin, dirs, lidar.config.max_range)
            expected = cast_rays(scene.layout, origin, dirs, lidar.config.max_range)
            both = (got > 0) & (expected > 0)
            o3d_diffs.append(float(np.abs(got[both] - expected[both]).max()) if both.any() else 0.0)
    ms = 1e3 * float(np.median(scan_s))
    ms_loop = 1e3 * float(np.median(loop_s))
    return {
        "scene": name,
        "ngeom": scene.ngeom,
        "rays_per_scan": lidar.rays_per_scan,
        "poses": len(poses),
        "ms_per_scan": round(ms, 3),
        "mrays_per_s": round(lidar.rays_per_scan / ms / 1e3, 2),
        "ms_per_scan_multiray_only": round(1e3 * float(np.median(multiray_s)), 3),
        "ms_per_scan_multiray_full_model": round(1e3 * float(np.median(full_model_s)), 3),
        "mean_geoms_per_tile_model": round(float(np.mean(tile_geoms)), 1),
        "ms_per_scan_multiray_nothing_to_hit": round(1e3 * multiray_nothing_to_hit(lidar, poses), 3),
        "ms_per_scan_multiray_by_wall_piece": multiray_by_wall_piece(config, poses),
        "meets_4_mrays_per_s": lidar.rays_per_scan / ms / 1e3 >= 4.0,
        "ms_per_scan_mj_ray_loop": round(ms_loop, 2),
        "speedup_vs_loop": round(ms_loop / ms, 1),
        "ms_per_scan_analytic_numpy": round(1e3 * float(np.median(analytic_s)), 2),
        "max_abs_diff_m": max(diffs),
        "hit_mismatches_vs_analytic": mismatches,
        "ms_per_scan_open3d": round(1e3 * float(np.median(o3d_s)), 3) if o3d_s else None,
        "max_abs_diff_m_open3d": max(o3d_diffs) if o3d_diffs else None,
    }


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    poses_count, loop_count = (2, 1) if args.smoke else (6, 2) if args.quick else (30, 5)
    core = pin_to_one_core()
    results = [bench_scene(n, c, poses_count, loop_count) for n, c in SCENES.items()]
    for r in results:
        print(f"{r['scene']:7s} {r['ngeom']:3d} geoms  {r['ms_per_scan']:.2f} ms/scan "
              f"({r['mrays_per_s']:.2f} Mrays/s)  mj_ray loop {r['ms_per_scan_mj_ray_loop']:.1f} ms "
              f"(x{r['speedup_vs_loop']})  numpy {r['ms_per_scan_analytic_numpy']:.1f} ms  "
              f"max diff {r['max_abs_diff_m']:.1e} m")
    emit({"benchmark": "lidar", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "pinned_core": core,
          "all_meet_4_mrays_per_s": all(r["meets_4_mrays_per_s"] for r in results), "results": results})


if __name__ == "__main__":
    main()
