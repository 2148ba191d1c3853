"""Offline probe of the ``loop_length`` node feature (plan.md, step 1): does it carry what EM's choice depends on?

On a ``graph.features=loops`` dataset (``DecisionDataset`` derived from an extended one by
``derive_loops_dataset``), split by layout as sessions 42-43 (``layout % 4 == 3`` is the probe split, never
trained on), two pairs of actors trained on the same minibatches (``em_choice`` distillation, not A2C):

* ``--arm scratch``: from scratch, ``extended`` against ``loops``, one pair per ``--seeds`` entry;
* ``--arm widened``: from an actor file (``--actor``), as it is (``extended``) against the same actor widened
  to ``loops`` with a zero weight on the new column (so it starts as the actor).

``--feature-sets loops`` trains one of the two only (then no pair difference); ``--dropout`` and ``--hidden``
change the scratch arm's network (session 45's fit probe, benchmarks/results/fit_probe/plan.md). The scratch arm of
``--feature-sets extended`` alone also reads an extended dataset (session 59's width probe).

Per actor, every ``--every`` steps: the offline gap closed (EM reward of the greedy pick above the frontiers'
mean, over EM's best above it, pooled) and the agreement with EM's best, held out (the probe split) and in
sample (a fixed draw of ``--in-sample`` training decisions); at the end, the pair's held-out difference with a
bootstrap interval over layouts. One JSON line per row; the last line is the summary.

    python benchmarks/results/loop_feature/probe.py --arm scratch [--dataset /work/runs/data_scratch_loops] \
        [--seeds 0 1] [--steps 3000] [--every 1000] [--lr 1e-3] [--out DIR] \
        [--feature-sets extended loops] [--dropout 0.5] [--hidden 128]
    python benchmarks/results/loop_feature/probe.py --arm widened [--actor FILE] [--steps 2000] [--lr 3e-4]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import torch

from explore_rl.config import load_config
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import read_actor_file
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DecisionDataset
from explore_rl.trainer.offline import offline_config, save_offline_actor, train_offline

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "stakes_distill"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "selection_v6"))
from probe import (  # noqa: E402
    add_training_arguments,
    bootstrap,
    check_training_arguments,
    clusters,
    figures,
    gap_closed,
    per_decision,
    split,
)
from revisit_probe import greedy_learner  # noqa: E402

DATASET = "/work/runs/data_scratch_loops"
ACTOR = "policies/buildings_sparse_em_choice/actor.pt"
FEATURE_SETS = ("extended", "loops")


def scratch_learner(feature_set: str, model, lr: float) -> Learner:
    """A new learner of ``em_choice`` reading ``feature_set``, with the network ``model``."""
    config = load_config(["scene=building", "slam=model", f"graph.features={feature_set}",
                          "algo.distill_target=em_choice", f"algo.lr={lr}"])
    return Learner(dataclasses.replace(offline_config(config), model=model))


def scratch_model(model, dropout: float | None, hidden: int | None):
    """``model`` with the given dropout and width (None: as it is)."""
    changes = {key: value for key, value in (("dropout", dropout), ("hidden", hidden)) if value is not None}
    return dataclasses.replace(model, **changes)


def widened_learner(actor: str, lr: float) -> Learner:
    """The ``extended`` actor file ``actor`` as a ``loops`` learner (``Learner.load_initial_actor``: every
    weight copied, the input layer's new column 0), so its logits equal the actor's until it trains."""
    wide = scratch_learner("loops", read_actor_file(actor).model, lr)
    wide.load_initial_actor(actor)
    wide.set_training(False)
    return wide


def in_sample_index(train_index: torch.Tensor, size: int, seed: int = 0) -> torch.Tensor:
    """A fixed draw of ``size`` training decisions (the in-sample figures)."""
    generator = torch.Generator().manual_seed(seed)
    return train_index[torch.randperm(len(train_index), generator=generator)[:size]]


def train_and_measure(name: str, learner: Learner, dataset: DecisionDataset, index: dict, groups: dict,
                      steps: int, every: int, seed: int) -> dict:
    """``steps`` offline steps of ``learner`` on the training split (minibatches from ``seed``), measured at the
    start and every ``every`` steps; returns the last held-out per-decision scores and figures."""
    columns = dataset.columns_for(feature_names(learner.config.graph.features))
    torch.manual_seed(seed)
    done, scores = 0, None
    while True:
        scores = {part: per_decision(learner, dataset, index[part], columns) for part in ("held_out", "in_sample")}
        row = {part: figures(scores[part], groups[part]) for part in scores}
        print(json.dumps({"actor": name, "steps": done, **row}), flush=True)
        if done >= steps:
            return {"scores": scores["held_out"], "figures": row}
        chunk = min(every, steps - done)
        train_offline(learner.config, dataset, chunk, index=index["train"], learner=learner)
        done += chunk


def pair_difference(first: dict, second: dict, groups: list[np.ndarray]) -> dict:
    """Held-out gap closed of ``second`` minus ``first`` on the same decisions, bootstrap over layouts."""
    difference = lambda rows: gap_closed(second, rows) - gap_closed(first, rows)  # noqa: E731
    return {"gap_closed": round(difference(np.concatenate(groups)), 4), "gap_closed_ci": bootstrap(difference, groups)}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arm", choices=("scratch", "widened"), required=True)
    parser.add_argument("--dataset", default=DATASET, help="a graph.features=loops DecisionDataset")
    parser.add_argument("--actor", default=ACTOR, help="the extended actor file: the network (scratch) or the start")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="training seeds (one pair each)")
    add_training_arguments(parser, steps=3000, every=1000, lr=1e-3)
    parser.add_argument("--in-sample", type=int, default=2400, help="training decisions measured in sample (>= 1)")
    parser.add_argument("--out", default="/work/runs/loop_feature", help="folder of the final actor files")
    parser.add_argument("--feature-sets", nargs="+", choices=FEATURE_SETS, default=list(FEATURE_SETS),
                        help="which of the pair to train (both: their held-out difference too)")
    parser.add_argument("--dropout", type=float, default=None, help="scratch arm: the network's dropout (default: --actor's)")
    parser.add_argument("--hidden", type=int, default=None, help="scratch arm: g-U-Net features (default: --actor's)")
    args = parser.parse_args(argv)
    check_training_arguments(parser, args)
    if args.in_sample < 1:
        parser.error(f"--in-sample {args.in_sample}: give at least 1")
    if args.arm == "widened" and (args.dropout is not None or args.hidden is not None):
        parser.error("--dropout/--hidden change the scratch arm's network; the widened arm keeps --actor's")
    if args.dropout is not None and not 0.0 <= args.dropout < 1.0:
        parser.error(f"--dropout {args.dropout}: give a value in [0, 1)")
    if args.hidden is not None and args.hidden < 1:
        parser.error(f"--hidden {args.hidden}: give at least 1")
    try:
        actor_file = read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(f"--actor {error}")
    if actor_file.feature_set != "extended":
        parser.error(f"--actor {args.actor}: reads graph.features={actor_file.feature_set}, give an extended one")
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    try:
        dataset = DecisionDataset(args.dataset)
        for feature_set in args.feature_sets if args.arm == "scratch" else FEATURE_SETS:  # the columns it reads
            dataset.columns_for(feature_names(feature_set))
    except ValueError as error:
        sys.exit(f"--dataset {error}")
    train_index, probe_index = split(dataset)
    if len(train_index) == 0 or len(probe_index) == 0:
        sys.exit(f"--dataset {args.dataset}: needs layouts on both sides of the split (layout % 4 == 3 or not)")
    layouts = dataset.rows()["layout"].numpy()
    index = {"train": train_index, "held_out": probe_index, "in_sample": in_sample_index(train_index, args.in_sample)}
    groups = {part: clusters(layouts[index[part].numpy()]) for part in ("held_out", "in_sample")}
    summary = {"arm": args.arm, "train_decisions": len(train_index), "probe_decisions": len(probe_index),
               "probe_layouts": len(groups["held_out"]), "steps": args.steps, "lr": args.lr, "pairs": []}
    model = scratch_model(read_actor_file(args.actor).model, args.dropout, args.hidden)
    summary["model"] = dataclasses.asdict(model)
    for seed in args.seeds if args.arm == "scratch" else [0]:
        final = {}
        for feature_set in args.feature_sets:
            if args.arm == "scratch":
                learner = scratch_learner(feature_set, model, args.lr)
            else:
                learner = (greedy_learner(args.actor, "algo.distill_target=em_choice", f"algo.lr={args.lr}")
                           if feature_set == "extended" else widened_learner(args.actor, args.lr))
            name = f"{args.arm}_{feature_set}_seed{seed}"
            final[feature_set] = train_and_measure(name, learner, dataset, index, groups, args.steps, args.every, seed)
            path = save_offline_actor(learner, Path(args.out) / f"{name}.pt",
                                      {"dataset": args.dataset, "steps": args.steps, "arm": args.arm})
            final[feature_set]["figures"]["actor"] = str(path)
        pair = {"seed": seed, **{key: final[key]["figures"] for key in args.feature_sets}}
        if len(final) == len(FEATURE_SETS):
            pair["loops_minus_extended"] = pair_difference(final["extended"]["scores"], final["loops"]["scores"],
                                                           groups["held_out"])
        print(json.dumps(pair), flush=True)
        summary["pairs"].append(pair)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
