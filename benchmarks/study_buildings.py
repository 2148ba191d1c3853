"""Variety of scene=building: a contact sheet of 16 seeds and structure statistics over 200.

Every plan is drawn by ``generate_building`` with the default ``conf/scene/building.yaml``
knobs and the default robot (seeds ``0..N-1``). Per seed: size, area, rooms, open halls,
corridor kind and bands, doors, loops (independent cycles E - V + C of the region graph
whose edges are doors and corridor joins; ``corridor_loops`` of the corridors alone), dead
ends (regions with a single door or join), clutter, starts, the reachable free fraction
of the floor, the MuJoCo geom count and which draw passed the checks. A plan with
``loops == 0`` is tree-like: no revisit can close a loop in it.

Writes into ``--out`` (default ``benchmarks/results/buildings``; ``--quick`` and ``--smoke`` without it: a
temporary folder, never the committed results): ``contact_sheet.png``
(seeds 0..15, one scale), ``buildings.csv`` (one row per seed), ``summary.json`` and
``table.md`` (mean, std and quantiles of each statistic, and the fractions).

    python benchmarks/study_buildings.py [--seeds 200] [--out DIR] [--quick | --smoke]

``--ordering DIR`` instead reads an ``explore-rl-eval`` sweep over building seeds (one
sub-folder per building, each with ``trials.jsonl``) and checks the paper's ordering per
building, at the travel every policy reached (the shortest final travel of the three):
nearest frontier explored the most (fastest coverage), nearest has the highest map error,
EM the lowest; and, since a policy that covers little can keep its error low (random),
the map error at equal coverage (the least any policy explored, once each reached it). Writes ``ordering.md`` and ``ordering.json`` into DIR. ``--smoke`` also
runs that check on a tiny evaluation it runs itself (one building, 3 m of travel).

    explore-rl-eval -m scene=building scene.seed=1000,...,1019 slam=model \
        "evaluate.policies=[em,nearest,random]" evaluate.trials=1 explore.travel_budget=150 out=DIR
    python benchmarks/study_buildings.py --ordering DIR
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, output_dir  # noqa: E402

from explore_rl import comparison, viz  # noqa: E402
from explore_rl.config import load_config  # noqa: E402
from explore_rl.scene.build import RobotBodyConfig, build_spec  # noqa: E402
from explore_rl.scene.building import CORRIDOR, HALL, BuildingPlan, generate_building  # noqa: E402
from explore_rl.scene.truth import free_space, layout_grid  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "buildings"
NUMERIC = ["size_x", "size_y", "area", "rooms", "halls", "corridors", "doors", "loops", "corridor_loops",
           "dead_ends", "objects", "starts", "free_fraction", "ngeom", "attempt"]


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200, help="statistics over seeds 0..N-1")
    parser.add_argument("--sheet", type=int, default=16, help="seeds on the contact sheet (a square number)")
    parser.add_argument("--out", default=None, help="default benchmarks/results/buildings; --quick/--smoke: a temporary folder")
    parser.add_argument("--ordering", default=None, metavar="DIR",
                        help="check the paper's ordering in an explore-rl-eval sweep over building seeds")
    parser.add_argument("--quick", action="store_true", help="50 seeds")
    parser.add_argument("--smoke", action="store_true", help="6 seeds, a 2x2 sheet: checks that it runs")
    args = parser.parse_args()
    if args.quick:
        args.seeds = min(args.seeds, 50)
    if args.smoke:
        args.seeds, args.sheet = 6, 4
    root = int(round(np.sqrt(args.sheet)))
    if root * root != args.sheet or args.sheet > args.seeds:
        parser.error(f"--sheet={args.sheet} must be a square number <= --seeds={args.seeds}")
    return args


def plan_row(seed: int, plan: BuildingPlan, body: RobotBodyConfig, max_geom_length: float) -> dict:
    row = {"seed": seed, **plan.stats()}
    row["ngeom"] = int(build_spec(plan.layout, body, max_geom_length).compile().ngeom)
    return row


def summarise(rows: list[dict]) -> dict:
    """Spread of each numeric statistic and the fractions that say what kind of family it is."""
    stats = {}
    for key in NUMERIC:
        values = np.array([row[key] for row in rows], dtype=float)
        p10, median, p90 = np.percentile(values, [10, 50, 90])
        stats[key] = {"mean": float(values.mean()), "std": float(values.std()), "min": float(values.min()),
                      "p10": float(p10), "median": float(median), "p90": float(p90), "max": float(values.max())}
    count = len(rows)
    kinds = sorted({row["corridor"] for row in rows})
    fractions = {
        "loop_plans": sum(row["loops"] > 0 for row in rows) / count,
        "tree_plans": sum(row["loops"] == 0 for row in rows) / count,
        "corridor_loop_plans": sum(row["corridor_loops"] > 0 for row in rows) / count,
        "room_loops_only_plans": sum(row["loops"] > 0 and row["corridor_loops"] == 0 for row in rows) / count,
        "plans_with_hall": sum(row["halls"] > 0 for row in rows) / count,
        "redrawn_plans": sum(row["attempt"] > 0 for row in rows) / count,
        **{f"corridor_{kind}": sum(row["corridor"] == kind for row in rows) / count for kind in kinds},
    }
    return {"seeds": count, "stats": stats, "fractions": fractions,
            "distinct_wall_sets": len({row["walls_key"] for row in rows})}


def markdown(summary: dict) -> str:
    lines = [f"Structure of `scene=building` over seeds 0..{summary['seeds'] - 1} (default knobs; "
             f"{summary['distinct_wall_sets']} distinct wall sets).", "",
             "| statistic | mean | std | min | p10 | median | p90 | max |", "|---|---|---|---|---|---|---|---|"]
    for key, s in summary["stats"].items():
        fmt = "{:.2f}" if key == "free_fraction" else "{:.1f}"
        lines.append(f"| {key} | " + " | ".join(fmt.format(s[c]) for c in
                                                 ("mean", "std", "min", "p10", "median", "p90", "max")) + " |")
    lines += ["", "| fraction of plans | value |", "|---|---|"]
    lines += [f"| {key} | {value:.3f} |" for key, value in summary["fractions"].items()]
    return "\n".join(lines) + "\n"


def contact_sheet(plans: dict[int, BuildingPlan], robot_radius: float, grid_resolution: float, out: Path) -> Path:
    """Plans side by side at one scale: corridors blue, halls yellow, reachable floor green, starts red."""
    import matplotlib.pyplot as plt

    side = int(round(np.sqrt(len(plans))))
    extent = max(max(plan.layout.size) for plan in plans.values()) + 0.5
    fig, axes = plt.subplots(side, side, figsize=(4 * side, 4 * side))
    for ax, (seed, plan) in zip(np.ravel(axes), plans.items()):
        layout = plan.layout
        grid = layout_grid(layout, grid_resolution)
        truth = free_space(layout, grid, robot_radius, layout.starts[0][:2])
        viz.draw_mask(ax, grid, truth.reachable, "tab:green", alpha=0.15)
        module_grid = layout_grid(layout, layout.size[0] / plan.labels.shape[1])
        kinds = np.array(plan.kinds)
        viz.draw_mask(ax, module_grid, kinds[plan.labels] == CORRIDOR, "tab:blue", alpha=0.25)
        viz.draw_mask(ax, module_grid, kinds[plan.labels] == HALL, "gold", alpha=0.3)
        viz.draw_layout(ax, layout)
        starts = np.array(layout.starts)
        ax.plot(starts[:, 0], starts[:, 1], "o", color="tab:red", ms=4, zorder=5)
        ax.plot(starts[0, 0], starts[0, 1], "*", color="tab:red", ms=11, zorder=5)
        s = plan.stats()
        ax.set_title(f"seed {seed}: {layout.size[0]:g} x {layout.size[1]:g} m, {s['corridor']}\n"
                     f"{s['rooms']} rooms, {s['halls']} hall, {s['doors']} doors, {s['loops']} loops", fontsize=9)
        ax.set_xlim(-0.5, extent)
        ax.set_ylim(-0.5, extent)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    return viz.save(fig, out)


def ordering(runs: list[dict], plans: dict[int, dict]) -> dict:
    """Per building: explored and map error of em, nearest, random at the travel all reached;
    whether nearest covered most, nearest erred most, EM erred least; and the counts."""
    rows = []
    for scene in sorted({r["scene"] for r in runs}):
        good = {r["policy"]: r for r in runs if r["scene"] == scene and r["status"] != "error" and r["rows"]}
        if not {"em", "nearest", "random"} <= good.keys():
            continue
        travel = min(r["travel_m"] for r in good.values())
        seed = int(scene.rsplit("_", 1)[1])
        row = {"scene": scene, "seed": seed, **{k: plans[seed][k] for k in ("corridor", "loops", "area")},
               "travel_m": travel}
        for policy, run in good.items():
            row[f"explored_{policy}"] = comparison.value_at_travel(run, "explored", travel)
            row[f"map_error_{policy}"] = comparison.value_at_travel(run, "map_error_m", travel)
            row[f"final_explored_{policy}"], row[f"final_travel_{policy}"] = run["explored"], run["travel_m"]
        explored = {p: row[f"explored_{p}"] for p in ("em", "nearest", "random")}
        error = {p: row[f"map_error_{p}"] for p in ("em", "nearest", "random")}
        # strict: a tie does not count
        row["nearest_fastest_coverage"] = bool(explored["nearest"] > max(explored["em"], explored["random"]))
        row["nearest_worst_map_error"] = bool(error["nearest"] > max(error["em"], error["random"]))
        row["em_lowest_map_error"] = bool(error["em"] < min(error["nearest"], error["random"]))
        row["paper_ordering"] = row["nearest_fastest_coverage"] and row["nearest_worst_map_error"] \
            and row["em_lowest_map_error"]
        row["em_lower_map_error_than_nearest"] = bool(error["em"] < error["nearest"])
        # at equal coverage (the least any policy reached): the travel each needed, its error then
        row["coverage"] = min(run["explored"] for run in good.values())
        for policy, run in good.items():
            reached = comparison.travel_to_reach(run, row["coverage"])
            row[f"travel_to_coverage_{policy}"] = reached
            row[f"map_error_at_coverage_{policy}"] = comparison.value_at_travel(run, "map_error_m", reached)
        at_coverage = {p: row[f"map_error_at_coverage_{p}"] for p in ("em", "nearest", "random")}
        row["em_lowest_map_error_at_equal_coverage"] = bool(
            at_coverage["em"] < min(at_coverage["nearest"], at_coverage["random"]))
        rows.append(row)
    flags = ("nearest_fastest_coverage", "nearest_worst_map_error", "em_lowest_map_error", "paper_ordering",
             "em_lower_map_error_than_nearest", "em_lowest_map_error_at_equal_coverage")
    counts = {flag: sum(row[flag] for row in rows) for flag in flags}
    by_loops = {kind: {flag: sum(row[flag] for row in rows if (row["loops"] > 0) == (kind == "loops"))
                       for flag in flags} | {"buildings": sum((row["loops"] > 0) == (kind == "loops") for row in rows)}
                for kind in ("loops", "tree")}
    return {"buildings": len(rows), "counts": counts, "by_loops": by_loops, "rows": rows}


def ordering_markdown(result: dict) -> str:
    n, counts = result["buildings"], result["counts"]
    lines = [f"Paper's ordering on {n} buildings, at the travel every policy reached (explored %, map error m):", "",
             f"* nearest frontier fastest coverage: **{counts['nearest_fastest_coverage']} / {n}**",
             f"* nearest frontier worst map error: **{counts['nearest_worst_map_error']} / {n}**",
             f"* EM lowest map error: **{counts['em_lowest_map_error']} / {n}**",
             f"* all three: **{counts['paper_ordering']} / {n}**",
             f"* EM lower map error than nearest frontier: **{counts['em_lower_map_error_than_nearest']} / {n}**",
             f"* EM lowest map error at equal coverage (the least any policy explored; error once each "
             f"reached it): **{counts['em_lowest_map_error_at_equal_coverage']} / {n}**", ""]
    for kind, c in result["by_loops"].items():
        lines.append(f"* {kind} plans ({c['buildings']}): nearest fastest {c['nearest_fastest_coverage']}, "
                     f"nearest worst error {c['nearest_worst_map_error']}, EM lowest error {c['em_lowest_map_error']}")
    lines += ["", "| building | corridor | loops | travel m | explored em / nearest / random | "
              "map error em / nearest / random | ordering | at coverage % | travel m em / nearest / random | "
              "map error em / nearest / random |", "|---|---|---|---|---|---|---|---|---|---|"]
    for row in result["rows"]:
        explored = " / ".join(f"{100 * row[f'explored_{p}']:.0f}" for p in ("em", "nearest", "random"))
        error = " / ".join(f"{row[f'map_error_{p}']:.3f}" for p in ("em", "nearest", "random"))
        mark = "yes" if row["paper_ordering"] else ", ".join(
            f for f, ok in (("NF not fastest", row["nearest_fastest_coverage"]),
                            ("NF not worst", row["nearest_worst_map_error"]),
                            ("EM not lowest", row["em_lowest_map_error"])) if not ok)
        travel = " / ".join(f"{row[f'travel_to_coverage_{p}']:.0f}" for p in ("em", "nearest", "random"))
        at_coverage = " / ".join(f"{row[f'map_error_at_coverage_{p}']:.3f}" for p in ("em", "nearest", "random"))
        lines.append(f"| {row['seed']} | {row['corridor']} | {row['loops']} | {row['travel_m']:.0f} | {explored} | "
                     f"{error} | {mark} | {100 * row['coverage']:.0f} | {travel} | {at_coverage} |")
    return "\n".join(lines) + "\n"


def check_ordering(directory: Path, config) -> dict:
    """:func:`ordering` of the sweep in ``directory``; ``ordering.md`` and ``.json`` into it."""
    runs = [run for path in sorted(directory.glob("*/trials.jsonl")) for run in comparison.read_trials(path)]
    seeds = sorted({int(r["scene"].rsplit("_", 1)[1]) for r in runs if r["scene"].startswith("building_")})
    plans = {seed: generate_building(replace(config.scene, seed=seed), config.robot.radius).stats() for seed in seeds}
    result = ordering(runs, plans)
    (directory / "ordering.json").write_text(json.dumps(result, indent=1) + "\n")
    (directory / "ordering.md").write_text(ordering_markdown(result))
    return result


def tiny_evaluation(out: Path) -> Path:
    """One building, em / nearest / random, 3 m of travel each: the smoke run of the check."""
    small = load_config(["scene=building", "scene.seed=1000", "slam=model", "explore.travel_budget=3",
                         "explore.progress_bar=false"])
    trials = comparison.make_trials(small, ["em", "nearest", "random"], 1)
    comparison.write_report([comparison.run_trial(t) for t in trials], out / "0_building_1000")
    return out


def main() -> None:
    args = parse_args()
    if args.ordering:
        config = load_config(["scene=building"])
        result = check_ordering(Path(args.ordering), config)
        print(ordering_markdown(result))
        emit({"smoke": False, "buildings": result["buildings"], "counts": result["counts"],
              "by_loops": result["by_loops"], "machine": machine()})
        return
    out = output_dir(args.out, RESULTS, args.quick or args.smoke, "buildings")
    out.mkdir(parents=True, exist_ok=True)
    config = load_config(["scene=building"])
    body = RobotBodyConfig(config.robot.radius, tuple(config.robot.body_size), config.lidar.mount_height)
    rows, sheet = [], {}
    for seed in range(args.seeds):
        plan = generate_building(replace(config.scene, seed=seed), config.robot.radius)
        row = plan_row(seed, plan, body, config.scene.max_geom_length)
        row["walls_key"] = hash(plan.layout.walls)
        rows.append(row)
        if seed < args.sheet:
            sheet[seed] = plan
    summary = summarise(rows)
    columns = ["seed", "corridor", *NUMERIC]
    with open(out / "buildings.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
    table = markdown(summary)
    (out / "table.md").write_text(table)
    sheet_path = contact_sheet(sheet, config.robot.radius, config.scene.grid_resolution, out / "contact_sheet.png")
    print(table)
    fractions = summary["fractions"]
    smoke_ordering = check_ordering(tiny_evaluation(out / "eval"), config) if args.smoke else None
    emit({"smoke": args.smoke, "quick": args.quick, "seeds": args.seeds, "loop_fraction": fractions["loop_plans"],
          "tree_fraction": fractions["tree_plans"], "fractions": fractions,
          "medians": {k: v["median"] for k, v in summary["stats"].items()},
          "distinct_wall_sets": summary["distinct_wall_sets"], "table": str(out / "table.md"),
          "contact_sheet": str(sheet_path), "ordering_buildings": smoke_ordering and smoke_ordering["buildings"],
          "machine": machine()})


if __name__ == "__main__":
    main()
