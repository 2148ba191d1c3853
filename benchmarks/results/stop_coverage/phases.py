"""How the learned policy and EM explore, phase by phase: where does the learned policy's early map error come from?

For each band of coverage (the coverage when a decision is taken), each policy's metres driven per decision, loop
closures per metre and open frontiers (the candidates it chose among), per building, and the learned / EM ratio of
each pooled over the buildings (geometric mean; 95 % expanded-percentile bootstrap interval over buildings,
``explore_rl.intervals``). A building where a policy took no decision in a band, or closed no loop there, is left
out of that band's ratio of that quantity. Reads every ``building_SEED/trials.jsonl`` (one trial per policy, with
its per-decision ``rows``). One JSON line per band.

    python benchmarks/results/stop_coverage/phases.py benchmarks/results/stop_coverage/runs/test
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from explore_rl.comparison import read_trials
from explore_rl.intervals import percentile_levels

QUANTITIES = ("metres_per_decision", "closures_per_m", "open_frontiers")
RESAMPLES = 2000


def band_totals(run: dict, low: float, high: float) -> dict | None:
    """One trial's decisions taken at a coverage in [low, high): their count, metres, closures and open frontiers."""
    before = {"travel_m": 0.0, "loop_closures": 0, "explored": 0.0}
    n = metres = closures = frontiers = 0.0
    for row in run["rows"]:
        if low <= before["explored"] < high:
            n += 1
            metres += row["travel_m"] - before["travel_m"]
            closures += row["loop_closures"] - before["loop_closures"]
            frontiers += row["candidates"]
        before = row
    if n == 0:
        return None
    return {"metres_per_decision": metres / n, "closures_per_m": closures / metres if metres > 0 else float("nan"),
            "open_frontiers": frontiers / n}


def building_ratios(totals: dict[str, dict | None], policy: str, reference: str) -> dict | None:
    """The policy / reference ratio of each quantity in one building's band (NaN where it is not defined);
    ``totals``: each policy's :func:`band_totals` in that building."""
    mine, theirs = totals.get(policy), totals.get(reference)
    if mine is None or theirs is None:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        ratios = {key: np.float64(mine[key]) / np.float64(theirs[key]) for key in QUANTITIES}
    return {key: float(value) if np.isfinite(value) and value > 0 else float("nan") for key, value in ratios.items()}


def pooled(values: list[float], resamples: int, seed: int = 0) -> dict:
    """Geometric mean of the finite ratios and its bootstrap interval over buildings."""
    logs = np.log([v for v in values if np.isfinite(v)])
    if len(logs) < 2:
        return {"ratio": float("nan"), "ci95": [float("nan"), float("nan")], "buildings": int(len(logs))}
    rng = np.random.default_rng(seed)
    draws = np.exp(logs[rng.integers(0, len(logs), (resamples, len(logs)))].mean(axis=1))
    return {"ratio": round(float(np.exp(logs.mean())), 3),
            "ci95": [round(float(v), 3) for v in np.percentile(draws, percentile_levels(len(logs)))],
            "buildings": int(len(logs))}


def band_row(buildings: list[list[dict]], low: float, high: float, policy: str, reference: str,
             resamples: int) -> dict:
    """One band: each policy's mean quantities over the buildings and the pooled ratios."""
    totals = [{run["policy"]: band_totals(run, low, high) for run in runs} for runs in buildings]
    ratios = [r for r in (building_ratios(t, policy, reference) for t in totals) if r]
    means = {}
    for name in (policy, reference):
        present = [t[name] for t in totals if t.get(name)]
        means[name] = {key: round(float(np.nanmean([t[key] for t in present])), 3) if present else float("nan")
                       for key in QUANTITIES}
    return {"band": [low, high], "buildings": len(ratios), **means,
            **{key: pooled([r[key] for r in ratios], resamples) for key in QUANTITIES}}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="folders of building_SEED/trials.jsonl (learned and em)")
    parser.add_argument("--bands", type=float, nargs="+", default=[0.0, 0.3, 0.5, 0.7],
                        help="band edges (coverage fractions, increasing; the last band runs to the end)")
    parser.add_argument("--policy", default="learned")
    parser.add_argument("--reference", default="em")
    parser.add_argument("--resamples", type=int, default=RESAMPLES)
    args = parser.parse_args(argv)
    edges = args.bands
    if any(not 0 <= e < 1 for e in edges) or any(b <= a for a, b in zip(edges, edges[1:])):
        parser.error(f"--bands {' '.join(map(str, edges))}: give increasing fractions in [0, 1)")
    files = sorted(f for run in args.runs for f in run.glob("*building_*/trials.jsonl"))
    if not files:
        parser.error(f"no building_SEED/trials.jsonl under {' '.join(map(str, args.runs))}: give finished runs")
    buildings = [read_trials(f) for f in files]
    for low, high in zip(edges, [*edges[1:], 2.0]):
        row = band_row(buildings, low, high, args.policy, args.reference, args.resamples)
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
