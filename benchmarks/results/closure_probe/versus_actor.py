"""Per-frontier ridge models against g-U-Net actors on the same held-out decisions (session 45,
closure_probe/plan.md, addendum of 21:23).

On a ``graph.features=loops`` ``DecisionDataset`` (``/work/runs/data_scratch_loops``): the ridge models of
``probe.py`` (``loops``, linear and pairwise, penalty by its cross-validation by layout) fitted on the frontier rows
of the training split (``layout % 4 != 3``), and the actor files (trained on that split), all scored on the
held-out decisions: offline gap closed with a bootstrap interval over layouts, and each ridge model minus the best
actor, paired. One JSON line per model or actor; the last line is the summary.

    python benchmarks/results/closure_probe/versus_actor.py ACTOR.pt [ACTOR.pt ...] [--dataset DIR]
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
from explore_rl.trainer.dataset import DecisionDataset

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
from common import module_at  # noqa: E402


distill = module_at(HERE.parent / "stakes_distill" / "probe.py", "stakes_distill_probe")
ridge = module_at(HERE / "probe.py", "closure_probe")
DATASET = "/work/runs/data_scratch_loops"


def frontier_rows(dataset: DecisionDataset, index: torch.Tensor, names: list[str]) -> list[dict]:
    """``probe.py``'s decision records of the stored decisions ``index``: the frontier rows' features, EM's
    rewards and choice (as the position among the frontiers), the layout."""
    rows = dataset.rows(index)
    columns = dataset.columns_for(names)
    records = []
    for k in range(len(index)):
        mask = rows["action_mask"][k]
        frontiers = torch.nonzero(mask).flatten()
        rewards = rows["action_rewards"][k][frontiers].double().numpy()
        best = int(rows["em_action"][k])
        records.append({"features": names, "x": rows["x"][k][frontiers][:, columns].double().numpy().tolist(),
                        "rewards": rewards.tolist(), "em_choice": int(torch.nonzero(frontiers == best).flatten()[0])
                        if best >= 0 else -1, "layout": int(rows["layout"][k]), "loop_uncertainty": []})
    return records


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("actors", nargs="+", help="loops actor files trained on the training split")
    parser.add_argument("--dataset", default=DATASET, help="a graph.features=loops DecisionDataset")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    names = list(feature_names("loops"))
    try:
        actors = [load_actor(path) for path in args.actors]
    except (ValueError, CheckpointError, FileNotFoundError) as error:
        sys.exit(f"actors: {error}")
    for path, (_, actor_file) in zip(args.actors, actors):
        if actor_file.feature_set != "loops":
            sys.exit(f"actors: {path} reads graph.features={actor_file.feature_set}; give loops actors")
    dataset, columns = distill.dataset_columns(args.dataset, names)
    train_index, probe_index = distill.split(dataset)
    if len(train_index) == 0 or len(probe_index) == 0:
        sys.exit(f"--dataset {args.dataset}: needs layouts on both sides of the split (layout % 4 == 3 or not)")
    train, held_out = frontier_rows(dataset, train_index, names), frontier_rows(dataset, probe_index, names)
    groups = ridge.layout_clusters(np.array([row["layout"] for row in held_out]))
    every = np.arange(len(held_out))
    scored = {}
    for pairwise in (False, True):
        name = "ridge loops" + (", pairwise" if pairwise else "")
        result = ridge.evaluate(train, held_out, (), pairwise)
        scored[name] = (result["gain"], result["stakes"])
        print(json.dumps({"model": name, "penalty": result["penalty"],
                          "gap_closed": round(ridge.gap_closed(*scored[name], every), 4),
                          "gap_closed_ci": ridge.bootstrap(lambda r, s=scored[name]: ridge.gap_closed(*s, r), groups)}), flush=True)
    for path, (actor, _) in zip(args.actors, actors):
        scores = distill.scores_of(lambda batch, a=actor: a(batch["x"], batch["adj"], batch["node_mask"]), dataset,
                           probe_index, columns, names)
        scored[path] = (scores["gain"], scores["stakes"])
        print(json.dumps({"model": path, "gap_closed": round(ridge.gap_closed(*scored[path], every), 4),
                          "gap_closed_ci": ridge.bootstrap(lambda r, s=scored[path]: ridge.gap_closed(*s, r), groups)}), flush=True)
    best = max(args.actors, key=lambda path: ridge.gap_closed(*scored[path], every))
    summary = {"train_decisions": len(train), "held_out_decisions": len(held_out), "held_out_layouts": len(groups),
               "best_actor": best, "ridge_minus_best_actor": {}}
    for name in ("ridge loops", "ridge loops, pairwise"):
        difference = lambda r, a=scored[name], b=scored[best]: ridge.gap_closed(*a, r) - ridge.gap_closed(*b, r)  # noqa: E731
        summary["ridge_minus_best_actor"][name] = {"gap_closed": round(difference(every), 4),
                                                   "gap_closed_ci": ridge.bootstrap(difference, groups)}
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
