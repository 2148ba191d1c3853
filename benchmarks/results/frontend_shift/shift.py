"""How a policy's per-building ratios against EM move between two front ends, paired by building.

Reads two ``targets.json`` of ``study_zero_shot.py`` (per-building entries of one policy against EM, scenes named
``report/building_SEED``), pairs the buildings both hold, and gives per ratio (map error, equal-travel map error,
travel, closures per metre) the geometric mean of ``ratio_B / ratio_A`` over the buildings with a 95 % interval
resampled over buildings (the expanded percentiles of ``explore_rl.intervals``, as the zero-shot checks use).
Below 1: the policy stands better against EM under B than under A.

    python benchmarks/results/frontend_shift/shift.py TARGETS_A.json TARGETS_B.json [--resamples N]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from explore_rl.intervals import percentile_levels

KEYS = ("error_ratio", "equal_travel_error_ratio", "travel_ratio", "closures_ratio")


def per_building(path: Path) -> dict[str, dict]:
    """Building name (the scene without its report) -> that building's entry; pooled rows left out."""
    entries = json.loads(path.read_text())["entries"]
    return {e["scene"].split("/")[-1]: e for e in entries if e.get("scenes", 1) == 1 and "/" in e["scene"]}


def paired_log_ratios(a: dict[str, dict], b: dict[str, dict], key: str) -> np.ndarray:
    """log(ratio under B) - log(ratio under A) of every building both hold with a finite ratio in each."""
    both = sorted(a.keys() & b.keys())
    values = np.array([np.log(b[s][key]) - np.log(a[s][key]) for s in both], dtype=float)
    return values[np.isfinite(values)]


def geometric_mean_interval(logs: np.ndarray, resamples: int, seed: int = 0) -> tuple[float, list[float]]:
    """exp(mean) of ``logs`` and its interval, resampling the buildings."""
    rng = np.random.default_rng(seed)
    draws = [logs[rng.integers(0, len(logs), len(logs))].mean() for _ in range(resamples)]
    low, high = np.percentile(draws, percentile_levels(len(logs)))
    return float(np.exp(logs.mean())), [float(np.exp(low)), float(np.exp(high))]


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("a", type=Path, help="targets.json of the first front end")
    parser.add_argument("b", type=Path, help="targets.json of the second front end")
    parser.add_argument("--resamples", type=int, default=10_000)
    args = parser.parse_args(argv)
    for path in (args.a, args.b):
        if not path.is_file():
            parser.exit(1, f"{path}: no such targets.json (study_zero_shot.py --out FOLDER writes one)\n")
    a, b = per_building(args.a), per_building(args.b)
    result: dict = {"buildings": len(a.keys() & b.keys())}
    if result["buildings"] < 2:
        parser.exit(1, f"{result['buildings']} building(s) in both files: a paired interval needs at least 2\n")
    for key in KEYS:
        logs = paired_log_ratios(a, b, key)
        mean, interval = geometric_mean_interval(logs, args.resamples)
        result[f"{key}_b_over_a"] = round(mean, 4)
        result[f"{key}_b_over_a_ci95"] = [round(v, 4) for v in interval]
        print(f"{key}: B/A {mean:.2f} [{interval[0]:.2f}, {interval[1]:.2f}] over {len(logs)} buildings")
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
