"""The EM planner's alpha (utility per metre of travel), swept on the training office.

For each alpha, explores the office with EM from several starts and records final map
error, travel and explored fraction; nearest frontier on the same starts is the baseline.
The chosen default is the alpha with the lowest mean map error among those whose mean
travel stays within ``--travel-factor`` of nearest frontier's (documented in
benchmarks/RESULTS.md). Last line JSON.

    python benchmarks/sweep_alpha.py [--quick | --smoke] [--alphas 0.3 1 3 10 30] [--starts 0 3 6]
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402


def explore_once(policy: str, alpha: float, start: int, frontend: str, max_decisions: int) -> dict:
    from explore_rl.config import load_config
    from explore_rl.runner import Explorer

    overrides = ["scene=office", f"scene.start_index={start}", f"policy={policy}", f"slam={frontend}",
                 f"planning.reward.alpha={alpha}", "explore.progress_bar=false",
                 f"explore.max_decisions={max_decisions}", "seed=0"]
    explorer = Explorer(load_config(overrides))
    result = explorer.run()
    last = result.records[-1] if result.records else None
    return {"policy": policy, "alpha": alpha, "start": start, "status": result.status.value,
            "travel_m": explorer.robot.travelled, "explored": last.explored if last else 0.0,
            "map_error_m": last.map_error_m if last else 0.0,
            "loop_closures": last.loop_closures if last else 0}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: the first alpha, the first start, 2 decisions, slam=model, 1 worker")
    parser.add_argument("--alphas", type=float, nargs="+", default=[0.3, 1.0, 3.0, 10.0, 30.0])
    parser.add_argument("--starts", type=int, nargs="+", default=[0, 3, 6])
    parser.add_argument("--frontend", default="icp", choices=["icp", "model"])
    parser.add_argument("--travel-factor", type=float, default=1.5)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    alphas, starts, max_decisions = args.alphas, args.starts, 300
    if args.quick:
        alphas, starts, max_decisions = alphas[:2], starts[:1], 5
    if args.smoke:
        alphas, starts, max_decisions = alphas[:1], starts[:1], 2
        args.frontend, args.workers = "model", 1
    jobs = [("nearest", 0.0, s) for s in starts] + [("em", a, s) for a in alphas for s in starts]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        runs = list(pool.map(explore_once, *zip(*jobs), [args.frontend] * len(jobs), [max_decisions] * len(jobs)))

    def mean(policy: str, alpha: float, key: str) -> float:
        return float(np.mean([r[key] for r in runs if r["policy"] == policy and r["alpha"] == alpha]))

    baseline_travel = mean("nearest", 0.0, "travel_m")
    rows = [{"alpha": a, "travel_m": mean("em", a, "travel_m"), "map_error_m": mean("em", a, "map_error_m"),
             "explored": mean("em", a, "explored"), "loop_closures": mean("em", a, "loop_closures")}
            for a in alphas]
    eligible = [r for r in rows if r["travel_m"] <= args.travel_factor * baseline_travel] or rows
    best = min(eligible, key=lambda r: r["map_error_m"])
    print(f"nearest: travel {baseline_travel:.1f} m, map error {mean('nearest', 0.0, 'map_error_m'):.3f} m")
    for r in rows:
        print(f"alpha {r['alpha']:6.2f}: travel {r['travel_m']:6.1f} m  map error {r['map_error_m']:.3f} m  "
              f"explored {100 * r['explored']:.1f} %  loops {r['loop_closures']:.1f}")
    emit({"benchmark": "sweep_alpha", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "starts": starts,
          "nearest_travel_m": baseline_travel, "nearest_map_error_m": mean("nearest", 0.0, "map_error_m"),
          "rows": rows, "chosen_alpha": best["alpha"], "runs": runs})


if __name__ == "__main__":
    main()
