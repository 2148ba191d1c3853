"""Where along the way does the learned policy's map error part from EM's? (session 32)

For each scene of a zero-shot report (``trials.jsonl`` per scene folder) and each travel
distance up to the shortest learned trial, the map error of every trial at that travel
(``comparison.value_at_travel``), and the ratio of the learned policy's mean to EM's with a
95 % percentile interval from resampling each policy's trials (2,000 resamples, as
``explore_rl.zero_shot``).

    python benchmarks/results/zero_shot_v4_10/error_by_travel.py benchmarks/results/zero_shot_v4_10 \
        [benchmarks/results/zero_shot_v3_10]
"""

import json
import sys
from pathlib import Path

import numpy as np

from explore_rl.comparison import value_at_travel

TRAVELS_M = (25, 50, 100, 150, 200, 250, 300)
RESAMPLES = 2000


def errors_at(runs: list[dict], travel: float) -> np.ndarray:
    return np.array([value_at_travel(run, "map_error_m", travel) for run in runs])


def ratio_interval(mine: np.ndarray, theirs: np.ndarray, rng: np.random.Generator) -> list[float]:
    draws = [mine[rng.integers(0, len(mine), len(mine))].mean() / theirs[rng.integers(0, len(theirs), len(theirs))].mean()
             for _ in range(RESAMPLES)]
    return [float(v) for v in np.percentile(draws, [2.5, 97.5])]


def report(folder: Path) -> None:
    print(f"\n{folder}\n\n| scene | travel m | map error m, learned / em | ratio [95 % CI] |\n|---|---|---|---|")
    for trials in sorted(folder.glob("*/trials.jsonl")):
        runs = [json.loads(line) for line in trials.read_text().splitlines() if line.strip()]
        learned = [r for r in runs if r["policy"] == "learned" and r["rows"]]
        em = [r for r in runs if r["policy"] == "em" and r["rows"]]
        shortest = min(max(row["travel_m"] for row in r["rows"]) for r in learned + em)
        rng = np.random.default_rng(0)
        for travel in (t for t in TRAVELS_M if t <= shortest):
            mine, theirs = errors_at(learned, travel), errors_at(em, travel)
            low, high = ratio_interval(mine, theirs, rng)
            print(f"| {runs[0]['scene']} | {travel} | {mine.mean():.3f} / {theirs.mean():.3f} | "
                  f"{mine.mean() / theirs.mean():.2f} [{low:.2f}, {high:.2f}] |")


if __name__ == "__main__":
    for argument in sys.argv[1:]:
        report(Path(argument))
