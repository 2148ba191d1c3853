"""Which whole-exploration figure could rank candidates with 20 single explorations? For several
figures, each taken at the coverage both runs of a scene reach (as the zero-shot check does), the
per-scene log ratio of a policy's run over EM's: its mean (the pooled geometric-mean ratio) and its
spread, for EM's seed-1 runs against its seed-0 runs (the noise floor) and for each candidate. A figure
whose noise floor is narrow and that still separates policies would be a better selection figure than
the map error at the stop coverage. Reads the runs in ``runs/``; no simulation.

    python benchmarks/results/selection_v6/metric_noise.py
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from explore_rl.comparison import travel_to_reach, value_at_travel
from explore_rl.zero_shot import common_coverage

RUNS = Path(__file__).resolve().parent / "runs"
KINDS = ("buildings", "sparse")
POLICIES = {"em_seed1": "em", "default": "learned", "wide": "learned", "dagger_wide": "learned",
            "buildings_lots_distill": "learned", "buildings_office_distill": "learned"}


def trials(name: str, kind: str) -> dict[str, dict]:
    """Scene name -> the run's single trial."""
    runs = [json.loads(line) for path in sorted((RUNS / f"{kind}_{name}").glob("*/trials.jsonl"))
            for line in path.read_text().splitlines() if line.strip()]
    return {run["scene"]: run for run in runs}


def figures(run: dict, coverage: float) -> dict[str, float]:
    """One trial's figures at ``coverage``: map error there, ATE there, the mean map error of
    its decisions up to there, loop closures (plus one: some runs have none) per metre up to
    there, the travel to reach it."""
    travel = travel_to_reach(run, coverage)
    rows = [row for row in run["rows"] if row["travel_m"] <= travel] or run["rows"][:1]
    return {"map_error": value_at_travel(run, "map_error_m", travel),
            "ate": value_at_travel(run, "ate_m", travel),
            "mean_map_error": float(np.mean([row["map_error_m"] for row in rows])),
            "closures_per_m": (value_at_travel(run, "loop_closures", travel) + 1.0) / max(travel, 1e-9),
            "travel": travel}


def log_ratios(name: str) -> dict[str, np.ndarray]:
    """Per figure, the 20 scenes' log ratios of ``name``'s run over EM's seed-0 run."""
    out: dict[str, list[float]] = {}
    for kind in KINDS:
        mine, em = trials(name, kind), trials("em", kind)
        for scene, run in mine.items():
            coverage = common_coverage([run, em[scene]], 0.85)
            a, b = figures(run, coverage), figures(em[scene], coverage)
            for key in a:
                out.setdefault(key, []).append(math.log(max(a[key], 1e-9) / max(b[key], 1e-9)))
    return {key: np.array(values) for key, values in out.items()}


def main() -> None:
    table = {name: log_ratios(name) for name in POLICIES}
    keys = list(next(iter(table.values())))
    print("geometric-mean ratio over EM seed 0 (sd of the per-scene log ratio), 20 scenes")
    print(f"{'policy':26s}" + "".join(f"{key:>24s}" for key in keys))
    for name, ratios in table.items():
        print(f"{name:26s}" + "".join(f"{math.exp(ratios[k].mean()):12.2f} ({ratios[k].std(ddof=1):.2f})    "
                                      for k in keys))
    summary = {name: {k: {"ratio": float(math.exp(v.mean())), "sd_log": float(v.std(ddof=1))}
                      for k, v in ratios.items()} for name, ratios in table.items()}
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
