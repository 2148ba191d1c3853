"""Decisions per second of the TorchRL environment with EM's fast and reference backends,
and where a step's time goes.

Office, ``slam=model``, one process, the same seed, starts and random valid actions
(``torch.manual_seed``) for every run, so both EM backends score the same states:

* the env with random valid actions (the figure training sees early on), one env with
  ``planning.em.backend=fast`` (the default) and one with ``reference`` (an iSAM2 copy
  per loop candidate, one marginal query per pose) stepped in lockstep with the same
  actions (a shared machine's load falls on both alike): decisions/s of each and their ratio
  (``speedup``; ``speedup_bound_em_free``: the ratio if the fast EM parts cost nothing,
  i.e. what the drive and observe steps leave), the fraction of decisions where EM chose the same frontier
  (``same_em_choice``), the largest gap between their Algorithm 1 rewards, and per
  decision the time in observe (escape, frontiers, Dijkstra), context (action set, pose
  marginals, virtual map: what the graph features and EM share), graph (graph +
  padding), reward (EM on every frontier node) and drive (path with SLAM);
* the env following EM's choice (``("expert", "em_action")``) and the plain runner with ``policy=em``
  (the baseline): both make the same decisions, so the difference is the environment's
  own overhead (fast backend).

``--profile`` instead runs cProfile over the random-action episodes (at least
``PROFILE_DECISIONS`` decisions) with each backend: the share of each part and the top
functions inside context, reward and drive, written to ``benchmarks/results/profile_env_<backend>.txt``.

``--set KEY=VALUE ...``: config overrides of every env (e.g. ``slam=model_45deg``).

    python benchmarks/bench_env.py [--quick | --smoke] [--profile] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import io
import pstats
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.envs import make_env  # noqa: E402
from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION  # noqa: E402
from explore_rl.planning.em import EMPlanner  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402

STAGES = ("observe", "context", "graph", "reward", "drive")
BACKENDS = ("fast", "reference")
PROFILE_DECISIONS = 40
TOP_FUNCTIONS = 15
RESULTS = Path(__file__).resolve().parent / "results"


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short episodes, under a few minutes")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds, for the test suite: checks that it runs; figures are meaningless")
    parser.add_argument("--profile", action="store_true",
                        help="cProfile each backend over >= 40 random-action decisions (logs in benchmarks/results/)")
    parser.add_argument("--backend", choices=BACKENDS, action="append",
                        help="--profile only these backends (repeatable; default both)")
    parser.add_argument("--tag", default="", help="--profile: suffix of the log names (e.g. _before)")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="config overrides of every env and run (e.g. slam=model_45deg)")
    return parser.parse_args()


def with_backend(config, backend: str):
    """``config`` with ``planning.em.backend=backend`` (code from before the knob existed
    is the reference: ``--profile --backend reference`` also profiles an older checkout)."""
    if not hasattr(config.planning.em, "backend") and backend == "reference":
        return config
    em = dataclasses.replace(config.planning.em, backend=backend)
    return dataclasses.replace(config, planning=dataclasses.replace(config.planning, em=em))


def run_env(config, episodes: int, max_decisions: int, follow_em: bool, min_decisions: int = 0) -> dict:
    """Episodes of one env with random valid actions (or EM's): :func:`run_lockstep` of one."""
    return run_lockstep({"env": config}, episodes, max_decisions, follow_em, min_decisions)["env"]


def run_lockstep(configs: dict, episodes: int, max_decisions: int, follow_em: bool = False,
                 min_decisions: int = 0) -> dict[str, dict]:
    """Envs of ``configs`` stepped in lockstep on the same episodes: each decision, one
    random valid action (the first env's mask; the states are the same) goes to every env,
    one after the other, so a shared machine's changing load falls on all of them alike.
    Per env: figures per decision and each decision's EM choice and Algorithm 1 rewards.
    Runs at least ``episodes`` episodes and more until ``min_decisions`` decisions."""
    make_env(next(iter(configs.values()))).reset()  # warm-up (first-call costs of the process), not timed
    envs = {name: make_env(config) for name, config in configs.items()}
    torch.manual_seed(0)
    wall = dict.fromkeys(envs, 0.0)
    em_actions = {name: [] for name in envs}
    rewards = {name: [] for name in envs}
    decisions, episode, diverged = 0, 0, 0
    tds = {}
    while episode < episodes or decisions < min_decisions:
        for name, env in envs.items():
            start = time.perf_counter()
            tds[name] = env.reset()
            wall[name] += time.perf_counter() - start
        episode += 1
        for _ in range(max_decisions):
            first = next(iter(envs))
            action = None if follow_em else envs[first].rand_action(tds[first].clone())["action"]
            for name, env in envs.items():
                td = tds[name]
                em_actions[name].append(int(td[EM_ACTION]))
                rewards[name].append(td[ACTION_REWARDS].numpy().copy())
                td = td.set("action", td[EM_ACTION] if follow_em else action.clone())
                start = time.perf_counter()
                tds[name] = env.step(td)["next"]
                wall[name] += time.perf_counter() - start
            decisions += 1
            done = [bool(td["done"].item()) for td in tds.values()]
            diverged += len(set(done)) > 1
            if done[0]:
                break
    return {name: env_figures(env, tds[name], decisions, episode, wall[name], em_actions[name], rewards[name],
                              diverged) for name, env in envs.items()}


def env_figures(env, td, decisions: int, episodes: int, wall: float, em_actions: list, rewards: list,
                diverged: int) -> dict:
    """Figures of one env's run (per decision: the env's stage timers)."""
    timings = env.timings_ms()
    per_decision = {f"ms_{stage}": round(timings.get(stage, 0.0) / max(decisions, 1), 1) for stage in STAGES}
    step_ms = 1e3 * wall / max(decisions, 1)
    return {"decisions": decisions, "episodes": episodes, "wall_s": round(wall, 1),
            "decisions_per_s": round(decisions / wall, 3), "ms_per_decision": round(step_ms, 1),
            **per_decision, "graph_fraction": round(per_decision["ms_graph"] / step_ms, 4),
            "max_nodes_seen": env.max_nodes_seen, "failures": dict(env.failures),
            "explored": round(float(td["explored"]), 4), "travel_m": round(float(td["travel"]), 1),
            "done_diverged": diverged, "em_actions": em_actions, "rewards": rewards}


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


def agreement(fast: dict, reference: dict) -> dict:
    """Same EM choice and reward gap over the decisions both runs scored."""
    count = min(len(fast["em_actions"]), len(reference["em_actions"]))
    same = [a == b for a, b in zip(fast["em_actions"][:count], reference["em_actions"][:count])]
    gaps = [float(np.abs(a - b).max()) for a, b in zip(fast["rewards"][:count], reference["rewards"][:count])]
    return {"compared_decisions": count, "same_em_choice": round(float(np.mean(same)), 4) if same else None,
            "max_reward_gap": round(max(gaps), 4) if gaps else None}


def summary(run: dict) -> dict:
    return {k: v for k, v in run.items() if k not in ("em_actions", "rewards")}


def speedup_bound_em_free(fast: dict, reference: dict) -> float:
    """The ``speedup`` if the fast backend's EM parts (context and reward) cost nothing: the
    reference step over what is left of the fast one (observe, graph, drive) -- how far the
    EM side alone can take the ratio."""
    rest = fast["ms_per_decision"] - fast["ms_context"] - fast["ms_reward"]
    return round(reference["ms_per_decision"] / max(rest, 1e-9), 3)


def benchmark(args: argparse.Namespace) -> None:
    episodes, max_decisions = (1, 2) if args.smoke else (1, 12) if args.quick else (3, 300)
    config = load_config(["scene=office", "slam=model", "seed=0", "explore.progress_bar=false",
                          f"explore.max_decisions={max_decisions}", *args.set])
    runs = run_lockstep({backend: with_backend(config, backend) for backend in BACKENDS}, episodes, max_decisions)
    fast, reference = runs["fast"], runs["reference"]
    env_em = run_env(config, 1, max_decisions, follow_em=True)
    runner_em = run_runner_em(config, max_decisions)
    for name, r in (("env fast", fast), ("env reference", reference), ("env em", env_em), ("runner em", runner_em)):
        print(f"{name:14s} {r['decisions']:4d} decisions {r['wall_s']:7.1f} s  {r['decisions_per_s']:.3f}/s")
    for name, r in (("fast", fast), ("reference", reference)):
        print(f"per decision ({name}):", {k: v for k, v in r.items() if k.startswith("ms_")})
    same = agreement(fast, reference)
    print("agreement:", same)
    emit({"benchmark": "env", "quick": args.quick, "smoke": args.smoke, "overrides": args.set, "machine": machine(),
          "decisions_per_s": fast["decisions_per_s"],
          "decisions_per_s_reference": reference["decisions_per_s"],
          "speedup": round(fast["decisions_per_s"] / reference["decisions_per_s"], 3),
          **same,
          "reward_ms": fast["ms_reward"], "reward_ms_reference": reference["ms_reward"],
          "reward_speedup": round(reference["ms_reward"] / max(fast["ms_reward"], 1e-9), 2),
          "speedup_bound_em_free": speedup_bound_em_free(fast, reference),
          **{k: fast[k] for k in ("ms_observe", "ms_context", "ms_graph", "ms_reward", "ms_drive",
                                  "graph_fraction", "max_nodes_seen")},
          **{f"{k}_reference": reference[k] for k in ("ms_observe", "ms_context", "ms_graph", "ms_reward",
                                                      "ms_drive")},
          "decisions_per_s_env_em": env_em["decisions_per_s"],
          "decisions_per_s_runner_em": runner_em["decisions_per_s"],
          "env_em_over_runner_em": round(env_em["decisions_per_s"] / runner_em["decisions_per_s"], 3),
          "same_decisions": env_em["decisions"] == runner_em["decisions"]
          and env_em["travel_m"] == runner_em["travel_m"],
          "env_fast": summary(fast), "env_reference": summary(reference), "env_em": summary(env_em),
          "runner_em": runner_em})


# ---------------------------------------------------------------------- profile


class PartProfiler:
    """cProfile switched on only inside ``EMPlanner.decision_context`` (context),
    ``EMPlanner.evaluate`` (reward) or ``Explorer.act`` (drive): the functions each part
    spends its time in. A part called inside another (``evaluate`` building its own
    context) counts to the outer one: one profiler runs at a time."""

    def __init__(self) -> None:
        self.profiles = {part: cProfile.Profile() for part in ("context", "reward", "drive")}
        self._originals = {}
        self._active = False

    def __enter__(self) -> PartProfiler:
        for part, owner, name in (("context", EMPlanner, "decision_context"), ("reward", EMPlanner, "evaluate"),
                                  ("drive", Explorer, "act")):
            original = getattr(owner, name)
            self._originals[(owner, name)] = original
            setattr(owner, name, self._wrap(self.profiles[part], original))
        return self

    def __exit__(self, *exc) -> None:
        for (owner, name), original in self._originals.items():
            setattr(owner, name, original)

    def _wrap(self, profile: cProfile.Profile, method):
        def wrapped(*args, **kwargs):
            if self._active:  # inside another part: its profiler is running
                return method(*args, **kwargs)
            self._active = True
            profile.enable()
            try:
                return method(*args, **kwargs)
            finally:
                profile.disable()
                self._active = False
        return wrapped

    def top(self, part: str) -> str:
        out = io.StringIO()
        pstats.Stats(self.profiles[part], stream=out).sort_stats("tottime").print_stats(TOP_FUNCTIONS)
        return out.getvalue()


def profile(args: argparse.Namespace) -> None:
    """Shares of each part and the top functions inside context, reward and drive, per backend."""
    minimum = 2 if args.smoke else PROFILE_DECISIONS
    config = load_config(["scene=office", "slam=model", "seed=0", "explore.progress_bar=false",
                          "explore.max_decisions=300", *args.set])
    result = {"benchmark": "env_profile", "smoke": args.smoke, "overrides": args.set, "machine": machine()}
    for backend in args.backend or BACKENDS:
        with PartProfiler() as profiler:
            run = run_env(with_backend(config, backend), 1, 2 if args.smoke else 300, follow_em=False,
                          min_decisions=minimum)
        step = run["ms_per_decision"]
        shares = {stage: round(run[f"ms_{stage}"] / step, 3) for stage in STAGES}
        text = [f"bench_env --profile, planning.em.backend={backend}: {run['decisions']} decisions in "
                f"{run['episodes']} episodes, {run['decisions_per_s']} decisions/s, {step} ms per decision, "
                f"load {machine()['load_average_1min']}",
                "share of a step: " + ", ".join(f"{k} {100 * v:.1f} % ({run[f'ms_{k}']} ms)" for k, v in shares.items()),
                "", "=== inside context (EMPlanner.decision_context), by own time ===", profiler.top("context"),
                "=== inside reward (EMPlanner.evaluate), by own time ===", profiler.top("reward"),
                "=== inside drive (Explorer.act), by own time ===", profiler.top("drive")]
        if not args.smoke:
            RESULTS.mkdir(exist_ok=True)
            (RESULTS / f"profile_env_{backend}{args.tag}.txt").write_text("\n".join(text))
        print("\n".join(text[:2]))
        result[backend] = {"decisions": run["decisions"], "decisions_per_s": run["decisions_per_s"],
                           "ms_per_decision": step, "shares": shares,
                           **{f"ms_{k}": run[f"ms_{k}"] for k in STAGES}}
    emit(result)


def main() -> None:
    args = parse_args()
    if args.profile:
        profile(args)
    else:
        benchmark(args)


if __name__ == "__main__":
    main()
