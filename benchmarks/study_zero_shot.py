"""Issue 24's zero-shot targets on finished ``explore-rl-eval`` reports, with 95 % intervals.

For each report folder (an ``explore-rl-eval`` run, or a sweep's parent with one sub-folder
per scene), reads every ``trials.jsonl`` and checks the learned policy against EM
(explore_rl/zero_shot.py): travel to the common coverage, map error there and at equal
travel, decision time; ratios of means with bootstrap intervals, a target met only when its
whole interval is within it. New reports carry the same table in their ``summary.md``; this
script re-reads reports written before it existed. Writes ``targets.md`` and
``targets.json`` into the folder (or into ``--out``), prints one JSON line last.

    python benchmarks/study_zero_shot.py benchmarks/results/zero_shot_v3_10 \
        benchmarks/results/zero_shot_buildings_v3
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl import comparison, zero_shot  # noqa: E402


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reports", nargs="+", help="explore-rl-eval output folders")
    parser.add_argument("--out", default=None, help="write targets.{md,json} here (one sub-folder per report) "
                                                    "instead of into each report")
    parser.add_argument("--resamples", type=int, default=zero_shot.RESAMPLES, help="bootstrap resamples")
    parser.add_argument("--smoke", action="store_true", help="for the test suite: 50 resamples")
    return parser.parse_args()


def read_report(folder: Path) -> list[dict]:
    """Every trial of a report: its own ``trials.jsonl`` or its sub-folders' (a sweep)."""
    paths = [folder / "trials.jsonl"] if (folder / "trials.jsonl").exists() else sorted(folder.glob("*/trials.jsonl"))
    if not paths:
        raise SystemExit(f"{folder}: no trials.jsonl in it or its sub-folders; pass an explore-rl-eval output folder")
    return [run for path in paths for run in comparison.read_trials(path)]


def main() -> None:
    args = parse_args()
    result = {"machine": machine(), "smoke": args.smoke, "reports": {}}
    resamples = 50 if args.smoke else args.resamples
    for name in args.reports:
        folder = Path(name)
        entries = zero_shot.check_targets(read_report(folder), resamples=resamples)
        out = folder if args.out is None else Path(args.out) / folder.name
        out.mkdir(parents=True, exist_ok=True)
        (out / "targets.md").write_text(zero_shot.targets_markdown(entries))
        (out / "targets.json").write_text(json.dumps(zero_shot.targets_json(entries), indent=1))
        print(zero_shot.targets_markdown(entries))
        result["reports"][folder.name] = {
            e["scene"]: {key: e[key] for key in ("travel_ratio", "travel_ratio_ci95", "error_ratio", "error_ratio_ci95",
                                                 "equal_travel_error_ratio", "speedup", "speedup_ci95",
                                                 "travel_met", "error_met", "speed_met", "trials_to_resolve")}
            for e in entries}
    emit(result)


if __name__ == "__main__":
    main()
