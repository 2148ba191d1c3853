"""The strength of ``policy.closure_bias`` matched to a ``policy.loop_bias`` (plan.md, session 54).

Explores training buildings with the shipped actor alone (the run config of stop_coverage/run.sh: ``slam=icp``,
``graph.max_nodes=4096``), and at every decision with at least two frontiers records, per frontier of the action
set, its ``loop_length`` (the loop prior's column) and its closure gain (the closure prior's,
``explore_rl.planning.learned.closure_gains``). The matched bias gives the closure prior the same mean
within-decision spread (standard deviation over the action set) of added logit as ``--loop-bias`` gives the loop
prior: ``closure_bias = loop_bias * mean spread(loop_length) / mean spread(gain)``. Also reported: how often the two
columns' largest frontier is the same one, and their rank correlation within decisions. One JSON line per building,
the summary last.

    python benchmarks/results/closure_prior/calibrate.py [--seeds 0-5] [--decisions 20] [--loop-bias 0.06] [--smoke]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from common import emit, seed_list, spawned_results  # noqa: E402

RUN_CONFIG = ["scene=building", "policy=learned", "slam=icp", "graph.max_nodes=4096", "explore.progress_bar=false",
              "explore.travel_budget=600"]


def building_columns(task: tuple[int, int, list[str]]) -> dict:
    """Per decision of one building's exploration (the actor alone): each action's loop_length and closure gain."""
    import torch

    from explore_rl.config import load_config
    from explore_rl.graph.encode import loop_length_rows
    from explore_rl.planning.learned import closure_gain_rows
    from explore_rl.runner import Explorer

    torch.set_num_threads(1)
    seed, decisions, overrides = task
    config = load_config([*RUN_CONFIG, f"seed={seed}", *overrides])
    explorer = Explorer(config)
    policy, sigma = explorer.policy, config.planning.em.loop_sigma_translation
    rows = []
    for _ in range(decisions):
        state = explorer.next_state()
        if state is None:
            break
        chosen = policy.choose(state)
        graph, encoded = policy.last_graph, policy.last_encoded
        frontier = np.flatnonzero(encoded.action_mask)
        gains = closure_gain_rows(state, policy.last_actions, graph, encoded, sigma)[frontier]
        loops = loop_length_rows(graph, encoded)[frontier]
        if len(frontier) >= 2:
            rows.append({"loop_length": loops.tolist(), "gain": gains.tolist()})
        explorer.act(state, chosen)
    return {"seed": seed, "decisions": rows}


def summary(buildings: list[dict], loop_bias: float) -> dict:
    """The matched bias and how the two columns agree within decisions."""
    decisions = [d for b in buildings for d in b["decisions"]]
    loops = [np.asarray(d["loop_length"]) for d in decisions]
    gains = [np.asarray(d["gain"]) for d in decisions]
    spread_loop = float(np.mean([v.std() for v in loops]))
    spread_gain = float(np.mean([v.std() for v in gains]))
    informative = [(lo, g) for lo, g in zip(loops, gains) if np.ptp(lo) > 0 and np.ptp(g) > 0]
    same_top = float(np.mean([lo.argmax() == g.argmax() for lo, g in informative])) if informative else float("nan")
    ranks = [np.corrcoef(np.argsort(np.argsort(lo)), np.argsort(np.argsort(g)))[0, 1]
             for lo, g in informative if len(lo) > 2]
    return {"buildings": len(buildings), "decisions": len(decisions), "informative_decisions": len(informative),
            "mean_spread_loop_length_m": spread_loop, "mean_spread_gain_m": spread_gain, "loop_bias": loop_bias,
            "closure_bias": loop_bias * spread_loop / spread_gain if spread_gain > 0 else float("nan"),
            "same_largest_frontier": same_top, "rank_correlation": float(np.mean(ranks)) if ranks else float("nan")}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-5", help="training buildings (scene seeds), e.g. 0-5 or 0,3")
    parser.add_argument("--decisions", type=int, default=20, help="decisions per building")
    parser.add_argument("--loop-bias", type=float, default=0.06, help="the loop prior's strength to match")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--smoke", action="store_true", help="one building, 3 decisions, slam=model (seconds)")
    args = parser.parse_args(argv)
    try:
        seeds = seed_list(args.seeds)
    except ValueError:
        parser.error(f"--seeds {args.seeds!r}: give seeds as 0-5 or 0,3,5")
    if not seeds or args.decisions < 1 or args.workers < 1 or args.loop_bias <= 0:
        parser.error("--seeds must name a building, --decisions and --workers must be >= 1 and --loop-bias > 0")
    overrides = []
    if args.smoke:
        seeds, args.decisions, overrides = seeds[:1], 3, ["slam=model", "planning.actions.max_frontiers=4"]
    buildings = []
    for result in spawned_results(building_columns, [(s, args.decisions, overrides) for s in seeds], args.workers):
        emit({"seed": result["seed"], "decisions": len(result["decisions"])})
        buildings.append(result)
    emit(summary(buildings, args.loop_bias))


if __name__ == "__main__":
    main()
