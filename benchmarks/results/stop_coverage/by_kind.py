"""Where the map-error gap is made: the learned / EM ratios per kind of building (descriptive).

Reads the per-building entries of ``study_zero_shot.py`` outputs (``targets.json``: each building's travel and
map-error ratio, learned over EM, at the common coverage) and the plan of each building (``generate_building`` with
the default ``conf/scene/building.yaml``: corridor kind, independent loops of the region graph, area). For each
group of buildings (with loops / without; by corridor kind; by area tercile): the geometric mean of the ratios (the
statistic of the headline pool, ``explore_rl.zero_shot``) and a bootstrap 95 % interval over the group's buildings.
Groups are post hoc and small: descriptive only. One JSON line per input and group.

    python benchmarks/results/stop_coverage/by_kind.py NAME=TARGETS_JSON [NAME=TARGETS_JSON ...]
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from common import emit, named_paths  # noqa: E402

BOOTSTRAP = 2000


def per_building(path: Path) -> dict[int, dict]:
    """Seed -> the building's entry of a ``targets.json`` (the pooled entry left out)."""
    entries = {}
    for entry in json.loads(path.read_text())["entries"]:
        found = re.search(r"building_(\d+)$", str(entry["scene"]))
        if found:
            entries[int(found.group(1))] = entry
    if not entries:
        raise ValueError(f"{path}: no building_SEED entries")
    return entries


def plan_stats(seeds: list[int], overrides: list[str] | tuple[str, ...] = ()) -> dict[int, dict]:
    """Seed -> ``BuildingPlan.stats()`` of the building family (the default one, or under config ``overrides``
    such as a collection's lot kind)."""
    from explore_rl.config import load_config
    from explore_rl.scene.building import generate_building

    config = load_config(["scene=building", *overrides])
    return {s: generate_building(replace(config.scene, seed=s), config.robot.radius).stats() for s in seeds}


def lot_seeds(plans: dict[int, dict]) -> set[int]:
    """The seeds of ``plan_stats`` whose plan is a parking lot."""
    from explore_rl.scene.building import LOT

    return {seed for seed, stats in plans.items() if stats["corridor"] == LOT}


def rows_on_lots(layouts: np.ndarray, plans: dict[int, dict]) -> np.ndarray:
    """Per row of a dataset (its layout seed in ``layouts``): whether that layout's plan (of ``plan_stats``) is a
    parking lot; a layout without a plan is not."""
    lots = lot_seeds(plans)
    return np.array([int(seed) in lots for seed in layouts], dtype=bool)


def geometric_mean(ratios: np.ndarray, seed: int = 0) -> tuple[float, list[float]]:
    """Geometric mean of ``ratios`` and its bootstrap 95 % interval over them."""
    logs = np.log(ratios)
    rng = np.random.default_rng(seed)
    means = logs[rng.integers(0, len(logs), size=(BOOTSTRAP, len(logs)))].mean(axis=1)
    return float(np.exp(logs.mean())), [float(np.exp(q)) for q in np.quantile(means, [0.025, 0.975])]


def groups(stats: dict[int, dict]) -> dict[str, list[int]]:
    """Named groups of seeds: with / without loops, each corridor kind, area terciles."""
    seeds = sorted(stats)
    named = {"all": seeds, "loops": [s for s in seeds if stats[s]["loops"] > 0],
             "no loops": [s for s in seeds if stats[s]["loops"] == 0]}
    for kind in sorted({stats[s]["corridor"] for s in seeds}):
        named[f"corridor {kind}"] = [s for s in seeds if stats[s]["corridor"] == kind]
    cuts = np.quantile([stats[s]["area"] for s in seeds], [1 / 3, 2 / 3])
    for label, low, high in (("small", -np.inf, cuts[0]), ("medium", cuts[0], cuts[1]), ("large", cuts[1], np.inf)):
        named[f"area {label}"] = [s for s in seeds if low < stats[s]["area"] <= high]
    return {name: members for name, members in named.items() if members}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", nargs="+", metavar="NAME=TARGETS_JSON", help="a name and a targets.json")
    args = parser.parse_args(argv)
    try:
        inputs = {name: per_building(path) for name, path in named_paths(args.inputs).items()}
    except (OSError, KeyError, ValueError) as error:
        parser.error(str(error).splitlines()[0])
    stats = plan_stats(sorted({s for entries in inputs.values() for s in entries}))
    for name, entries in inputs.items():
        for group, members in groups({s: stats[s] for s in entries}).items():
            travel = geometric_mean(np.array([entries[s]["travel_ratio"] for s in members]))
            error = geometric_mean(np.array([entries[s]["error_ratio"] for s in members]))
            emit({"input": name, "group": group, "buildings": len(members), "travel_ratio": round(travel[0], 3),
                  "travel_ci95": [round(v, 3) for v in travel[1]], "error_ratio": round(error[0], 3),
                  "error_ci95": [round(v, 3) for v in error[1]]})


if __name__ == "__main__":
    main()
