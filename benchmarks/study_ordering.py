"""The paper's ordering study: nearest frontier, EM and random on street and garage.

Runs every (scene, policy, seed) exploration with the chosen SLAM front end in parallel
worker processes, then writes to ``benchmarks/results/``: a table (mean and std per policy
and scene), per-scene plots of map error and 3D volume against travel distance (mean over
seeds with a +-1 std band), and the per-run CSV. The trials, the table and the plots are
``explore_rl.comparison``'s, as for ``explore-rl-eval``. The last stdout line is JSON with
the table and the ordering checks:

* EM ends with lower map error than nearest frontier (paper: EM has the lowest error);
* nearest frontier covers the most ground per metre; random covers the least.

    python benchmarks/study_ordering.py [--quick | --smoke] [--seeds 5] [--frontend icp] [--workers 2] [--resume]
                                        [--override planning.reward.alpha=1 ...] [--out DIR]

Every finished run is appended to ``results/ordering_runs.jsonl`` as it completes;
``--resume`` continues an interrupted study and ``--summarise-only`` rebuilds the table
and plots from that log. ``--quick`` and ``--smoke`` write to a temporary directory
(``--smoke``: to ``--out`` if given), never to ``results/``.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl import comparison  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
POLICIES = ["nearest", "em", "random"]


def scene_config(scene: str, frontend: str, extra: tuple[str, ...]):
    """The config of every run on ``scene`` (seed 0: a run's seed is its trial number)."""
    from explore_rl.config import load_config

    return load_config([f"scene={scene}", f"slam={frontend}", "seed=0", "explore.progress_bar=false", *extra])


def explore_once(scene: str, policy: str, seed: int, frontend: str, extra: tuple[str, ...]) -> dict:
    """One exploration, its per-decision table and final figures (``comparison.run_trial``;
    also used by benchmarks/study_inflation.py). Raises if the run failed."""
    trial = comparison.Trial(comparison.trial_config(scene_config(scene, frontend, extra), policy, seed), seed)
    run = comparison.run_trial(trial)
    if run["status"] == "error":
        raise RuntimeError(f"{scene} {policy} seed {seed}: {run['error']}")
    return run


def make_trials(scenes: list[str], seeds: int, frontend: str, extra: tuple[str, ...],
                done: set[tuple[str, str, int]]) -> list[comparison.Trial]:
    """Seed-major order (an interrupted study still holds whole (scene, policy) sets per
    seed), without the runs already in the log."""
    configs = {scene: scene_config(scene, frontend, extra) for scene in scenes}
    trials = [comparison.Trial(comparison.trial_config(configs[scene], policy, seed), seed)
              for seed in range(seeds) for scene in scenes for policy in POLICIES]
    return [t for t in trials if (t.scene, t.policy, t.trial) not in done]


def read_runs(path: Path) -> list[dict]:
    """Runs already logged (one JSON object a line) by an earlier, interrupted study."""
    runs = comparison.read_trials(path)
    for run in runs:  # logs written before explore_rl.comparison ran the trials
        run.setdefault("trial", run["seed"])
        run.setdefault("explored_per_m", run["explored"] / max(run["travel_m"], 1e-9))
        if run["rows"]:
            run.setdefault("ms_decide", sum(row["ms_decide"] for row in run["rows"]) / len(run["rows"]))
    return runs


def ordering_checks(table: list[dict]) -> dict:
    checks = {}
    for scene in sorted({t["scene"] for t in table}):
        by = {t["policy"]: t for t in table if t["scene"] == scene}
        if {"nearest", "em"} <= by.keys():
            checks[f"{scene}_em_lower_map_error_than_nearest"] = by["em"]["map_error_m"] < by["nearest"]["map_error_m"]
        if len(by) == 3:
            rates = {p: by[p]["explored_per_m"] for p in by}
            checks[f"{scene}_nearest_most_ground_per_m"] = max(rates, key=rates.get) == "nearest"
            checks[f"{scene}_random_least_ground_per_m"] = min(rates, key=rates.get) == "random"
    return checks


def plot(runs: list[dict], out: Path) -> list[str]:
    """``ordering_{scene}.png``: map error and 3D volume against travel, side by side."""
    from explore_rl import viz

    written = []
    for scene in sorted({r["scene"] for r in runs}):
        fig, axes = viz.plt.subplots(1, 2, figsize=(11, 4))
        scene_runs = [r for r in runs if r["scene"] == scene]
        for ax, (metric, ylabel, title) in zip(axes, comparison.PLOTS):
            comparison.plot_metric(ax, scene_runs, metric, ylabel, f"{scene}: {title}")
        path = viz.save(fig, out / f"ordering_{scene}.png")
        written.append(str(path.relative_to(out.parent.parent)) if path.is_relative_to(out.parent.parent)
                       else str(path))
    return written


def write_tables(runs: list[dict], table: list[dict], out: Path) -> None:
    with open(out / "ordering_runs.csv", "w", newline="") as handle:
        fields = list(dict.fromkeys(k for r in runs for k in r if k != "rows"))
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows({k: r.get(k) for k in fields} for r in runs)
    (out / "ordering_table.md").write_text(comparison.markdown_table(table))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="street only, 1 seed, 6 decisions")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: street, 1 seed, 2 decisions, slam=model, 1 worker; "
                             "writes tables and plots to --out (default: a temporary directory)")
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--scenes", nargs="+", default=["street", "garage"])
    parser.add_argument("--frontend", default="icp", choices=["icp", "model"])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--out", default=None, help=f"default {RESULTS}")
    parser.add_argument("--override", nargs="*", action="extend", default=[],
                        help="Hydra overrides for every run, e.g. planning.reward.alpha=1")
    parser.add_argument("--resume", action="store_true", help="keep runs already in ordering_runs.jsonl")
    parser.add_argument("--summarise-only", action="store_true", help="no new runs: table/plots from the log")
    args = parser.parse_args()
    scenes, seeds, extra = args.scenes, args.seeds, tuple(args.override)
    if args.quick:
        scenes, seeds, extra = ["street"], 1, ("explore.max_decisions=6", *args.override)
        args.out = tempfile.mkdtemp(prefix="ordering_quick_")  # never touch the committed results
    elif args.smoke:
        scenes, seeds, extra = ["street"], 1, ("explore.max_decisions=2", *args.override)
        args.frontend, args.workers = "model", 1
        args.out = args.out or tempfile.mkdtemp(prefix="ordering_smoke_")
    args.out = args.out or str(RESULTS)
    args.resume = args.resume or args.summarise_only
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    log = out / "ordering_runs.jsonl"
    runs = read_runs(log) if args.resume else []
    if not args.resume:
        log.unlink(missing_ok=True)
    done = {(r["scene"], r["policy"], r["trial"]) for r in runs}
    trials = [] if args.summarise_only else make_trials(scenes, seeds, args.frontend, extra, done)
    runs += comparison.run_trials(trials, args.workers, progress=not args.smoke,
                                  on_result=functools.partial(comparison.log_trial, log), desc="ordering runs")
    for r in runs:
        print(f"{r['scene']:7s} {r['policy']:8s} seed {r['seed']}: {r['status']:22s} {r.get('travel_m', 0):6.1f} m "
              f"explored {100 * r.get('explored', 0):5.1f} %  map error {r.get('map_error_m', 0):.3f} m  "
              f"volume {r.get('volume_m3', 0):6.1f} m3  loops {r.get('loop_closures', 0)}")
    table = comparison.summarise(runs)
    checks = ordering_checks(table)
    plots = [] if args.quick else plot(runs, out)
    if not args.quick:
        write_tables(runs, table, out)
        (out / "ordering_summary.json").write_text(json.dumps({"table": table, "checks": checks}, indent=1))
    emit({"benchmark": "ordering", "quick": args.quick, "smoke": args.smoke, "frontend": args.frontend,
          "seeds": seeds, "machine": machine(), "table": table, "checks": checks, "plots": plots})


if __name__ == "__main__":
    main()
