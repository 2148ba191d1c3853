"""The radix-pass stable sorts against numpy's own, on the keys of real decisions.

A nearest-frontier exploration of a generated building (``slam=model``, 600 m: the decision
sizes of issue 24's explorations) is driven, and on every few decisions' states the action
set and the shipped learned policy's choice are computed once with every key that
:func:`explore_rl.sorting.stable_argsort` and :func:`~explore_rl.sorting.unique_first_inverse`
receive recorded (revisit pairs, segment lengths, landmark observations). Each recorded
key array is then sorted by both the radix passes and numpy's stable sort (``np.argsort(...,
kind="stable")``, ``np.unique(..., return_index=True, return_inverse=True)``: the baseline,
in the same run); the permutations must be equal (``same_order``). Reported: the summed ms
per decision of each, their ratio (``speedup``) and the keys' sizes.

    python benchmarks/bench_sorting.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args, time_call  # noqa: E402

import explore_rl.mapping.visibility as visibility  # noqa: E402
import explore_rl.planning.em_fast as em_fast  # noqa: E402
import explore_rl.planning.revisits as revisits  # noqa: E402
import explore_rl.planning.virtual_map as virtual_map  # noqa: E402
from explore_rl import sorting  # noqa: E402
from explore_rl.config import load_config  # noqa: E402
from explore_rl.planning.actions import select_actions  # noqa: E402
from explore_rl.planning.learned import LearnedPolicy  # noqa: E402
from explore_rl.planning.policies import NearestFrontier  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402
from explore_rl.state import ExplorationState  # noqa: E402

USERS = (visibility, em_fast, revisits, virtual_map)  # the modules that sort with explore_rl.sorting


def record_keys(build) -> list[tuple[str, np.ndarray]]:
    """Run ``build()`` with every key array the sorting helpers receive recorded (kind, keys)."""
    recorded: list[tuple[str, np.ndarray]] = []

    def recording(kind: str, helper):
        def call(keys):
            recorded.append((kind, np.array(keys)))
            return helper(keys)
        return call

    saved = {module: dict(vars(module)) for module in USERS}
    try:
        for module in USERS:
            for name, kind in (("stable_argsort", "argsort"), ("unique_first_inverse", "unique")):
                if name in vars(module):
                    setattr(module, name, recording(kind, getattr(sorting, name)))
        build()
    finally:
        for module, names in saved.items():
            for name in ("stable_argsort", "unique_first_inverse"):
                if name in names:
                    setattr(module, name, names[name])
    return recorded


def numpy_sort(kind: str, keys: np.ndarray):
    """The baseline: numpy's stable sort, or ``np.unique`` with first indices and inverse."""
    if kind == "argsort":
        return np.argsort(keys, kind="stable")
    return np.unique(keys, return_index=True, return_inverse=True)


def radix_sort(kind: str, keys: np.ndarray):
    return sorting.stable_argsort(keys) if kind == "argsort" else sorting.unique_first_inverse(keys)


def same(kind: str, mine, numpys) -> bool:
    if kind == "argsort":
        return bool(np.array_equal(mine, numpys))
    return all(np.array_equal(a, np.asarray(b).reshape(-1)) for a, b in zip(mine, numpys))


def decision_keys(state: ExplorationState, learned: LearnedPolicy) -> list[tuple[str, np.ndarray]]:
    """The keys of one decision's action set and the learned policy's choice (its landmark fusion)."""
    planning = learned.planning

    def build():
        select_actions(state, planning.actions, planning.revisits)
        learned.choose(state)
    return record_keys(build)


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    decisions, every, repeats = (4, 2, 1) if args.smoke else (24, 6, 3) if args.quick else (60, 6, 5)
    extra = ["scene=office"] if args.smoke else ["scene=building", "scene.seed=1011", "explore.travel_budget=600"]
    config = load_config([*extra, "slam=model", "policy=learned", "seed=0", "explore.progress_bar=false",
                          "graph.max_nodes=4096"])
    learned = LearnedPolicy(config.policy, config.planning, graph=config.graph, robot=config.robot)
    explorer = Explorer(config, policy=NearestFrontier())
    rows = []
    for decision in range(decisions):
        state = explorer.next_state()
        if state is None:
            break
        if decision % every == every - 1:
            keys = decision_keys(state, learned)
            ms_radix = sum(1e3 * time_call(lambda k=k, a=a: radix_sort(k, a), repeats) for k, a in keys)
            ms_numpy = sum(1e3 * time_call(lambda k=k, a=a: numpy_sort(k, a), repeats) for k, a in keys)
            rows.append({"decision": decision, "poses": int(explorer.session.graph.num_poses), "sorts": len(keys),
                         "largest": max((len(a) for _, a in keys), default=0), "ms_radix": round(ms_radix, 3),
                         "ms_numpy": round(ms_numpy, 3),
                         "same_order": all(same(k, radix_sort(k, a), numpy_sort(k, a)) for k, a in keys)})
            print(rows[-1], flush=True)
        explorer.act(state, explorer.policy.choose(state))
    ms_radix = float(np.mean([r["ms_radix"] for r in rows]))
    ms_numpy = float(np.mean([r["ms_numpy"] for r in rows]))
    emit({"benchmark": "sorting", "quick": args.quick, "smoke": args.smoke, "states": len(rows),
          "ms_radix_per_decision": round(ms_radix, 3), "ms_numpy_per_decision": round(ms_numpy, 3),
          "speedup": round(ms_numpy / max(ms_radix, 1e-9), 2), "same_order": all(r["same_order"] for r in rows),
          "largest_keys": max(r["largest"] for r in rows), "rows": rows, "machine": machine()})


if __name__ == "__main__":
    main()
