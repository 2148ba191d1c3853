"""Which decision-time prior moves the shipped actor's choices towards EM's in the opening phase?

Offline, on EM-scored decisions collected with the actor in the loop (benchmarks/collect_decisions.py,
``--features loops``, training buildings): for each per-frontier column ``f`` of the stored set and
each bias ``b`` of a grid, the actor's greedy choice after adding ``b * f`` to its logits, scored by

* ``agree``: the fraction of decisions where it is EM's choice;
* ``gap``: the offline gap closed, mean over decisions of (r[choice] - mean r) / (max r - mean r),
  ``r`` EM's per-frontier reward (Algorithm 1) over the valid frontiers (decisions with max r = mean r skipped).

Layouts are split in two by parity: ``b`` is chosen on the even layouts (highest ``gap``), reported on
the odd ones, so the screen does not pick on the decisions it reports. Descriptive: it proposes a prior
for whole explorations, it selects nothing (plan.md).

    python benchmarks/results/opening_prior/probe.py DATASET [--biases -1 -0.5 ... ] [--first-decisions 6]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT))

PRIOR_COLUMNS = ("path_length", "frontier_size", "unknown_nearby", "revisits", "revisit_uncertainty",
                 "landmark_uncertainty", "loop_length")
BIASES = (-2.0, -1.0, -0.5, -0.2, -0.1, -0.05, -0.02, 0.0, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)


def decision_index(layout: np.ndarray, episode: np.ndarray) -> np.ndarray:
    """Each row's decision number within its episode (rows are stored episode by episode, in order)."""
    index = np.zeros(len(layout), dtype=int)
    for row in range(1, len(layout)):
        same = layout[row] == layout[row - 1] and episode[row] == episode[row - 1]
        index[row] = index[row - 1] + 1 if same else 0
    return index


def scores(logits: torch.Tensor, rewards: torch.Tensor, mask: torch.Tensor, em: torch.Tensor) -> tuple[float, float]:
    """``agree`` and ``gap`` of the greedy choice of ``logits`` over the decisions given."""
    choice = logits.masked_fill(~mask, -torch.inf).argmax(-1)
    agree = float((choice == em).float().mean())
    valid_rewards = rewards.masked_fill(~mask, 0.0)
    mean = valid_rewards.sum(-1) / mask.sum(-1)
    best = rewards.masked_fill(~mask, -torch.inf).max(-1).values
    spread = best - mean
    keep = spread > 1e-9
    chosen = rewards.gather(-1, choice.unsqueeze(-1)).squeeze(-1)
    gap = float(((chosen - mean)[keep] / spread[keep]).mean())
    return agree, gap


def probe(path: str, biases: tuple[float, ...], first_decisions: int) -> dict:
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset, padded_batch

    dataset = DecisionDataset(path)
    rows = dataset.rows()
    batch = padded_batch(rows)
    actor, actor_file = load_actor(ROOT / "policies/buildings_sparse_em_choice/actor.pt")
    reads = dataset.columns_for(actor_file.features)
    with torch.no_grad():
        logits = torch.cat([actor(batch["x"][s:s + 256][..., reads], batch["adj"][s:s + 256],
                                  batch["node_mask"][s:s + 256]) for s in range(0, len(batch), 256)])
    mask, em = batch["action_mask"], batch["expert", "em_action"]
    rewards = batch["expert", "action_rewards"]
    layout = rows["layout"].numpy()
    step = decision_index(layout, rows["episode"].numpy())
    ok = (em >= 0) & (mask.sum(-1) >= 2)
    halves = {"select": torch.from_numpy(layout % 2 == 0) & ok, "report": torch.from_numpy(layout % 2 == 1) & ok}
    phases = {"opening": torch.from_numpy(step < first_decisions), "later": torch.from_numpy(step >= first_decisions)}
    out = {"decisions": int(ok.sum()), "layouts": int(len(np.unique(layout))), "columns": {}}
    for name in PRIOR_COLUMNS:
        column = batch["x"][..., dataset.columns_for([name])[0]]
        per_bias = {}
        for b in biases:
            biased = logits + b * column
            per_bias[b] = {half: scores(biased[sel], rewards[sel], mask[sel], em[sel]) for half, sel in halves.items()}
        best = max(biases, key=lambda b: per_bias[b]["select"][1])
        report = halves["report"]
        out["columns"][name] = {
            "best_bias_on_select": best,
            "report_gap_at_best": per_bias[best]["report"][1], "report_agree_at_best": per_bias[best]["report"][0],
            "report_by_phase_at_best": {p: scores((logits + best * column)[report & s], rewards[report & s],
                                                  mask[report & s], em[report & s]) for p, s in phases.items()},
            "select_curve_gap": {str(b): round(per_bias[b]["select"][1], 4) for b in biases}}
    report = halves["report"]
    out["actor_alone_report"] = {"agree": scores(logits[report], rewards[report], mask[report], em[report])[0],
                                 "gap": scores(logits[report], rewards[report], mask[report], em[report])[1],
                                 "by_phase": {p: scores(logits[report & s], rewards[report & s], mask[report & s],
                                                        em[report & s]) for p, s in phases.items()}}
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset")
    parser.add_argument("--biases", type=float, nargs="+", default=list(BIASES))
    parser.add_argument("--first-decisions", type=int, default=6, help="decisions counted as the opening phase")
    args = parser.parse_args(argv)
    if not (Path(args.dataset) / "dataset.json").is_file():
        parser.error(f"{args.dataset}: no dataset.json (collect with benchmarks/collect_decisions.py --features loops)")
    if args.first_decisions < 1:
        parser.error(f"--first-decisions must be >= 1, got {args.first_decisions}")
    print(json.dumps(probe(args.dataset, tuple(args.biases), args.first_decisions), indent=1))


if __name__ == "__main__":
    main()
