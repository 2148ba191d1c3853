"""The named scenes' explorations as they go on: where along the way does a policy's map error part from EM's?

For each run and each travel distance ``T``: the mean map error, trajectory error (ATE), explored fraction and loop
closures per metre so far over the trials that drove at least ``T`` (each trial's values at ``T`` interpolated
linearly between its decisions), and each run's ratio of means to the first run's on the seeds both drove that far
(95 % expanded-percentile bootstrap interval over seeds, ``explore_rl.intervals``). Then the same at the stop (each
trial's final values). A run is ``NAME=FILE[:POLICY]``: an ``explore-rl-eval`` ``trials.jsonl`` and the policy whose
trials it holds (default ``learned``). One JSON line per distance, the stop's last.

    python benchmarks/results/stop_coverage/at_travel.py \
        em=benchmarks/results/stop_coverage/runs/street_garage50/1_garage/trials.jsonl:em \
        default=benchmarks/results/stop_coverage/runs/street_garage50/1_garage/trials.jsonl:learned \
        late150=benchmarks/results/stop_coverage/runs/street_garage50_late150/1_garage/trials.jsonl \
        --travel 50 100 150 200 300
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from explore_rl.comparison import read_trials
from explore_rl.intervals import percentile_levels

MEASURED = ("map_error_m", "ate_m", "explored")  # logged per decision and per trial
QUANTITIES = (*MEASURED, "closures_per_m")
RESAMPLES = 2000


def value_at(trial: dict, travel: float) -> dict | None:
    """One trial's quantities after ``travel`` metres (interpolated between decisions); None if it stopped before.
    The trial has decisions (:func:`read_run` keeps only those)."""
    rows = trial["rows"]
    metres = np.array([row["travel_m"] for row in rows])
    if metres[-1] < travel:
        return None
    values = {key: float(np.interp(travel, metres, [row[key] for row in rows])) for key in MEASURED}
    closures = float(np.interp(travel, metres, [row["loop_closures"] for row in rows]))
    return {**values, "closures_per_m": closures / travel}


def value_at_stop(trial: dict) -> dict:
    """One trial's final quantities."""
    return {**{key: float(trial[key]) for key in MEASURED},
            "closures_per_m": trial["loop_closures"] / trial["travel_m"] if trial["travel_m"] > 0 else float("nan")}


def ratio_of_means(mine: np.ndarray, theirs: np.ndarray, resamples: int, seed: int = 0) -> dict:
    """mean(mine) / mean(theirs) over paired seeds, with its bootstrap interval over seeds."""
    if len(mine) < 2:
        return {"ratio": float("nan"), "ci95": [float("nan"), float("nan")], "seeds": int(len(mine))}
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, len(mine), (resamples, len(mine)))
    draws = mine[picks].mean(axis=1) / theirs[picks].mean(axis=1)
    return {"ratio": round(float(mine.mean() / theirs.mean()), 3),
            "ci95": [round(float(v), 3) for v in np.percentile(draws, percentile_levels(len(mine)))],
            "seeds": int(len(mine))}


def row(runs: dict[str, dict[int, dict]], point, resamples: int) -> dict:
    """One distance (or the stop, ``point=None``): each run's means and its ratios to the first run."""
    values = {name: {seed: value_at(trial, point) if point is not None else value_at_stop(trial)
                     for seed, trial in trials.items()} for name, trials in runs.items()}
    values = {name: {seed: v for seed, v in by_seed.items() if v is not None} for name, by_seed in values.items()}
    reference = next(iter(runs))
    out = {"travel_m": point if point is not None else "stop"}
    for name, by_seed in values.items():
        entry = {"trials": len(by_seed)}
        entry.update({key: round(float(np.mean([v[key] for v in by_seed.values()])), 4) if by_seed else float("nan")
                      for key in QUANTITIES})
        if name != reference:
            seeds = sorted(set(by_seed) & set(values[reference]))
            for key in QUANTITIES:
                mine = np.array([by_seed[s][key] for s in seeds])
                theirs = np.array([values[reference][s][key] for s in seeds])
                entry[f"{key}_ratio"] = ratio_of_means(mine, theirs, resamples)
        out[name] = entry
    return out


def read_run(spec: str, parser: argparse.ArgumentParser) -> tuple[str, dict[int, dict]]:
    """``NAME=FILE[:POLICY]`` -> the name and that policy's trials by seed (bad specs refused in one line)."""
    name, _, rest = spec.partition("=")
    if not name or not rest:
        parser.error(f"run {spec!r}: give NAME=FILE[:POLICY], e.g. em=runs/x/1_garage/trials.jsonl:em")
    path, _, policy = rest.partition(":")
    policy = policy or "learned"
    if not Path(path).is_file():
        parser.error(f"run {name}: {path} is no file (an explore-rl-eval trials.jsonl)")
    trials = {t["seed"]: t for t in read_trials(Path(path)) if t.get("policy") == policy and t.get("rows")}
    if len(trials) < 2:
        parser.error(f"run {name}: {path} holds {len(trials)} trials of policy {policy!r} with decisions (need 2)")
    return name, trials


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="NAME=FILE[:POLICY], the first is the reference")
    parser.add_argument("--travel", nargs="+", type=float, default=[50.0, 100.0, 150.0, 200.0, 300.0],
                        help="travel distances (m), increasing")
    parser.add_argument("--resamples", type=int, default=RESAMPLES)
    args = parser.parse_args(argv)
    if any(t <= 0 for t in args.travel) or list(args.travel) != sorted(set(args.travel)):
        parser.error(f"--travel {' '.join(map(str, args.travel))}: give positive, increasing distances")
    if len(args.runs) < 2:
        parser.error("give at least two runs: the reference first, then the runs compared with it")
    runs = dict(read_run(spec, parser) for spec in args.runs)
    if len(runs) != len(args.runs):
        parser.error("two runs share a NAME: give each its own")
    for point in [*args.travel, None]:
        print(json.dumps(row(runs, point, args.resamples)))


if __name__ == "__main__":
    main()
