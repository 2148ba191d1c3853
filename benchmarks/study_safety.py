"""The local safety layer on vs off: blocked decisions, contacts, coverage, travel, map error.

Runs every (scene, policy, seed) exploration twice in one study, with the local safety
layer (``robot.safety``, explore_rl/local_planner.py) on and off, with ``slam=model``,
plus ``slam=icp`` pairs (office, nearest; seed 0, ``--icp-seeds`` for more). Per run:
decisions, blocked decisions (path ended ``blocked``), contacts (motion steps whose true
footprint would have entered an obstacle), the least true footprint clearance, explored
fraction, travel, map error, and the time per decision (decide + drive) and in the layer.
The last stdout line is JSON with the table and the issue-15 targets, checked on the
``slam=model`` runs:

* blocked decisions under 2 % and contacts near zero (at most one per four runs) with it on;
* explored % not lower: as many runs reach the 85 % target, and the mean final explored
  fraction within one point (runs stop at the first decision past 85 %, so the final
  figure is mostly that decision's overshoot); travel at most 10 % longer; map error not
  worse (means over all runs) than with it off.

    python benchmarks/study_safety.py [--quick | --smoke] [--seeds 4] [--workers 1]
        [--scenes office street garage] [--policies nearest em] [--no-icp] [--icp-seeds 1]
        [--resume] [--summarise-only] [--out DIR]

Every finished run is appended to ``DIR/safety_runs.jsonl`` (default
``benchmarks/results/safety``; ``--quick`` and ``--smoke`` without ``--out``: a temporary folder, so they never
overwrite the committed runs) as it completes; ``--resume`` skips runs already there and
``--summarise-only`` rebuilds the table from that log.
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, output_dir  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
SCENES = ["office", "street", "garage"]
POLICIES = ["nearest", "em"]
VARIANTS = {"on": "robot.safety.enabled=true", "off": "robot.safety.enabled=false"}
KEYS = ("decisions", "blocked", "contacts", "min_clearance_m", "explored", "travel_m", "map_error_m",
        "ms_per_decision", "ms_drive", "ms_safety", "interventions")


def run(scene: str, policy: str, seed: int, variant: str, frontend: str, extra: tuple[str, ...]) -> dict:
    """One exploration with the layer ``variant`` (on/off); its figures, not its rows."""
    from explore_rl.config import load_config
    from explore_rl.runner import Explorer

    overrides = [f"scene={scene}", f"policy={policy}", f"seed={seed}", f"slam={frontend}",
                 "explore.progress_bar=false", VARIANTS[variant], *extra]
    explorer = Explorer(load_config(overrides))
    result = explorer.run()
    rows = result.table()
    last = rows[-1] if rows else {}
    n = max(len(rows), 1)
    return {
        "scene": scene, "policy": policy, "seed": seed, "variant": variant, "frontend": frontend,
        "status": result.status.value, "decisions": len(rows),
        "blocked": sum(r["path_status"] == "blocked" for r in rows),
        "contacts": explorer.robot.contacts, "min_clearance_m": explorer.robot.min_clearance,
        "explored": last.get("explored", 0.0), "travel_m": explorer.robot.travelled,
        "map_error_m": last.get("map_error_m", 0.0),
        "ms_per_decision": sum(r["ms_decide"] + r["ms_drive"] for r in rows) / n,
        "ms_drive": sum(r["ms_drive"] for r in rows) / n, "ms_safety": sum(r["ms_safety"] for r in rows) / n,
        "interventions": last.get("safety_interventions", 0),
    }


def mean(runs: list[dict], key: str) -> float:
    return round(float(np.mean([r[key] for r in runs])), 4)


def summarise(runs: list[dict]) -> list[dict]:
    """Means per (frontend, scene, policy, variant)."""
    table = []
    groups = sorted({(r["frontend"], r["scene"], r["policy"]) for r in runs},
                    key=lambda g: (g[0] != "model", SCENES.index(g[1]) if g[1] in SCENES else 99,
                                   POLICIES.index(g[2]) if g[2] in POLICIES else 99, g[2]))
    for frontend, scene, policy in groups:
        for variant in VARIANTS:
            group = [r for r in runs if (r["frontend"], r["scene"], r["policy"], r["variant"])
                     == (frontend, scene, policy, variant)]
            if group:
                entry = {"frontend": frontend, "scene": scene, "policy": policy, "variant": variant,
                         "runs": len(group), **{key: mean(group, key) for key in KEYS}}
                entry["min_clearance_m"] = round(float(min(r["min_clearance_m"] for r in group)), 4)
                entry["blocked_fraction"] = round(sum(r["blocked"] for r in group)
                                                  / max(sum(r["decisions"] for r in group), 1), 4)
                table.append(entry)
    return table


def overall(runs: list[dict]) -> dict:
    """Totals and means per variant over a set of runs."""
    out = {}
    for variant in VARIANTS:
        group = [r for r in runs if r["variant"] == variant]
        if not group:
            continue
        decisions = sum(r["decisions"] for r in group)
        out[variant] = {
            "runs": len(group), "decisions": decisions, "blocked": sum(r["blocked"] for r in group),
            "blocked_fraction": round(sum(r["blocked"] for r in group) / max(decisions, 1), 4),
            "contacts": sum(r["contacts"] for r in group),
            "contacts_per_run": round(sum(r["contacts"] for r in group) / len(group), 3),
            "reached_target": sum(r["status"] == "explored" for r in group),
            "min_clearance_m": round(float(min(r["min_clearance_m"] for r in group)), 4),
            **{key: mean(group, key) for key in ("explored", "travel_m", "map_error_m", "ms_per_decision",
                                                 "ms_drive", "ms_safety")},
        }
    return out


def targets(summary: dict) -> dict:
    """Issue 15's targets, on the layer-on vs layer-off means of one set of runs."""
    on, off = summary.get("on"), summary.get("off")
    if not on or not off:
        return {}
    return {
        "blocked_under_2_percent": on["blocked_fraction"] < 0.02,
        "contacts_near_zero": on["contacts_per_run"] <= 0.25,
        "explored_not_lower": (on["reached_target"] >= off["reached_target"]
                               and on["explored"] >= off["explored"] - 0.01),
        "travel_at_most_10_percent_longer": on["travel_m"] <= 1.10 * off["travel_m"],
        "map_error_not_worse": on["map_error_m"] <= off["map_error_m"],
    }


