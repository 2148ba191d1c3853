"""Where exploration time goes: one nearest-frontier exploration of `street`, per decision.

Splits the time per decision into decide (frontiers, Dijkstra, paths, policy) and drive
(LiDAR, registration, iSAM2, maps), and runs the random-frontier policy on the same scene
and seed as the in-run baseline.

    python benchmarks/bench_explore.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402


def explore(policy: str, max_decisions: int, extra: list[str]) -> dict:
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
    }


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    max_decisions = 2 if args.smoke else 12 if args.quick else 300
    nearest = explore("nearest", max_decisions, [])
    random = explore("random", max_decisions, [])
    for r in (nearest, random):
        print(f"{r['policy']:8s} {r['status']:22s} {r['decisions']:3d} decisions  "
              f"{r['ms_per_decision']:7.1f} ms/decision (decide {r['ms_decide']:.1f}, drive {r['ms_drive']:.1f})  "
              f"{r['keyframes_per_s']:.1f} kf/s  explored {100 * r['explored']:.1f} %  {r['travel_m']:.1f} m")
    print("per keyframe:", nearest["ms_per_keyframe_by_stage"])
    emit({"benchmark": "explore", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          **nearest,
          "baseline_random": random})


if __name__ == "__main__":
    main()
