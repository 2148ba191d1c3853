"""How much of a scene's floor a 3 m LiDAR sees nothing from (plan.md, session 70 step 2).

kiss-icp needs geometry in range: where the nearest solid is farther than the LiDAR reaches, a scan holds
nothing to match and the odometry drifts. For the garage and for parking lots of the building family (one
``scene.building.*`` override set per lot kind), the fraction of the free floor (clearance above the robot's
radius) whose nearest solid is farther than ``--blind`` metres, and the number of cars, averaged over seeds:

    python lot_blind.py --seeds 1050 1059 --lots "E=lot_lane_width=[2.0,4.5] lot_car_pitch=[5.5,6.5] ..."

Policy-independent: it reads the plans only (no SLAM, no policy), so a lot kind can be matched to the garage
before any policy runs there. One JSON line per scene kind.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from explore_rl.config import load_config
from explore_rl.scene.building import generate_building
from explore_rl.scene.layout import Layout
from explore_rl.scene.procedural import garage_layout
from explore_rl.scene.truth import clearance, layout_grid

RESOLUTION = 0.25  # m, the grid the clearance is read on


def floor_stats(layout: Layout, robot_radius: float, blind: float) -> dict[str, float]:
    """Fraction of the free floor farther than ``blind`` from every solid, and the number of boxes (cars)."""
    distance = clearance(layout, layout_grid(layout, RESOLUTION))
    floor = distance > robot_radius
    return {"blind": float(np.mean(distance[floor] > blind)), "cars": float(len(layout.boxes))}


def lot_layouts(overrides: list[str], seeds: range, robot_radius: float) -> list[Layout]:
    """The building family's plans of ``seeds`` with ``scene.building.lot_probability=1`` and ``overrides``."""
    base = ["scene=building", "scene.building.lot_probability=1"] + [f"scene.building.{o}" for o in overrides]
    return [generate_building(load_config(base + [f"scene.seed={seed}"]).scene, robot_radius).layout
            for seed in seeds]


def parse_lots(text: str) -> tuple[str, list[str]]:
    """``NAME=key=value key=value``: a lot kind's name and its ``scene.building`` overrides."""
    name, _, rest = text.partition("=")
    if not name or not rest.strip():
        raise SystemExit(f"lot_blind.py: --lots {text!r}: give NAME=key=value ... (scene.building overrides)")
    return name, rest.split()


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(1050, 1059), metavar=("FIRST", "LAST"))
    parser.add_argument("--lots", action="append", default=[], help="NAME=scene.building overrides (repeatable)")
    parser.add_argument("--blind", type=float, default=2.5, help="m: farther than this from every solid is blind")
    parser.add_argument("--garage-seeds", type=int, default=1, help="garage car jitter seeds 0..n-1")
    args = parser.parse_args(argv)
    first, last = args.seeds
    if last < first:
        raise SystemExit(f"lot_blind.py: --seeds {first} {last}: FIRST must be <= LAST")
    if args.garage_seeds < 1:
        raise SystemExit(f"lot_blind.py: --garage-seeds {args.garage_seeds}: give at least 1")
    radius = load_config([]).robot.radius
    kinds = {"garage": [garage_layout(load_config(["scene=garage", f"scene.seed={s}"]).scene)
                        for s in range(args.garage_seeds)]}
    for text in args.lots:
        name, overrides = parse_lots(text)
        kinds[name] = lot_layouts(overrides, range(first, last + 1), radius)
    for name, layouts in kinds.items():
        rows = [floor_stats(layout, radius, args.blind) for layout in layouts]
        print(json.dumps({"scene": name, "layouts": len(rows), "blind_m": args.blind,
                          **{k: round(float(np.mean([r[k] for r in rows])), 3) for k in rows[0]}}))


if __name__ == "__main__":
    main()
