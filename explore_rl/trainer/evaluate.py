"""Does the policy learn? Greedy evaluation episodes scored by the Algorithm 1 reward.

Each policy runs the same episodes: one per start of the scene (the office's 9), each
with an evaluation seed that training never uses, at most ``max_decisions`` decisions.
Every decision is scored by the env's Algorithm 1 reward (EM's evaluation of every
frontier node at that state) and compared with EM's own choice there. EM's reward is the
best possible at every state (0 when the nearest frontier is best, else 1), nearest
frontier's is <= 0; a policy that learned something lies in between.

Policies: ``learned`` (the actor of a checkpoint, greedy: the most probable frontier),
``nearest``, ``em`` and ``random`` (a uniformly random frontier node, seeded).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch
from tensordict import TensorDictBase

from explore_rl.config import Config
from explore_rl.envs.factory import make_env
from explore_rl.models.actor_file import load_actor

EVAL_SEED = 1_000_003  # episode seeds derive from it; training seeds derive from config.seed

Chooser = Callable[[TensorDictBase], int]


@dataclass
class EvalEpisode:
    policy: str
    start: int
    decisions: int
    mean_reward: float
    em_agreement: float
    explored: float
    travel: float
    map_error: float


def greedy_actor(config: Config, checkpoint_path: Path) -> Chooser:
    """The checkpoint's actor (training checkpoint or actor file) choosing its most probable
    frontier: the highest logit among the ``action_mask`` rows."""
    actor, _ = load_actor(checkpoint_path, expected_model=config.model)

    def choose(td: TensorDictBase) -> int:
        with torch.no_grad():
            logits = actor(td["x"], td["adj"], td["node_mask"])
        return int(logits.masked_fill(~td["action_mask"], -torch.inf).argmax())

    return choose


def baseline(name: str, seed: int = 0) -> Chooser:
    """nearest, em or random (seeded) as a chooser of encoded rows."""
    if name == "nearest":
        return lambda td: int(td["nearest_action"])
    if name == "em":
        return lambda td: int(td["em_action"])
    if name == "random":
        rng = np.random.default_rng(seed)
        return lambda td: int(rng.choice(np.flatnonzero(td["action_mask"].numpy())))
    raise ValueError(f"unknown policy {name!r}: choose learned, nearest, em or random")


def run_episode(config: Config, start: int, choose: Chooser, policy: str, max_decisions: int) -> EvalEpisode:
    """One evaluation episode from ``start`` (its seed depends on the start only)."""
    episode_config = dataclasses.replace(
        config, env=dataclasses.replace(config.env, starts="default"),
        scene=dataclasses.replace(config.scene, start_index=start))
    env = make_env(episode_config)
    env.set_seed(EVAL_SEED + start)
    td = env.reset()
    rewards, agree, labelled = [], 0, 0
    for _ in range(max_decisions):
        action = choose(td)
        if td["em_action"] >= 0:
            labelled += 1
            agree += action == int(td["em_action"])
        out = env.step(td.set("action", torch.tensor(action)))["next"]
        rewards.append(float(out["reward"]))
        td = out
        if bool(out["done"]):
            break
    return EvalEpisode(policy=policy, start=start, decisions=len(rewards), mean_reward=float(np.mean(rewards)),
                       em_agreement=agree / labelled if labelled else float("nan"),
                       explored=float(td["explored"]), travel=float(td["travel"]), map_error=float(td["map_error"]))


def evaluate(config: Config, policy: str, choose: Chooser, starts: list[int], max_decisions: int) -> list[EvalEpisode]:
    return [run_episode(config, start, choose, policy, max_decisions) for start in starts]


def summarize(episodes: list[EvalEpisode]) -> dict:
    """Means over episodes (each episode weighs the same)."""
    return {
        "episodes": len(episodes),
        "mean_reward": float(np.mean([e.mean_reward for e in episodes])),
        "std_reward": float(np.std([e.mean_reward for e in episodes])),
        "em_agreement": float(np.nanmean([e.em_agreement for e in episodes])),
        "decisions": int(sum(e.decisions for e in episodes)),
    }


def learning_target(nearest: float, em: float) -> float:
    """Issue 13's bar: nearest's reward plus half of the gap to EM's."""
    return nearest + 0.5 * (em - nearest)
