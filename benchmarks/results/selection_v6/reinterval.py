"""The shipped default's held-out test (session 33) with the expanded intervals of
explore_rl/intervals.py, from the episodes it already played (nothing is replayed).

    # 1. with the code frozen at the session-32 start (the cache's keys): the per-episode rewards
    cd /work/train_code32 && PYTHONPATH=/work/train_code32 python .../reinterval.py dump OUT.json
    # 2. with main: gap_closed and its interval, plain and expanded
    python benchmarks/results/selection_v6/reinterval.py intervals OUT.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ACTOR = "/work/main/policies/buildings_sparse_distill/actor.pt"
SETS = {  # name: (config overrides, layouts, starts, cache)
    "office": (["scene=office"], [2000, 2001], 9, "/work/runs/test33/office/episodes.jsonl"),
    "building": (["scene=building"], [2000, 2001, 2002, 2003, 2004], 4, "/work/runs/test33/building/episodes.jsonl"),
}
POLICIES = ("learned", "em", "nearest", "random")


def dump(out: Path) -> None:
    """Every policy's per-episode mean reward, read from the caches (playing is refused)."""
    from explore_rl.config import load_config
    from explore_rl.trainer import evaluate

    def refuse(task: object) -> None:
        raise RuntimeError("an episode is not in the cache: this script only reads")

    evaluate._play_task = refuse
    values = {}
    for name, (overrides, layouts, starts, cache) in SETS.items():
        config = load_config([*overrides, "slam=model", "graph.features=extended"])
        results = evaluate.run_protocol(config, evaluate.episode_specs(layouts, starts), POLICIES, 10,
                                        actor_path=Path(ACTOR), cache=Path(cache))
        values[name] = {policy: [e.mean_reward for e in episodes] for policy, episodes in results.items()}
    out.write_text(json.dumps(values))


def intervals(path: Path) -> None:
    """gap_closed with the plain and the expanded 95 % interval per set."""
    from explore_rl.trainer.evaluate import gap_closed, paired_bootstrap

    for name, columns in json.loads(path.read_text()).items():
        values = {policy: np.array(column) for policy, column in columns.items()}
        statistic = lambda v: gap_closed({k: float(np.mean(c)) for k, c in v.items()})  # noqa: E731
        low, high = paired_bootstrap(values, statistic)
        print(f"{name}: {len(values['learned'])} episodes, gap_closed {statistic(values):+.3f} "
              f"[{low:+.3f}, {high:+.3f}] (expanded percentile interval)")


if __name__ == "__main__":
    {"dump": dump, "intervals": intervals}[sys.argv[1]](Path(sys.argv[2]))
