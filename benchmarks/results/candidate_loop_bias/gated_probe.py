"""Offline: the loop prior scaled by the robot's own uncertainty, against the plain prior (plan.md, addendum).

``policy.loop_bias=b`` adds ``b`` per metre of a frontier's ``loop_length`` to the actor's logits. A loop closure
corrects more when the robot is more uncertain, so this probe scales the prior per decision by
``(u / u_ref) ** power``, ``u`` the current pose's ``uncertainty`` feature and ``u_ref`` its mean over the
dataset (``power`` 0 is the plain prior). For each power, over ``loop_bias/calibrate.py``'s grid: the greedy
choice's pooled offline gap closed against EM's reward of every frontier; the best ``b`` per power, and its gain
over the plain prior's best with a paired bootstrap interval over layouts. One JSON line per power, the
summary last. Offline, training-distribution states: it says whether the gate moves the one-step choice
towards EM's, not what it does to whole explorations.

    python benchmarks/results/candidate_loop_bias/gated_probe.py --dataset /work/runs/tmb_data_loops \
        [--actor policies/buildings_model_em_choice/actor.pt] [--powers 0 1 2]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

from explore_rl.graph.exploration_graph import CURRENT
from explore_rl.models.actor_file import read_actor_file
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.trainer.dataset import DecisionDataset

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
from common import add_bias_grid, bias_grid, cluster_bootstrap, layout_clusters, module_at  # noqa: E402


def load_calibration():
    """``loop_bias/calibrate.py`` (its actor scoring and per-decision figures), loaded by path."""
    return module_at(HERE.parent / "loop_bias" / "calibrate.py", "loop_bias_calibrate")


def current_uncertainty(dataset: DecisionDataset, chunk: int) -> torch.Tensor:
    """``(D,)``: each decision's ``uncertainty`` feature of the current pose node."""
    identity, uncertainty = dataset.columns_for(["identity", "uncertainty"])
    values = []
    for index in torch.arange(len(dataset)).split(chunk):
        x = dataset.rows(index)["x"]
        current = x[..., identity] == CURRENT
        values.append((x[..., uncertainty] * current).sum(-1))
    return torch.cat(values)


def gated(decisions, gate: torch.Tensor, chunk: int):
    """A copy of ``decisions`` whose ``loops`` rows are scaled by each decision's ``gate``."""
    scaled = type(decisions)(logits=decisions.logits, rewards=decisions.rewards, revisits=decisions.revisits,
                             layouts=decisions.layouts)
    scaled.loops = [loops * part.unsqueeze(-1) for loops, part in zip(decisions.loops, gate.split(chunk))]
    return scaled


def probe(calibration, decisions, uncertainty: torch.Tensor, powers: list[float], grid: np.ndarray,
          chunk: int) -> tuple[list[dict], dict]:
    """Per power: the best grid value and its gap closed; the summary: each power's paired gain over power 0."""
    reference = float(uncertainty.mean())
    rows, best_scores = [], {}
    for power in powers:
        gate = (uncertainty / reference) ** power
        scores = [calibration.per_decision(gated(decisions, gate, chunk), float(b)) for b in grid]
        figures = [calibration.gap_closed(s, np.arange(len(s["gain"]))) for s in scores]
        pick = int(np.argmax(figures))
        best_scores[power] = scores[pick]
        rows.append({"power": power, "loop_bias": round(float(grid[pick]), 6), "gap_closed": round(figures[pick], 4),
                     "same_choice": round(float(scores[pick]["same"].mean()), 4),
                     "actor_alone": round(figures[0], 4)})
    groups = layout_clusters(decisions.layouts)
    plain = best_scores[powers[0]]
    gains = {str(p): cluster_bootstrap(lambda r, s=best_scores[p]: calibration.gap_closed(s, r)
                                       - calibration.gap_closed(plain, r), groups) for p in powers[1:]}
    return rows, {"u_ref": reference, "gain_over_power_0": gains, "decisions": len(plain["gain"]),
                  "layouts": len(groups)}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, help="a DecisionDataset folder with the loop_length column")
    parser.add_argument("--actor", default="policies/buildings_model_em_choice/actor.pt")
    parser.add_argument("--powers", type=float, nargs="+", default=[0.0, 1.0, 2.0],
                        help="gate exponents; the first is the reference (give 0 first)")
    add_bias_grid(parser, step=0.01, top=0.3)
    args = parser.parse_args(argv)
    grid = bias_grid(parser, args)
    if args.powers[0] != 0.0:
        parser.error(f"--powers: the first is the plain prior's reference and must be 0, got {args.powers[0]}")
    calibration = load_calibration()
    try:  # every input checked before the actor runs
        dataset = DecisionDataset(args.dataset)
        dataset.columns_for([calibration.LOOP, "revisits", "uncertainty", "identity"])
        read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(f"--dataset/--actor: {error}")
    uncertainty = current_uncertainty(dataset, calibration.CHUNK)
    if not float(uncertainty.mean()) > 0:
        parser.error(f"--dataset {args.dataset}: no decision has a current pose with an uncertainty above 0 "
                     "(identity column): collect with the env's graphs")
    decisions = calibration.scored(args.actor, dataset)
    rows, summary = probe(calibration, decisions, uncertainty, args.powers, grid, calibration.CHUNK)
    for row in rows:
        print(json.dumps(row))
    print(json.dumps(summary | {"actor": args.actor, "dataset": args.dataset}))


if __name__ == "__main__":
    main()
