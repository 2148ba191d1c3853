"""The paper's ordering study: nearest frontier, EM and random on street and garage.

Runs every (scene, policy, seed) exploration with the chosen SLAM front end in parallel
worker processes, then writes to ``benchmarks/results/``: a table (mean and std per policy
and scene), per-scene plots of map error and 3D volume against travel distance, and the
raw per-decision CSVs. The last stdout line is JSON with the table and the ordering checks:

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
import json
import tempfile
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
POLICIES = ["nearest", "em", "random"]


def explore_once(scene: str, policy: str, seed: int, frontend: str, extra: tuple[str, ...]) -> dict:
    """One exploration; returns its per-decision table and final figures."""
    from explore_rl.config import load_config
    from explore_rl.runner import Explorer

    overrides = [f"scene={scene}", f"policy={policy}", f"seed={seed}", f"slam={frontend}",
                 "explore.progress_bar=false", *extra]
    explorer = Explorer(load_config(overrides))
    result = explorer.run()
    rows = result.table()
    last = rows[-1] if rows else {}
    return {
        "scene": scene, "policy": policy, "seed": seed, "status": result.status.value,
        "decisions": len(rows), "travel_m": explorer.robot.travelled,
        "explored": last.get("explored", 0.0), "map_error_m": last.get("map_error_m", 0.0),
        "volume_m3": last.get("volume_m3", 0.0), "loop_closures": last.get("loop_closures", 0),
        "ate_m": last.get("ate_m", 0.0), "rows": rows,
    }


def read_runs(path: Path) -> list[dict]:
    """Runs already logged (one JSON object a line) by an earlier, interrupted study."""
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def summarise(runs: list[dict]) -> list[dict]:
    table = []
    for scene in sorted({r["scene"] for r in runs}):
        for policy in POLICIES:
            group = [r for r in runs if r["scene"] == scene and r["policy"] == policy]
            if not group:
                continue
            entry = {"scene": scene, "policy": policy, "runs": len(group)}
            for key in ("travel_m", "explored", "map_error_m", "volume_m3", "loop_closures", "ate_m"):
                values = np.array([r[key] for r in group], dtype=float)
                entry[key] = round(float(values.mean()), 4)
                entry[key + "_std"] = round(float(values.std()), 4)
            per_metre = np.array([r["explored"] / max(r["travel_m"], 1e-9) for r in group])
            entry["explored_per_m"] = round(float(per_metre.mean()), 5)
            table.append(entry)
    return table


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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    colours = {"nearest": "tab:blue", "em": "tab:red", "random": "tab:gray"}
    for scene in sorted({r["scene"] for r in runs}):
        fig, axes = plt.subplots(1, 2, figsize=(11, 4))
        for r in (r for r in runs if r["scene"] == scene):
            travel = [row["travel_m"] for row in r["rows"]]
            label = r["policy"] if r["seed"] == min(x["seed"] for x in runs) else None
            axes[0].plot(travel, [row["map_error_m"] for row in r["rows"]], color=colours[r["policy"]],
                         alpha=0.7, label=label)
            axes[1].plot(travel, [row["volume_m3"] for row in r["rows"]], color=colours[r["policy"]],
                         alpha=0.7, label=label)
        axes[0].set(xlabel="travel distance [m]", ylabel="map error [m]", title=f"{scene}: map error")
        axes[1].set(xlabel="travel distance [m]", ylabel="3D occupied volume [m$^3$]", title=f"{scene}: volume")
        for ax in axes:
            ax.legend()
            ax.grid(alpha=0.3)
        path = out / f"ordering_{scene}.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        written.append(str(path.relative_to(out.parent.parent)))
    return written


def write_tables(runs: list[dict], table: list[dict], out: Path) -> None:
    with open(out / "ordering_runs.csv", "w", newline="") as handle:
        fields = [k for k in runs[0] if k != "rows"]
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows({k: r[k] for k in fields} for r in runs)
    lines = ["| scene | policy | runs | travel m | explored % | map error m | volume m3 | loop closures | explored %/m |",
             "|---|---|---|---|---|---|---|---|---|"]
    for t in table:
        lines.append(f"| {t['scene']} | {t['policy']} | {t['runs']} | {t['travel_m']:.1f} ± {t['travel_m_std']:.1f} | "
                     f"{100 * t['explored']:.1f} ± {100 * t['explored_std']:.1f} | "
                     f"{t['map_error_m']:.3f} ± {t['map_error_m_std']:.3f} | {t['volume_m3']:.1f} ± {t['volume_m3_std']:.1f} | "
                     f"{t['loop_closures']:.1f} ± {t['loop_closures_std']:.1f} | {100 * t['explored_per_m']:.2f} |")
    (out / "ordering_table.md").write_text("\n".join(lines) + "\n")


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
    parser.add_argument("--override", nargs="*", default=[],
                        help="Hydra overrides for every run, e.g. planning.reward.alpha=1")
    parser.add_argument("--resume", action="store_true", help="keep runs already in ordering_runs.jsonl")
    parser.add_argument("--summarise-only", action="store_true", help="no new runs: table/plots from the log")
    args = parser.parse_args()
    scenes, seeds, extra = args.scenes, range(args.seeds), tuple(args.override)
    if args.quick:
        scenes, seeds, extra = ["street"], range(1), ("explore.max_decisions=6", *args.override)
        args.out = tempfile.mkdtemp(prefix="ordering_quick_")  # never touch the committed results
    elif args.smoke:
        scenes, seeds, extra = ["street"], range(1), ("explore.max_decisions=2", *args.override)
        args.frontend, args.workers = "model", 1
        args.out = args.out or tempfile.mkdtemp(prefix="ordering_smoke_")
    args.out = args.out or str(RESULTS)
    args.resume = args.resume or args.summarise_only
    # seed-major order: an interrupted study still holds whole (scene, policy) sets per seed
    jobs = [(scene, policy, seed, args.frontend, extra) for seed in seeds for scene in scenes for policy in POLICIES]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    log = out / "ordering_runs.jsonl"
    runs = read_runs(log) if args.resume else []
    if not args.resume:
        log.unlink(missing_ok=True)
    done = {(r["scene"], r["policy"], r["seed"]) for r in runs}
    jobs = [] if args.summarise_only else [j for j in jobs if j[:3] not in done]
    with ProcessPoolExecutor(max_workers=args.workers) as pool, open(log, "a") as handle:
        futures = [pool.submit(explore_once, *job) for job in jobs]
        for future in as_completed(futures):
            run = future.result()
            runs.append(run)
            handle.write(json.dumps(run) + "\n")
            handle.flush()
    for r in runs:
        print(f"{r['scene']:7s} {r['policy']:8s} seed {r['seed']}: {r['status']:22s} {r['travel_m']:6.1f} m "
              f"explored {100 * r['explored']:5.1f} %  map error {r['map_error_m']:.3f} m  "
              f"volume {r['volume_m3']:6.1f} m3  loops {r['loop_closures']}")
    table = summarise(runs)
    checks = ordering_checks(table)
    plots = [] if args.quick else plot(runs, out)
    if not args.quick:
        write_tables(runs, table, out)
        (out / "ordering_summary.json").write_text(json.dumps({"table": table, "checks": checks}, indent=1))
    emit({"benchmark": "ordering", "quick": args.quick, "smoke": args.smoke, "frontend": args.frontend,
          "seeds": len(seeds), "machine": machine(), "table": table, "checks": checks, "plots": plots})


if __name__ == "__main__":
    main()
