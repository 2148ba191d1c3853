"""Which single per-frontier column, as a decision-time prior, moves the shipped actor's choices towards EM's?

loop_bias/calibrate.py's calibration (the biased greedy choice's pooled offline gap closed and agreement with EM's
best, the calibrated bias and its paired gain over the actor alone with a bootstrap interval over layouts) run
for every per-frontier column of the ``loops`` set in turn, with a grid of positive and one of negative biases,
on EM-scored decisions collected with the actor in the loop (benchmarks/collect_decisions.py ``--features
loops``). Descriptive (plan.md, session 53 step 0): one JSON line per column and sign, a summary last.

    python benchmarks/results/opening_prior/probe.py --dataset /work/data/opening_diag [--step 0.05] [--top 2]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from common import add_bias_grid, bias_grid, module_at  # noqa: E402

from explore_rl.graph.features import FRONTIER_EXTRAS, LOOP_EXTRAS  # noqa: E402
from explore_rl.models.actor_file import read_actor_file  # noqa: E402
from explore_rl.models.checkpoint import CheckpointError  # noqa: E402
from explore_rl.trainer.dataset import DecisionDataset  # noqa: E402

calibration = module_at(Path(__file__).resolve().parents[1] / "loop_bias" / "calibrate.py", "loop_bias_calibrate")
COLUMNS = FRONTIER_EXTRAS + LOOP_EXTRAS


def probe(actor: str, dataset: DecisionDataset, grid) -> list[dict]:
    """Per column and sign: the calibrated bias, its figures, the actor alone's, and the gain's interval."""
    rows = []
    for column in COLUMNS:
        decisions = calibration.scored(actor, dataset, prior=column)
        for sign in (1.0, -1.0):
            _, summary = calibration.calibrate(decisions, sign * grid)
            at = summary["at_bias"]
            rows.append({"column": column, "sign": sign, "bias": at["loop_bias"], "gap_closed": at["gap_closed"],
                         "same_choice": at["same_choice"], "alone_gap_closed": summary["alone"]["gap_closed"],
                         "alone_same_choice": summary["alone"]["same_choice"],
                         "gain_over_alone": summary["gain_over_alone"], "gain_ci": summary["gain_ci"],
                         "decisions": summary["decisions"], "layouts": summary["layouts"]})
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", required=True, help="a DecisionDataset folder of the loops set")
    parser.add_argument("--actor", default=calibration.ACTOR, help="actor file or training checkpoint")
    add_bias_grid(parser, step=0.05, top=2.0)
    args = parser.parse_args(argv)
    grid = bias_grid(parser, args)
    try:  # every input checked before the actor runs
        dataset = DecisionDataset(args.dataset)
        dataset.columns_for(list(COLUMNS))
        read_actor_file(args.actor)
    except (ValueError, CheckpointError) as error:
        parser.error(f"--dataset/--actor: {error}")
    rows = probe(args.actor, dataset, grid)
    for row in rows:
        print(json.dumps(row))
    best = max(rows, key=lambda row: row["gain_over_alone"])
    print(json.dumps({"largest_gain": best, "columns": len(COLUMNS), "actor": args.actor, "dataset": args.dataset}))


if __name__ == "__main__":
    main()
