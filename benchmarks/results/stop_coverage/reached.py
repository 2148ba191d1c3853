"""The buildings where every policy's trials reached the stop coverage (plan.md: the targets' literal definition).

Reads each ``building_SEED/trials.jsonl`` of the given run folders (``explore-rl-eval`` outputs, one trial per
policy or more) and copies the folders whose every trial of ``--policies`` explored at least ``--target`` into
``--out`` (their ``trials.jsonl`` and ``summary.md``), so that ``study_zero_shot.py`` pools just those. One JSON
line: buildings read, how many each policy brought to the target, how many all did.

    python benchmarks/results/stop_coverage/reached.py runs/val --out runs/val_reached [--target 0.85]
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

from explore_rl.comparison import read_trials


def reached(trials: list[dict], policy: str, target: float) -> bool | None:
    """Whether every trial of ``policy`` explored ``target``; None if the building has none of its trials."""
    own = [t for t in trials if t["policy"] == policy]
    return all(t["explored"] >= target for t in own) if own else None


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="explore-rl-eval output folders of building_SEED folders")
    parser.add_argument("--out", type=Path, required=True, help="where the buildings all policies brought there go")
    parser.add_argument("--target", type=float, default=0.85, help="the stop coverage (explore.target_explored)")
    parser.add_argument("--policies", nargs="+", default=["learned", "em"])
    args = parser.parse_args(argv)
    if not 0 < args.target <= 1:
        parser.error(f"--target {args.target}: give a fraction in (0, 1]")
    folders = sorted(f for run in args.runs for f in run.glob("*building_*") if (f / "trials.jsonl").exists())
    if not folders:
        parser.error(f"no building_SEED/trials.jsonl under {' '.join(map(str, args.runs))}: give finished runs")
    counts = {policy: 0 for policy in args.policies}
    kept = 0
    for folder in folders:
        trials = read_trials(folder / "trials.jsonl")
        flags = {policy: reached(trials, policy, args.target) for policy in args.policies}
        for policy, flag in flags.items():
            counts[policy] += bool(flag)
        if all(flags.values()):
            kept += 1
            (args.out / folder.name).mkdir(parents=True, exist_ok=True)
            for name in ("trials.jsonl", "summary.md"):
                if (folder / name).exists():
                    shutil.copy(folder / name, args.out / folder.name / name)
    print(json.dumps({"buildings": len(folders), "target": args.target, "reached": counts, "all_reached": kept,
                      "out": str(args.out)}))


if __name__ == "__main__":
    main()
