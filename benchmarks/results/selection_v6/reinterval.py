"""A held-out test (session 33's default; session 35's em_choice_long) with the expanded
intervals of explore_rl/intervals.py, from the episodes it already played (nothing is replayed).

    # 1. with the code frozen at the session-32 start (the cache's keys): the per-episode rewards
    #    (ACTOR and TEST_DIR default to the session-33 default and /work/runs/test33)
    cd /work/train_code32 && PYTHONPATH=/work/train_code32 python .../reinterval.py dump OUT.json [ACTOR TEST_DIR]
    # 2. with main: gap_closed and its interval, plain and expanded
    python benchmarks/results/selection_v6/reinterval.py intervals OUT.json
    # 3. with main: the paired difference of two actors' gap_closed on the same episodes
    python benchmarks/results/selection_v6/reinterval.py compare OUT_A.json OUT_B.json
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ACTOR = "/work/main/policies/buildings_sparse_distill/actor.pt"
TEST_DIR = "/work/runs/test33"
SETS = {  # name: (config overrides, layouts, starts)
    "office": (["scene=office"], [2000, 2001], 9),
    "building": (["scene=building"], [2000, 2001, 2002, 2003, 2004], 4),
}
POLICIES = ("learned", "em", "nearest", "random")


def dump(out: Path, actor: str = ACTOR, test_dir: str = TEST_DIR) -> None:
    """Every policy's per-episode mean reward, read from the caches (playing is refused)."""
    from explore_rl.config import load_config
    from explore_rl.trainer import evaluate

    def refuse(task: object) -> None:
        raise RuntimeError("an episode is not in the cache: this script only reads")

    evaluate._play_task = refuse
    values = {}
    for name, (overrides, layouts, starts) in SETS.items():
        cache = Path(test_dir) / name / "episodes.jsonl"
        config = load_config([*overrides, "slam=model", "graph.features=extended"])
        results = evaluate.run_protocol(config, evaluate.episode_specs(layouts, starts), POLICIES, 10,
                                        actor_path=Path(actor), cache=cache)
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


def compare(path_a: Path, path_b: Path) -> None:
    """gap_closed of A minus B, paired by episode (the baselines' episodes are the same)."""
    from explore_rl.trainer.evaluate import gap_closed, paired_bootstrap

    a_sets, b_sets = json.loads(path_a.read_text()), json.loads(path_b.read_text())
    for name, columns in a_sets.items():
        for policy in ("em", "nearest", "random"):  # the same episodes, so the same baselines
            if not np.allclose(columns[policy], b_sets[name][policy]):
                raise SystemExit(f"{name}: {policy} differs between the two files: not the same episodes")
        values = {policy: np.array(column) for policy, column in columns.items()}
        values["other"] = np.array(b_sets[name]["learned"])

        def difference(v: dict) -> float:
            means = {k: float(np.mean(c)) for k, c in v.items()}
            return gap_closed(means) - gap_closed({**means, "learned": means["other"]})

        low, high = paired_bootstrap(values, difference)
        print(f"{name}: {len(values['learned'])} episodes, gap_closed difference {difference(values):+.3f} "
              f"[{low:+.3f}, {high:+.3f}] (paired, expanded percentile interval)")


if __name__ == "__main__":
    command, paths = sys.argv[1], sys.argv[2:]
    if command == "dump":
        dump(Path(paths[0]), *paths[1:])
    else:
        {"intervals": intervals, "compare": compare}[command](*map(Path, paths))
