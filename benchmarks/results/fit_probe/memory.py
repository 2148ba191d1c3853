"""The offline trainer's memory over steps (session 45): resident set size every ``--every`` offline steps of
``em_choice`` distillation on a ``loops`` dataset, from scratch. Before the g-U-Net's COO product
(explore_rl/models/graph_unet.py: sparse_product) it grew ~1 MB a step (torch 2.13's CSR @ CSR leaked); now it
stays flat. One JSON line per measurement; the last line is the summary (``mb_per_100_steps`` after the first
measurement). Linux (/proc/self/statm).

    python benchmarks/results/fit_probe/memory.py [--dataset /work/runs/data_scratch_loops] [--steps 600] [--every 100]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
import torch

from explore_rl.config import load_config
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DecisionDataset
from explore_rl.trainer.offline import offline_config, train_offline

DATASET = "/work/runs/data_scratch_loops"


def resident_mb() -> float:
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DATASET, help="a graph.features=loops DecisionDataset")
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--every", type=int, default=100)
    args = parser.parse_args(argv)
    if args.steps < 1 or not 1 <= args.every <= args.steps:
        parser.error(f"--steps {args.steps} --every {args.every}: give 1 <= every <= steps")
    try:
        dataset = DecisionDataset(args.dataset)
    except ValueError as error:
        sys.exit(f"--dataset {error}")
    torch.manual_seed(0)
    config = offline_config(load_config(["scene=building", "slam=model", "graph.features=loops",
                                         "algo.distill_target=em_choice"]))
    learner = Learner(config)
    done, sizes = 0, []
    while done < args.steps:
        chunk = min(args.every, args.steps - done)
        train_offline(config, dataset, chunk, learner=learner)
        done += chunk
        sizes.append(resident_mb())
        print(json.dumps({"steps": done, "resident_mb": round(sizes[-1], 1)}), flush=True)
    growth = (sizes[-1] - sizes[0]) / max(done - args.every, 1) * 100
    print(json.dumps({"steps": done, "first_mb": round(sizes[0], 1), "last_mb": round(sizes[-1], 1),
                      "mb_per_100_steps": round(float(growth), 2), "torch": torch.__version__,
                      "numpy": np.__version__}))


if __name__ == "__main__":
    main()
