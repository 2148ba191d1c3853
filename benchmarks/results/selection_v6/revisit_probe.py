"""Do the learned policies pick frontiers whose paths revisit fewer keyframes than EM's best?
On a DAgger dataset (EM's Algorithm 1 reward of every frontier of each decision), per actor: the mean
``revisits`` (keyframes the path revisits: predicted loop closures) and ``path_length`` of its greedy
choice and of EM's best, and how often each picks a frontier with any revisit. No simulation. Each
actor is read with its own model and node features (from its file).

    # session 34's record: the default's dataset (19,260 decisions, in-sample for all three actors)
    python benchmarks/results/selection_v6/revisit_probe.py
    # another dataset and actors
    python benchmarks/results/selection_v6/revisit_probe.py --dataset DIR --actor NAME=PATH [--actor ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from dataclasses import dataclass, field

import torch

from explore_rl.config import load_config
from explore_rl.envs.keys import ACTION_REWARDS
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import read_actor_file
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DecisionDataset, padded_batch
from explore_rl.trainer.offline import offline_config

DATASET = "/work/runs/data_dagger_sparse"
ACTORS = {"default": "/work/main/policies/buildings_sparse_distill/actor.pt",
          "wide": "/work/main/benchmarks/results/selection_v5/candidate_wide_actor.pt",
          "dagger_wide": "/work/runs/dagger_wide/checkpoints/last.pt"}


def greedy_learner(path: str, *overrides: str) -> Learner:
    """A learner holding the actor of ``path`` (actor file or training checkpoint) with its own model and
    node features, in evaluation mode; ``overrides``: more config (e.g. the distillation target and step size
    of a learner that goes on training it)."""
    actor_file = read_actor_file(path)
    config = load_config(["scene=building", "slam=model", f"graph.features={actor_file.feature_set}", *overrides])
    learner = Learner(dataclasses.replace(offline_config(config), model=actor_file.model))
    learner.load_initial_actor(path)
    learner.set_training(False)
    return learner


@dataclass
class ScoredDecisions:
    """Per chunk of padded decisions: the actor's logits (-inf off the frontier rows), the rows'
    ``revisits`` and ``path_length``, and EM's best row (its largest reward)."""

    logits: list[torch.Tensor] = field(default_factory=list)
    revisits: list[torch.Tensor] = field(default_factory=list)
    path_m: list[torch.Tensor] = field(default_factory=list)
    best: list[torch.Tensor] = field(default_factory=list)


def scored_decisions(path: str, dataset: DecisionDataset) -> ScoredDecisions:
    """The actor of ``path`` (its own model and node features) on every decision of ``dataset``."""
    learner = greedy_learner(path)
    names = list(feature_names(learner.config.graph.features))
    if "revisits" not in names or "path_length" not in names:
        raise SystemExit(f"{path}: the actor reads graph.features={learner.config.graph.features}; the probe reads "
                         "the revisits and path_length its features hold: give an actor of graph.features=extended")
    columns = dataset.columns_for(names)
    scored = ScoredDecisions()
    with torch.no_grad():
        for chunk in torch.arange(len(dataset)).split(128):
            batch = padded_batch(dataset.rows(chunk), columns)
            mask, rewards = batch["action_mask"], batch[ACTION_REWARDS]
            scored.logits.append(learner.actor.get_dist(batch).logits.masked_fill(~mask, -torch.inf))
            scored.revisits.append(batch["x"][..., names.index("revisits")])
            scored.path_m.append(batch["x"][..., names.index("path_length")])
            scored.best.append(rewards.masked_fill(~mask, -torch.inf).argmax(-1))
    return scored


def figures(scored: ScoredDecisions, revisit_bias: float = 0.0) -> dict[str, float]:
    """Mean revisits, path length and any-revisit share of the greedy choice (the actor's logits plus
    ``revisit_bias`` per revisited keyframe, as ``policy.revisit_bias``) and of EM's best, and how often
    they are the same frontier."""
    sums = {"policy_revisits": 0.0, "em_revisits": 0.0, "policy_path_m": 0.0, "em_path_m": 0.0,
            "policy_any_revisit": 0.0, "em_any_revisit": 0.0, "same_choice": 0.0}
    count = 0
    for logits, revisits, path_m, best in zip(scored.logits, scored.revisits, scored.path_m, scored.best):
        mine = (logits + revisit_bias * revisits).argmax(-1)
        rows = torch.arange(len(best))
        for who, pick in (("policy", mine), ("em", best)):
            sums[f"{who}_revisits"] += float(revisits[rows, pick].sum())
            sums[f"{who}_path_m"] += float(path_m[rows, pick].sum())
            sums[f"{who}_any_revisit"] += float((revisits[rows, pick] > 0).sum())
        sums["same_choice"] += float((mine == best).sum())
        count += len(best)
    return {key: round(value / count, 3) for key, value in sums.items()} | {"decisions": count}


def choices(path: str, dataset: DecisionDataset) -> dict[str, float]:
    """:func:`figures` of the actor of ``path`` alone."""
    return figures(scored_decisions(path, dataset))


def parse_actor(text: str) -> tuple[str, str]:
    name, separator, path = text.partition("=")
    if not separator or not name or not path:
        raise argparse.ArgumentTypeError(f"--actor {text!r}: give NAME=PATH")
    return name, path


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DATASET, help="a DecisionDataset folder (EM's rewards of every frontier)")
    parser.add_argument("--actor", type=parse_actor, action="append", help="NAME=PATH (repeat; default: session 34's)")
    args = parser.parse_args(argv)
    actors = dict(args.actor or ACTORS.items())
    try:  # every input checked before the first actor runs
        dataset = DecisionDataset(args.dataset)
        for path in actors.values():
            read_actor_file(path)
    except (ValueError, CheckpointError) as error:
        parser.error(str(error))
    result = {name: choices(path, dataset) for name, path in actors.items()}
    for name, row in result.items():
        print(name, row)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
