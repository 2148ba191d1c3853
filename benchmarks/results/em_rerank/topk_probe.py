"""Offline probe of the learned-then-EM decision (``policy.em_top_k``): how often EM's pick is among the actor's
``k`` most probable frontiers, and the offline gap closed when EM picks among those ``k`` (plan.md, step 1).

On the probe split of a DAgger dataset (layouts with ``layout % 4 == 3``; training-distribution states, EM's
Algorithm 1 reward of every frontier recorded): per ``k``, the pooled offline gap closed (EM reward of the pick
above the frontiers' mean, over EM's best above it), how often the pick is EM's best, and the share of the action
set EM evaluates (``min(k, |A|) / |A|``); intervals by a bootstrap over layouts. One JSON line per ``k``, the last
line the summary.

    python benchmarks/results/em_rerank/topk_probe.py [--dataset /work/runs/data_scratch] \
        [--actor policies/buildings_sparse_em_choice/actor.pt] [--k 1 2 3 4]
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
from explore_rl.trainer.a2c import decision_stakes
from explore_rl.trainer.dataset import DecisionDataset, padded_batch

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "stakes_distill"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "selection_v6"))
from probe import CHUNK, DATASET, bootstrap, clusters, gap_closed, split  # noqa: E402
from revisit_probe import greedy_learner  # noqa: E402

ACTOR = "policies/buildings_sparse_em_choice/actor.pt"


def top_k_pick(logits: torch.Tensor, rewards: torch.Tensor, mask: torch.Tensor, k: int) -> torch.Tensor:
    """Per row, the frontier of highest EM reward among the ``k`` of highest logit (valid rows only)."""
    order = logits.masked_fill(~mask, -torch.inf).argsort(-1, descending=True)
    shortlisted = torch.zeros_like(mask)
    shortlisted.scatter_(-1, order[:, :k], True)
    return rewards.masked_fill(~(shortlisted & mask), -torch.inf).argmax(-1)


def scores_for(logits: torch.Tensor, rewards: torch.Tensor, mask: torch.Tensor, k: int) -> dict:
    """The offline figures' per-decision terms of the top-``k`` pick."""
    pick = top_k_pick(logits, rewards, mask, k)
    best = rewards.masked_fill(~mask, -torch.inf).argmax(-1)
    rows = torch.arange(len(pick))
    stakes = decision_stakes(rewards, mask)
    actions = mask.sum(-1).float()
    return {"gain": rewards[rows, pick] - (rewards[rows, best] - stakes), "stakes": stakes,
            "same": (pick == best).float(), "evaluated": torch.clamp(actions, max=k) / actions}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DATASET, help="a DecisionDataset folder (EM's rewards of every frontier)")
    parser.add_argument("--actor", default=ACTOR, help="the actor file that shortlists")
    parser.add_argument("--k", type=int, nargs="+", default=[1, 2, 3, 4], help="shortlist sizes (>= 1)")
    args = parser.parse_args(argv)
    if min(args.k) < 1:
        parser.error(f"--k {args.k}: every k must be >= 1")
    try:  # every input checked before anything runs
        read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(f"--actor {error}")
    try:
        dataset = DecisionDataset(args.dataset)
    except ValueError as error:
        parser.error(f"--dataset {error}")
    _, probe_index = split(dataset)
    if len(probe_index) == 0:
        parser.error(f"--dataset {args.dataset}: no decisions of the probe layouts (layout % 4 == 3)")
    groups = clusters(dataset.rows(probe_index)["layout"].numpy())
    learner = greedy_learner(args.actor)
    learner.set_training(False)
    columns = dataset.columns_for(feature_names(learner.config.graph.features))
    parts = {k: [] for k in args.k}
    with torch.no_grad():
        for chunk in probe_index.split(CHUNK):
            batch = padded_batch(dataset.rows(chunk), columns)
            logits = learner.actor.get_dist(batch).logits
            for k in args.k:
                parts[k].append(scores_for(logits, batch[ACTION_REWARDS], batch["action_mask"], k))
    summary = {"probe_decisions": len(probe_index), "probe_layouts": len(groups), "actor": args.actor}
    for k in args.k:
        scores = {key: torch.cat([p[key] for p in parts[k]]).numpy() for key in parts[k][0]}
        row = {"k": k, "gap_closed": round(gap_closed(scores, np.concatenate(groups)), 4),
               "gap_closed_ci": bootstrap(lambda r: gap_closed(scores, r), groups),
               "same_choice": round(float(scores["same"].mean()), 4),
               "evaluated_share": round(float(scores["evaluated"].mean()), 4)}
        print(json.dumps(row), flush=True)
        summary[f"k{k}"] = row
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
