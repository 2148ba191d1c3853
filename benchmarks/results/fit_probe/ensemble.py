"""Offline probe of an ensemble (session 45, fit_probe/plan.md addendum): do actors trained on the same decisions
decide better together (their log-probabilities over the frontiers averaged) than alone?

Every actor file must read the dataset's node features and should have been trained on the training split only
(``layout % 4 != 3``, as ``loop_feature/probe.py``); the figures are on the probe split (held out). Per member
and for the ensemble: offline gap closed (pooled, bootstrap interval over layouts) and agreement with EM's best;
then the ensemble's paired difference to the best member. One JSON line per row; the last line is the summary.

    python benchmarks/results/fit_probe/ensemble.py ACTOR.pt ACTOR.pt ... [--dataset /work/runs/data_scratch_loops]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import load_actor
from explore_rl.models.checkpoint import CheckpointError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "stakes_distill"))
from probe import bootstrap, clusters, dataset_columns, figures, gap_closed, scores_of, split  # noqa: E402

DATASET = "/work/runs/data_scratch_loops"


def log_probabilities(actor, batch) -> torch.Tensor:
    """``(B, N)`` the actor's log-probability of every frontier row (-inf elsewhere)."""
    logits = actor(batch["x"], batch["adj"], batch["node_mask"]).masked_fill(~batch["action_mask"], -torch.inf)
    return torch.log_softmax(logits, dim=-1)


def ensemble_logits(actors: list):
    """``logits_of(batch)`` of the ensemble: the members' log-probabilities averaged."""
    return lambda batch: torch.stack([log_probabilities(actor, batch) for actor in actors]).mean(0)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("actors", nargs="+", help="actor files (two or more), all reading the same features")
    parser.add_argument("--dataset", default=DATASET, help="a DecisionDataset holding the actors' node features")
    args = parser.parse_args(argv)
    if len(args.actors) < 2:
        parser.error(f"actors: give two or more, got {len(args.actors)}")
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    try:
        loaded = [load_actor(path) for path in args.actors]
    except (ValueError, CheckpointError, FileNotFoundError) as error:
        sys.exit(f"actors: {error}")
    feature_sets = {actor_file.feature_set for _, actor_file in loaded}
    if len(feature_sets) != 1:
        sys.exit(f"actors: they read different node features ({', '.join(sorted(feature_sets))}); give one set")
    names = list(feature_names(feature_sets.pop()))
    dataset, columns = dataset_columns(args.dataset, names)
    _, probe_index = split(dataset)
    if len(probe_index) == 0:
        sys.exit(f"--dataset {args.dataset}: has no probe layouts (layout % 4 == 3)")
    groups = clusters(dataset.rows()["layout"].numpy()[probe_index.numpy()])
    actors = [actor for actor, _ in loaded]
    members = []
    for path, actor in zip(args.actors, actors):
        scores = scores_of(lambda batch, a=actor: log_probabilities(a, batch), dataset, probe_index, columns, names)
        members.append({"actor": path, "scores": scores, "held_out": figures(scores, groups)})
        print(json.dumps({"actor": path, "held_out": members[-1]["held_out"]}), flush=True)
    scores = scores_of(ensemble_logits(actors), dataset, probe_index, columns, names)
    ensemble = figures(scores, groups)
    print(json.dumps({"actor": "ensemble", "held_out": ensemble}), flush=True)
    best = max(members, key=lambda member: member["held_out"]["gap_closed"])
    difference = lambda rows: gap_closed(scores, rows) - gap_closed(best["scores"], rows)  # noqa: E731
    summary = {"members": len(actors), "probe_decisions": len(probe_index), "probe_layouts": len(groups),
               "ensemble": ensemble, "best_member": best["actor"], "best_member_held_out": best["held_out"],
               "ensemble_minus_best": {"gap_closed": round(difference(np.concatenate(groups)), 4),
                                       "gap_closed_ci": bootstrap(difference, groups)}}
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
