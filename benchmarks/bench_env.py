"""Decisions per second of the TorchRL environment, and where a step's time goes.

Office, ``slam=model``, one process. Three runs on the same seed and start:

* the env with random valid actions (the figure training sees early on): decisions/s
  and per decision the time in observe (escape, frontiers, Dijkstra), context (action
  set, pose marginals, virtual map: what the graph features and EM share), graph
  (graph + padding), reward (EM on every frontier node) and drive (path with SLAM);
* the env following EM's choice (``em_action``) and
* the plain runner with ``policy=em`` (the baseline): both make the same decisions, so
  the difference is the environment's own overhead.

    python benchmarks/bench_env.py [--quick | --smoke]
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.envs import make_env  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402

STAGES = ("observe", "context", "graph", "reward", "drive")


def run_env(config, episodes: int, max_decisions: int, follow_em: bool) -> dict:
    """Episodes of the env with random valid actions (or EM's); figures per decision."""
    env = make_env(config)
    decisions, start = 0, time.perf_counter()
    for _ in range(episodes):
        td = env.reset()
        for _ in range(max_decisions):
            td = td.set("action", td["em_action"]) if follow_em else env.rand_action(td)
            td = env.step(td)["next"]
            decisions += 1
            if td["done"].item():
                break
    wall = time.perf_counter() - start
    timings = env.timings_ms()
    per_decision = {f"ms_{stage}": round(timings.get(stage, 0.0) / max(decisions, 1), 1) for stage in STAGES}
    step_ms = 1e3 * wall / max(decisions, 1)
    return {"decisions": decisions, "wall_s": round(wall, 1),
            "decisions_per_s": round(decisions / wall, 3), "ms_per_decision": round(step_ms, 1),
            **per_decision, "graph_fraction": round(per_decision["ms_graph"] / step_ms, 4),
            "max_nodes_seen": env.max_nodes_seen, "failures": dict(env.failures),
            "explored": round(float(td["explored"]), 4), "travel_m": round(float(td["travel"]), 1)}


def run_runner_em(config, max_decisions: int) -> dict:
    """The runner with EM on the env's first episode (same seed and start)."""
    env = make_env(config)  # only to reproduce the env's episode seed and start
    env.reset()
    episode = env.explorer.config
    runner_config = dataclasses.replace(episode, policy=dataclasses.replace(episode.policy, name="em"),
                                        explore=dataclasses.replace(episode.explore, max_decisions=max_decisions))
    start = time.perf_counter()  # set-up included, as the env's reset is
    explorer = Explorer(runner_config)
    result = explorer.run()
    wall = time.perf_counter() - start
    return {"decisions": len(result.records), "wall_s": round(wall, 1),
            "decisions_per_s": round(len(result.records) / wall, 3),
            "explored": round(result.records[-1].explored, 4), "travel_m": round(explorer.robot.travelled, 1)}


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    episodes, max_decisions = (1, 2) if args.smoke else (1, 12) if args.quick else (3, 300)
    config = load_config(["scene=office", "slam=model", "seed=0", "explore.progress_bar=false",
                          f"explore.max_decisions={max_decisions}"])
    random = run_env(config, episodes, max_decisions, follow_em=False)
    env_em = run_env(config, 1, max_decisions, follow_em=True)
    runner_em = run_runner_em(config, max_decisions)
    for name, r in (("env random", random), ("env em", env_em), ("runner em", runner_em)):
        print(f"{name:11s} {r['decisions']:4d} decisions {r['wall_s']:7.1f} s  {r['decisions_per_s']:.3f}/s")
    print("per decision (env random):", {k: v for k, v in random.items() if k.startswith("ms_")})
    emit({"benchmark": "env", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "decisions_per_s": random["decisions_per_s"],
          **{k: random[k] for k in ("ms_observe", "ms_context", "ms_graph", "ms_reward", "ms_drive",
                                    "graph_fraction", "max_nodes_seen")},
          "decisions_per_s_env_em": env_em["decisions_per_s"],
          "decisions_per_s_runner_em": runner_em["decisions_per_s"],
          "env_em_over_runner_em": round(env_em["decisions_per_s"] / runner_em["decisions_per_s"], 3),
          "same_decisions": env_em["decisions"] == runner_em["decisions"]
          and env_em["travel_m"] == runner_em["travel_m"],
          "env_random": random, "env_em": env_em, "runner_em": runner_em})


if __name__ == "__main__":
    main()
