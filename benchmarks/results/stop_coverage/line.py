"""Decision-time variants measured on the same validation buildings at 85 %, on one travel / map-error figure.

Reads the pooled row (``all N scenes``) of each ``study_zero_shot.py`` output (``targets.json``: the learned
policy's travel and map-error ratios to EM's, 95 % intervals) and draws them with the line through two of them
(``--line A B``: plan.md's line through the shipped default and session 52's candidate with the loop prior). For
every point: its map-error ratio minus the line's at its travel (negative: a better trade than the line). Writes
``line.csv`` and ``line.png`` into ``--out``; one JSON line per point, the line's slope and intercept last.

    python benchmarks/results/stop_coverage/line.py --out benchmarks/results/stop_coverage \
        --point default=targets_val90/val90/targets.json ... --line default cand0.08
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from common import named_paths  # noqa: E402


def pooled(path: Path) -> dict:
    """The pooled entry of a ``targets.json`` (the one named ``all N scenes``)."""
    entries = [e for e in json.loads(path.read_text())["entries"] if str(e["scene"]).startswith("all ")]
    if len(entries) != 1:
        raise ValueError(f"{path}: expected one pooled 'all N scenes' entry, found {len(entries)}")
    return entries[0]


def line_through(a: dict, b: dict) -> tuple[float, float]:
    """Slope and intercept of map error against travel through two points."""
    if a["travel_ratio"] == b["travel_ratio"]:
        raise ValueError("--line: the two points have the same travel ratio; no line through them")
    slope = (b["error_ratio"] - a["error_ratio"]) / (b["travel_ratio"] - a["travel_ratio"])
    return slope, a["error_ratio"] - slope * a["travel_ratio"]


def plot(rows: list[dict], slope: float, intercept: float, target: float, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    colours, markers = plt.get_cmap("tab20").colors, "os^Dv"  # distinct for up to 20 points
    for index, row in enumerate(rows):
        t, e = row["travel_ratio"], row["error_ratio"]
        ax.errorbar(t, e, xerr=[[t - row["travel_lo"]], [row["travel_hi"] - t]],
                    yerr=[[e - row["error_lo"]], [row["error_hi"] - e]], fmt=markers[index % len(markers)],
                    color=colours[index % len(colours)], capsize=3, label=row["name"])
    xs = [min(r["travel_lo"] for r in rows) - 0.02, max(r["travel_hi"] for r in rows) + 0.02]
    ax.plot(xs, [slope * x + intercept for x in xs], "k--", lw=1, label="line")
    ax.axvline(target, color="grey", lw=0.8)
    ax.axhline(target, color="grey", lw=0.8)
    ax.set_xlabel("travel to 85 % explored / EM's")
    ax.set_ylabel("map error there / EM's")
    ax.set_title(f"learned against EM, pooled buildings (target: both <= {target})", fontsize=10)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--point", action="append", required=True, metavar="NAME=TARGETS_JSON",
                        help="a variant's name and its study_zero_shot.py targets.json (repeat)")
    parser.add_argument("--line", nargs=2, required=True, metavar="NAME", help="the two points the line goes through")
    parser.add_argument("--target", type=float, default=1.1, help="the issue's ratio target, drawn on both axes")
    parser.add_argument("--out", type=Path, required=True, help="folder for line.csv and line.png")
    args = parser.parse_args(argv)
    try:
        points = {name: pooled(path) for name, path in named_paths(args.point, "--point ").items()}
        missing = [n for n in args.line if n not in points]
        if missing:
            raise ValueError(f"--line {missing[0]!r}: not among the --point names {sorted(points)}")
        slope, intercept = line_through(points[args.line[0]], points[args.line[1]])
    except (OSError, KeyError, ValueError) as error:
        parser.error(str(error).splitlines()[0])
    rows = []
    for name, entry in points.items():
        (travel_lo, travel_hi), (error_lo, error_hi) = entry["travel_ratio_ci95"], entry["error_ratio_ci95"]
        rows.append({"name": name, "buildings": entry["scenes"], "travel_ratio": entry["travel_ratio"],
                     "travel_lo": travel_lo, "travel_hi": travel_hi, "error_ratio": entry["error_ratio"],
                     "error_lo": error_lo, "error_hi": error_hi,
                     "above_line": entry["error_ratio"] - (slope * entry["travel_ratio"] + intercept)})
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "line.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(rows, slope, intercept, args.target, args.out / "line.png")
    for row in rows:
        print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}))
    print(json.dumps({"slope": round(slope, 4), "intercept": round(intercept, 4), "points": len(rows),
                      "out": str(args.out)}))


if __name__ == "__main__":
    main()
