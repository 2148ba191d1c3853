"""Offline probe of two distillation targets on training-distribution states (plan.md, step 1).

From one actor, ``--steps`` Adam steps of each target (``em_choice``, ``em_choice_stakes``) on a DAgger dataset's
training split; every ``--every`` steps, on the probe split (layouts with ``layout % 4 == 3``, never trained on):
the offline gap closed (EM reward of the greedy pick above the frontiers' mean, over EM's best above it, pooled),
agreement with EM's best, and the pick's mean revisits; intervals by a bootstrap over layouts, the targets'
difference paired. Writes each target's final actor file to ``--out``. One JSON line per row; the last line
is the summary.

    python benchmarks/results/stakes_distill/probe.py [--dataset /work/runs/data_scratch] \
        [--actor policies/buildings_sparse_em_choice/actor.pt] [--steps 2000] [--every 500] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

from explore_rl.envs.keys import ACTION_REWARDS
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import read_actor_file
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.trainer.a2c import Learner, decision_stakes
from explore_rl.trainer.dataset import DecisionDataset, padded_batch
from explore_rl.trainer.offline import save_offline_actor, train_offline

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "selection_v6"))
from common import cluster_bootstrap as bootstrap  # noqa: E402  (a bootstrap over layouts)
from common import layout_clusters as clusters  # noqa: E402
from revisit_probe import greedy_learner  # noqa: E402  (an actor file's learner, with its model and features)

DATASET = "/work/runs/data_scratch"
ACTOR = "policies/buildings_sparse_em_choice/actor.pt"
TARGETS = ("em_choice", "em_choice_stakes")
PROBE_EVERY = 4  # layouts with layout % 4 == 3 are the probe split
CHUNK = 128


def learner_for(actor: str, target: str, lr: float) -> Learner:
    """A learner of ``target`` starting from the actor file ``actor`` (its model and node features)."""
    return greedy_learner(actor, f"algo.distill_target={target}", f"algo.lr={lr}")


def dataset_columns(path: str, names: list[str]) -> tuple[DecisionDataset, list[int]]:
    """The dataset at ``path`` and the columns of the node features ``names``; exits in one line naming
    ``--dataset`` if it is not there or lacks them."""
    try:
        dataset = DecisionDataset(path)
        return dataset, dataset.columns_for(names)
    except ValueError as error:
        sys.exit(f"--dataset {error}")


def split(dataset: DecisionDataset) -> tuple[torch.Tensor, torch.Tensor]:
    """Training and probe decisions, by layout (the probe split's layouts are never trained on)."""
    layouts = dataset.rows()["layout"]
    probe = layouts % PROBE_EVERY == PROBE_EVERY - 1
    return torch.nonzero(~probe).flatten(), torch.nonzero(probe).flatten()


def per_decision(learner: Learner, dataset: DecisionDataset, index: torch.Tensor, columns: list[int]) -> dict:
    """Per decision of ``index`` (dropout off): the greedy pick's EM reward above the frontiers' mean, EM's
    best above it, whether the pick is EM's best, and the pick's revisits."""
    learner.set_training(False)
    names = list(feature_names(learner.config.graph.features))
    return scores_of(lambda batch: learner.actor.get_dist(batch).logits, dataset, index, columns, names)


def scores_of(logits_of, dataset: DecisionDataset, index: torch.Tensor, columns: list[int], names: list[str]) -> dict:
    """:func:`per_decision` for any ``logits_of(batch) -> (B, N)`` (an actor, or several averaged)."""
    out = {"gain": [], "stakes": [], "same": [], "revisits": []}
    with torch.no_grad():
        for chunk in index.split(CHUNK):
            batch = padded_batch(dataset.rows(chunk), columns)
            mask, rewards = batch["action_mask"], batch[ACTION_REWARDS]
            pick = logits_of(batch).masked_fill(~mask, -torch.inf).argmax(-1)
            best = rewards.masked_fill(~mask, -torch.inf).argmax(-1)
            rows = torch.arange(len(chunk))
            stakes = decision_stakes(rewards, mask)  # EM's best above the frontiers' mean
            out["gain"].append(rewards[rows, pick] - (rewards[rows, best] - stakes))
            out["stakes"].append(stakes)
            out["same"].append((pick == best).float())
            out["revisits"].append(batch["x"][..., names.index("revisits")][rows, pick])
    return {key: torch.cat(value).numpy() for key, value in out.items()}


def gap_closed(scores: dict, rows: np.ndarray) -> float:
    """Pooled offline gap closed of the decisions ``rows``."""
    return float(scores["gain"][rows].sum() / max(scores["stakes"][rows].sum(), 1e-12))


def figures(scores: dict, groups: list[np.ndarray]) -> dict:
    rows = np.concatenate(groups)
    return {"gap_closed": round(gap_closed(scores, rows), 4),
            "gap_closed_ci": bootstrap(lambda r: gap_closed(scores, r), groups),
            "same_choice": round(float(scores["same"].mean()), 4),
            "revisits": round(float(scores["revisits"].mean()), 4)}


def add_training_arguments(parser: argparse.ArgumentParser, steps: int, every: int, lr: float) -> None:
    """``--steps``, ``--every`` and ``--lr`` of an offline probe (shared by the probes of later sessions)."""
    parser.add_argument("--steps", type=int, default=steps, help="Adam steps per actor (>= 1)")
    parser.add_argument("--every", type=int, default=every, help="steps between probe measurements (>= 1)")
    parser.add_argument("--lr", type=float, default=lr, help="Adam step size (> 0)")


def check_training_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """One line naming the values if a step count is below 1 or the step size not positive."""
    if args.steps < 1 or args.every < 1 or not args.lr > 0:
        parser.error(f"--steps {args.steps} --every {args.every} --lr {args.lr}: give steps, every >= 1, lr > 0")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DATASET, help="a DecisionDataset folder (EM's rewards of every frontier)")
    parser.add_argument("--actor", default=ACTOR, help="the actor file both targets start from")
    add_training_arguments(parser, steps=2000, every=500, lr=3e-4)
    parser.add_argument("--seed", type=int, default=0, help="minibatch order")
    parser.add_argument("--out", default="runs/stakes_distill", help="folder of the final actor files")
    args = parser.parse_args(argv)
    check_training_arguments(parser, args)
    try:  # every input checked before anything trains
        dataset = DecisionDataset(args.dataset)
    except ValueError as error:
        parser.error(f"--dataset {error}")
    try:
        read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(f"--actor {error}")
    train_index, probe_index = split(dataset)
    if len(train_index) == 0 or len(probe_index) == 0:
        parser.error(f"--dataset {args.dataset}: needs layouts on both sides of the split (layout % 4 == 3 or not)")
    groups = clusters(dataset.rows(probe_index)["layout"].numpy())
    summary, finals = {"train_decisions": len(train_index), "probe_decisions": len(probe_index),
                       "probe_layouts": len(groups), "steps": args.steps, "lr": args.lr}, {}
    for target in TARGETS:
        torch.manual_seed(args.seed)
        learner = learner_for(args.actor, target, args.lr)
        columns = dataset.columns_for(feature_names(learner.config.graph.features))
        scores = per_decision(learner, dataset, probe_index, columns)
        summary.setdefault("start", figures(scores, groups))
        print(json.dumps({"target": target, "steps": 0, **summary["start"]}), flush=True)
        done = 0
        while done < args.steps:
            chunk = min(args.every, args.steps - done)
            train_offline(learner.config, dataset, chunk, index=train_index, learner=learner)
            done += chunk
            scores = per_decision(learner, dataset, probe_index, columns)
            print(json.dumps({"target": target, "steps": done, **figures(scores, groups)}), flush=True)
        finals[target] = scores
        summary[target] = figures(scores, groups)
        path = save_offline_actor(learner, Path(args.out) / f"{target}.pt",
                                  {"dataset": args.dataset, "from": args.actor, "steps": args.steps})
        summary[target]["actor"] = str(path)
    first, second = (finals[target] for target in TARGETS)
    difference = lambda rows: gap_closed(second, rows) - gap_closed(first, rows)  # noqa: E731
    summary["difference"] = {"gap_closed": round(difference(np.concatenate(groups)), 4),
                             "gap_closed_ci": bootstrap(difference, groups)}
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
