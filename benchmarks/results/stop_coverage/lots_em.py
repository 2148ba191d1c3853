"""EM's map error and trajectory error per building of a run folder (``building_SEED/trials.jsonl``), and their means
and medians: is a family of scenes in the garage's SLAM regime (plan.md, session 69 step 7)? One JSON line.

    python benchmarks/results/stop_coverage/lots_em.py benchmarks/results/stop_coverage/runs/lots_gap0.1_em
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from explore_rl.comparison import read_trials

KEYS = ("map_error_m", "ate_m", "travel_m", "explored", "loop_closures")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", help="a folder of building_SEED/trials.jsonl")
    parser.add_argument("--policy", default="em")
    args = parser.parse_args(argv)
    per_building = {}
    for path in sorted(Path(args.run).glob("building_*/trials.jsonl")):
        trials = [t for t in read_trials(path) if t.get("policy") == args.policy]
        if trials:
            per_building[path.parent.name] = {key: float(trials[0][key]) for key in KEYS}
    if not per_building:
        parser.error(f"{args.run}: no building_SEED/trials.jsonl with a {args.policy!r} trial")
    summary = {"buildings": len(per_building), "policy": args.policy}
    for key in KEYS:
        values = np.array([b[key] for b in per_building.values()])
        summary[key] = {"mean": round(float(values.mean()), 4), "median": round(float(np.median(values)), 4)}
    print(json.dumps({**summary, "per_building": per_building}))


if __name__ == "__main__":
    main()
