"""The zero-shot ratios as the explorations go on: the pooled targets of ``study_zero_shot.py`` at several coverages.

At each coverage ``c`` the learned policy and EM are compared on every building where both reached ``c`` (a
building where either stopped short of ``c`` is left out at that ``c``): travel to ``c``, the map error there and
the map error at equal travel, pooled over the buildings with ``explore_rl.zero_shot``'s interval (plan.md: does
the map-error gap measured at 250 m, 30-80 % explored, hold by 85 %?). One JSON line per coverage.

    python benchmarks/results/stop_coverage/by_coverage.py runs/val [--coverages 0.5 0.6 0.7 0.8 0.85]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from explore_rl.comparison import read_trials
from explore_rl.zero_shot import RESAMPLES, ZeroShotTargets, check_targets

KEYS = ("travel_ratio", "error_ratio", "equal_travel_error_ratio")


def reached_by_all(runs: list[dict], coverage: float) -> bool:
    """Whether every trial of one building explored at least ``coverage``."""
    return all(run["explored"] >= coverage for run in runs)


def at_coverage(buildings: list[list[dict]], coverage: float, resamples: int) -> dict:
    """The pooled ratios at ``coverage`` over the buildings every trial of which reached it."""
    kept = [runs for runs in buildings if reached_by_all(runs, coverage)]
    row = {"coverage": coverage, "buildings": len(kept)}
    if len(kept) < 2:
        return row
    entries = check_targets([run for runs in kept for run in runs], targets=ZeroShotTargets(coverage=coverage),
                            resamples=resamples)
    if not entries:  # no building holds both a learned and an EM trial
        return row | {"note": "no building with both a learned and an em trial"}
    pooled = entries[-1]
    return row | {key: round(pooled[key], 3) for key in KEYS} | {
        f"{key}_ci95": [round(v, 3) for v in pooled[f"{key}_ci95"]] for key in KEYS}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="folders of building_SEED/trials.jsonl (learned and em)")
    parser.add_argument("--coverages", type=float, nargs="+", default=[0.5, 0.6, 0.7, 0.8, 0.85])
    parser.add_argument("--resamples", type=int, default=RESAMPLES)
    args = parser.parse_args(argv)
    bad = [c for c in args.coverages if not 0 < c <= 1]
    if bad:
        parser.error(f"--coverages {bad[0]}: give fractions in (0, 1]")
    files = sorted(f for run in args.runs for f in run.glob("*building_*/trials.jsonl"))
    if not files:
        parser.error(f"no building_SEED/trials.jsonl under {' '.join(map(str, args.runs))}: give finished runs")
    buildings = [read_trials(f) for f in files]
    for coverage in args.coverages:
        print(json.dumps(at_coverage(buildings, coverage, args.resamples)), flush=True)


if __name__ == "__main__":
    main()
