"""Variety of scene=building: a contact sheet of 16 seeds and structure statistics over 200.

Every plan is drawn by ``generate_building`` with the default ``conf/scene/building.yaml``
knobs and the default robot (seeds ``0..N-1``). Per seed: size, area, rooms, open halls,
corridor kind and bands, doors, loops (independent cycles E - V + C of the region graph
whose edges are doors and corridor joins; ``corridor_loops`` of the corridors alone), dead
ends (regions with a single door or join), clutter, starts, the reachable free fraction
of the floor, the MuJoCo geom count and which draw passed the checks. A plan with
``loops == 0`` is tree-like: no revisit can close a loop in it.

Writes into ``--out`` (default ``benchmarks/results/buildings``): ``contact_sheet.png``
(seeds 0..15, one scale), ``buildings.csv`` (one row per seed), ``summary.json`` and
``table.md`` (mean, std and quantiles of each statistic, and the fractions).

    python benchmarks/study_buildings.py [--seeds 200] [--out DIR] [--quick | --smoke]
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
from common import emit, machine  # noqa: E402

from explore_rl import viz  # noqa: E402
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
    parser.add_argument("--out", default=str(RESULTS))
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


def main() -> None:
    args = parse_args()
    out = Path(args.out)
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
    emit({"smoke": args.smoke, "quick": args.quick, "seeds": args.seeds, "loop_fraction": fractions["loop_plans"],
          "tree_fraction": fractions["tree_plans"], "fractions": fractions,
          "medians": {k: v["median"] for k, v in summary["stats"].items()},
          "distinct_wall_sets": summary["distinct_wall_sets"], "table": str(out / "table.md"),
          "contact_sheet": str(sheet_path), "machine": machine()})


if __name__ == "__main__":
    main()
