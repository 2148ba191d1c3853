"""How a collection's decisions split between parking lots and ordinary buildings (plan.md, session 71).

A `collect_decisions.py` dataset whose building family draws lots (``scene.building.lot_probability`` > 0) records
each episode's layout seed in ``collect.jsonl``; the plan of that seed, drawn again with the collection's own
``--set`` overrides, says whether it was a lot. One JSON line: decisions and episodes per kind, in all and on the
training split the offline fine-tune reads (``layout % 4 != 3``, ``one_step.held_out``'s complement), and each
kind's decisions per second of its episodes' own time (one worker's rate):

    python dataset_kinds.py /work/data/s71_glots --set scene.building.lot_probability=0.5 ...
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from by_kind import lot_seeds, plan_stats  # noqa: E402
from one_step import held_out  # noqa: E402  (the layouts no fine-tune trains on)


def episodes(dataset: Path) -> list[dict]:
    """The episode rows of ``dataset/collect.jsonl`` (the session summaries, which name no layout, left out)."""
    rows = [json.loads(line) for line in dataset.joinpath("collect.jsonl").read_text().splitlines() if line.strip()]
    return [row for row in rows if "layout" in row]


def kinds(rows: list[dict], overrides: list[str]) -> dict:
    """Decisions and episodes per kind, in all and on the training split, the layouts of each kind and its decisions
    per second of episode time."""
    plans = plan_stats(sorted({row["layout"] for row in rows}), overrides)
    lots = lot_seeds(plans)
    lot = {layout: layout in lots for layout in plans}
    decisions, count, training, seconds = Counter(), Counter(), Counter(), Counter()
    for row in rows:
        kind = "lot" if lot[row["layout"]] else "building"
        decisions[kind] += row["stored"]
        count[kind] += 1
        seconds[kind] += row["seconds"]
        if not held_out(row["layout"]):
            training[kind] += row["stored"]
    return {"decisions": dict(decisions), "episodes": dict(count), "training_decisions": dict(training),
            "layouts": {"lot": sum(lot.values()), "building": len(lot) - sum(lot.values())},
            "decisions_per_s": {kind: round(decisions[kind] / seconds[kind], 3) for kind in seconds if seconds[kind] > 0}}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a dataset folder of benchmarks/collect_decisions.py")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="the collection's --set overrides (its lot kind)")
    args = parser.parse_args(argv)
    if not args.dataset.joinpath("collect.jsonl").is_file():
        parser.error(f"{args.dataset}: no collect.jsonl; give a dataset folder of collect_decisions.py")
    try:
        counts = kinds(episodes(args.dataset), args.set)
    except ValueError as error:  # a bad override, in one line
        parser.error(f"--set: {error}")
    print(json.dumps({"dataset": str(args.dataset), **counts}))


if __name__ == "__main__":
    main()
