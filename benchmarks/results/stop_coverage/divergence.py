"""Where two runs of the same policy part ways: the first decision at which a variant's trial leaves the reference's.

Reads the ``--policy`` trial of each ``building_SEED/trials.jsonl`` in a variant run (e.g. the shipped actor with
``graph.max_nodes=512``) and in reference runs (the same actor at 4096), and walks their per-decision rows until
the chosen frontier or the keyframe count differs (plan.md, session 55). Why: a change to what the actor sees can
only move a decision where it changes the actor's input; if every first divergence falls on a decision whose graph
is over ``--nodes`` (keyframes + candidates), the runs part ways there and not by the machine's round-off. One JSON
line per building that diverges, then a summary line: buildings, identical runs, divergences over and up to
``--nodes``.

    python benchmarks/results/stop_coverage/divergence.py runs/nodes512_val90 --reference runs/val runs/val2 --nodes 512
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from explore_rl.comparison import read_trials


def trial_of(folder: Path, policy: str) -> dict | None:
    """The first ``policy`` trial of a building folder, None if it has none (or no trials.jsonl)."""
    path = folder / "trials.jsonl"
    if not path.exists():
        return None
    return next((t for t in read_trials(path) if t["policy"] == policy), None)


def first_difference(rows: list[dict], reference: list[dict]) -> int | None:
    """Index of the first decision whose choice or keyframe count differs; the shorter length if one run is a
    prefix of the other; None if the two are the same decision by decision."""
    for index, (row, other) in enumerate(zip(rows, reference)):
        if (row["chosen_x"], row["chosen_y"], row["keyframes"]) != (other["chosen_x"], other["chosen_y"],
                                                                   other["keyframes"]):
            return index
    return None if len(rows) == len(reference) else min(len(rows), len(reference))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="the variant's explore-rl-eval output (building_SEED folders)")
    parser.add_argument("--reference", type=Path, nargs="+", required=True,
                        help="runs holding the reference trials of the same buildings")
    parser.add_argument("--policy", default="learned", help="the policy whose trials are compared")
    parser.add_argument("--nodes", type=int, default=512, help="graph size (keyframes + candidates) to split by")
    args = parser.parse_args(argv)
    if args.nodes <= 0:
        parser.error(f"--nodes {args.nodes}: give a positive graph size")
    references = {f.name: f for run in args.reference for f in run.glob("building_*")}
    pairs = [(f.name, trial_of(f, args.policy), trial_of(references[f.name], args.policy))
             for f in sorted(args.run.glob("building_*")) if f.name in references]
    pairs = [(name, a, b) for name, a, b in pairs if a is not None and b is not None]
    if not pairs:
        parser.error(f"no building with a {args.policy!r} trial in both {args.run} and the references: "
                     "give finished runs of the same buildings")
    identical, over, within = 0, 0, 0
    for name, trial, reference in pairs:
        index = first_difference(trial["rows"], reference["rows"])
        if index is None:
            identical += 1
            continue
        row = trial["rows"][index] if index < len(trial["rows"]) else None
        nodes = None if row is None else int(row["keyframes"] + row["candidates"])
        over += nodes is not None and nodes > args.nodes
        within += nodes is None or nodes <= args.nodes
        print(json.dumps({"building": name, "first_difference": index, "nodes": nodes}))
    print(json.dumps({"buildings": len(pairs), "identical": identical, "diverge_over_nodes": over,
                      "diverge_within_nodes": within, "nodes": args.nodes}))


if __name__ == "__main__":
    main()
