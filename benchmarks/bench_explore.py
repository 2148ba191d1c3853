"""Where exploration time goes: one nearest-frontier exploration of `street`, per decision.

Splits the time per decision into decide (frontiers, Dijkstra, paths, policy) and drive
(LiDAR, registration, iSAM2, maps), and runs the random-frontier policy on the same scene
and seed as the in-run baseline. The run's metrics (map error, ATE, explored, ...: the
runner logs them after every decision) are timed on its final session, at once
(``ms_metrics``) and keyframe by keyframe as first written (``ms_metrics_reference``),
with the two map errors' relative difference. The shortest paths of the final map are timed
the same way: the planner of the runner (grid graph of the traversable cells over their
window, then one Dijkstra; ``ms_paths``) and the whole grid's as first written
(``PathPlanner(..., reference=True)``; ``ms_paths_reference``), whose distance fields must be
equal (``same_distance_field``).

    python benchmarks/bench_explore.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args, time_call  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.mapping.paths import PathPlanner, traversability  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402


def metrics_cost(explorer: Explorer, repeats: int) -> dict:
    """Milliseconds of the session's metrics, vectorised and by the reference code, and
    the relative difference of their map errors (round-off only)."""
    session = explorer.session
    fast, reference = session.metrics(), session.metrics(reference=True)
    return {"ms_metrics": round(1e3 * time_call(session.metrics, repeats), 2),
            "ms_metrics_reference": round(1e3 * time_call(lambda: session.metrics(reference=True), repeats), 2),
            "map_error_rel_diff": abs(fast.map_error_m - reference.map_error_m) / max(reference.map_error_m, 1e-300),
            "metrics_keyframes": len(session.keyframes)}


def paths_cost(explorer: Explorer, repeats: int) -> dict:
    """Milliseconds of the final map's shortest paths from the robot (graph + Dijkstra), by the
    runner's planner and by the whole grid's reference, and whether their distances agree."""
    occupancy, grid, config = explorer.session.occupancy, explorer.scene.grid, explorer.config
    traversable, cost = traversability(occupancy.known_free, occupancy.known_occupied, grid, config.robot.radius,
                                       config.mapping.paths)
    start = explorer.robot.belief_pose[:2]

    def paths(reference: bool):
        return PathPlanner(grid, traversable, cost, config.mapping.paths, reference=reference).from_start(start)

    same = np.array_equal(paths(False).distances, paths(True).distances)
    return {"ms_paths": round(1e3 * time_call(lambda: paths(False), repeats), 2),
            "ms_paths_reference": round(1e3 * time_call(lambda: paths(True), repeats), 2),
            "same_distance_field": bool(same), "traversable_cells": int(traversable.sum())}


def explore(policy: str, max_decisions: int, extra: list[str], metrics_repeats: int = 0) -> dict:
    explorer = Explorer(load_config(["scene=street", f"policy={policy}", "seed=0", "explore.progress_bar=false",
                                     f"explore.max_decisions={max_decisions}", *extra]))
    start = time.perf_counter()
    result = explorer.run()
    wall = time.perf_counter() - start
    records = result.records
    keyframes = len(explorer.session.keyframes)
    stages = {k: round(1e3 * v / max(keyframes, 1), 2) for k, v in explorer.session.timer.seconds.items()}
    return {
        "policy": policy,
        "status": result.status.value,
        "decisions": len(records),
        "ms_per_decision": round(1e3 * wall / max(len(records), 1), 1),
        "ms_decide": round(float(np.mean([r.ms_decide for r in records])), 1),
        "ms_drive": round(float(np.mean([r.ms_drive for r in records])), 1),
        "keyframes": keyframes,
        "keyframes_per_s": round(keyframes / wall, 2),
        "ms_per_keyframe_by_stage": stages,
        "explored": round(records[-1].explored, 4) if records else 0.0,
        "travel_m": round(explorer.robot.travelled, 2),
        "map_error_m": round(records[-1].map_error_m, 4) if records else 0.0,
        "wall_s": round(wall, 1),
        **(metrics_cost(explorer, metrics_repeats) if metrics_repeats else {}),
        **(paths_cost(explorer, metrics_repeats) if metrics_repeats else {}),
    }


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    max_decisions = 2 if args.smoke else 12 if args.quick else 300
    nearest = explore("nearest", max_decisions, [], metrics_repeats=2 if args.smoke else 10)
    random = explore("random", max_decisions, [])
    for r in (nearest, random):
        print(f"{r['policy']:8s} {r['status']:22s} {r['decisions']:3d} decisions  "
              f"{r['ms_per_decision']:7.1f} ms/decision (decide {r['ms_decide']:.1f}, drive {r['ms_drive']:.1f})  "
              f"{r['keyframes_per_s']:.1f} kf/s  explored {100 * r['explored']:.1f} %  {r['travel_m']:.1f} m")
    print("per keyframe:", nearest["ms_per_keyframe_by_stage"])
    print(f"metrics at {nearest['metrics_keyframes']} keyframes: {nearest['ms_metrics']:.2f} ms "
          f"(reference {nearest['ms_metrics_reference']:.2f} ms), map errors {nearest['map_error_rel_diff']:.1e} apart")
    print(f"paths of the final map ({nearest['traversable_cells']} traversable cells): {nearest['ms_paths']:.2f} ms "
          f"(reference {nearest['ms_paths_reference']:.2f} ms), same distances: {nearest['same_distance_field']}")
    emit({"benchmark": "explore", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          **nearest, "metrics_speedup": round(nearest["ms_metrics_reference"] / nearest["ms_metrics"], 2),
          "paths_speedup": round(nearest["ms_paths_reference"] / nearest["ms_paths"], 2),
          "baseline_random": random})


if __name__ == "__main__":
    main()
