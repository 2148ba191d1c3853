"""The loop prior's strength, calibrated on training-distribution states (plan.md).

``policy.loop_bias=b`` adds ``b`` per metre of a frontier's ``loop_length`` to the actor's logits before the
greedy choice. On a DAgger dataset holding the ``loop_length`` column (EM's reward of every frontier), over the
grid ``0, step, ..., top``: the biased greedy choice's pooled offline gap closed (its EM reward above the
frontiers' mean, over EM's best above it), agreement with EM's best, and the mean ``loop_length`` and
``revisits`` of the choice and of EM's best. The calibrated ``b`` is the grid value with the largest gap
closed (ties to the smallest); its gain over ``b = 0`` gets a bootstrap interval over layouts (paired).
One JSON line per grid value, the summary last.

    python benchmarks/results/loop_bias/calibrate.py [--dataset /work/runs/data_scratch_loops] \
        [--actor policies/buildings_sparse_em_choice/actor.pt] [--step 0.01] [--top 0.3]
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from explore_rl.envs.keys import ACTION_REWARDS
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_file import read_actor_file
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.trainer.a2c import decision_stakes
from explore_rl.trainer.dataset import DecisionDataset, padded_batch

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "selection_v6"))
from common import add_bias_grid, bias_grid, cluster_bootstrap, layout_clusters  # noqa: E402
from revisit_probe import greedy_learner  # noqa: E402  (an actor file's learner, with its model and features)

DATASET = "/work/runs/data_scratch_loops"
ACTOR = "policies/buildings_sparse_em_choice/actor.pt"
LOOP = "loop_length"
CHUNK = 128


@dataclass
class Decisions:
    """Per chunk of padded decisions: the actor's logits (-inf off the frontier rows), EM's rewards (0 off
    them), the rows' ``loop_length`` and ``revisits``, and each decision's layout."""

    logits: list[torch.Tensor] = field(default_factory=list)
    rewards: list[torch.Tensor] = field(default_factory=list)
    loops: list[torch.Tensor] = field(default_factory=list)
    revisits: list[torch.Tensor] = field(default_factory=list)
    layouts: np.ndarray | None = None


def scored(actor: str, dataset: DecisionDataset, prior: str = LOOP) -> Decisions:
    """The actor of ``actor`` (its own model and node features) on every decision of ``dataset``; the prior's
    column (``loops``) is ``prior``, ``loop_length`` unless another per-frontier column is probed."""
    learner = greedy_learner(actor)
    names = list(feature_names(learner.config.graph.features))
    columns = dataset.columns_for(names + [prior]) if prior not in names else dataset.columns_for(names)
    out = Decisions(layouts=dataset.rows()["layout"].numpy())
    with torch.no_grad():
        for chunk in torch.arange(len(dataset)).split(CHUNK):
            batch = padded_batch(dataset.rows(chunk), columns)
            x, mask = batch["x"], batch["action_mask"]
            own = batch.clone(False)
            own["x"] = x[..., :len(names)]
            out.logits.append(learner.actor.get_dist(own).logits.masked_fill(~mask, -torch.inf))
            out.rewards.append(batch[ACTION_REWARDS].masked_fill(~mask, 0.0))
            out.loops.append(x[..., names.index(prior) if prior in names else len(names)])
            out.revisits.append(x[..., names.index("revisits")])
    return out


def per_decision(decisions: Decisions, bias: float) -> dict[str, np.ndarray]:
    """Per decision, with ``bias`` per metre of ``loop_length``: the pick's EM reward above the frontiers'
    mean (``gain``), EM's best above it (``stakes``), whether they agree, and both picks' loop and revisits."""
    out = {key: [] for key in ("gain", "stakes", "same", "loop", "em_loop", "revisits", "em_revisits")}
    for logits, rewards, loops, revisits in zip(decisions.logits, decisions.rewards, decisions.loops,
                                                decisions.revisits):
        mask = torch.isfinite(logits)
        pick = (logits + bias * loops).argmax(-1)
        best = rewards.masked_fill(~mask, -torch.inf).argmax(-1)
        rows = torch.arange(len(pick))
        stakes = decision_stakes(rewards, mask)
        out["gain"].append(rewards[rows, pick] - (rewards[rows, best] - stakes))
        out["stakes"].append(stakes)
        out["same"].append((pick == best).float())
        for name, values in (("loop", loops), ("revisits", revisits)):
            out[name].append(values[rows, pick])
            out[f"em_{name}"].append(values[rows, best])
    return {key: torch.cat(value).numpy() for key, value in out.items()}


def gap_closed(scores: dict[str, np.ndarray], rows: np.ndarray) -> float:
    return float(scores["gain"][rows].sum() / max(scores["stakes"][rows].sum(), 1e-12))


def grid_row(scores: dict[str, np.ndarray], bias: float) -> dict:
    return {"loop_bias": round(bias, 6), "gap_closed": round(gap_closed(scores, np.arange(len(scores["gain"]))), 4),
            "same_choice": round(float(scores["same"].mean()), 4),
            **{f"{name}_m" if "loop" in name else name: round(float(scores[name].mean()), 3)
               for name in ("loop", "em_loop", "revisits", "em_revisits")}}


def calibrate(decisions: Decisions, grid: np.ndarray) -> tuple[list[dict], dict]:
    """Every grid value's figures, and the summary: the calibrated bias and its paired gain over 0."""
    scores = [per_decision(decisions, float(bias)) for bias in grid]
    rows = [grid_row(value, float(bias)) for bias, value in zip(grid, scores)]
    pick = max(range(len(rows)), key=lambda i: (rows[i]["gap_closed"], -rows[i]["loop_bias"]))
    best, chosen, alone = rows[pick], scores[pick], scores[0]
    groups = layout_clusters(decisions.layouts)
    difference = cluster_bootstrap(lambda r: gap_closed(chosen, r) - gap_closed(alone, r), groups)
    return rows, {"loop_bias": best["loop_bias"], "at_bias": best, "alone": rows[0],
                  "gain_over_alone": round(best["gap_closed"] - rows[0]["gap_closed"], 4),
                  "gain_ci": difference, "decisions": len(alone["gain"]), "layouts": len(groups)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DATASET, help="a DecisionDataset folder with the loop_length column")
    parser.add_argument("--actor", default=ACTOR, help="actor file or training checkpoint (reads revisits)")
    add_bias_grid(parser, step=0.01, top=0.3)
    args = parser.parse_args(argv)
    grid = bias_grid(parser, args)
    try:  # every input checked before the actor runs
        dataset = DecisionDataset(args.dataset)
        dataset.columns_for([LOOP, "revisits"])
        read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(f"--dataset/--actor: {error}")
    rows, summary = calibrate(scored(args.actor, dataset), grid)
    for row in rows:
        print(json.dumps(row))
    print(json.dumps(summary | {"actor": args.actor, "dataset": args.dataset}))


if __name__ == "__main__":
    main()
