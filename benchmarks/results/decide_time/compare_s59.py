"""Re-run trials against the stored ones: the same trajectories? and each policy's decision time on one machine.

Reads the trials ``buildings_s59.sh`` wrote (one ``building_SEED/trials.jsonl`` per building, EM and the learned
policy) and, per policy, the stored trial of the same building and seed (``--stored POLICY=DIR``: EM's of
``stop_coverage/runs/test``, session 51; the shipped actor's of ``stop_coverage/runs/dagger9k_test``, sessions 57-58).
Per trial: whether the decisions, travel, explored fraction and map error are those of the stored run (the code
changes of a session must not move a trajectory, or every stored trial it is paired with would be stale), and the
mean ``ms_decide`` now and then. Per policy, the pooled mean decision time of the re-run; EM's over the learned
policy's on the same machine, code and buildings (the stored times come from other machines and loads, and since
session 59 ``ms_decide`` holds observing and choosing only). One JSON line last.

    python benchmarks/results/decide_time/compare_s59.py /work/runs/decide_s59 \
        --stored em=benchmarks/results/stop_coverage/runs/test learned=benchmarks/results/stop_coverage/runs/dagger9k_test
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

SAME_KEYS = ("decisions", "travel_m", "explored", "map_error_m")


def trials_of(folder: Path) -> dict[tuple[str, str, int], dict]:
    """``(scene, policy, seed) -> trial`` of every ``*/trials.jsonl`` under ``folder``."""
    found = {}
    for path in sorted(folder.glob("*/trials.jsonl")):
        for line in path.read_text().splitlines():
            trial = json.loads(line)
            found[(trial["scene"], trial["policy"], int(trial["seed"]))] = trial
    return found


def same_run(now: dict, then: dict) -> bool:
    """Whether two trials made the same decisions to the same end (every figure equal to 1e-9 relative: the map error
    is now computed at once, equal to the old code's up to round-off)."""
    return all(np.isclose(now[key], then[key], rtol=1e-9, atol=0.0) for key in SAME_KEYS)


def compare(runs: dict, stored: dict[str, dict]) -> dict:
    """Per trial the comparison with its stored run; per policy the decision times; EM's over the learned policy's."""
    rows = []
    for (scene, policy, seed), trial in sorted(runs.items()):
        then = stored.get(policy, {}).get((scene, policy, seed))
        rows.append({"scene": scene, "policy": policy, "seed": seed, "decisions": trial["decisions"],
                     "travel_m": round(trial["travel_m"], 3), "map_error_m": round(trial["map_error_m"], 5),
                     "ms_decide": round(trial["ms_decide"], 1),
                     "stored": then is not None, "same_run": None if then is None else same_run(trial, then),
                     "ms_decide_stored": None if then is None else round(then["ms_decide"], 1)})
    policies = {}
    for policy in sorted({row["policy"] for row in rows}):
        decide = [r["ms_decide"] for (_, p, _), trial in runs.items() if p == policy for r in trial["rows"]]
        policies[policy] = {"trials": sum(row["policy"] == policy for row in rows),
                            "decisions": len(decide), "ms_decide": round(float(np.mean(decide)), 1)}
    summary = {"rows": rows, "policies": policies,
               "all_same_run": all(row["same_run"] for row in rows if row["stored"]),
               "compared": sum(row["stored"] for row in rows)}
    if {"em", "learned"} <= set(policies):
        summary["em_over_learned_decide"] = round(policies["em"]["ms_decide"] / policies["learned"]["ms_decide"], 2)
    return summary


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, help="the folder buildings_s59.sh wrote (building_SEED/trials.jsonl)")
    parser.add_argument("--stored", nargs="+", default=[], metavar="POLICY=DIR",
                        help="per policy, a folder of stored trials of the same buildings and seeds")
    args = parser.parse_args(argv)
    runs = trials_of(args.runs)
    if not runs:
        parser.error(f"{args.runs}: no */trials.jsonl there; give the folder buildings_s59.sh wrote")
    stored = {}
    for item in args.stored:
        policy, _, folder = item.partition("=")
        if not policy or not Path(folder).is_dir():
            parser.error(f"--stored {item}: give POLICY=DIR with an existing folder of trials")
        stored[policy] = trials_of(Path(folder))
    summary = compare(runs, stored)
    print("| scene | policy | decisions | travel m | map error m | same run as stored | ms_decide now | stored |")
    print("|---|---|---|---|---|---|---|---|")
    for r in summary["rows"]:
        print(f"| {r['scene']} | {r['policy']} | {r['decisions']} | {r['travel_m']} | {r['map_error_m']} | "
              f"{r['same_run']} | {r['ms_decide']} | {r['ms_decide_stored']} |")
    print(json.dumps({key: value for key, value in summary.items() if key != "rows"}))


if __name__ == "__main__":
    main()
