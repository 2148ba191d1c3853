"""The revisit prior's strength, calibrated on training-distribution states (plan.md).

``policy.revisit_bias=b`` adds ``b`` per keyframe a frontier's path revisits to the actor's logits before
the greedy choice. On a DAgger dataset (EM's reward of every frontier), over the grid ``0, step, ..., top``:
the greedy choice's mean revisits, path length, any-revisit share and agreement with EM's best frontier
(``revisit_probe.py``'s figures). The calibrated ``b`` is the smallest on the grid at which the choice
revisits on average at least as many keyframes as EM's best; none if no value on the grid does.

    python benchmarks/results/revisit_bias/calibrate.py [--dataset /work/runs/data_scratch] \
        [--actor policies/buildings_sparse_em_choice/actor.pt] [--step 0.05] [--top 5]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from explore_rl.models.actor_file import read_actor_file
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.trainer.dataset import DecisionDataset

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "selection_v6"))
from common import add_bias_grid, bias_grid  # noqa: E402  (the grid of prior strengths)
from revisit_probe import figures, scored_decisions  # noqa: E402  (the probe's figures, with the bias)

DATASET = "/work/runs/data_scratch"
ACTOR = "policies/buildings_sparse_em_choice/actor.pt"


def calibrate(scored, grid: np.ndarray) -> tuple[float | None, list[dict]]:
    """The smallest bias of ``grid`` whose greedy choice revisits at least as much as EM's best, and every
    grid value's figures."""
    rows = [{"revisit_bias": round(float(bias), 6)} | figures(scored, float(bias)) for bias in grid]
    enough = [row["revisit_bias"] for row in rows if row["policy_revisits"] >= row["em_revisits"]]
    return (enough[0] if enough else None), rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DATASET, help="a DecisionDataset folder (EM's rewards of every frontier)")
    parser.add_argument("--actor", default=ACTOR, help="actor file or training checkpoint (graph.features=extended)")
    add_bias_grid(parser, step=0.05, top=5.0)
    args = parser.parse_args(argv)
    grid = bias_grid(parser, args)
    try:  # every input checked before the actor runs
        dataset = DecisionDataset(args.dataset)
        read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(str(error))
    bias, rows = calibrate(scored_decisions(args.actor, dataset), grid)
    for row in rows:
        print(json.dumps(row))
    print(json.dumps({"revisit_bias": bias, "actor": args.actor, "dataset": args.dataset,
                      "at_bias": next((row for row in rows if row["revisit_bias"] == bias), None),
                      "alone": rows[0]}))


if __name__ == "__main__":
    main()
