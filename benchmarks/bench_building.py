"""scene=building: the cost of a new plan, against building the office in the same run.

Per seed (``0..N-1``): ``ms_plan`` draws the plan (``generate_building``: raster, doors,
walls, starts, clutter and the reachability check on the 0.1 m truth grid), ``ms_compile``
turns it into an ``MjSpec`` and compiles it, ``ms_scene`` is the whole ``make_scene`` a
training env pays per new plan (plan, compile, ground-truth masks). The baseline is the
office built the same ways, over as many seeds, in the same process. The LiDAR part
compares one scan (the project's tiled ``mj_multiRay``) at sampled reachable poses in
buildings against the office: buildings hold more geoms in total, the tiles keep a scan
local. Medians; the process is pinned to one core.

    python benchmarks/bench_building.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args, pin_to_one_core  # noqa: E402

from explore_rl.robot import RobotConfig  # noqa: E402
from explore_rl.scene.build import RobotBodyConfig, Scene, build_spec, make_layout, make_scene  # noqa: E402
from explore_rl.scene.building import generate_building  # noqa: E402
from explore_rl.scene.config import SceneConfig  # noqa: E402
from explore_rl.sensors.lidar import Lidar, LidarConfig  # noqa: E402


def seconds(fn) -> tuple[float, object]:
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def time_builds(scene: SceneConfig, seeds: range, robot: RobotConfig, lidar: LidarConfig) -> dict:
    """Median/p90/max ms of layout, compile and whole scene over ``seeds``, and geom counts."""
    body = RobotBodyConfig(robot.radius, tuple(robot.body_size), lidar.mount_height)
    plan_ms, compile_ms, scene_ms, ngeom, redraws = [], [], [], [], 0
    make_scene(replace(scene, seed=seeds[0]), robot, lidar)  # warm-up (imports, first compile)
    for seed in seeds:
        config = replace(scene, seed=seed)
        if scene.name == "building":
            dt, plan = seconds(lambda: generate_building(config, robot.radius))
            layout, redraws = plan.layout, redraws + (plan.attempt > 0)
        else:
            dt, layout = seconds(lambda: make_layout(config, robot.radius))
        plan_ms.append(dt * 1e3)
        dt, model = seconds(lambda: build_spec(layout, body, config.max_geom_length).compile())
        compile_ms.append(dt * 1e3)
        ngeom.append(model.ngeom)
        dt, _ = seconds(lambda: make_scene(config, robot, lidar))
        scene_ms.append(dt * 1e3)
    both = np.add(plan_ms, compile_ms)
    return {"ms_plan": float(np.median(plan_ms)), "ms_compile": float(np.median(compile_ms)),
            "ms_plan_compile": float(np.median(both)), "ms_plan_compile_p90": float(np.percentile(both, 90)),
            "ms_plan_compile_max": float(np.max(both)), "ms_scene": float(np.median(scene_ms)),
            "ms_scene_max": float(np.max(scene_ms)), "ngeom_median": float(np.median(ngeom)),
            "ngeom_max": int(np.max(ngeom)), "redraws": redraws}


def time_scans(scene: Scene, lidar_config: LidarConfig, poses: int, seed: int = 0) -> tuple[list[float], list[int]]:
    """ms per scan at ``poses`` sampled reachable poses, and the geoms of each tile used."""
    lidar = Lidar(scene, lidar_config, np.random.default_rng(seed))
    rng = np.random.default_rng(seed)
    cells = np.argwhere(scene.truth.drivable)
    xy = scene.grid.cell_to_world(cells[rng.choice(len(cells), poses, replace=False)])
    chosen = np.column_stack([xy, rng.uniform(-np.pi, np.pi, poses)])
    for pose in chosen:  # build the tiles first: their cost is once per tile, not per scan
        lidar.cast_raw(pose)
    times = []
    for pose in chosen:
        dt, _ = seconds(lambda: lidar.cast_raw(pose))
        times.append(dt * 1e3)
    tiles = lidar.tiles
    geoms = [] if tiles is None else [len(tiles.geoms_near(tiles.tile_of(p[:2]))) for p in chosen]
    return times, geoms


def lidar_comparison(office: SceneConfig, building: SceneConfig, seeds: range, poses: int) -> dict:
    """Scan time and geoms per tile: buildings (several seeds) against the office."""
    robot, lidar = RobotConfig(), LidarConfig()
    out = {}
    for name, configs in (("office", [office]), ("building", [replace(building, seed=s) for s in seeds])):
        times, geoms = [], []
        for config in configs:
            t, g = time_scans(make_scene(config, robot, lidar), lidar, poses)
            times += t
            geoms += g
        out[f"lidar_ms_scan_{name}"] = float(np.median(times))
        out[f"tile_geoms_median_{name}"] = float(np.median(geoms))
        out[f"tile_geoms_max_{name}"] = int(np.max(geoms))
    out["lidar_scan_ratio_building_vs_office"] = out["lidar_ms_scan_building"] / out["lidar_ms_scan_office"]
    return out


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    seeds = 3 if args.smoke else 50 if args.quick else 200
    scan_seeds, poses = (1, 3) if args.smoke else (5, 20) if args.quick else (20, 30)
    core = pin_to_one_core()
    robot, lidar = RobotConfig(), LidarConfig()
    office, building = SceneConfig(name="office"), SceneConfig(name="building")
    result = {"smoke": args.smoke, "quick": args.quick, "seeds": seeds, "core": core}
    built = time_builds(building, range(seeds), robot, lidar)
    baseline = time_builds(office, range(seeds), robot, lidar)
    result.update({f"{k}": v for k, v in built.items()})
    result.update({f"office_{k}": v for k, v in baseline.items() if k != "redraws"})
    result["plan_compile_ratio_vs_office"] = built["ms_plan_compile"] / baseline["ms_plan_compile"]
    result["scene_ratio_vs_office"] = built["ms_scene"] / baseline["ms_scene"]
    result.update(lidar_comparison(office, building, range(scan_seeds), poses))
    result["machine"] = machine()
    for key, value in result.items():
        if key != "machine":
            print(f"{key:40s} {value:.2f}" if isinstance(value, float) else f"{key:40s} {value}")
    emit(result)


if __name__ == "__main__":
    main()
