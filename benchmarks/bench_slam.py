"""SLAM against dead reckoning on the scripted office tour, over several seeds.

Each seed drives the same tour (it comes back near its start) with the full SLAM session
and scores the SLAM estimate and, on the same keyframes and the same map-error sample
points, dead reckoning (wheel odometry alone).

    python benchmarks/bench_slam.py [--quick]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

from explore_rl.cli import CONF_DIR  # noqa: E402
from explore_rl.tour import run_tour  # noqa: E402


def load_config(seed: int, overrides: list[str]):
    with initialize_config_dir(CONF_DIR, version_base="1.3"):
        cfg = compose("config", overrides=[f"seed={seed}", *overrides])
    return OmegaConf.to_object(cfg)


def run_seed(seed: int, goals_limit: int | None, overrides: list[str]) -> dict:
    config = load_config(seed, overrides)
    start = time.perf_counter()
    run = run_tour(config, goals_limit)
    wall = time.perf_counter() - start
    session = run.session
    slam = session.metrics()
    odometry = session.metrics(session.odometry_poses())
    keyframes = len(session.keyframes)
    registration_ms = [k.match.ms for k in session.keyframes if k.match is not None]
    return {
        "seed": seed,
        "status": run.status.value,
        "travel_m": round(run.robot.travelled, 2),
        "keyframes": keyframes,
        "ms_per_keyframe": 1e3 * wall / keyframes,
        "ms_registration_median": float(np.median(registration_ms)),
        "stage_ms_per_keyframe": {k: 1e3 * v / keyframes for k, v in session.timer.seconds.items()},
        "ate_m": slam.ate_m,
        "ate_m_odometry": odometry.ate_m,
        "map_error_m": slam.map_error_m,
        "map_error_m_odometry": odometry.map_error_m,
        "degenerate_registrations": slam.degenerate_registrations,
        "loop_closures": slam.loop_closures,
    }


def summarise(runs: list[dict]) -> dict:
    stages = {k: round(float(np.mean([r["stage_ms_per_keyframe"][k] for r in runs])), 2)
              for k in runs[0]["stage_ms_per_keyframe"]}
    mean = lambda key: round(float(np.mean([r[key] for r in runs])), 4)  # noqa: E731
    return {
        "seeds": [r["seed"] for r in runs],
        "keyframes": int(sum(r["keyframes"] for r in runs)),
        "ms_per_keyframe": mean("ms_per_keyframe"),
        "ms_registration_median": round(float(np.median([r["ms_registration_median"] for r in runs])), 2),
        "ate_m": mean("ate_m"),
        "ate_m_odometry": mean("ate_m_odometry"),
        "map_error_m": mean("map_error_m"),
        "map_error_m_odometry": mean("map_error_m_odometry"),
        "degenerate_registrations": int(sum(r["degenerate_registrations"] for r in runs)),
        "stage_ms_per_keyframe": stages,
        "slam_beats_odometry_every_seed": all(
            r["ate_m"] < r["ate_m_odometry"] and r["map_error_m"] < r["map_error_m_odometry"] for r in runs),
        "tours_completed": sum(r["status"] == "reached" for r in runs),
    }


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    seeds, goals_limit = ([0, 1, 2], 4) if args.quick else ([0, 1, 2, 3, 4], None)
    runs = [run_seed(seed, goals_limit, ["slam=icp"]) for seed in seeds]
    for r in runs:
        print(f"seed {r['seed']}: {r['status']:8s} {r['travel_m']:6.1f} m {r['keyframes']:4d} kf  "
              f"ATE {r['ate_m']:.3f} (odom {r['ate_m_odometry']:.3f})  map error {r['map_error_m']:.3f} "
              f"(odom {r['map_error_m_odometry']:.3f})  degenerate {r['degenerate_registrations']}  "
              f"{r['ms_per_keyframe']:.1f} ms/kf")
    summary = summarise(runs)
    print("per-keyframe stages (ms):", summary["stage_ms_per_keyframe"])
    emit({"benchmark": "slam", "quick": args.quick, "machine": machine(), **summary, "per_seed": runs})


if __name__ == "__main__":
    main()
