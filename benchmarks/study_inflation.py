"""How far should paths keep from obstacles? Blocked paths against reachable space.

Paths are planned on the occupancy grid with obstacles inflated by the robot radius plus
``mapping.paths.inflation_margin`` (a hard margin), and each cell costs ``1 +
clearance_weight * exp(-clearance / clearance_scale)`` (a soft one). A path that grazes a
wall lets the robot's odometry and SLAM error put its footprint into the wall: the path
ends ``blocked`` and the decision is wasted (the robot escapes and decides again). A hard
margin keeps paths away from walls but closes narrow passages; a soft one only makes
them expensive. This runs nearest-frontier explorations (slam=model) of every scene for
each variant (a set of Hydra overrides; the first is the baseline). Per variant: blocked
decisions per run, decisions, explored fraction, travel, map error and how the runs
ended. The last stdout line is JSON.

    python benchmarks/study_inflation.py [--quick | --smoke] [--seeds 4] [--workers 2]
        [--variants "" "mapping.paths.inflation_margin=0.1" "mapping.paths.clearance_weight=10" ...]
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402
from study_ordering import explore_once  # noqa: E402

SCENES = ["office", "street", "garage"]


DEFAULT_VARIANTS = ["", "mapping.paths.inflation_margin=0.1", "mapping.paths.inflation_margin=0.2",
                    "mapping.paths.clearance_weight=5", "mapping.paths.clearance_weight=20"]


def run(scene: str, seed: int, variant: str, extra: tuple[str, ...] = ()) -> dict:
    result = explore_once(scene, "nearest", seed, "model", (*variant.split(), *extra))
    statuses = [row["path_status"] for row in result.pop("rows")]
    return {**result, "variant": variant, "blocked": statuses.count("blocked")}


def summarise(runs: list[dict], variants: list[str]) -> list[dict]:
    table = []
    for variant in variants:
        for scene in SCENES:
            group = [r for r in runs if r["variant"] == variant and r["scene"] == scene]
            if not group:
                continue
            mean = {key: round(float(np.mean([r[key] for r in group])), 4)
                    for key in ("blocked", "decisions", "explored", "travel_m", "map_error_m")}
            ends = sorted({r["status"] for r in group})
            table.append({"variant": variant or "baseline", "scene": scene, "runs": len(group), **mean,
                          "blocked_per_decision": round(mean["blocked"] / max(mean["decisions"], 1), 4),
                          "ends": {s: sum(r["status"] == s for r in group) for s in ends}})
    return table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 seed, the first two variants")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: office, 1 seed, the first two variants, 2 decisions, 1 worker")
    parser.add_argument("--variants", nargs="+", default=DEFAULT_VARIANTS,
                        help="each a space-separated list of Hydra overrides ('' = the defaults)")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    if args.seeds < 1 or args.workers < 1:
        parser.error(f"--seeds and --workers must be >= 1, got {args.seeds} and {args.workers}")
    from explore_rl.config import load_config

    for variant in args.variants:  # fail before any run starts
        try:
            load_config(variant.split())
        except Exception as error:  # Hydra's override errors and our validation's
            parser.error(f"bad --variants entry {variant!r}: {error}")
    variants, seeds = (args.variants[:2], 1) if args.quick or args.smoke else (args.variants, args.seeds)
    scenes, extra, workers = SCENES, (), args.workers
    if args.smoke:
        scenes, extra, workers = ["office"], ("explore.max_decisions=2",), 1
    jobs = [(scene, seed, variant, extra) for variant in variants for scene in scenes for seed in range(seeds)]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        runs = list(pool.map(run, *zip(*jobs)))
    table = summarise(runs, variants)
    print(f"{'variant':36} {'scene':8} {'blocked/run':>11} {'blocked/dec':>11} {'decisions':>9} "
          f"{'explored':>8} {'travel m':>8} {'map err':>8}  ends")
    for t in table:
        print(f"{t['variant']:36} {t['scene']:8} {t['blocked']:11.2f} {t['blocked_per_decision']:11.3f} "
              f"{t['decisions']:9.1f} {t['explored']:8.3f} {t['travel_m']:8.1f} {t['map_error_m']:8.3f}  {t['ends']}")
    per_variant = {}
    for variant in variants:
        rows = [t for t in table if t["variant"] == (variant or "baseline")]
        per_variant[variant or "baseline"] = {
            "blocked_per_run": round(float(np.mean([t["blocked"] for t in rows])), 3),
            "explored": round(float(np.mean([t["explored"] for t in rows])), 4),
            "travel_m": round(float(np.mean([t["travel_m"] for t in rows])), 2),
            "no_reachable_frontier_runs": sum(t["ends"].get("no_reachable_frontier", 0) for t in rows),
        }
    emit({"benchmark": "inflation", "quick": args.quick, "smoke": args.smoke, "machine": machine(), "seeds": seeds,
          "baseline": variants[0] or "baseline", "per_variant": per_variant, "table": table})


if __name__ == "__main__":
    main()