def read_runs(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def key(job: tuple) -> tuple:
    return tuple(job[:5])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="nearest on office and street, 1 seed, no icp")
    parser.add_argument("--smoke", action="store_true", help="a few seconds: office, nearest, 1 seed, 2 decisions")
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--scenes", nargs="+", default=SCENES)
    parser.add_argument("--policies", nargs="+", default=POLICIES)
    parser.add_argument("--no-icp", action="store_true", help="skip the slam=icp pairs")
    parser.add_argument("--icp-seeds", type=int, default=1, help="seeds of the slam=icp pair (office, nearest)")
    parser.add_argument("--override", nargs="*", action="extend", default=[], help="Hydra overrides for every run")
    parser.add_argument("--resume", action="store_true", help="skip runs already in the run log")
    parser.add_argument("--summarise-only", action="store_true", help="only rebuild the table from the run log")
    parser.add_argument("--out", type=Path, default=None,
                        help="default benchmarks/results/safety; --quick/--smoke: a temporary folder")
    args = parser.parse_args()
    if args.seeds < 1 or args.workers < 1:
        parser.error(f"--seeds and --workers must be >= 1, got {args.seeds} and {args.workers}")
    scenes, policies, seeds, icp, extra = args.scenes, args.policies, args.seeds, not args.no_icp, tuple(args.override)
    if args.quick:
        scenes, policies, seeds, icp = ["office", "street"], ["nearest"], 1, False
    if args.smoke:
        scenes, policies, seeds, icp, extra = ["office"], ["nearest"], 1, False, extra + ("explore.max_decisions=2",)
    jobs = [(scene, policy, seed, variant, "model", extra) for scene in scenes for policy in policies
            for seed in range(seeds) for variant in VARIANTS]
    if icp:
        jobs += [("office", "nearest", seed, variant, "icp", extra) for seed in range(args.icp_seeds)
                 for variant in VARIANTS]
    args.out = output_dir(args.out, RESULTS / "safety", args.quick or args.smoke, "safety")
    args.out.mkdir(parents=True, exist_ok=True)
    log_path = args.out / "safety_runs.jsonl"
    done = [r for r in read_runs(log_path) if args.resume or args.summarise_only]
    if args.summarise_only:
        jobs = [job for job in jobs if key(job) in {(r["scene"], r["policy"], r["seed"], r["variant"],
                                                     r["frontend"]) for r in done}]
    elif not args.resume:
        log_path.write_text("")
    seen = {(r["scene"], r["policy"], r["seed"], r["variant"], r["frontend"]) for r in done}
    todo = [job for job in jobs if key(job) not in seen]
    runs = [r for r in done if (r["scene"], r["policy"], r["seed"], r["variant"], r["frontend"])
            in {key(job) for job in jobs}]
    with ProcessPoolExecutor(max_workers=args.workers) as pool, open(log_path, "a") as log:
        futures = {pool.submit(run, *job): job for job in todo}
        for future in as_completed(futures):
            result = future.result()
            runs.append(result)
            log.write(json.dumps(result) + "\n")
            log.flush()
            print(f"{result['frontend']:5} {result['scene']:7} {result['policy']:8} seed {result['seed']} "
                  f"{result['variant']:3}: {result['decisions']:3d} decisions, {result['blocked']:2d} blocked, "
                  f"{result['contacts']:2d} contacts, explored {result['explored']:.3f}, "
                  f"{result['travel_m']:6.1f} m, map error {result['map_error_m']:.3f}, "
                  f"{result['ms_per_decision']:6.0f} ms/decision", flush=True)
    table = summarise(runs)
    print(f"\n{'slam':5} {'scene':7} {'policy':8} {'layer':5} {'runs':>4} {'blocked %':>9} {'contacts':>8} "
          f"{'min clr':>7} {'explored':>8} {'travel m':>8} {'map err':>7} {'ms/dec':>7} {'ms layer':>8}")
    for t in table:
        print(f"{t['frontend']:5} {t['scene']:7} {t['policy']:8} {t['variant']:5} {t['runs']:4d} "
              f"{100 * t['blocked_fraction']:9.1f} {t['contacts']:8.2f} {t['min_clearance_m']:7.3f} "
              f"{t['explored']:8.3f} {t['travel_m']:8.1f} {t['map_error_m']:7.3f} {t['ms_per_decision']:7.0f} "
              f"{t['ms_safety']:8.1f}")
    model = overall([r for r in runs if r["frontend"] == "model"])
    icp_pair = overall([r for r in runs if r["frontend"] == "icp"])
    per_policy = {policy: overall([r for r in runs if r["frontend"] == "model" and r["policy"] == policy])
                  for policy in policies}
    checks = targets(model)
    print(f"\nslam=model, all runs: {json.dumps(model)}\nslam=icp pair: {json.dumps(icp_pair)}\n"
          f"targets: {json.dumps(checks)}")
    emit({"benchmark": "safety", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "seeds": seeds, "scenes": scenes, "policies": policies, "overrides": list(extra),
          "model": model, "per_policy": per_policy, "icp": icp_pair, "targets": checks,
          "all_targets_met": bool(checks) and all(checks.values()), "table": table})


if __name__ == "__main__":
    main()
